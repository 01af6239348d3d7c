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
//! The three divisions of `point` (by the group length, `gc` and `Lc`) and
//! those of `index_of` are by per-triangle constants, so they are done with
//! precomputed reciprocals (Möller–Granlund, `recip.rs`): a few multiplications,
//! the same cost at every triangle size (a hardware 64- or 128-bit `div` gets
//! slower as the operands grow).
//!
//! # Enumeration
//!
//! An index range is walked from one `O(1)` locate with additions only: the
//! next line's first point is the previous one plus `E`, minus one step along
//! the line when `T` wraps past `Lc` (a carried remainder, no division).
//! [`TriangleIndex::for_each_in_range_unordered`] visits the same range in no
//! particular order: the whole skew lines inside it form a strip
//! `S_lo ≤ S ≤ S_hi` (`2·S_hi < |D|`), whose kept points are the triangle's
//! points in the strip and whose mirrored points are the triangle's points with
//! `|D| − S_hi ≤ S ≤ |D| − S_lo, S + T < |D|` — two convex lattice polygons,
//! scanned row by row like [`ScanlineLattice`](super::ScanlineLattice). On fat
//! triangles, whose skew lines hold one to three points, this is several times
//! cheaper per point than the ordered walk.
//!
//! The inverse follows the same route backwards: `j = S/gc`, `n = ⌊T/Lc⌋`,
//! rank `j·gc + ⌈j/M⌉ + n` (`M = |D|/(gb·gc)` lines per group), and a rank
//! `≥ H` belongs to the mirror point, index `k − 1 − rank`.
//!
//! # Range
//!
//! Vertex coordinates must satisfy `|x|, |y| ≤ 2^30` ([`COORD_LIMIT`]). Then
//! `|D| ≤ 2^62`, every count and index fits in `u64`, and all internal values
//! are exact (i64 / u64, one 64×64→128-bit product per point, no wide division).
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

use super::recip::Recip;
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
    /// Reciprocals of the group length `|D|/gb + 1`, `gc`, `Lc`, `M` and `|D|/gbc`: the
    /// divisions of `point` and `index_of` by these per-triangle constants
    /// become multiplications, so their cost does not grow with the triangle.
    div_group: Recip,
    div_gc: Recip,
    div_lc: Recip,
    div_lines: Recip,
    div_bm: Recip,
}

