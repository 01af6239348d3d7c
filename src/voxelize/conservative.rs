//! Exact conservative voxelization: every voxel whose **closed** cube meets a
//! (closed) triangle.
//!
//! The decision is the separating-axis theorem (Akenine-Möller 2001) with the
//! 13 candidate axes — 3 box normals, the triangle normal and the 9 products
//! `unit_j × edge_i` — evaluated in integers on fixed-point vertices
//! ([`crate::fixed`], 2^-20 voxel). Touching counts as meeting (closed cubes),
//! so a face lying exactly in a voxel face plane marks the voxels on both
//! sides, and a vertex on a voxel corner marks all eight voxels around it.
//!
//! # Exactness and range
//! Coordinates satisfy `|x| ≤ 2^30` voxels (`2^50` fixed units). Everything is
//! computed relative to a lattice point next to the triangle (an exact integer
//! translation), so edge-axis projections need at most 106 bits (`i128`). The
//! normal-axis projection needs up to ~160 bits for triangles spanning more
//! than 2^19 voxels; those take an exact 192-bit path (`Wide`), smaller
//! triangles a plain `i128` path. Degenerate triangles need no special case:
//! for a segment (collinear vertices) or a point (coincident vertices) the
//! normal and some cross products vanish, a zero axis separates nothing, and the
//! remaining axes are exactly the separating-axis set of a segment or a point.
//!
//! # Enumeration
//! [`conservative_voxels`] does not scan the whole bounding box: it clips the
//! triangle to each z-slab and then to each row in `f64` with a safety margin
//! ([`clip margin`](ConservativeVoxels) `1e-9·(extent + 1)` voxel, far above
//! the rounding error) to get candidate x-ranges, and decides each candidate
//! with the exact test. The floating point only prunes; it never decides.

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Result, VoxkitError};
use crate::fixed::{FixedPoint, HALF, ONE};
use crate::grid::Voxel;

/// A triangle with fixed-point grid-space vertices (see [`crate::fixed`]).
pub type FixedTriangle = [FixedPoint; 3];

/// Largest fixed-point coordinate magnitude accepted (`2^30` voxels).
const MAX_FIXED: i64 = 1 << 50;

/// `|c|` bound (fixed units) under which the normal-axis test fits in `i128`.
const NARROW_LIMIT: i64 = 1 << 40;

/// A signed 192-bit-range integer `hi · 2^64 + lo`, `lo ∈ [0, 2^64)`, used for
/// the normal-axis projection of very large triangles. The derived order is the
/// numeric order because the representation is canonical.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Wide {
    hi: i128,
    lo: u64,
}

impl Wide {
    fn from_i128(v: i128) -> Wide {
        Wide {
            hi: v >> 64,
            lo: v as u64,
        }
    }

    /// Exact `a · b` for `|a_i| < 2^110`, `|b_i| < 2^60`.
    fn dot(a: [i128; 3], b: [i64; 3]) -> Wide {
        let mut hi: i128 = 0;
        let mut lo: i128 = 0;
        for i in 0..3 {
            let ah = a[i] >> 64; // floor: a = ah·2^64 + al, al ∈ [0, 2^64)
            let al = (a[i] as u64) as i128;
            hi += ah * b[i] as i128;
            lo += al * b[i] as i128; // |lo| < 2^64 + 2^124: no overflow
            hi += lo >> 64;
            lo &= u64::MAX as i128;
        }
        Wide { hi, lo: lo as u64 }
    }
}

