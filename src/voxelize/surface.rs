//! Thin (6-tunnel-free) and thick (26-tunnel-free) surface voxelization by
//! lattice-line crossings.
//!
//! # Method
//! A *family* of lattice lines is a set of parallel lines through voxel
//! centres: the three axis families (thin) or the four body-diagonal families
//! `(1, ±1, ±1)` (thick). For each family, a unimodular integer map takes grid
//! coordinates `(x, y, z)` to `(u, v, t)` so that the family's lines are the
//! lines `u = i, v = j` (integers) and `t` runs along them. A triangle is
//! projected onto the `(u, v)` plane; for every lattice point `(i, j)` in the
//! *closed* projected triangle the line meets the triangle at depth `t`, and
//! the voxel at `T = floor(t + 1/2)` on that line is set.
//!
//! *Why thin blocks 6-tunnels:* a 6-step between two voxel centres lies on an
//! axis line; if the surface crosses it at depth `t ∈ [k, k+1]`, the line's
//! crossing voxel `floor(t + 1/2)` is `k` or `k + 1`, one of the step's ends.
//! *Thick* does the same for the body diagonals: any 26-step is two half-steps
//! along body diagonals through a shared voxel corner.
//!
//! # Exactness
//! Vertices are fixed point with [`VOXEL_FRAC_BITS`] fraction bits in grid
//! space. Every decision — which lattice points lie in the closed projected
//! triangle, and the rounded depth — is exact integer arithmetic on those
//! fixed-point vertices: no epsilon, no sliver threshold. A projection with
//! zero area (the plane contains the family's direction) is skipped: the
//! family's lines meet such a triangle in segments or not at all, and the
//! other families of the mode cover it. Each triangle is translated to a local
//! lattice origin so that all products fit `i64` for triangles spanning up to
//! [`MAX_TRIANGLE_SPAN`] voxels; wider triangles take an `i128` path.

use super::slab::{BRICK, BrickBits, BrickBox, BrickList, SlabBricks};
use crate::grid::Voxel;

/// Fraction bits of the fixed-point vertices the surface kernels take
/// (1/256 voxel).
pub const VOXEL_FRAC_BITS: u32 = 8;

/// The fixed-point value of one voxel for [`VOXEL_FRAC_BITS`].
pub const VOXEL_ONE: i64 = 1 << VOXEL_FRAC_BITS;

/// Widest triangle (in voxels, along any family axis) handled by the `i64`
/// kernel; the numerator of the depth rounding is bounded by about
/// `2^(3·FRAC + 5) · span^3`, which must stay below `2^62`.
pub const MAX_TRIANGLE_SPAN: i64 = 1 << 10;

/// A triangle with fixed-point grid-space vertices ([`VOXEL_FRAC_BITS`]).
pub type SurfaceTriangle = [[i64; 3]; 3];

/// A family of parallel lattice lines through voxel centres.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineFamily {
    /// Lines parallel to axis 0 (x), 1 (y) or 2 (z).
    Axis(usize),
    /// Lines along the body diagonal `(1, s1, s2)` with `s1, s2 ∈ {−1, 1}`.
    Diagonal(i8, i8),
}

/// The three axis families: thin, 6-tunnel-free surfaces.
pub const THIN_FAMILIES: [LineFamily; 3] = [
    LineFamily::Axis(0),
    LineFamily::Axis(1),
    LineFamily::Axis(2),
];

/// The four body-diagonal families: thick, 26-tunnel-free surfaces.
pub const THICK_FAMILIES: [LineFamily; 4] = [
    LineFamily::Diagonal(1, 1),
    LineFamily::Diagonal(1, -1),
    LineFamily::Diagonal(-1, 1),
    LineFamily::Diagonal(-1, -1),
];

impl LineFamily {
    /// Grid `(x, y, z)` → family coordinates `(u, v, t)`; lines are `u, v`
    /// constant. Linear and unimodular, so it maps fixed-point values and the
    /// integer lattice onto themselves.
    #[inline]
    pub fn to_family(self, p: [i64; 3]) -> [i64; 3] {
        let [x, y, z] = p;
        match self {
            LineFamily::Axis(0) => [y, z, x],
            LineFamily::Axis(1) => [z, x, y],
            LineFamily::Axis(_) => [x, y, z],
            LineFamily::Diagonal(s1, s2) => [y - s1 as i64 * x, z - s2 as i64 * x, x],
        }
    }

    /// The family's compile-time code for [`family_voxel`]: axes 0–2, then
    /// the diagonals `(1,1)`, `(1,−1)`, `(−1,1)`, `(−1,−1)` as 3–6.
    const fn code(self) -> u8 {
        match self {
            LineFamily::Axis(a) => {
                if a < 2 {
                    a as u8
                } else {
                    2
                }
            }
            LineFamily::Diagonal(s1, s2) => 3 + 2 * (s1 < 0) as u8 + (s2 < 0) as u8,
        }
    }

    /// Family coordinates of a lattice point `(i, j, T)` → its voxel.
    #[inline]
    pub fn to_voxel(self, i: i64, j: i64, t: i64) -> Voxel {
        let (x, y, z) = match self {
            LineFamily::Axis(0) => (t, i, j),
            LineFamily::Axis(1) => (j, t, i),
            LineFamily::Axis(_) => (i, j, t),
            LineFamily::Diagonal(s1, s2) => (t, i + s1 as i64 * t, j + s2 as i64 * t),
        };
        Voxel::new(x as i32, y as i32, z as i32)
    }
}

/// [`family_voxel`] of a row's lattice point: `(i, j, t)`, or with `T`
/// (a row scanned along v) `(j, i, t)`.
#[inline(always)]
fn row_voxel<const F: u8, const T: bool>(i: i64, j: i64, t: i64) -> Voxel {
    if T {
        family_voxel::<F>(j, i, t)
    } else {
        family_voxel::<F>(i, j, t)
    }
}

/// [`LineFamily::to_voxel`] for the family with code `F`, resolved at compile
/// time so the per-voxel path has no branch on the family.
#[inline(always)]
fn family_voxel<const F: u8>(i: i64, j: i64, t: i64) -> Voxel {
    let (x, y, z) = match F {
        0 => (t, i, j),
        1 => (j, t, i),
        2 => (i, j, t),
        3 => (t, i + t, j + t),
        4 => (t, i + t, j - t),
        5 => (t, i - t, j + t),
        _ => (t, i - t, j - t),
    };
    Voxel::new(x as i32, y as i32, z as i32)
}