// Unboxed on purpose: `point(i)` reads these constants on every call, and
// `TriangleIndex` stays `Copy`; a few hundred bytes per triangle is fine.
#[allow(clippy::large_enum_variant)]
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
            cs,
            e,
            tau,
            k,
            half: k / 2,
            bm_step: [(c[0] - b[0]) / gbc as i64, (c[1] - b[1]) / gbc as i64],
            bm_t_step: dabs / gbc,
            div_group: Recip::new(dabs / gb + 1),
            div_gc: Recip::new(gc),
            div_lc: Recip::new(lc),
            div_lines: Recip::new(dabs / (gb * gc)),
            div_bm: Recip::new(dabs / gbc),
        }
    }

    /// Number of points: `⌊k/2⌋ + ⌊gbc/2⌋ + 1`.
    fn len(&self) -> u64 {
        self.half + (self.dabs / self.bm_t_step) / 2 + 1
    }

    /// Line `j` and position `n` on it of parallelogram rank `i < H`.
    #[inline(always)]
    fn line_of(&self, i: u64) -> (u64, u64) {
        let (g, r) = self.div_group.divrem(i);
        let (l, n) = if r <= self.gc {
            (0, r)
        } else {
            let (l, n) = self.div_gc.divrem(r - self.gc - 1);
            (l + 1, n)
        };
        (g * self.lines_per_group + l, n)
    }

    /// Start of a run at parallelogram rank `i < H`.
    #[inline(always)]
    fn run_at(&self, i: u64) -> Run {
        let (j, n) = self.line_of(i);
        // j·τ < Lc·2^64 (τ < Lc), so the quotient fits u64.
        let (q, rem) = self.div_lc.mul_divrem(j, self.tau);
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
            return Some(self.half + self.div_bm.divrem(t).0);
        }
        let j = self.div_gc.divrem(s).0;
        // ⌈j/M⌉ with j ≤ |D| < 2^63: no overflow.
        let groups = self.div_lines.divrem(j + self.lines_per_group - 1).0;
        let rank = j * self.gc + groups + self.div_lc.divrem(t).0;
        Some(if rank < self.half {
            rank
        } else {
            self.k - 1 - rank
        })
    }

    /// Visits parallelogram ranks `lo..hi` (`lo < hi ≤ H`), line by line.
    ///
    /// One `O(1)` locate ([`run_at`](Self::run_at)), then additions only:
    /// each next line's first point and `T` come from the previous line's by
    /// adding `E` and carrying `τ` modulo `Lc` ([`Run::next_line`]).
    #[inline(always)]
    fn visit_half<B>(
        &self,
        lo: u64,
        hi: u64,
        f: &mut impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let mut r = self.run_at(lo);
        let mut left = hi - lo;
        // The first line may be entered mid-line.
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
        if self.gc == 1 {
            self.visit_lines_gc1(r, left, f)
        } else {
            self.visit_lines(r, left, f)
        }
    }

    /// `left ≥ 1` points from the start of line `r`, lines of `gc` or
    /// `gc + 1` points.
    #[inline(always)]
    fn visit_lines<B>(
        &self,
        mut r: Run,
        mut left: u64,
        f: &mut impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        loop {
            let take = r.line_len.min(left);
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

    /// [`visit_lines`](Self::visit_lines) for `gc = 1` (the common case of
    /// fat generic triangles): one point per line (`T` = the carried
    /// remainder), two when the remainder is 0 (`T = 0` and `T = Lc`). No
    /// inner loop, so the per-point cost is a handful of additions.
    #[inline(always)]
    fn visit_lines_gc1<B>(
        &self,
        r: Run,
        mut left: u64,
        f: &mut impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let (mut s, mut rem, mut first) = (r.s, r.rem, r.first);
        let (lc, tau) = (self.lc, self.tau);
        let step = self.e;
        let step_wrap = sub(self.e, self.cs);
        loop {
            f(self.resolve(s, rem, first))?;
            left -= 1;
            if rem == 0 && left > 0 {
                f(self.resolve(s, lc, add(first, self.cs)))?;
                left -= 1;
            }
            if left == 0 {
                return ControlFlow::Continue(());
            }
            s += 1;
            rem += tau;
            // Masks, not branches: the wrap is unpredictable.
            let m = 0u64.wrapping_sub((rem >= lc) as u64);
            rem -= lc & m;
            let mi = m as i64;
            first = add(
                first,
                [
                    step[0] ^ ((step[0] ^ step_wrap[0]) & mi),
                    step[1] ^ ((step[1] ^ step_wrap[1]) & mi),
                ],
            );
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

impl Proper {
    /// Rank of the first point of line `j`: `j·gc + ⌈j/M⌉`.
    #[inline(always)]
    fn line_start(&self, j: u64) -> u64 {
        j * self.gc + self.div_lines.divrem(j + self.lines_per_group - 1).0
    }

    /// Points of line `j` in the parallelogram: `gc`, or `gc + 1` when its
    /// first point has `T = 0`.
    #[inline(always)]
    fn line_len(&self, j: u64) -> u64 {
        self.gc + (self.div_lc.mul_divrem(j, self.tau).1 == 0) as u64
    }

    /// Visits parallelogram ranks `lo..hi` (`lo < hi ≤ H`) once each, in no
    /// particular order.
    ///
    /// The whole skew lines `jf..jz` inside the range are a strip
    /// `S_lo ≤ S ≤ S_hi` of the parallelogram with `2·S_hi < |D|`. Its points
    /// with `S + T ≤ |D|` are emitted as they are and the others mirrored
    /// (`P' = b + c − P`), so the emitted set is the triangle's points in the
    /// strip plus the triangle's points with `|D| − S_hi ≤ S ≤ |D| − S_lo`,
    /// `S + T < |D|`: two convex lattice polygons, scanned row by row with
    /// additions only ([`scan_strip`](Self::scan_strip)). The cut lines at
    /// both ends are walked in index order. Strips are used only when they hold
    /// at least twice as many points as they span rows (fat triangles with short
    /// skew lines); otherwise the index walk is cheaper.
    fn visit_half_unordered<B>(
        &self,
        lo: u64,
        hi: u64,
        f: &mut impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let Some(plan) = self.strip_plan(lo, hi) else {
            return self.visit_half(lo, hi, f);
        };
        if lo < plan.ranks.start {
            self.visit_half(lo, plan.ranks.start, f)?;
        }
        let (s_lo, s_hi, d) = (plan.s.0, plan.s.1, self.dabs);
        self.scan_strip(s_lo, s_hi, d, plan.direct_rows, f)?;
        self.scan_strip(d - s_hi, d - s_lo, d - 1, plan.mirror_rows, f)?;
        if plan.ranks.end < hi {
            self.visit_half(plan.ranks.end, hi, f)?;
        }
        ControlFlow::Continue(())
    }

    /// The strip of whole lines inside ranks `lo..hi` (`lo < hi ≤ H`), if
    /// scanning it row by row pays (see
    /// [`visit_half_unordered`](Self::visit_half_unordered)).
    fn strip_plan(&self, lo: u64, hi: u64) -> Option<StripPlan> {
        let (j0, n0) = self.line_of(lo);
        let jf = j0 + (n0 != 0) as u64;
        let (jl, nl) = self.line_of(hi - 1);
        let jz = jl + (nl + 1 == self.line_len(jl)) as u64;
        if jz <= jf || 2 * (jz - 1) * self.gc >= self.dabs {
            return None;
        }
        let (s_lo, s_hi) = (jf * self.gc, (jz - 1) * self.gc);
        let ranks = self.line_start(jf)..self.line_start(jz);
        debug_assert!(lo <= ranks.start && ranks.start < ranks.end && ranks.end <= hi);
        let direct_rows = self.strip_rows(s_lo, s_hi, self.dabs);
        let mirror_rows = self.strip_rows(self.dabs - s_hi, self.dabs - s_lo, self.dabs - 1);
        let rows =
            (direct_rows.1 - direct_rows.0 + 1).max(0) + (mirror_rows.1 - mirror_rows.0 + 1).max(0);
        ((ranks.end - ranks.start) as i128 >= 2 * rows).then_some(StripPlan {
            s: (s_lo, s_hi),
            ranks,
            direct_rows,
            mirror_rows,
        })
    }

    /// Row range `(Y_lo, Y_hi)` (relative to `a`) of the polygon
    /// `s_lo ≤ S ≤ s_hi, T ≥ 0, S + T ≤ u`, from its vertices `P = (S·b + T·c)/|D|`.
    fn strip_rows(&self, s_lo: u64, s_hi: u64, u: u64) -> (i128, i128) {
        let y = |s: u64, t: u64| s as i128 * self.b[1] as i128 + t as i128 * self.c[1] as i128;
        // Past S = u the side S + T ≤ u cuts the strip off before S = s_hi
        // (the mirror strip can reach S = |D| > u = |D| − 1).
        if s_lo > u {
            return (0, -1); // empty: the mirror of a strip holding only S = 0
        }
        let s_hi = s_hi.min(u);
        let v = [y(s_lo, 0), y(s_hi, 0), y(s_hi, u - s_hi), y(s_lo, u - s_lo)];
        let d = self.dabs as i128;
        let min = v.iter().copied().min().unwrap_or(0);
        let max = v.iter().copied().max().unwrap_or(0);
        (-(-min).div_euclid(d), max.div_euclid(d))
    }

    /// Visits the lattice points of `s_lo ≤ S ≤ s_hi, T ≥ 0, S + T ≤ u` on rows
    /// `rows.0..=rows.1` (from [`strip_rows`](Self::strip_rows)), row by row.
    /// Each side `α·X ≤ β·Y + γ` bounds `X` by `⌊(β·Y + γ)/|α|⌋`, stepped per
    /// row as quotient + remainder (i128: `β·Y + γ` can pass 2^63).
    #[inline(always)]
    fn scan_strip<B>(
        &self,
        s_lo: u64,
        s_hi: u64,
        u: u64,
        rows: (i128, i128),
        f: &mut impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let sg = self.sigma as i128;
        let (xb, yb) = (self.b[0] as i128, self.b[1] as i128);
        let (xc, yc) = (self.c[0] as i128, self.c[1] as i128);
        // (α, β, γ) of the four sides.
        let sides = [
            (sg * yc, sg * xc, -(s_lo as i128)),
            (-sg * yc, -sg * xc, s_hi as i128),
            (-sg * yb, -sg * xb, 0),
            (sg * (yb - yc), sg * (xb - xc), u as i128),
        ];
        let mut bounds = [(false, FloorStep128::new(0, 0, 1)); 4];
        let mut nb = 0;
        for (al, be, ga) in sides {
            if al != 0 {
                // α = 0 sides only bound Y, which the row range already does.
                bounds[nb] = (al > 0, FloorStep128::new(be * rows.0 + ga, be, al.abs()));
                nb += 1;
            }
        }
        let bounds = &mut bounds[..nb];
        // The polygon lies in the triangle's box: clamping there makes the
        // spans fit i64.
        let x_min = 0.min(self.b[0]).min(self.c[0]);
        let x_max = 0.max(self.b[0]).max(self.c[0]);
        let mut y = rows.0;
        while y <= rows.1 {
            let (mut lo, mut hi) = (x_min as i128, x_max as i128);
            for (upper, fs) in bounds.iter_mut() {
                if *upper {
                    hi = hi.min(fs.q);
                } else {
                    lo = lo.max(-fs.q);
                }
                fs.step();
            }
            let yy = self.a[1] + y as i64;
            for x in lo as i64..=hi as i64 {
                f([self.a[0] + x, yy])?;
            }
            y += 1;
        }
        ControlFlow::Continue(())
    }

    fn visit_unordered<B>(
        &self,
        lo: u64,
        hi: u64,
        f: &mut impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let mid = hi.min(self.half);
        if lo < mid {
            self.visit_half_unordered(lo, mid, f)?;
        }
        self.visit(lo.max(self.half), hi.max(self.half), f)
    }
}

/// Whole skew lines `S = s.0 ..= s.1` (ranks `ranks`) of an index range and
/// the row ranges of their two polygons.
#[derive(Clone, Debug)]
struct StripPlan {
    s: (u64, u64),
    ranks: Range<u64>,
    direct_rows: (i128, i128),
    mirror_rows: (i128, i128),
}

/// Exact incremental `⌊num/den⌋` (`den > 0`) with `num` growing by `dnum` per step.
#[derive(Clone, Copy, Debug)]
struct FloorStep128 {
    q: i128,
    r: i128,
    dq: i128,
    dr: i128,
    den: i128,
}

impl FloorStep128 {
    fn new(num: i128, dnum: i128, den: i128) -> Self {
        FloorStep128 {
            q: num.div_euclid(den),
            r: num.rem_euclid(den),
            dq: dnum.div_euclid(den),
            dr: dnum.rem_euclid(den),
            den,
        }
    }

    #[inline(always)]
    fn step(&mut self) {
        self.q += self.dq;
        self.r += self.dr;
        if self.r >= self.den {
            self.r -= self.den;
            self.q += 1;
        }
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

    /// Visits the points with indices in `range` (clamped to `0..len()`) once
    /// each, in an unspecified order; `f` returns [`ControlFlow::Break`] to stop
    /// early. `O(1)` setup like the ordered walk, but on fat triangles with
    /// short skew lines the whole lines inside the range are scanned as two
    /// lattice polygons row by row (see the module docs), which is about as
    /// fast as scanline enumeration. Threads may call this on disjoint ranges
    /// with no coordination; together they visit every point exactly once.
    ///
    /// ```
    /// use voxkit::triangle::TriangleIndex;
    /// let t = TriangleIndex::new([[0, 0], [90, 20], [25, 80]]).unwrap();
    /// let mut got = Vec::new();
    /// t.for_each_in_range_unordered(100..3000, |p| got.push(p));
    /// got.sort();
    /// let mut want: Vec<_> = (100..3000).map(|i| t.point(i).unwrap()).collect();
    /// want.sort();
    /// assert_eq!(got, want);
    /// ```
    #[inline]
    pub fn try_for_each_in_range_unordered<B>(
        &self,
        range: Range<u64>,
        mut f: impl FnMut(LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let hi = range.end.min(self.len);
        let lo = range.start.min(hi);
        match &self.kind {
            Kind::Proper(p) => p.visit_unordered(lo, hi, &mut f),
            Kind::Segment { .. } => self.try_for_each_in_range(lo..hi, f),
        }
    }

    /// [`try_for_each_in_range_unordered`](Self::try_for_each_in_range_unordered)
    /// without early stop.
    #[inline]
    pub fn for_each_in_range_unordered(&self, range: Range<u64>, mut f: impl FnMut(LatticePoint)) {
        let _ = self.try_for_each_in_range_unordered(range, |p| -> ControlFlow<()> {
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
            .for_each(|r| self.for_each_in_range_unordered(r, &f));
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The row-strip path of the unordered range walk is taken on fat
    /// triangles with short skew lines (also next to the coordinate limits,
    /// where the strip bounds need i128), and not on skinny slivers; where it
    /// is taken, it visits exactly the range's points.
    #[test]
    fn strip_path_taken_where_it_pays() {
        let l = COORD_LIMIT;
        let fat = [
            [[-1, -3], [141, 21], [33, 141]],
            [[l - 150, l], [l, l - 140], [l - 20, l - 3]],
            [[-l, -l + 90], [-l + 101, -l], [-l + 7, -l + 2]],
        ];
        for v in fat {
            let t = TriangleIndex::new(v).unwrap();
            let Kind::Proper(p) = t.kind else { panic!() };
            for (lo, hi) in [(0, p.half), (3, p.half - 5), (p.half / 3, p.half - 1)] {
                assert!(p.strip_plan(lo, hi).is_some(), "{v:?} {lo}..{hi}");
                let mut got = Vec::new();
                t.for_each_in_range_unordered(lo..hi, |q| got.push(q));
                got.sort();
                let mut want: Vec<_> = (lo..hi).map(|i| t.point_unchecked(i)).collect();
                want.sort();
                assert_eq!(got, want, "{v:?} {lo}..{hi}");
            }
        }
        let t = TriangleIndex::new([[0, 0], [100_000, 100_001], [300, 300]]).unwrap();
        let Kind::Proper(p) = t.kind else { panic!() };
        assert!(p.strip_plan(0, p.half).is_none());
    }
}