/// The exact triangle–voxel test for one triangle, with everything that does
/// not depend on the voxel precomputed.
///
/// ```
/// use glam::IVec3;
/// use voxkit::fixed::ONE;
/// use voxkit::voxelize::conservative::TriangleBoxTest;
/// // A triangle in the plane z = 0.5: the face plane between voxel layers 0 and 1.
/// let t = TriangleBoxTest::new(&[[0, 0, ONE / 2], [3 * ONE, 0, ONE / 2], [0, 3 * ONE, ONE / 2]]).unwrap();
/// assert!(t.meets(IVec3::new(0, 0, 0)) && t.meets(IVec3::new(0, 0, 1)));  // touching counts
/// assert!(!t.meets(IVec3::new(0, 0, 2)));
/// // Voxel (2, 2, 0) only touches the hypotenuse x + y = 3 at its corner (1.5, 1.5).
/// assert!(t.meets(IVec3::new(2, 2, 0)));
/// assert!(!t.meets(IVec3::new(2, 3, 0)));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct TriangleBoxTest {
    /// Vertices relative to the lattice point `lo · ONE`.
    p: [[i64; 3]; 3],
    /// Inclusive voxel bounding box (absolute voxel indices).
    lo: [i32; 3],
    hi: [i32; 3],
    /// Triangle normal `e0 × e1` (zero for degenerate triangles).
    n: [i128; 3],
    /// `n · p0` (relative), narrow path only.
    n_p0: i128,
    /// Box radius along the normal: `HALF · (|nx| + |ny| + |nz|)`.
    n_r: i128,
    /// Whether the normal test must use [`Wide`] arithmetic.
    wide: bool,
    /// The 9 edge axes `u_j × e_i` as `(a, pmin, pmax, r)`.
    edge_axes: [([i64; 3], i128, i128, i128); 9],
}

fn check_range(tri: &FixedTriangle) -> Result<()> {
    for p in tri {
        for &c in p {
            if !(-MAX_FIXED..=MAX_FIXED).contains(&c) {
                return Err(VoxkitError::invalid(format!(
                    "triangle vertex coordinate {c} (fixed point) is outside ±2^50 (±2^30 voxels)"
                )));
            }
        }
    }
    Ok(())
}

/// Lowest voxel whose closed cube `[i·ONE − HALF, i·ONE + HALF]` reaches `min`.
#[inline]
fn voxel_lo(min: i64) -> i64 {
    // i·ONE + HALF ≥ min  ⇔  i ≥ ceil((min − HALF) / ONE)
    -((HALF - min).div_euclid(ONE))
}

/// Highest voxel whose closed cube reaches down to `max`.
#[inline]
fn voxel_hi(max: i64) -> i64 {
    (max + HALF).div_euclid(ONE)
}