/// Calls `emit` with the crossing voxel of every lattice line of `family`
/// that meets the closed triangle in a single point.
///
/// ```
/// use voxkit::voxelize::surface::{triangle_crossings, LineFamily, VOXEL_ONE};
/// // A triangle in the plane z = 0.25 covering lattice points (0,0), (1,0), (0,1).
/// let q = VOXEL_ONE / 4;
/// let tri = [[0, 0, q], [VOXEL_ONE, 0, q], [0, VOXEL_ONE, q]];
/// let mut got = Vec::new();
/// triangle_crossings(&tri, LineFamily::Axis(2), &mut |v| got.push(v.to_array()));
/// got.sort();
/// assert_eq!(got, vec![[0, 0, 0], [0, 1, 0], [1, 0, 0]]);
/// ```
pub fn triangle_crossings(tri: &SurfaceTriangle, family: LineFamily, emit: &mut impl FnMut(Voxel)) {
    match family.code() {
        0 => family_crossings::<0>(tri, emit),
        1 => family_crossings::<1>(tri, emit),
        2 => family_crossings::<2>(tri, emit),
        3 => family_crossings::<3>(tri, emit),
        4 => family_crossings::<4>(tri, emit),
        5 => family_crossings::<5>(tri, emit),
        _ => family_crossings::<6>(tri, emit),
    }
}

/// [`triangle_crossings`] for the family with code `F`.
#[inline(always)]
fn family_crossings<const F: u8>(tri: &SurfaceTriangle, emit: &mut impl CrossingSink) {
    let family = match F {
        0..=2 => LineFamily::Axis(F as usize),
        3 => LineFamily::Diagonal(1, 1),
        4 => LineFamily::Diagonal(1, -1),
        5 => LineFamily::Diagonal(-1, 1),
        _ => LineFamily::Diagonal(-1, -1),
    };
    let p = tri.map(|q| family.to_family(q));
    let (origin, l, span) = localize(&p);
    let n = normal(&l);
    crossings_from::<F>(&l, n, origin, span, emit);
}

/// The thin mode's three axis families of one triangle, sharing the set-up
/// they have in common: the axis families' maps are cyclic permutations of
/// the coordinates, so one local origin and one normal serve all three,
/// permuted.
#[inline(always)]
fn thin_crossings(tri: &SurfaceTriangle, emit: &mut impl CrossingSink) {
    let (origin, l, span) = localize(tri);
    let n = normal(&l);
    let cyc = |v: [i64; 3], k: usize| [v[k % 3], v[(k + 1) % 3], v[(k + 2) % 3]];
    // Axis(0) maps (x, y, z) to (y, z, x): rotation by one; Axis(1) by two.
    crossings_from::<0>(&l.map(|q| cyc(q, 1)), cyc(n, 1), cyc(origin, 1), span, emit);
    crossings_from::<1>(&l.map(|q| cyc(q, 2)), cyc(n, 2), cyc(origin, 2), span, emit);
    crossings_from::<2>(&l, n, origin, span, emit);
}

/// Local lattice origin (the floored minimum corner, in lattice units), the
/// vertices relative to it (non-negative, bounded by the span) and the span
/// in voxels.
#[inline(always)]
fn localize(p: &[[i64; 3]; 3]) -> ([i64; 3], [[i64; 3]; 3], i64) {
    let mut origin = [0i64; 3];
    let mut span = 0i64;
    for a in 0..3 {
        let lo = p[0][a].min(p[1][a]).min(p[2][a]);
        let hi = p[0][a].max(p[1][a]).max(p[2][a]);
        origin[a] = lo >> VOXEL_FRAC_BITS;
        span = span.max((hi >> VOXEL_FRAC_BITS) - origin[a] + 1);
    }
    let l = p.map(|q| std::array::from_fn(|a| q[a] - (origin[a] << VOXEL_FRAC_BITS)));
    (origin, l, span)
}

/// The plane normal `e1 × e2` of local vertices; in `i64` it cannot
/// overflow for spans up to [`MAX_TRIANGLE_SPAN`] (products below 2^38).
/// Wider triangles recompute it in `i128`.
#[inline(always)]
fn normal<I: KernelInt>(p: &[[I; 3]; 3]) -> [I; 3] {
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ]
}

/// Runs the kernel on local family coordinates `l` with normal `n`, emitting
/// grid voxels of family `F` (offset by the local `origin`).
#[inline(always)]
fn crossings_from<const F: u8>(
    l: &[[i64; 3]; 3],
    n: [i64; 3],
    origin: [i64; 3],
    span: i64,
    sink: &mut impl CrossingSink,
) {
    // The family's voxel map is linear: map the origin once.
    let base = family_voxel::<F>(origin[0], origin[1], origin[2]);
    if span <= MAX_TRIANGLE_SPAN {
        // Rows cost a set-up each and crossings the same either way: scan
        // along whichever of u and v gives fewer rows. Scanning along v is
        // the kernel on (v, u, t), whose normal is −(b, a, c) (swapping two
        // coordinates flips the cross product).
        let rows = |a: usize| {
            let lo = l[0][a].min(l[1][a]).min(l[2][a]);
            let hi = l[0][a].max(l[1][a]).max(l[2][a]);
            (hi >> VOXEL_FRAC_BITS) + ((-lo) >> VOXEL_FRAC_BITS)
        };
        if rows(0) < rows(1) {
            let swapped = l.map(|q| [q[1], q[0], q[2]]);
            let n = [-n[1], -n[0], -n[2]];
            crossings_local::<i64>(&swapped, n, &mut |row| sink.row::<F, true>(base, row));
        } else {
            crossings_local::<i64>(l, n, &mut |row| sink.row::<F, false>(base, row));
        }
    } else {
        for [i, j, t] in crossings_wide(l) {
            sink.voxel(family_voxel::<F>(i, j, t) + base);
        }
    }
}

/// One row of a projected triangle's crossings in local family coordinates:
/// the lattice points `i` in `lo..=hi` of row `j`. The first has depth voxel
/// `t` with remainder `r` (of `den`); each step in `i` adds `qi` to `t` and
/// `ri` to `r`, carrying one into `t` when `r` reaches `den`.
#[derive(Clone, Copy, Debug)]
struct Row<I> {
    j: I,
    lo: I,
    hi: I,
    t: I,
    r: I,
    qi: I,
    ri: I,
    den: I,
}

impl<I: KernelInt> Row<I> {
    /// Calls `f(i, t)` for every crossing of the row, in order.
    #[inline(always)]
    fn for_each(self, mut f: impl FnMut(I, I)) {
        let Row {
            lo,
            hi,
            mut t,
            mut r,
            qi,
            ri,
            den,
            ..
        } = self;
        let mut i = lo;
        loop {
            f(i, t);
            if i == hi {
                break;
            }
            i += I::ONE;
            t += qi;
            r += ri;
            let over = r >= den;
            r -= I::select(over, den, I::ZERO);
            t += I::select(over, I::ONE, I::ZERO);
        }
    }
}

/// Where the kernel's crossings go: one voxel at a time, or (to let a sink
/// step its own storage along the row) a row of family `F` at a time.
/// Every `FnMut(Voxel)` closure is a sink.
trait CrossingSink {
    /// Takes one crossing voxel.
    fn voxel(&mut self, v: Voxel);

