//! Kahan–Kelsen constant-time indexing of the lattice points of a triangle.
//!
//! # The bijection
//!
//! Put `a` (the first vertex) at the origin, `b` and `c` relative to it, and let
//! `D = x_c·y_b − y_c·x_b`, `σ = sign D`. Every lattice point `P = (X, Y)` has
//! scaled skew coordinates
//!
//! ```text
//! S = σ(x_c·Y − y_c·X) = |D|·s,   T = σ(y_b·X − x_b·Y) = |D|·t,   P = s·b + t·c,
//! ```
//!
//! and lies in the closed triangle iff `S ≥ 0, T ≥ 0, S + T ≤ |D|`. The
//! parallelogram `(abdc)` (`d = b + c`) holds `k = |D| + gb + gc + 1` lattice
//! points on the lines `S = j·gc`, `j = 0..=|D|/gc`, parallel to `(ac)`; on each
//! line `T` steps by `Lc = |D|/gc`. Ordering the parallelogram lexicographically
//! by `(S, T)`, its first `H = ⌊k/2⌋` points contain exactly one point of every
//! pair `{P, b + c − P}`; so does "the triangle minus the segment `(bm)`"
//! (`m` the midpoint of `bc`). Index `i < H` is therefore the `i`-th point of
//! the parallelogram, reflected (`P' = b + c − P`) when it falls outside that
//! set; indices `H..K` walk `(bm)` from `b` towards `m`.
//! `K = ⌊k/2⌋ + ⌊gbc/2⌋ + 1`, which equals Pick's count.
//!
//! The `i`-th parallelogram point: groups of `|D|/gb + 1` points (one line
//! with `gc + 1` points through a lattice point of `(ab)`, then `|D|/(gb·gc) − 1`
//! lines of `gc` points) give `(j, n)` = (line, point on line) with two
//! divisions. The first point of line `j` is `j·E − ⌊j·τ/Lc⌋·c/gc`, where `E`
//! is a fixed lattice point with `S = gc` reduced so that its `T` value `τ`
//! satisfies `0 ≤ τ < Lc` (extended Euclid, done once). That reduction keeps
//! the only wide product `j·τ < 2^124` (u128); the coordinates themselves are
//! computed with wrapping i64 arithmetic, exact because the result fits.
//!
//! The inverse follows the same route backwards: `j = S/gc`, `n = ⌊T/Lc⌋`,
//! rank `j·gc + ⌈j/M⌉ + n` (`M = |D|/(gb·gc)` lines per group), and a rank
//! `≥ H` belongs to the mirror point, index `k − 1 − rank`.
//!
//! # Range
//!
//! Vertex coordinates must satisfy `|x|, |y| ≤ 2^30` ([`COORD_LIMIT`]). Then
//! `|D| ≤ 2^62`, every count and index fits in `u64`, and all internal values
//! are exact (i64 / u64, one u128 product per point at most).
//!
//! # Degenerate (collinear) triangles
//!
//! Three collinear vertices are accepted: the closed "triangle" is then the
//! segment between the two extreme vertices (a single point if all coincide),
//! and its lattice points are indexed from the lexicographically smallest
//! `(x, y)` end to the other. [`TriangleIndex::shape`] tells which case holds.

use std::ops::{ControlFlow, Range};

use rand::Rng;
use rayon::prelude::*;

use crate::{Result, VoxkitError};

/// A lattice point `[x, y]`.
pub type LatticePoint = [i64; 2];

/// Largest supported absolute value of a vertex coordinate: `2^30`.
pub const COORD_LIMIT: i64 = 1 << 30;

/// What the closed triangle degenerates to, if anything.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriangleShape {
    /// All three vertices coincide.
    Point,
    /// The vertices are collinear but not all equal: the lattice points of a segment.
    Segment,
    /// A proper triangle (non-zero area).
    Triangle,
}