#[inline]
fn sub(a: [i64; 3], b: [i64; 3]) -> [i64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn dot_i(a: [i64; 3], b: [i64; 3]) -> i128 {
    a[0] as i128 * b[0] as i128 + a[1] as i128 * b[1] as i128 + a[2] as i128 * b[2] as i128
}

impl TriangleBoxTest {
    /// Precomputes the test for `tri`; rejects coordinates beyond ±2^30 voxels.
    pub fn new(tri: &FixedTriangle) -> Result<Self> {
        check_range(tri)?;
        let mut lo = [0i32; 3];
        let mut hi = [0i32; 3];
        for a in 0..3 {
            let mn = tri.iter().map(|p| p[a]).min().unwrap_or(0);
            let mx = tri.iter().map(|p| p[a]).max().unwrap_or(0);
            lo[a] = voxel_lo(mn) as i32;
            hi[a] = voxel_hi(mx) as i32;
        }
        let base = [lo[0] as i64 * ONE, lo[1] as i64 * ONE, lo[2] as i64 * ONE];
        let p = [sub(tri[0], base), sub(tri[1], base), sub(tri[2], base)];
        let e = [sub(p[1], p[0]), sub(p[2], p[1]), sub(p[0], p[2])];
        let (e0, e1) = (e[0], e[1]);
        let n = [
            e0[1] as i128 * e1[2] as i128 - e0[2] as i128 * e1[1] as i128,
            e0[2] as i128 * e1[0] as i128 - e0[0] as i128 * e1[2] as i128,
            e0[0] as i128 * e1[1] as i128 - e0[1] as i128 * e1[0] as i128,
        ];
        let n_r = HALF as i128 * (n[0].abs() + n[1].abs() + n[2].abs());
        // Every voxel centre tested lies in the bbox, so |c| ≤ extent + ONE;
        // vertices too. Above NARROW_LIMIT n·c may exceed i128.
        let reach = (0..3)
            .map(|a| (hi[a] as i64 - lo[a] as i64 + 1) * ONE)
            .max()
            .unwrap_or(0);
        let wide = reach > NARROW_LIMIT;
        let n_p0 = if wide {
            0
        } else {
            n[0] * p[0][0] as i128 + n[1] * p[0][1] as i128 + n[2] * p[0][2] as i128
        };
        let mut edge_axes = [([0i64; 3], 0i128, 0i128, 0i128); 9];
        let mut slot = 0;
        for ei in e {
            // x̂ × e, ŷ × e, ẑ × e
            for a in [[0, -ei[2], ei[1]], [ei[2], 0, -ei[0]], [-ei[1], ei[0], 0]] {
                let pr = [dot_i(a, p[0]), dot_i(a, p[1]), dot_i(a, p[2])];
                let pmin = pr[0].min(pr[1]).min(pr[2]);
                let pmax = pr[0].max(pr[1]).max(pr[2]);
                let r = HALF as i128
                    * (a[0].unsigned_abs() as i128
                        + a[1].unsigned_abs() as i128
                        + a[2].unsigned_abs() as i128);
                edge_axes[slot] = (a, pmin, pmax, r);
                slot += 1;
            }
        }
        Ok(TriangleBoxTest {
            p,
            lo,
            hi,
            n,
            n_p0,
            n_r,
            wide,
            edge_axes,
        })
    }

    /// Inclusive voxel bounding box `(lo, hi)`: the voxels whose closed cube
    /// meets the triangle's bounding box.
    pub fn voxel_bbox(&self) -> (Voxel, Voxel) {
        (Voxel::from_array(self.lo), Voxel::from_array(self.hi))
    }

    /// Whether the closed cube of voxel `v` meets the closed triangle.
    #[inline]
    pub fn meets(&self, v: Voxel) -> bool {
        let v = v.to_array();
        if (0..3).any(|a| v[a] < self.lo[a] || v[a] > self.hi[a]) {
            return false; // box-normal axes
        }
        // Voxel centre relative to lo; in the bbox so |c| ≤ extent + ONE.
        let c = [
            (v[0] - self.lo[0]) as i64 * ONE,
            (v[1] - self.lo[1]) as i64 * ONE,
            (v[2] - self.lo[2]) as i64 * ONE,
        ];
        // Triangle normal: |n·(p0 − c)| ≤ r.
        if self.wide {
            let d = Wide::dot(self.n, sub(self.p[0], c));
            if d > Wide::from_i128(self.n_r) || d < Wide::from_i128(-self.n_r) {
                return false;
            }
        } else {
            let s = self.n[0] * c[0] as i128 + self.n[1] * c[1] as i128 + self.n[2] * c[2] as i128;
            let d = self.n_p0 - s;
            if d > self.n_r || d < -self.n_r {
                return false;
            }
        }
        for &(a, pmin, pmax, r) in &self.edge_axes {
            let s = dot_i(a, c);
            if pmin - s > r || pmax - s < -r {
                return false;
            }
        }
        true
    }

    /// The triangle in `f64` voxel units relative to `lo` (exact: ≤ 53 bits).
    fn local_f64(&self) -> [DVec3; 3] {
        self.p.map(|q| {
            DVec3::new(
                q[0] as f64 / ONE as f64,
                q[1] as f64 / ONE as f64,
                q[2] as f64 / ONE as f64,
            )
        })
    }
}

/// Whether the closed cube of voxel `v` meets the closed triangle `tri`
/// (touching counts). Exact; see the [module docs](self).
///
/// ```
/// use glam::IVec3;
/// use voxkit::fixed::ONE;
/// use voxkit::voxelize::conservative::triangle_meets_voxel;
/// // A degenerate triangle (a point) exactly on the corner shared by 8 voxels.
/// let h = ONE / 2;
/// let tri = [[h, h, h]; 3];
/// assert!(triangle_meets_voxel(&tri, IVec3::new(0, 0, 0)).unwrap());
/// assert!(triangle_meets_voxel(&tri, IVec3::new(1, 1, 1)).unwrap());
/// assert!(!triangle_meets_voxel(&tri, IVec3::new(2, 1, 1)).unwrap());
/// ```
pub fn triangle_meets_voxel(tri: &FixedTriangle, v: Voxel) -> Result<bool> {
    Ok(TriangleBoxTest::new(tri)?.meets(v))
}

/// Clips a convex polygon to `lo ≤ p[axis] ≤ hi` (Sutherland–Hodgman, f64).
fn clip_axis(poly: &[DVec3], axis: usize, lo: f64, hi: f64) -> Vec<DVec3> {
    let keep = |p: &DVec3, sign: f64, c: f64| sign * (p[axis] - c) >= 0.0;
    let mut cur: Vec<DVec3> = poly.to_vec();
    for (sign, c) in [(1.0, lo), (-1.0, hi)] {
        if cur.is_empty() {
            break;
        }
        let mut out = Vec::with_capacity(cur.len() + 2);
        for i in 0..cur.len() {
            let a = cur[i];
            let b = cur[(i + 1) % cur.len()];
            let (ka, kb) = (keep(&a, sign, c), keep(&b, sign, c));
            if ka {
                out.push(a);
            }
            if ka != kb {
                let t = ((c - a[axis]) / (b[axis] - a[axis])).clamp(0.0, 1.0);
                let mut q = a + (b - a) * t;
                q[axis] = c;
                out.push(q);
            }
        }
        cur = out;
    }
    cur
}

/// Candidate voxels of one z-slab (a superset of the meeting ones), filtered
/// by the exact test.
fn slab_voxels(
    test: &TriangleBoxTest,
    tri: &[DVec3; 3],
    margin: f64,
    k: i32,
    out: &mut Vec<Voxel>,
) {
    let (lo, hi) = (test.lo, test.hi);
    let zc = (k - lo[2]) as f64;
    let slab = clip_axis(tri, 2, zc - 0.5 - margin, zc + 0.5 + margin);
    if slab.is_empty() {
        return;
    }
    let (ymin, ymax) = slab
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.y), b.max(p.y))
        });
    let j0 = ((ymin - margin - 0.5).ceil() as i64 + lo[1] as i64).max(lo[1] as i64) as i32;
    let j1 = ((ymax + margin + 0.5).floor() as i64 + lo[1] as i64).min(hi[1] as i64) as i32;
    for j in j0..=j1 {
        let yc = (j - lo[1]) as f64;
        let row = clip_axis(&slab, 1, yc - 0.5 - margin, yc + 0.5 + margin);
        if row.is_empty() {
            continue;
        }
        let (xmin, xmax) = row
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.x), b.max(p.x))
            });
        let i0 = ((xmin - margin - 0.5).ceil() as i64 + lo[0] as i64).max(lo[0] as i64) as i32;
        let i1 = ((xmax + margin + 0.5).floor() as i64 + lo[0] as i64).min(hi[0] as i64) as i32;
        for i in i0..=i1 {
            let v = Voxel::new(i, j, k);
            if test.meets(v) {
                out.push(v);
            }
        }
    }
}