    /// Takes the crossings of `row` of family `F`, offset by `base` (grid
    /// voxel of the local origin), with the row's coordinates swapped when
    /// `T` (see [`row_voxel`]); by default one voxel at a time.
    #[inline(always)]
    fn row<const F: u8, const T: bool>(&mut self, base: Voxel, row: Row<i64>) {
        let j = row.j;
        row.for_each(|i, t| self.voxel(row_voxel::<F, T>(i, j, t) + base));
    }
}

impl<T: FnMut(Voxel)> CrossingSink for T {
    #[inline(always)]
    fn voxel(&mut self, v: Voxel) {
        self(v)
    }
}

/// A [`BrickBox`] placed at `origin` as a crossing sink: rows are stepped in
/// the box's bit address directly.
struct Staging<'a> {
    staged: &'a mut BrickBox,
    origin: [i32; 3],
}

impl CrossingSink for Staging<'_> {
    #[inline(always)]
    fn voxel(&mut self, v: Voxel) {
        self.staged.set(self.origin, v);
    }

    /// A crossing's bit in the box is `x₀₋₂ | y₀₋₂ << 3 | z₀₋₂ << 6 | x₃₋₄ << 9
    /// | y₃₋₄ << 11 | z₃₋₄ << 13` (bit in brick word, word in brick, brick in
    /// box) of its box-relative coordinates: each coordinate sits in its own
    /// bits ("dilated"), so a step along the row adds a constant to each
    /// coordinate's bits — with the other bits set to one so the carry runs
    /// through them — instead of recomputing the address from x, y, z.
    #[inline(always)]
    fn row<const F: u8, const T: bool>(&mut self, base: Voxel, row: Row<i64>) {
        #[inline(always)]
        fn dilate(v: u32, axis: u32) -> u32 {
            (v & 7) << (3 * axis) | (v >> 3 & 3) << (9 + 2 * axis)
        }
        let o = self.origin;
        let first = row_voxel::<F, T>(row.lo, row.j, row.t) + base;
        let first = [first.x - o[0], first.y - o[1], first.z - o[2]];
        // The family's map is linear: a step moves by the row map of
        // (1, 0, qi) or (1, 0, qi + 1), taken modulo the box's 32 voxels.
        let step = |dt: i64| {
            let v = row_voxel::<F, T>(1, 0, dt);
            [v.x, v.y, v.z]
        };
        let (s0, s1) = (step(row.qi), step(row.qi + 1));
        // Axes the family never moves along a row (known at compile time).
        let moves = {
            let (a, b) = (step(0), family_voxel::<F>(0, 0, 1));
            [
                a[0] != 0 || b.x != 0,
                a[1] != 0 || b.y != 0,
                a[2] != 0 || b.z != 0,
            ]
        };
        let mask: [u32; 3] = std::array::from_fn(|a| dilate(31, a as u32));
        let mut p: [u32; 3] = std::array::from_fn(|a| dilate(first[a] as u32, a as u32));
        let d0: [u32; 3] = std::array::from_fn(|a| dilate(s0[a] as u32 & 31, a as u32));
        let d1: [u32; 3] = std::array::from_fn(|a| dilate(s1[a] as u32 & 31, a as u32));
        let words = self.staged.words_mut();
        let (mut r, ri, den) = (row.r, row.ri, row.den);
        let mut left = row.hi - row.lo;
        loop {
            let addr = (p[0] | p[1] | p[2]) as usize;
            words[(addr >> 6) & 511] |= 1u64 << (addr & 63);
            if left == 0 {
                break;
            }
            left -= 1;
            r += ri;
            let over = r >= den;
            r -= if over { den } else { 0 };
            for a in 0..3 {
                if moves[a] {
                    let d = if over { d1[a] } else { d0[a] };
                    p[a] = ((p[a] | !mask[a]).wrapping_add(d)) & mask[a];
                }
            }
        }
    }
}

/// The `i128` kernel for triangles wider than [`MAX_TRIANGLE_SPAN`]: rare,
/// so kept out of line, and returning its crossings (local `(i, j, T)`)
/// rather than taking the voxel sink: a sink passed out of line would make
/// the compiler keep the hot path's sink state in memory instead of
/// registers.
#[cold]
#[inline(never)]
fn crossings_wide(l: &[[i64; 3]; 3]) -> Vec<[i64; 3]> {
    let wide = l.map(|q| q.map(i128::from));
    let mut out = Vec::new();
    crossings_local::<i128>(&wide, normal(&wide), &mut |row| {
        let j = row.j.to_i64();
        row.for_each(|i, t| out.push([i.to_i64(), j, t.to_i64()]));
    });
    out
}

/// The integer operations the crossing kernel needs; implemented for `i64`
/// (the fast path) and `i128` (wide triangles).
trait KernelInt:
    Copy
    + Ord
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Neg<Output = Self>
    + std::ops::AddAssign
    + std::ops::SubAssign
    + std::ops::Shr<u32, Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    fn from_i64(v: i64) -> Self;
    fn to_i64(self) -> i64;
    /// `floor(self / d)` for `d > 0`.
    fn div_floor_pos(self, d: Self) -> Self;
    /// What [`KernelInt::div_rem_floor`] needs to divide by `d` quickly.
    fn reciprocal(d: Self) -> f64;
    /// `(floor(self / d), self mod d)` for `d > 0`, given `recip =
    /// reciprocal(d)`.
    fn div_rem_floor(self, d: Self, recip: f64) -> (Self, Self);
    /// `if c { a } else { b }`, meant to compile to a conditional move.
    fn select(c: bool, a: Self, b: Self) -> Self;
}

macro_rules! kernel_int {
    ($t:ty, $fast:expr, $recip:expr) => {
        impl KernelInt for $t {
            const ZERO: Self = 0;
            const ONE: Self = 1;
            #[inline(always)]
            fn from_i64(v: i64) -> Self {
                v as $t
            }
            #[inline(always)]
            fn to_i64(self) -> i64 {
                self as i64
            }
            #[inline(always)]
            fn div_floor_pos(self, d: Self) -> Self {
                $fast(self, d)
            }
            #[inline(always)]
            fn reciprocal(d: Self) -> f64 {
                1.0 / d as f64
            }
            #[inline(always)]
            fn div_rem_floor(self, d: Self, recip: f64) -> (Self, Self) {
                $recip(self, d, recip)
            }
            #[inline(always)]
            fn select(c: bool, a: Self, b: Self) -> Self {
                if c { a } else { b }
            }
        }
    };
}
kernel_int!(i64, div_floor_pos_i64, div_rem_recip_i64);
kernel_int!(
    i128,
    |n: i128, d: i128| n.div_euclid(d),
    |n: i128, d: i128, _| { (n.div_euclid(d), n.rem_euclid(d)) }
);