/// Precomputed constants of a proper (non-degenerate) triangle.
#[derive(Clone, Copy, Debug)]
struct Proper {
    /// Vertex `a`, absolute.
    a: LatticePoint,
    /// `b + c` in absolute coordinates: the reflection is `P' = bc_sum − P`.
    bc_sum: LatticePoint,
    /// Vertex `b`, absolute (start of the `(bm)` run).
    b_abs: LatticePoint,
    /// `|D|`.
    dabs: u64,
    /// `σ = sign D` as ±1.
    sigma: i64,
    /// `b − a`, `c − a`.
    b: LatticePoint,
    c: LatticePoint,
    /// gcds of the edges `ab`, `ac`.
    gc: u64,
    /// `Lc = |D|/gc`: the step of `T` along a line.
    lc: u64,
    /// `M = |D|/(gb·gc)`: lines per group.
    lines_per_group: u64,
    /// `|D|/gb + 1`: points per group.
    group_len: u64,
    /// `c/gc`: the step between consecutive points on a line.
    cs: LatticePoint,
    /// Lattice point with `S = gc`, `0 ≤ T < Lc` (relative to `a`).
    e: LatticePoint,
    /// `T(e)`.
    tau: u64,
    /// `k` (points in the parallelogram).
    k: u64,
    /// `H = ⌊k/2⌋`.
    half: u64,
    /// `(c − b)/gbc`: the step along `(bm)`.
    bm_step: LatticePoint,
    /// `|D|/gbc`: the change of `T` per step along `bc`.
    bm_t_step: u64,
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    /// Collinear: points `start + i·step`, `i < len`.
    Segment {
        start: LatticePoint,
        step: LatticePoint,
    },
    Proper(Proper),
}

/// Constant-time indexing of the lattice points of a closed lattice triangle
/// (Kahan & Kelsen).
///
/// After an `O(bits)` precomputation, [`point`](Self::point),
/// [`index_of`](Self::index_of) and [`sample`](Self::sample) take `O(1)`;
/// enumeration of any index range costs `O(1)` per point with no setup beyond
/// `O(1)`, so threads can split `0..len()` without coordination.
///
/// # Guarantees
/// * `point` is a bijection from `0..len()` onto the lattice points of the closed
///   triangle (boundary included), for vertex coordinates within ±[`COORD_LIMIT`],
///   in either winding, collinear vertices included (see [`TriangleShape`]).
/// * `index_of(point(i)) == Some(i)`; `index_of(p) == None` iff `p` is outside.
/// * The order is the paper's: skew-coordinate lines parallel to `(ac)`, then the
///   points of `(bm)` from `b` last. It depends on the vertex order given.
///
/// ```
/// use voxkit::triangle::TriangleIndex;
/// let t = TriangleIndex::new([[0, 0], [4, 0], [0, 4]]).unwrap();
/// assert_eq!(t.len(), 15); // Pick: area 8, 12 boundary points
/// let p = t.point(7).unwrap();
/// assert_eq!(t.index_of(p), Some(7));
/// assert_eq!(t.index_of([3, 3]), None);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct TriangleIndex {
    vertices: [LatticePoint; 3],
    len: u64,
    kind: Kind,
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Extended Euclid on signed inputs: `(g, x, y)` with `a·x + b·y = g = gcd(|a|, |b|) ≥ 0`.
fn ext_gcd(a: i128, b: i128) -> (i128, i128, i128) {
    let (mut r0, mut r1) = (a, b);
    let (mut x0, mut x1) = (1i128, 0i128);
    let (mut y0, mut y1) = (0i128, 1i128);
    while r1 != 0 {
        let q = r0.div_euclid(r1);
        (r0, r1) = (r1, r0 - q * r1);
        (x0, x1) = (x1, x0 - q * x1);
        (y0, y1) = (y1, y0 - q * y1);
    }
    if r0 < 0 {
        (-r0, -x0, -y0)
    } else {
        (r0, x0, y0)
    }
}