/// Lazy enumeration of a triangle's conservative voxels, one z-slab at a
/// time, in x-fastest order (sorted by `(z, y, x)`, no duplicates).
///
/// Candidates come from an `f64` clip of the triangle to the slab and row,
/// widened by a margin of `1e-9 · (extent + 1)` voxel; each candidate is
/// decided by the exact [`TriangleBoxTest::meets`].
#[derive(Clone, Debug)]
pub struct ConservativeVoxels {
    test: TriangleBoxTest,
    tri: [DVec3; 3],
    margin: f64,
    next_k: i64,
    buf: Vec<Voxel>,
    pos: usize,
}

impl Iterator for ConservativeVoxels {
    type Item = Voxel;

    fn next(&mut self) -> Option<Voxel> {
        loop {
            if self.pos < self.buf.len() {
                self.pos += 1;
                return Some(self.buf[self.pos - 1]);
            }
            if self.next_k > self.test.hi[2] as i64 {
                return None;
            }
            self.buf.clear();
            self.pos = 0;
            slab_voxels(
                &self.test,
                &self.tri,
                self.margin,
                self.next_k as i32,
                &mut self.buf,
            );
            self.next_k += 1;
        }
    }
}

/// The voxels whose closed cube meets the closed triangle `tri`, exactly.
///
/// ```
/// use voxkit::fixed::ONE;
/// use voxkit::voxelize::conservative::conservative_voxels;
/// // An axis-aligned right triangle lying in the voxel face plane z = 0.5.
/// let h = ONE / 2;
/// let tri = [[0, 0, h], [2 * ONE, 0, h], [0, 2 * ONE, h]];
/// let v: Vec<_> = conservative_voxels(&tri).unwrap().collect();
/// // Both layers z = 0 and z = 1; per layer the 6 voxels with i + j ≤ 2
/// // plus (1,2),(2,1) whose corners (0.5,1.5),(1.5,0.5) lie on the hypotenuse.
/// assert_eq!(v.len(), 2 * 8);
/// ```
pub fn conservative_voxels(tri: &FixedTriangle) -> Result<ConservativeVoxels> {
    let test = TriangleBoxTest::new(tri)?;
    let local = test.local_f64();
    let extent = (0..3)
        .map(|a| (test.hi[a] as f64 - test.lo[a] as f64) + 1.0)
        .fold(0.0, f64::max);
    Ok(ConservativeVoxels {
        test,
        tri: local,
        margin: 1e-9 * (extent + 1.0),
        next_k: test.lo[2] as i64,
        buf: Vec::new(),
        pos: 0,
    })
}