/// `floor(n / d)` for `d > 0`. Where both fit the 53-bit mantissa, the
/// quotient is taken in `f64` and corrected to the exact floor: a 64-bit
/// `idiv` costs 40–90 cycles on the Skylake-class cores this was tuned on,
/// and the kernel divides about a dozen times per triangle and family.
/// Why one correction suffices: `n` and `d` are exact in `f64`, so the
/// correctly rounded quotient `f` lies between `floor(n/d)` and the next
/// integer when `n/d` is not an integer (and is exact when it is); hence
/// `trunc(f)` is `floor(n/d)` or `floor(n/d) + 1`, the latter exactly when
/// `n − trunc(f)·d < 0`. (`trunc` is one instruction on baseline x86-64;
/// `floor` is a library call.)
#[inline(always)]
fn div_floor_pos_i64(n: i64, d: i64) -> i64 {
    debug_assert!(d > 0);
    const EXACT: u64 = 1 << 53;
    if n.unsigned_abs() < EXACT && (d as u64) < EXACT {
        // SAFETY: |n| < 2^53 and d ≥ 1, so the quotient is finite and below
        // 2^53 in magnitude: it fits i64 (`as` would add saturation checks).
        let q: i64 = unsafe { (n as f64 / d as f64).to_int_unchecked() };
        if n - q * d < 0 { q - 1 } else { q }
    } else {
        n.div_euclid(d)
    }
}

/// `(floor(n / d), n mod d)` for `d > 0` by a multiplication with `recip =
/// 1/d` (rounded) where `|n|` and `d` are below 2^50, corrected exactly:
/// the product carries two roundings of relative size 2^-53 each, so for a
/// quotient below 2^50 in magnitude it is within 1/4 of `n/d`, and its
/// truncation within one of the floor; one step either way restores it.
/// Larger operands divide exactly in integers.
#[inline(always)]
fn div_rem_recip_i64(n: i64, d: i64, recip: f64) -> (i64, i64) {
    debug_assert!(d > 0);
    const SAFE: u64 = 1 << 50;
    if n.unsigned_abs() < SAFE && (d as u64) < SAFE {
        // SAFETY: |n| < 2^50 and recip ≤ 1 (d ≥ 1), so the product is
        // finite and below 2^51 in magnitude: it fits i64.
        let mut q: i64 = unsafe { (n as f64 * recip).to_int_unchecked() };
        let mut r = n - q * d;
        if r < 0 {
            q -= 1;
            r += d;
        } else if r >= d {
            q += 1;
            r -= d;
        }
        (q, r)
    } else {
        (n.div_euclid(d), n.rem_euclid(d))
    }
}

/// The kernel on a triangle in local family coordinates (fixed point, all
/// coordinates in `0..=span·ONE`): emits the rows of crossings `(i, j, T)`
/// in local lattice units.
#[inline(always)]
fn crossings_local<I: KernelInt>(p: &[[I; 3]; 3], n: [I; 3], emit: &mut impl FnMut(Row<I>)) {
    let s = I::from_i64(VOXEL_ONE);
    // Plane normal (a, b, c); c is twice the signed projected area.
    let [mut a, mut b, mut c] = n;
    if c == I::ZERO {
        return;
    }
    // Orient so that the projected triangle is counter-clockwise (c > 0):
    // then its closed interior is where all three edge functions are ≥ 0.
    let q = if c < I::ZERO {
        a = -a;
        b = -b;
        c = -c;
        [p[0], p[2], p[1]]
    } else {
        *p
    };

    // Depth rounding: T = floor(t/S + 1/2) = floor(num / den) with
    // num(i, j) = 2·c·t0 − 2·(a·(iS − u0) + b·(jS − v0)) + c·S, den = 2·c·S,
    // written as num = k0 + i·di + j·dj.
    let (u0, v0, t0) = (q[0][0], q[0][1], q[0][2]);
    let two = I::ONE + I::ONE;
    let den = two * c * s;
    let recip = I::reciprocal(den);
    let di = -two * a * s;
    let dj = -two * b * s;
    let k0 = two * c * t0 + two * (a * u0 + b * v0) + c * s;
    // Stepping i by one changes num by di: split into quotient and remainder
    // once so the row loop only adds.
    let qi = di.div_floor_pos(den);
    let ri = di - qi * den;

    // Rows. Sort the vertices by v: A lowest, C highest, B between. A row
    // j with A.v ≤ jS ≤ B.v crosses edges AB and AC, a row with
    // B.v < jS ≤ C.v crosses BC and AC; on a row the other edge's half-plane
    // is implied by convexity, so each row is bounded by exactly two edges,
    // one from below and one from above. A flat edge (equal v) bounds no
    // row of its half, which is why a flat AB hands its row to BC.
    let v = |k: usize| q[k][1];
    let (mut ia, mut ib, mut ic) = (0usize, 1usize, 2usize);
    if v(ib) < v(ia) {
        std::mem::swap(&mut ia, &mut ib);
    }
    if v(ic) < v(ib) {
        std::mem::swap(&mut ib, &mut ic);
    }
    if v(ib) < v(ia) {
        std::mem::swap(&mut ia, &mut ib);
    }
    // Counter-clockwise, the vertices run A→B→C when (A, B, C) is a
    // rotation of (0, 1, 2), else A→C→B. In the first case AC is walked
    // downwards (C→A, dv < 0) and bounds rows from below while AB and BC
    // bound them from above; in the second the sides swap.
    let long_lower = ib == [1, 2, 0][ia];
    // Edge P→Q (P lower in v, dv > 0) crosses row j at u = N(j)/(dv·S),
    // N(j) = du·(jS − v_P) + dv·u_P: the row's lattice points run from
    // ceil(N/(dv·S)) when the edge bounds from below, and up to
    // floor(N/(dv·S)) when it bounds from above; carried from row j0 on.
    #[inline(always)]
    fn edge<I: KernelInt>(p: [I; 3], q: [I; 3], j0: I, lower: bool) -> Carry<I> {
        let s = I::from_i64(VOXEL_ONE);
        let (du, dv) = (q[0] - p[0], q[1] - p[1]);
        let d = dv * s;
        let n0 = du * (j0 * s - p[1]) + dv * p[0];
        Carry::new(n0 + I::select(lower, d - I::ONE, I::ZERO), du * s, d)
    }
    // S = 2^VOXEL_FRAC_BITS: floor and ceil divisions by S are shifts.
    let j_lo = -((-v(ia)) >> VOXEL_FRAC_BITS);
    let j_hi = v(ic) >> VOXEL_FRAC_BITS;
    let j_mid = if v(ia) == v(ib) {
        j_lo - I::ONE
    } else {
        (v(ib) >> VOXEL_FRAC_BITS).min(j_hi)
    };
    if j_lo > j_hi {
        return;
    }
    // The long edge AC bounds every row; the short edge is AB up to row
    // j_mid, then BC. Convexity puts them on opposite sides. The rows run
    // in (at most) two stretches, one per short edge, so no row tests for
    // the switch.
    let mut long = edge(q[ia], q[ic], j_lo, long_lower);
    let (mut short, mut end) = if j_lo <= j_mid {
        (edge(q[ia], q[ib], j_lo, !long_lower), j_mid + I::ONE)
    } else {
        (edge(q[ib], q[ic], j_lo, !long_lower), j_hi + I::ONE)
    };
    let mut j = j_lo;
    let mut num_j = k0 + j_lo * dj;
    loop {
        while j < end {
            let (lo, hi) = if long_lower {
                (long.q, short.q)
            } else {
                (short.q, long.q)
            };
            long.step();
            short.step();
            if lo <= hi {
                let (t, r) = (num_j + lo * di).div_rem_floor(den, recip);
                emit(Row {
                    j,
                    lo,
                    hi,
                    t,
                    r,
                    qi,
                    ri,
                    den,
                });
            }
            num_j += dj;
            j += I::ONE;
        }
        if j > j_hi {
            break;
        }
        short = edge(q[ib], q[ic], j, !long_lower);
        end = j_hi + I::ONE;
    }
}