/// `(⌊j·t/l⌋, j·t mod l)` exactly; u64 when the product fits, u128 otherwise.
#[inline(always)]
fn mul_divrem(j: u64, t: u64, l: u64) -> (u64, u64) {
    match j.checked_mul(t) {
        Some(p) => (p / l, p % l),
        None => {
            let p = j as u128 * t as u128;
            ((p / l as u128) as u64, (p % l as u128) as u64)
        }
    }
}

#[inline(always)]
fn add(p: LatticePoint, q: LatticePoint) -> LatticePoint {
    [p[0].wrapping_add(q[0]), p[1].wrapping_add(q[1])]
}

#[inline(always)]
fn sub(p: LatticePoint, q: LatticePoint) -> LatticePoint {
    [p[0].wrapping_sub(q[0]), p[1].wrapping_sub(q[1])]
}

#[inline(always)]
fn scale(k: i64, p: LatticePoint) -> LatticePoint {
    [k.wrapping_mul(p[0]), k.wrapping_mul(p[1])]
}

/// Checks one vertex coordinate against ±[`COORD_LIMIT`].
fn check_vertices(v: &[LatticePoint; 3]) -> Result<()> {
    for (n, p) in v.iter().enumerate() {
        for &c in p {
            if !(-COORD_LIMIT..=COORD_LIMIT).contains(&c) {
                return Err(VoxkitError::invalid(format!(
                    "triangle vertex {n} coordinate {c} is outside ±2^30"
                )));
            }
        }
    }
    Ok(())
}

/// Doubled signed area `(v1 − v0) × (v2 − v0)`, exact.
pub(crate) fn orient(v: &[LatticePoint; 3]) -> i128 {
    let (bx, by) = (
        v[1][0] as i128 - v[0][0] as i128,
        v[1][1] as i128 - v[0][1] as i128,
    );
    let (cx, cy) = (
        v[2][0] as i128 - v[0][0] as i128,
        v[2][1] as i128 - v[0][1] as i128,
    );
    bx * cy - by * cx
}

/// Lattice points of the segment spanned by three collinear points: the
/// lexicographically smallest point, the unit lattice step towards the largest,
/// and the number of points.
pub(crate) fn collinear_segment(v: &[LatticePoint; 3]) -> (LatticePoint, LatticePoint, u64) {
    let lo = *v.iter().min().expect("three points");
    let hi = *v.iter().max().expect("three points");
    let d = sub(hi, lo);
    let g = gcd(d[0].unsigned_abs(), d[1].unsigned_abs());
    if g == 0 {
        (lo, [0, 0], 1)
    } else {
        (lo, [d[0] / g as i64, d[1] / g as i64], g + 1)
    }
}

impl Proper {
    fn new(v: &[LatticePoint; 3], d: i128) -> Proper {
        let a = v[0];
        let b = sub(v[1], a);
        let c = sub(v[2], a);
        let sigma: i64 = if d > 0 { 1 } else { -1 };
        let dabs = d.unsigned_abs() as u64; // ≤ 2^62 for coordinates within ±2^30
        let gb = gcd(b[0].unsigned_abs(), b[1].unsigned_abs());
        let gc = gcd(c[0].unsigned_abs(), c[1].unsigned_abs());
        let gbc = gcd((c[0] - b[0]).unsigned_abs(), (c[1] - b[1]).unsigned_abs());
        let lc = dabs / gc;
        let k = dabs + gb + gc + 1;
        let cs = [c[0] / gc as i64, c[1] / gc as i64];
        // E with S(E) = σ(x_c·Y − y_c·X) = gc, i.e. u·Y − v·X = σ for (u, v) = c/gc.
        let (g, p, q) = ext_gcd(cs[0] as i128, -(cs[1] as i128));
        debug_assert_eq!(g, 1);
        let (ey, ex) = (sigma as i128 * p, sigma as i128 * q);
        let t = sigma as i128 * (b[1] as i128 * ex - b[0] as i128 * ey);
        // Reduce: subtract ⌊T/Lc⌋ steps along the line so that 0 ≤ T(E) < Lc.
        let q0 = t.div_euclid(lc as i128);
        let tau = t.rem_euclid(lc as i128) as u64;
        let e = [
            (ex - q0 * cs[0] as i128) as i64,
            (ey - q0 * cs[1] as i128) as i64,
        ];
        Proper {
            a,
            bc_sum: add(v[1], v[2]),
            b_abs: v[1],
            dabs,
            sigma,
            b,
            c,
            gc,
            lc,
            lines_per_group: dabs / (gb * gc),
            group_len: dabs / gb + 1,
            cs,
            e,
            tau,
            k,
            half: k / 2,
            bm_step: [(c[0] - b[0]) / gbc as i64, (c[1] - b[1]) / gbc as i64],
            bm_t_step: dabs / gbc,
        }
    }