/// Sorts voxels in x-fastest order (by `(z, y, x)`) and removes duplicates.
pub fn sort_dedup_voxels(v: &mut Vec<Voxel>) {
    v.par_sort_unstable_by_key(|p| (p.z, p.y, p.x));
    v.dedup();
}

/// The exact conservative voxel set of a triangle soup: every voxel whose
/// closed cube meets at least one closed triangle. Sorted by `(z, y, x)`
/// (x fastest), without duplicates. Parallel over triangles (rayon);
/// identical to the sequential result.
///
/// # Errors
/// [`VoxkitError::Invalid`] naming the first triangle with a coordinate beyond
/// ±2^30 voxels.
///
/// ```
/// use voxkit::fixed::ONE;
/// use voxkit::voxelize::conservative::conservative_reference;
/// let q = ONE / 4;
/// let tris = [[[q, q, q], [q, q, q], [q, q, q]], [[q, q, q], [q, q, q], [q, q, q]]];
/// assert_eq!(conservative_reference(&tris).unwrap().len(), 1);
/// ```
pub fn conservative_reference(tris: &[FixedTriangle]) -> Result<Vec<Voxel>> {
    if let Some((i, _)) = tris
        .iter()
        .enumerate()
        .find(|(_, t)| check_range(t).is_err())
    {
        return Err(VoxkitError::invalid(format!(
            "triangle {i}: coordinate outside ±2^30 voxels"
        )));
    }
    let mut all: Vec<Voxel> = tris
        .par_iter()
        .fold(Vec::new, |mut acc, t| {
            // Range checked above, so construction cannot fail.
            if let Ok(it) = conservative_voxels(t) {
                acc.extend(it);
            }
            acc
        })
        .reduce(Vec::new, |mut a, mut b| {
            if a.len() < b.len() {
                std::mem::swap(&mut a, &mut b);
            }
            a.extend_from_slice(&b);
            a
        });
    sort_dedup_voxels(&mut all);
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voxel_bbox_is_closed() {
        // Coordinates exactly on a face plane reach both neighbours.
        assert_eq!(voxel_lo(HALF), 0);
        assert_eq!(voxel_hi(HALF), 1);
        assert_eq!(voxel_lo(HALF + 1), 1);
        assert_eq!(voxel_hi(HALF - 1), 0);
        assert_eq!(voxel_lo(-HALF), -1);
        assert_eq!(voxel_hi(-HALF), 0);
    }

    #[test]
    fn wide_dot_matches_i128_when_small() {
        let a = [3i128 << 70, -(5i128 << 68) + 12345, 7];
        let b = [1 << 20, -(1 << 18) + 3, -(1 << 40)];
        let exact: i128 = a[0] * b[0] as i128 + a[1] * b[1] as i128 + a[2] * b[2] as i128;
        assert_eq!(Wide::dot(a, b), Wide::from_i128(exact));
        assert!(Wide::from_i128(-1) < Wide::from_i128(0));
        assert!(Wide::from_i128(i128::MIN / 2) < Wide::from_i128(-1));
    }
}