/// `floor(n / d)` carried along `n += step` with remainder, for `d > 0`.
#[derive(Clone, Copy)]
struct Carry<I> {
    q: I,
    r: I,
    sq: I,
    sr: I,
    d: I,
}

impl<I: KernelInt> Carry<I> {
    #[inline(always)]
    fn new(n: I, step: I, d: I) -> Self {
        let q = n.div_floor_pos(d);
        let sq = step.div_floor_pos(d);
        Carry {
            q,
            r: n - q * d,
            sq,
            sr: step - sq * d,
            d,
        }
    }

    /// Advance to `n + step` (branch-free).
    #[inline(always)]
    fn step(&mut self) {
        self.q += self.sq;
        self.r += self.sr;
        let over = self.r >= self.d;
        self.r -= I::select(over, self.d, I::ZERO);
        self.q += I::select(over, I::ONE, I::ZERO);
    }
}

/// Which surface to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SurfaceMode {
    /// 6-tunnel-free: the three axis families.
    Thin,
    /// 26-tunnel-free: the four body-diagonal families.
    Thick,
}

impl SurfaceMode {
    /// The lattice-line families this mode marks.
    pub fn families(self) -> &'static [LineFamily] {
        match self {
            SurfaceMode::Thin => &THIN_FAMILIES,
            SurfaceMode::Thick => &THICK_FAMILIES,
        }
    }
}

/// Voxelizes `triangles` (fixed-point grid coordinates, [`VOXEL_FRAC_BITS`])
/// into a grid of `dims`, in parallel over z-slabs balanced by expected work.
/// Crossing voxels outside `0..dims` are clamped into the grid (see
/// [`SlabBricks::set`]: for meshes fitted with the `-r N` rule they come
/// from crossings on the grid box's faces). Returns the occupied bricks (min
/// corner, bits), each brick exactly once. The set does not depend on the
/// number of threads; the order is by slab (slab cuts follow the thread
/// count), then by first touch in the slab's Morton order of triangles.
pub fn voxelize_surface(
    triangles: &[SurfaceTriangle],
    dims: [i32; 3],
    mode: SurfaceMode,
) -> Vec<([i32; 3], BrickBits)> {
    voxelize_surface_slabs(triangles, dims, mode)
        .into_iter()
        .flatten()
        .collect()
}

/// [`voxelize_surface`] before its slabs' bricks are concatenated: one list
/// per z-slab, in slab order (so a caller building its own storage copies
/// the bricks once, not twice).
pub fn voxelize_surface_slabs(
    triangles: &[SurfaceTriangle],
    dims: [i32; 3],
    mode: SurfaceMode,
) -> Vec<BrickList> {
    use rayon::prelude::*;
    let plan = SlabPlan::new(triangles, dims);
    // Cleared slab tables for the next slab: a table per thread at a time
    // is mapped once instead of once per slab.
    let tables = std::sync::Mutex::new(Vec::<Vec<u32>>::new());
    plan.slabs
        .par_iter()
        .map(|slab| {
            let table = tables.lock().map(|mut t| t.pop()).unwrap_or_default();
            let mut bricks =
                SlabBricks::with_table(dims, slab.z0, slab.z1, table.unwrap_or_default());
            let mut staged = BrickBox::new();
            // Where the box is placed while it holds staged crossings.
            let mut placed: Option<[i32; 3]> = None;
            for (k, &t) in slab.triangles.iter().enumerate() {
                // The slab's triangles are in spatial order, not memory
                // order: fetch a few ahead so their loads overlap.
                if let Some(&ahead) = slab.triangles.get(k + PREFETCH_AHEAD) {
                    prefetch_triangle(&triangles[ahead as usize]);
                }
                let tri = &triangles[t as usize];
                // Most triangles lie well inside the grid: small ones are
                // staged in a box of bricks (whose bricks outside this slab
                // are dropped at the merge: slabs are whole bricks), larger
                // ones inside the slab skip the clamping and the slab test
                // per voxel. In spatial order, consecutive triangles mostly
                // fit the box where it is: it is merged into the slab only
                // when the next one does not.
                let (lo, hi) = crossing_bounds(tri);
                let staged_at = if !bricks.holds_in_grid(lo, hi) {
                    None
                } else {
                    match placed {
                        Some(origin) if staged.extend(origin, lo, hi) => Some(origin),
                        _ => {
                            if let Some(origin) = placed {
                                bricks.merge(&mut staged, origin);
                            }
                            placed = staged.place(lo, hi);
                            placed
                        }
                    }
                };
                if let Some(origin) = staged_at {
                    all_families(
                        mode,
                        tri,
                        &mut Staging {
                            staged: &mut staged,
                            origin,
                        },
                    );
                } else if bricks.holds(lo, hi) {
                    all_families(mode, tri, &mut |v| bricks.set_inside(v));
                } else {
                    all_families(mode, tri, &mut |v| bricks.set(v));
                }
            }
            if let Some(origin) = placed {
                bricks.merge(&mut staged, origin);
            }
            let (list, table) = bricks.finish();
            if let Ok(mut t) = tables.lock() {
                t.push(table);
            }
            list
        })
        .collect()
}

/// How many triangles ahead the slab loop prefetches.
const PREFETCH_AHEAD: usize = 8;

/// Hints the CPU to fetch `tri` (both cache lines it may span).
#[inline(always)]
fn prefetch_triangle(tri: &SurfaceTriangle) {
    let p = (tri as *const SurfaceTriangle).cast::<u8>();
    crate::hint::prefetch(p);
    crate::hint::prefetch(p.wrapping_add(std::mem::size_of::<SurfaceTriangle>() - 1));
}

/// Every crossing of `tri` in the families of `mode`.
#[inline(always)]
fn all_families(mode: SurfaceMode, tri: &SurfaceTriangle, emit: &mut impl CrossingSink) {
    match mode {
        SurfaceMode::Thin => thin_crossings(tri, emit),
        SurfaceMode::Thick => {
            family_crossings::<3>(tri, emit);
            family_crossings::<4>(tri, emit);
            family_crossings::<5>(tri, emit);
            family_crossings::<6>(tri, emit);
        }
    }
}