    /// Number of points: `⌊k/2⌋ + ⌊gbc/2⌋ + 1`.
    fn len(&self) -> u64 {
        self.half + (self.dabs / self.bm_t_step) / 2 + 1
    }

    /// Line `j` and position `n` on it of parallelogram rank `i < H`.
    #[inline(always)]
    fn line_of(&self, i: u64) -> (u64, u64) {
        let g = i / self.group_len;
        let r = i - g * self.group_len;
        let (l, n) = if r <= self.gc {
            (0, r)
        } else {
            let r2 = r - self.gc - 1;
            (r2 / self.gc + 1, r2 % self.gc)
        };
        (g * self.lines_per_group + l, n)
    }

    /// Start of a run at parallelogram rank `i < H`.
    #[inline(always)]
    fn run_at(&self, i: u64) -> Run {
        let (j, n) = self.line_of(i);
        let (q, rem) = mul_divrem(j, self.tau, self.lc);
        let first = add(
            self.a,
            sub(scale(j as i64, self.e), scale(q as i64, self.cs)),
        );
        Run {
            s: j * self.gc,
            t: rem + n * self.lc,
            rem,
            n,
            line_len: self.gc + (rem == 0) as u64,
            first,
            p: add(first, scale(n as i64, self.cs)),
        }
    }

    /// Emit rule: the point of the parallelogram at `(s, t)`, or its mirror.
    #[inline(always)]
    fn resolve(&self, s: u64, t: u64, p: LatticePoint) -> LatticePoint {
        let st = s + t;
        if st > self.dabs || (st == self.dabs && s >= t) {
            sub(self.bc_sum, p)
        } else {
            p
        }
    }

    #[inline(always)]
    fn point(&self, i: u64) -> LatticePoint {
        if i < self.half {
            let r = self.run_at(i);
            self.resolve(r.s, r.t, r.p)
        } else {
            add(self.b_abs, scale((i - self.half) as i64, self.bm_step))
        }
    }

    fn index_of(&self, p: LatticePoint) -> Option<u64> {
        let x = p[0] as i128 - self.a[0] as i128;
        let y = p[1] as i128 - self.a[1] as i128;
        let sg = self.sigma as i128;
        let s = sg * (self.c[0] as i128 * y - self.c[1] as i128 * x);
        let t = sg * (self.b[1] as i128 * x - self.b[0] as i128 * y);
        let dabs = self.dabs as i128;
        if s < 0 || t < 0 || s + t > dabs {
            return None;
        }
        let (s, t) = (s as u64, t as u64);
        if s + t == self.dabs && s >= t {
            return Some(self.half + t / self.bm_t_step);
        }
        let j = s / self.gc;
        let rank = j * self.gc + j.div_ceil(self.lines_per_group) + t / self.lc;
        Some(if rank < self.half {
            rank
        } else {
            self.k - 1 - rank
        })
    }