/// A voxel box holding every crossing voxel of `tri` in any family: each
/// coordinate of a crossing voxel is within 1/2 of the same coordinate of a
/// point of the triangle (the lattice coordinates exactly, the rounded one
/// by `|T − t| ≤ 1/2`, and a diagonal family's sheared coordinates `i ± T`
/// by the same amount), so per axis it lies in
/// `[ceil(min − 1/2), floor(max + 1/2)]`.
#[inline]
fn crossing_bounds(tri: &SurfaceTriangle) -> ([i32; 3], [i32; 3]) {
    const HALF: i64 = VOXEL_ONE / 2;
    let mut lo = [0i32; 3];
    let mut hi = [0i32; 3];
    for a in 0..3 {
        let mn = tri[0][a].min(tri[1][a]).min(tri[2][a]);
        let mx = tri[0][a].max(tri[1][a]).max(tri[2][a]);
        let clamp = |v: i64| v.clamp(i32::MIN as i64, i32::MAX as i64) as i32;
        lo[a] = clamp(-((HALF - mn) >> VOXEL_FRAC_BITS));
        hi[a] = clamp((mx + HALF) >> VOXEL_FRAC_BITS);
    }
    (lo, hi)
}

/// A z-slab of the grid and the triangles that can reach it.
struct Slab {
    z0: i32,
    z1: i32,
    triangles: Vec<u32>,
}

/// Cuts the grid into z-slabs of whole bricks with about equal expected work.
struct SlabPlan {
    slabs: Vec<Slab>,
}

impl SlabPlan {
    /// Slabs per thread: more than one so rayon can even out what the work
    /// estimate misses.
    const SLABS_PER_THREAD: usize = 4;

    fn new(triangles: &[SurfaceTriangle], dims: [i32; 3]) -> Self {
        use rayon::prelude::*;
        let nz = dims[2].max(1);
        // Voxel layers a triangle can write: every crossing voxel contains a
        // point of the triangle, so it lies within ±1/2 of the z extent.
        let z_range = |tri: &SurfaceTriangle| {
            let lo = tri.iter().map(|p| p[2]).min().unwrap_or(0);
            let hi = tri.iter().map(|p| p[2]).max().unwrap_or(0);
            let lo = (lo - VOXEL_ONE / 2)
                .div_euclid(VOXEL_ONE)
                .clamp(0, nz as i64 - 1) as i32;
            let hi = (hi + VOXEL_ONE / 2)
                .div_euclid(VOXEL_ONE)
                .clamp(0, nz as i64 - 1) as i32;
            (lo, hi)
        };
        // Expected work: lattice points ≈ projected areas, plus a set-up cost.
        let weight = |tri: &SurfaceTriangle| {
            let s2 = (VOXEL_ONE * VOXEL_ONE) as f64;
            let e1 = [0, 1, 2].map(|a| (tri[1][a] - tri[0][a]) as f64);
            let e2 = [0, 1, 2].map(|a| (tri[2][a] - tri[0][a]) as f64);
            let n = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            (n[0].abs() + n[1].abs() + n[2].abs()) / (2.0 * s2) + 8.0
        };
        // Per-triangle z range and weight in parallel; the rest is a few
        // passes over layers and slabs.
        // Locality: each slab walks its triangles in Morton order of their
        // min brick, so consecutive triangles mostly write the same few
        // bricks (slab table cells and arena entries stay in cache); the
        // mesh's own order can jump anywhere.
        let ranges: Vec<((i32, i32), f64, u32)> = triangles
            .par_iter()
            .map(|tri| (z_range(tri), weight(tri), brick_morton(tri)))
            .collect();
        let mut per_layer = vec![0f64; nz as usize + 1];
        for &((lo, hi), w, _) in &ranges {
            let w = w / (hi - lo + 1) as f64;
            per_layer[lo as usize] += w;
            per_layer[hi as usize + 1] -= w;
        }
        let mut acc = 0.0;
        let layer_work: Vec<f64> = per_layer[..nz as usize]
            .iter()
            .map(|d| {
                acc += d;
                acc.max(0.0)
            })
            .collect();
        let total: f64 = layer_work.iter().sum();
        let n_bricks = (nz as usize).div_ceil(BRICK as usize);
        let want = (rayon::current_num_threads() * Self::SLABS_PER_THREAD).clamp(1, n_bricks);
        let mut cuts = vec![0i32];
        let mut run = 0.0;
        for bz in 0..n_bricks {
            let (a, b) = (
                bz * BRICK as usize,
                ((bz + 1) * BRICK as usize).min(nz as usize),
            );
            run += layer_work[a..b].iter().sum::<f64>();
            let target = total * cuts.len() as f64 / want as f64;
            if run >= target && cuts.len() < want && b < nz as usize {
                cuts.push(b as i32);
            }
        }
        cuts.push(nz);
        // Each slab gathers its triangles (in parallel: every slab scans
        // all ranges, writing branch-free into a lazily zeroed buffer of
        // which only the written part is touched) and orders them by the
        // Morton key, ties by index.
        let slabs = cuts
            .par_windows(2)
            .map(|w| {
                let (z0, z1) = (w[0], w[1]);
                let mut keyed = vec![0u64; ranges.len()];
                let mut n = 0;
                for (t, &((lo, hi), _, key)) in ranges.iter().enumerate() {
                    keyed[n] = (key as u64) << 32 | t as u64;
                    n += usize::from(lo < z1 && hi >= z0);
                }
                keyed.truncate(n);
                let sorted = radix_sort_by_high_word(keyed);
                Slab {
                    z0,
                    z1,
                    triangles: sorted.into_iter().map(|k| k as u32).collect(),
                }
            })
            .collect();
        SlabPlan { slabs }
    }
}

/// `items` ordered by their high 32 bits, ties in input order: an LSD radix
/// sort in three stable 11-bit counting passes (the keys are 30-bit Morton
/// codes; a comparison sort of a slab's ten thousand triangles took a third
/// of the slab plan's time).
fn radix_sort_by_high_word(mut items: Vec<u64>) -> Vec<u64> {
    const BITS: u32 = 11;
    const BUCKETS: usize = 1 << BITS;
    let mut out = vec![0u64; items.len()];
    for pass in 0..3 {
        let shift = 32 + BITS * pass;
        let digit = |x: u64| (x >> shift) as usize & (BUCKETS - 1);
        let mut start = [0u32; BUCKETS];
        for &x in &items {
            start[digit(x)] += 1;
        }
        let mut sum = 0;
        for c in start.iter_mut() {
            (*c, sum) = (sum, sum + *c);
        }
        for &x in &items {
            let b = digit(x);
            out[start[b] as usize] = x;
            start[b] += 1;
        }
        std::mem::swap(&mut items, &mut out);
    }
    items
}