    /// Visits parallelogram ranks `lo..hi` (`hi ≤ H`), line by line.
    #[inline(always)]
    fn visit_half<B>(
        &self,
        lo: u64,
        hi: u64,
        f: &mut impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let mut r = self.run_at(lo);
        let mut left = hi - lo;
        loop {
            let take = (r.line_len - r.n).min(left);
            let (mut t, mut p) = (r.t, r.p);
            for _ in 0..take {
                f(self.resolve(r.s, t, p))?;
                t += self.lc;
                p = add(p, self.cs);
            }
            left -= take;
            if left == 0 {
                return ControlFlow::Continue(());
            }
            r.next_line(self);
        }
    }

    fn visit<B>(
        &self,
        lo: u64,
        hi: u64,
        f: &mut impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        if lo < self.half {
            self.visit_half(lo, hi.min(self.half), f)?;
        }
        let start = lo.max(self.half);
        if start < hi {
            let mut p = add(self.b_abs, scale((start - self.half) as i64, self.bm_step));
            for _ in start..hi {
                f(p)?;
                p = add(p, self.bm_step);
            }
        }
        ControlFlow::Continue(())
    }
}

/// Incremental state on one skew line of the parallelogram.
#[derive(Clone, Copy, Debug)]
struct Run {
    /// `S` of the line.
    s: u64,
    /// `T` of the current point.
    t: u64,
    /// `T` of the line's first point (`j·τ mod Lc`).
    rem: u64,
    /// Position of the current point on the line.
    n: u64,
    /// Points of the parallelogram on this line (`gc` or `gc + 1`).
    line_len: u64,
    /// First point of the line (absolute, unreflected).
    first: LatticePoint,
    /// Current point (absolute, unreflected).
    p: LatticePoint,
}

impl Run {
    /// Moves to the first point of the next line: `F += E`, minus one step
    /// along the line when `j·τ mod Lc` wraps (τ < Lc, so at most once).
    #[inline(always)]
    fn next_line(&mut self, pr: &Proper) {
        self.s += pr.gc;
        self.rem += pr.tau;
        // Branch-free: the wrap is data-dependent and unpredictable when lines
        // are short (gc = 1 is the common case).
        let wrap = (self.rem >= pr.lc) as u64;
        self.rem -= wrap * pr.lc;
        let w = wrap as i64;
        self.first = add(self.first, [pr.e[0] - w * pr.cs[0], pr.e[1] - w * pr.cs[1]]);
        self.p = self.first;
        self.t = self.rem;
        self.n = 0;
        self.line_len = pr.gc + (self.rem == 0) as u64;
    }

    #[inline(always)]
    fn advance(&mut self, pr: &Proper) {
        self.n += 1;
        if self.n == self.line_len {
            self.next_line(pr);
        } else {
            self.t += pr.lc;
            self.p = add(self.p, pr.cs);
        }
    }
}

impl TriangleIndex {
    /// Precomputes the indexing of the closed triangle `v[0] v[1] v[2]` (`O(bits)`).
    ///
    /// # Errors
    /// [`VoxkitError::Invalid`] if a coordinate is outside ±[`COORD_LIMIT`].
    /// Collinear vertices are not an error (see [`TriangleShape`]).
    pub fn new(v: [LatticePoint; 3]) -> Result<TriangleIndex> {
        check_vertices(&v)?;
        let d = orient(&v);
        // orient = (b−a)×(c−a) = x_b·y_c − y_b·x_c = −D in the paper's notation.
        let kind = if d == 0 {
            let (start, step, _) = collinear_segment(&v);
            Kind::Segment { start, step }
        } else {
            Kind::Proper(Proper::new(&v, -d))
        };
        let len = match &kind {
            Kind::Segment { .. } => collinear_segment(&v).2,
            Kind::Proper(p) => p.len(),
        };
        Ok(TriangleIndex {
            vertices: v,
            len,
            kind,
        })
    }

    /// The vertices as given.
    pub fn vertices(&self) -> [LatticePoint; 3] {
        self.vertices
    }