/// The Morton code (bits of x, y, z interleaved, x lowest) of the brick
/// holding the triangle's min corner, clamped to the 2^10 bricks per axis
/// the code has room for: on grids beyond 8192 voxels per axis, the far
/// bricks share codes, which only loosens the order (it is a cache
/// heuristic; any order gives the same voxels).
fn brick_morton(tri: &SurfaceTriangle) -> u32 {
    /// Spreads the low 10 bits of `v` to every third bit.
    fn spread(v: u32) -> u32 {
        let mut v = v & 0x3ff;
        v = (v | v << 16) & 0x0300_00ff;
        v = (v | v << 8) & 0x0300_f00f;
        v = (v | v << 4) & 0x030c_30c3;
        (v | v << 2) & 0x0924_9249
    }
    let brick = |a: usize| {
        let lo = tri[0][a].min(tri[1][a]).min(tri[2][a]);
        (lo >> (VOXEL_FRAC_BITS + 3)).clamp(0, 0x3ff) as u32
    };
    spread(brick(0)) | spread(brick(1)) << 1 | spread(brick(2)) << 2
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Independent reference: for every lattice line of the family through the
    /// triangle's bounding box, intersect exactly by Cramer's rule on
    /// `P0 + s·e1 + w·e2 = (i, j, t)` in family coordinates (i128 rationals),
    /// keep closed-triangle hits and round `t` by `floor(t + 1/2)`.
    fn reference(tri: &SurfaceTriangle, family: LineFamily) -> Vec<[i32; 3]> {
        let p = tri.map(|q| family.to_family(q).map(i128::from));
        let s = VOXEL_ONE as i128;
        let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
        let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
        let det = e1[0] * e2[1] - e1[1] * e2[0];
        let mut out = Vec::new();
        if det == 0 {
            return out;
        }
        let lo = |a: usize| p.iter().map(|q| q[a]).min().unwrap().div_euclid(s) - 1;
        let hi = |a: usize| p.iter().map(|q| q[a]).max().unwrap().div_euclid(s) + 1;
        for i in lo(0)..=hi(0) {
            for j in lo(1)..=hi(1) {
                let (du, dv) = (i * s - p[0][0], j * s - p[0][1]);
                // Barycentric weights times det.
                let sw = du * e2[1] - dv * e2[0];
                let ww = e1[0] * dv - e1[1] * du;
                let inside = if det > 0 {
                    sw >= 0 && ww >= 0 && sw + ww <= det
                } else {
                    sw <= 0 && ww <= 0 && sw + ww >= det
                };
                if !inside {
                    continue;
                }
                // t·det = t0·det + sw·e1t + ww·e2t; T = floor(t/S + 1/2).
                let tnum = p[0][2] * det + sw * e1[2] + ww * e2[2];
                let (n, d) = if det > 0 { (tnum, det) } else { (-tnum, -det) };
                let t = (2 * n + s * d).div_euclid(2 * s * d);
                let v = family.to_voxel(i as i64, j as i64, t as i64);
                out.push(v.to_array());
            }
        }
        out.sort();
        out
    }

    /// A triangle with vertices on multiples of `unit` (fixed point) within
    /// `extent` voxels of a random lattice point within `reach` voxels of
    /// the origin.
    fn random_triangle(
        rng: &mut rand_chacha::ChaCha8Rng,
        unit: i64,
        extent: i64,
        reach: i64,
    ) -> SurfaceTriangle {
        let extent = extent * VOXEL_ONE / unit;
        let off = rng.random_range(-reach..reach) * VOXEL_ONE;
        std::array::from_fn(|_| {
            std::array::from_fn(|_| off + rng.random_range(-extent..=extent) * unit)
        })
    }

    fn kernel(tri: &SurfaceTriangle, family: LineFamily) -> Vec<[i32; 3]> {
        let mut got = Vec::new();
        triangle_crossings(tri, family, &mut |v| got.push(v.to_array()));
        got.sort();
        got
    }

    fn check(tri: &SurfaceTriangle) {
        for family in THIN_FAMILIES.iter().chain(THICK_FAMILIES.iter()) {
            assert_eq!(
                kernel(tri, *family),
                reference(tri, *family),
                "{tri:?} {family:?}"
            );
        }
    }

    #[test]
    fn radix_sort_orders_by_the_high_word_and_keeps_ties_in_input_order() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        for (len, key_bits) in [(0, 30), (1, 30), (5000, 30), (5000, 4), (3000, 33)] {
            let items: Vec<u64> = (0..len)
                .map(|_| {
                    let key = rng.random_range(0..1u64 << key_bits.min(33));
                    key << 32 | rng.random_range(0..1u64 << 32)
                })
                .collect();
            let mut want = items.clone();
            want.sort_by_key(|&x| x >> 32);
            assert_eq!(
                radix_sort_by_high_word(items),
                want,
                "{len} items, {key_bits}-bit keys"
            );
        }
    }

    #[test]
    fn f64_floor_division_is_exact() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        for _ in 0..200_000 {
            let bits = rng.random_range(1..63);
            let dbits = rng.random_range(0..54);
            let d = rng.random_range(1..=(1i64 << dbits));
            let n = rng.random_range(-(1i64 << bits)..(1i64 << bits));
            // Multiples of d and their neighbours are where rounding bites.
            let m = (n / d).saturating_mul(d);
            for n in [n, m, m.saturating_add(1), m.saturating_sub(1)] {
                assert_eq!(div_floor_pos_i64(n, d), n.div_euclid(d), "{n} / {d}");
            }
        }
        let big = (1i64 << 53) - 1;
        for (n, d) in [
            (big, 3),
            (-big, 3),
            (big - 1, big),
            (-big, big),
            (i64::MIN, 7),
            (i64::MAX, 1),
        ] {
            for n in [n.saturating_sub(1), n, n.saturating_add(1)] {
                assert_eq!(div_floor_pos_i64(n, d), n.div_euclid(d), "{n} / {d}");
            }
        }
    }

    #[test]
    fn reciprocal_division_is_exact() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(10);
        for _ in 0..200_000 {
            let bits = rng.random_range(1..63);
            let dbits = rng.random_range(0..52);
            let d = rng.random_range(1..=(1i64 << dbits));
            let n = rng.random_range(-(1i64 << bits)..(1i64 << bits));
            let recip = <i64 as KernelInt>::reciprocal(d);
            let m = (n / d).saturating_mul(d);
            for n in [n, m, m.saturating_add(1), m.saturating_sub(1)] {
                let want = (n.div_euclid(d), n.rem_euclid(d));
                assert_eq!(div_rem_recip_i64(n, d, recip), want, "{n} / {d}");
            }
        }
    }

    #[test]
    fn shared_thin_set_up_equals_the_three_families() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for case in 0..3000 {
            let extent = [2, 9, 60][case % 3] * VOXEL_ONE;
            let off = rng.random_range(-5000..5000) * VOXEL_ONE;
            let mut tri: SurfaceTriangle = std::array::from_fn(|_| {
                std::array::from_fn(|_| {
                    off + rng.random_range(-extent..=extent) / (1 + case as i64 % 4)
                })
            });
            if case % 100 == 0 {
                // A sliver wider than the i64 kernel takes: the i128 path.
                tri[1][case / 100 % 3] += MAX_TRIANGLE_SPAN * VOXEL_ONE;
            }
            let mut want = Vec::new();
            for f in THIN_FAMILIES {
                want.extend(kernel(&tri, f));
            }
            want.sort();
            let mut got = Vec::new();
            thin_crossings(&tri, &mut |v: Voxel| got.push(v.to_array()));
            got.sort();
            assert_eq!(got, want, "{tri:?}");
        }
    }

    #[test]
    fn kernel_matches_cramer_reference_on_random_triangles() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for case in 0..3000 {
            // Mix of sub-voxel, lattice-snapped and half-voxel vertices.
            let scale = [1, VOXEL_ONE / 2, VOXEL_ONE][case % 3];
            let extent = [3, 12, 40][case % 4 % 3];
            check(&random_triangle(&mut rng, scale, extent, 1000));
        }
    }

    /// The kernel scans along whichever projected axis gives fewer rows:
    /// slivers long in x, then in y (and their mirror images, which flip
    /// the orientation the kernel normalizes), for every family.
    #[test]
    fn both_scan_directions_match_the_reference() {
        let o = VOXEL_ONE;
        for long in [[1, 0], [0, 1]] {
            for flip in [false, true] {
                let p = |u: i64, v: i64, z: i64| {
                    let (x, y) = (u * long[0] + v * long[1], u * long[1] + v * long[0]);
                    [x, y, z]
                };
                let mut tri = [
                    p(o / 3, o / 5, o / 7),
                    p(17 * o + o / 2, o + o / 3, 3 * o),
                    p(9 * o, 3 * o - 1, 5 * o / 2 + 1),
                ];
                if flip {
                    tri.swap(1, 2);
                }
                check(&tri);
            }
        }
    }

    #[test]
    fn wide_triangles_take_the_i128_path_and_agree() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
        for _ in 0..20 {
            let big = (MAX_TRIANGLE_SPAN + 500) * VOXEL_ONE;
            // A long thin sliver keeps the brute-force reference small.
            let a = [rng.random_range(-big..big), 0, 0];
            let b = [a[0] + big, VOXEL_ONE * 3 / 2, VOXEL_ONE / 3];
            let c = [a[0] + big / 2, VOXEL_ONE * 2, VOXEL_ONE * 5 / 4];
            let tri = [a, b, c];
            assert_eq!(
                kernel(&tri, LineFamily::Axis(2)),
                reference(&tri, LineFamily::Axis(2))
            );
        }
    }

    #[test]
    fn crossing_bounds_hold_every_crossing() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        for case in 0..4000 {
            // Half-voxel multiples put crossings exactly on rounding ties.
            let unit = [1, VOXEL_ONE / 2, VOXEL_ONE][case % 3];
            let tri = random_triangle(&mut rng, unit, [2, 7, 30][case % 4 % 3], 300);
            let (lo, hi) = crossing_bounds(&tri);
            for family in THIN_FAMILIES.iter().chain(THICK_FAMILIES.iter()) {
                triangle_crossings(&tri, *family, &mut |v| {
                    let v = v.to_array();
                    assert!(
                        (0..3).all(|a| lo[a] <= v[a] && v[a] <= hi[a]),
                        "{tri:?} {family:?}: {v:?} outside {lo:?}..={hi:?}"
                    );
                });
            }
        }
    }

    /// `voxelize_surface` (slabs, staging boxes, clamping) against the plain
    /// union of every family's crossings, clamped into the grid.
    #[test]
    fn voxelize_surface_equals_the_union_of_crossings() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        let dims = [70, 45, 90];
        for round in 0..12 {
            // Small triangles (staged in a box), large ones (set directly)
            // and ones poking out of the grid (clamped).
            let tris: Vec<SurfaceTriangle> = (0..150)
                .map(|k| {
                    let extent = [3, 12, 40, 70][(k + round) % 4] * VOXEL_ONE;
                    let c: [i64; 3] = std::array::from_fn(|a| {
                        rng.random_range(-2..dims[a] as i64 + 2) * VOXEL_ONE
                    });
                    std::array::from_fn(|_| {
                        std::array::from_fn(|a| {
                            (c[a] + rng.random_range(-extent..=extent) / 2)
                                .clamp(-VOXEL_ONE / 2, dims[a] as i64 * VOXEL_ONE - VOXEL_ONE / 2)
                        })
                    })
                })
                .collect();
            for mode in [SurfaceMode::Thin, SurfaceMode::Thick] {
                let mut want = std::collections::BTreeSet::new();
                for tri in &tris {
                    for family in mode.families() {
                        triangle_crossings(tri, *family, &mut |v| {
                            let v = v.to_array();
                            want.insert(std::array::from_fn::<i32, 3, _>(|a| {
                                v[a].clamp(0, dims[a] - 1)
                            }));
                        });
                    }
                }
                let mut got = std::collections::BTreeSet::new();
                let bricks = voxelize_surface(&tris, dims, mode);
                let mut seen = std::collections::HashSet::new();
                for (corner, bits) in &bricks {
                    assert!(seen.insert(*corner), "brick {corner:?} twice");
                    assert!(bits.iter().any(|&w| w != 0), "empty brick {corner:?}");
                    for (z, w) in bits.iter().enumerate() {
                        for b in 0..64 {
                            if w >> b & 1 == 1 {
                                got.insert([
                                    corner[0] + (b & 7),
                                    corner[1] + (b >> 3),
                                    corner[2] + z as i32,
                                ]);
                            }
                        }
                    }
                }
                assert_eq!(got, want, "round {round} {mode:?}");
            }
        }
    }

    #[test]
    fn degenerate_and_axis_aligned_triangles() {
        let o = VOXEL_ONE;
        // Collinear: no crossings in any family.
        let line = [[0, 0, 0], [o, o, o], [2 * o, 2 * o, 2 * o]];
        check(&line);
        // Lying in a voxel face plane (z = 1/2) and in a lattice plane (z = 0).
        check(&[[0, 0, o / 2], [5 * o, 0, o / 2], [0, 5 * o, o / 2]]);
        check(&[[0, 0, 0], [5 * o, 0, 0], [0, 5 * o, 0]]);
        // Vertical (contains the z direction): skipped by the z family only.
        check(&[[0, 0, 0], [4 * o, 4 * o, 0], [0, 0, 4 * o]]);
        assert!(
            kernel(
                &[[0, 0, 0], [4 * o, 4 * o, 0], [0, 0, 4 * o]],
                LineFamily::Axis(2)
            )
            .is_empty()
        );
    }
}