    /// Whether the triangle is proper, a segment or a point.
    pub fn shape(&self) -> TriangleShape {
        match self.kind {
            Kind::Proper(_) => TriangleShape::Triangle,
            Kind::Segment { step: [0, 0], .. } => TriangleShape::Point,
            Kind::Segment { .. } => TriangleShape::Segment,
        }
    }

    /// Number `K` of lattice points in the closed triangle (always ≥ 1).
    #[allow(clippy::len_without_is_empty)]
    pub fn len(&self) -> u64 {
        self.len
    }

    /// The point with index `i`, or `None` if `i ≥ len()`. `O(1)`.
    #[inline]
    pub fn point(&self, i: u64) -> Option<LatticePoint> {
        (i < self.len).then(|| self.point_unchecked(i))
    }

    /// The point with index `i`; `i` must be `< len()` (checked in debug builds
    /// only; a larger `i` gives an unspecified point, never undefined behaviour).
    #[inline]
    pub fn point_unchecked(&self, i: u64) -> LatticePoint {
        debug_assert!(i < self.len);
        match &self.kind {
            Kind::Proper(p) => p.point(i),
            Kind::Segment { start, step } => add(*start, scale(i as i64, *step)),
        }
    }

    /// The index of lattice point `p`, or `None` if `p` is outside the closed
    /// triangle. `O(1)`; any `p` is accepted.
    pub fn index_of(&self, p: LatticePoint) -> Option<u64> {
        match &self.kind {
            Kind::Proper(pr) => pr.index_of(p),
            Kind::Segment { start, step } => {
                let dx = p[0] as i128 - start[0] as i128;
                let dy = p[1] as i128 - start[1] as i128;
                let (sx, sy) = (step[0] as i128, step[1] as i128);
                let t = if sx != 0 {
                    dx / sx
                } else if sy != 0 {
                    dy / sy
                } else {
                    0
                };
                (t >= 0 && t < self.len as i128 && dx == t * sx && dy == t * sy).then_some(t as u64)
            }
        }
    }

    /// A uniformly random lattice point of the closed triangle. `O(1)`.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> LatticePoint {
        self.point_unchecked(rng.random_range(0..self.len))
    }

    /// Iterator over the points with indices in `range` (clamped to `0..len()`),
    /// in index order, stepping incrementally (`O(1)` setup).
    pub fn iter_range(&self, range: Range<u64>) -> Points<'_> {
        let end = range.end.min(self.len);
        let start = range.start.min(end);
        let run = match &self.kind {
            Kind::Proper(p) if start < p.half => Some(p.run_at(start)),
            _ => None,
        };
        Points {
            tri: self,
            next: start,
            end,
            run,
        }
    }

    /// Iterator over all points in index order.
    pub fn iter(&self) -> Points<'_> {
        self.iter_range(0..self.len)
    }

    /// Visits the points with indices in `range` (clamped to `0..len()`) in index
    /// order; `f` returns [`ControlFlow::Break`] to stop early, which is returned.
    #[inline]
    pub fn try_for_each_in_range<B>(
        &self,
        range: Range<u64>,
        mut f: impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let hi = range.end.min(self.len);
        let lo = range.start.min(hi);
        match &self.kind {
            Kind::Proper(p) => p.visit(lo, hi, &mut f),
            Kind::Segment { start, step } => {
                let mut q = add(*start, scale(lo as i64, *step));
                for _ in lo..hi {
                    f(q)?;
                    q = add(q, *step);
                }
                ControlFlow::Continue(())
            }
        }
    }

    /// Visits the points with indices in `range` (clamped) in index order.
    /// Threads may call this on disjoint ranges with no coordination.
    #[inline]
    pub fn for_each_in_range(&self, range: Range<u64>, mut f: impl FnMut(LatticePoint)) {
        let _ = self.try_for_each_in_range(range, |p| -> ControlFlow<()> {
            f(p);
            ControlFlow::Continue(())
        });
    }

    /// Visits every point in index order.
    pub fn for_each_point(&self, f: impl FnMut(LatticePoint)) {
        self.for_each_in_range(0..self.len, f)
    }

    /// Visits every point once in whichever order is cheapest: the index walk
    /// when its skew lines are long (`gc ≥ 4`) or the triangle has more rows
    /// than a quarter of its points (skinny), the scanline walk
    /// ([`ScanlineLattice`](super::ScanlineLattice)) otherwise (fat triangles
    /// with short skew lines). Use it when the order does not matter.
    pub fn for_each_point_unordered(&self, f: impl FnMut(LatticePoint)) {
        // The vertices were validated by `new`, so the scanline setup cannot fail.
        if self.prefers_scanline()
            && let Ok(s) = super::ScanlineLattice::new(self.vertices)
        {
            return s.for_each(f);
        }
        self.for_each_point(f)
    }

    /// Whether a full enumeration is cheaper row by row (see
    /// [`for_each_point_unordered`](Self::for_each_point_unordered)).
    pub fn prefers_scanline(&self) -> bool {
        match &self.kind {
            Kind::Segment { .. } => false,
            Kind::Proper(p) => {
                let y0 = self.vertices.iter().map(|v| v[1]).min().unwrap_or(0);
                let y1 = self.vertices.iter().map(|v| v[1]).max().unwrap_or(0);
                let rows = (y1 - y0) as u64 + 1;
                p.gc < 4 && rows.saturating_mul(4) <= self.len
            }
        }
    }

    /// Visits every point once, in parallel: `0..len()` is cut into even index
    /// ranges (about four per rayon thread, at least `min_chunk` points each)
    /// that threads enumerate independently. Order is unspecified.
    pub fn for_each_point_par(&self, min_chunk: u64, f: impl Fn(LatticePoint) + Sync + Send) {
        let chunks = even_chunks(self.len, min_chunk);
        chunks
            .into_par_iter()
            .for_each(|r| self.for_each_in_range(r, &f));
    }

    /// A rayon parallel iterator over all points (even index ranges, each
    /// stepped incrementally). Collecting it gives the points in index order.
    pub fn par_points(&self) -> impl ParallelIterator<Item = LatticePoint> + '_ {
        even_chunks(self.len, 1 << 12)
            .into_par_iter()
            .flat_map_iter(move |r| self.iter_range(r))
    }
}

/// Cuts `0..len` into about `4 × threads` even ranges of at least `min_chunk`
/// indices (at least one range).
pub(crate) fn even_chunks(len: u64, min_chunk: u64) -> Vec<Range<u64>> {
    let want = (rayon::current_num_threads() as u64 * 4).max(1);
    let size = len.div_ceil(want).max(min_chunk.max(1));
    let n = len.div_ceil(size).max(1);
    (0..n)
        .map(|c| (c * size).min(len)..((c + 1) * size).min(len))
        .collect()
}

/// Iterator over an index range of a [`TriangleIndex`] (see
/// [`TriangleIndex::iter_range`]); exact-size.
#[derive(Clone, Debug)]
pub struct Points<'a> {
    tri: &'a TriangleIndex,
    next: u64,
    end: u64,
    run: Option<Run>,
}

impl Iterator for Points<'_> {
    type Item = LatticePoint;

    #[inline]
    fn next(&mut self) -> Option<LatticePoint> {
        if self.next >= self.end {
            return None;
        }
        let i = self.next;
        self.next += 1;
        match (&self.tri.kind, &mut self.run) {
            (Kind::Proper(pr), Some(run)) if i < pr.half => {
                let out = pr.resolve(run.s, run.t, run.p);
                run.advance(pr);
                Some(out)
            }
            _ => Some(self.tri.point_unchecked(i)),
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = (self.end - self.next) as usize;
        (n, Some(n))
    }
}

impl ExactSizeIterator for Points<'_> {}
