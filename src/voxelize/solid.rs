//! Solid (inside) references: which voxel centres lie inside a triangle mesh.
//!
//! * [`winding_number`]: the generalized winding number, the sum of the signed
//!   solid angles of the triangles (van Oosterom–Strackee) over 4π, in `f64`.
//!   For a closed, outward-oriented mesh it is 1 inside and 0 outside; for a
//!   mesh with holes it degrades smoothly. A centre is inside when
//!   `w ≥` [`WINDING_THRESHOLD`] (0.5). [`solid_voxels_winding`] applies it to
//!   every centre (O(voxels × triangles): a reference for small grids).
//! * [`solid_voxels_parity`]: exact crossing parity along axis-parallel lines
//!   through voxel centres, for watertight meshes (orientation not needed).
//! * [`solid_voxels_voting`]: parity along x, y and z, majority of three: for
//!   non-watertight meshes. A hole only flips voxels whose lines pass through
//!   it; a voxel goes wrong only if two of its three lines do, which confines
//!   the damage of a missing triangle to that triangle's bounding box.
//!
//! # Exact parity and its tie rule
//! Vertices are fixed point ([`crate::fixed`]). For an x-line through the
//! lattice point `q = (y, z)`, a triangle is crossed iff the point
//! `q + (ε, ε²)` (ε → 0⁺, in the `(y, z)` plane) lies in its projection:
//! symbolic perturbation, decided by exact integer edge functions, so a line
//! through a shared edge or vertex of a watertight mesh is counted exactly
//! once per sheet. Projections of zero area are never crossed. The crossing
//! depth is the exact rational `x*`; a crossing counts for the centre `x = i`
//! iff `x* ≤ i` (a centre exactly on the surface takes the side beyond it).
//! Centre `i` is inside iff an odd number of crossings count. Lines along y
//! and z use the cyclic frames `(z, x)` and `(x, y)`.
//!
//! Range: exact for triangles whose extent is below 2^20 voxels on every axis
//! (i128 throughout); larger triangles are rejected with
//! [`VoxkitError::Unsupported`].

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Result, VoxkitError};
use crate::fixed::{ONE, to_f64};
use crate::grid::{BitGrid, Dims, MemoryLimit, Voxel};
use crate::voxelize::conservative::FixedTriangle;

/// A centre is inside when its winding number is at least this.
pub const WINDING_THRESHOLD: f64 = 0.5;

/// Largest triangle extent (fixed units) the parity fill accepts.
const MAX_EXTENT: i64 = 1 << 40;

/// A coordinate axis: the direction of the lines a parity fill runs along.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Axis {
    /// Lines parallel to x.
    X,
    /// Lines parallel to y.
    Y,
    /// Lines parallel to z.
    Z,
}

impl Axis {
    /// The axis index (x = 0, y = 1, z = 2).
    pub const fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// The generalized winding number of `point` (grid space) with respect to a
/// triangle soup: `Σ Ω_t / 4π`, with each signed solid angle from
/// van Oosterom–Strackee: `tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| +
/// (b·c)|a| + (c·a)|b|)`, `a, b, c` the vertices relative to the point.
/// Positive inside an outward-oriented closed mesh. Not meaningful for a
/// point exactly on the surface (a triangle containing it contributes ±2π or 0).
///
/// ```
/// use glam::DVec3;
/// use voxkit::voxelize::shapes::IndexedMesh;
/// use voxkit::voxelize::solid::winding_number;
/// let m = IndexedMesh::cuboid(DVec3::ZERO, DVec3::splat(4.0)).to_fixed_triangles().unwrap();
/// assert!((winding_number(DVec3::splat(1.0), &m) - 1.0).abs() < 1e-12);
/// assert!(winding_number(DVec3::splat(5.0), &m).abs() < 1e-12);
/// ```
pub fn winding_number(point: DVec3, mesh: &[FixedTriangle]) -> f64 {
    let mut total = 0.0;
    for t in mesh {
        let [a, b, c] = t.map(|p| DVec3::new(to_f64(p[0]), to_f64(p[1]), to_f64(p[2])) - point);
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        total += 2.0 * num.atan2(den);
    }
    total / (4.0 * std::f64::consts::PI)
}

/// Solid voxels of the grid box `[0, dims)` by the winding-number rule
/// (`w ≥ 0.5` at the voxel centre). O(voxels × triangles), parallel over
/// z-layers: the slow robust reference.
///
/// # Errors
/// [`VoxkitError::Limits`] / [`VoxkitError::Invalid`] from the grid allocation.
pub fn solid_voxels_winding(
    mesh: &[FixedTriangle],
    dims: Dims,
    limit: MemoryLimit,
) -> Result<BitGrid> {
    let mut grid = BitGrid::new(dims, limit)?;
    let [nx, ny, nz] = dims;
    let layers: Vec<Vec<usize>> = (0..nz)
        .into_par_iter()
        .map(|z| {
            let mut inside = Vec::new();
            for y in 0..ny {
                for x in 0..nx {
                    let p = DVec3::new(x as f64, y as f64, z as f64);
                    if winding_number(p, mesh) >= WINDING_THRESHOLD {
                        inside.push(x + nx * (y + ny * z));
                    }
                }
            }
            inside
        })
        .collect();
    for i in layers.into_iter().flatten() {
        grid.set_index(i, true);
    }
    Ok(grid)
}

/// Sign of `(b − a) × (q + (ε, ε²) − a)` for ε → 0⁺ (never zero for `a ≠ b`).
#[inline]
fn perturbed_side(a: [i64; 2], b: [i64; 2], q: [i64; 2]) -> i32 {
    let (du, dw) = (b[0] - a[0], b[1] - a[1]);
    let e = du as i128 * (q[1] - a[1]) as i128 - dw as i128 * (q[0] - a[0]) as i128;
    if e != 0 {
        return e.signum() as i32;
    }
    // e(ε) = e + du·ε² − dw·ε: the ε term decides, then the ε² term.
    if dw != 0 {
        return -(dw.signum() as i32);
    }
    du.signum() as i32
}

/// Crossings `(column, first voxel at or beyond the crossing)` of one
/// triangle with the lattice lines along `axis` inside the grid's columns.
fn triangle_crossings(t: &FixedTriangle, axis: usize, dims: Dims, out: &mut Vec<(u64, i64)>) {
    let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
    let p = t.map(|v| [v[u], v[w]]);
    let d = t.map(|v| v[axis]);
    let cross = |a: [i64; 2], b: [i64; 2], q: [i64; 2]| {
        (b[0] - a[0]) as i128 * (q[1] - a[1]) as i128
            - (b[1] - a[1]) as i128 * (q[0] - a[0]) as i128
    };
    let area = cross(p[0], p[1], p[2]);
    if area == 0 {
        return;
    }
    let s = area.signum() as i32;
    let umin = p.iter().map(|q| q[0]).min().unwrap_or(0);
    let umax = p.iter().map(|q| q[0]).max().unwrap_or(0);
    let wmin = p.iter().map(|q| q[1]).min().unwrap_or(0);
    let wmax = p.iter().map(|q| q[1]).max().unwrap_or(0);
    let j0 = (-((-umin).div_euclid(ONE))).max(0);
    let j1 = umax.div_euclid(ONE).min(dims[u] as i64 - 1);
    let k0 = (-((-wmin).div_euclid(ONE))).max(0);
    let k1 = wmax.div_euclid(ONE).min(dims[w] as i64 - 1);
    for k in k0..=k1 {
        for j in j0..=j1 {
            let q = [j * ONE, k * ONE];
            if perturbed_side(p[0], p[1], q) != s
                || perturbed_side(p[1], p[2], q) != s
                || perturbed_side(p[2], p[0], q) != s
            {
                continue;
            }
            // Depth by barycentric weights: d0 + (λ1 (d1−d0) + λ2 (d2−d0)) / area.
            let l1 = cross(p[2], p[0], q);
            let l2 = cross(p[0], p[1], q);
            let mut num = l1 * (d[1] - d[0]) as i128 + l2 * (d[2] - d[0]) as i128;
            let mut den = area;
            if den < 0 {
                num = -num;
                den = -den;
            }
            let x = d[0] as i128 + num.div_euclid(den);
            let frac = num.rem_euclid(den) != 0;
            // First centre i with i·ONE ≥ exact depth.
            let f = if frac {
                x.div_euclid(ONE as i128) + 1
            } else {
                -((-x).div_euclid(ONE as i128))
            };
            let column = j as u64 + dims[u] as u64 * k as u64;
            out.push((column, f as i64));
        }
    }
}

fn check_extents(mesh: &[FixedTriangle]) -> Result<()> {
    for (i, t) in mesh.iter().enumerate() {
        for a in 0..3 {
            let mn = t.iter().map(|p| p[a]).min().unwrap_or(0);
            let mx = t.iter().map(|p| p[a]).max().unwrap_or(0);
            if mx.checked_sub(mn).is_none_or(|e| e >= MAX_EXTENT) {
                return Err(VoxkitError::Unsupported(format!(
                    "triangle {i} spans 2^20 voxels or more; the exact parity fill supports less"
                )));
            }
        }
    }
    Ok(())
}

/// Solid voxels of the grid box `[0, dims)` by exact crossing parity along
/// lines parallel to `axis` (see the [module docs](self) for the tie rule).
/// Correct for watertight meshes; triangles may extend beyond the grid.
///
/// # Errors
/// [`VoxkitError::Unsupported`] for a triangle spanning 2^20 voxels or more;
/// grid allocation errors.
pub fn solid_voxels_parity_axis(
    mesh: &[FixedTriangle],
    dims: Dims,
    axis: Axis,
    limit: MemoryLimit,
) -> Result<BitGrid> {
    check_extents(mesh)?;
    let mut grid = BitGrid::new(dims, limit)?;
    let a = axis.index();
    let (u, w) = ((a + 1) % 3, (a + 2) % 3);
    let mut crossings: Vec<(u64, i64)> = mesh
        .par_iter()
        .fold(Vec::new, |mut acc, t| {
            triangle_crossings(t, a, dims, &mut acc);
            acc
        })
        .reduce(Vec::new, |mut x, mut y| {
            if x.len() < y.len() {
                std::mem::swap(&mut x, &mut y);
            }
            x.extend_from_slice(&y);
            x
        });
    crossings.par_sort_unstable();
    let n = dims[a] as i64;
    let mut start = 0;
    while start < crossings.len() {
        let column = crossings[start].0;
        let mut end = start;
        while end < crossings.len() && crossings[end].0 == column {
            end += 1;
        }
        let (j, k) = (column % dims[u] as u64, column / dims[u] as u64);
        let mut v = [0usize; 3];
        v[u] = j as usize;
        v[w] = k as usize;
        // Odd prefix counts: [f0, f1), [f2, f3), …; an unpaired last crossing
        // (open mesh) leaves the line inside to the end.
        for pair in crossings[start..end].chunks(2) {
            let lo = pair[0].1.clamp(0, n);
            let hi = pair.get(1).map_or(n, |c| c.1).clamp(0, n);
            for t in lo..hi {
                v[a] = t as usize;
                grid.set_index(v[0] + dims[0] * (v[1] + dims[1] * v[2]), true);
            }
        }
        start = end;
    }
    Ok(grid)
}

/// Solid voxels by exact parity along x ([`solid_voxels_parity_axis`] with
/// [`Axis::X`]): the fast reference for watertight meshes.
///
/// ```
/// use glam::DVec3;
/// use voxkit::grid::MemoryLimit;
/// use voxkit::voxelize::shapes::IndexedMesh;
/// use voxkit::voxelize::solid::solid_voxels_parity;
/// // Box [0.5, 3.5]³ (faces on voxel faces): centres 1..=3 on each axis.
/// let m = IndexedMesh::cuboid(DVec3::splat(0.5), DVec3::splat(3.5)).to_fixed_triangles().unwrap();
/// let g = solid_voxels_parity(&m, [5, 5, 5], MemoryLimit::DEFAULT).unwrap();
/// assert_eq!(g.count_ones(), 27);
/// assert!(g.get(glam::IVec3::new(1, 3, 2)) && !g.get(glam::IVec3::new(0, 2, 2)));
/// ```
pub fn solid_voxels_parity(
    mesh: &[FixedTriangle],
    dims: Dims,
    limit: MemoryLimit,
) -> Result<BitGrid> {
    solid_voxels_parity_axis(mesh, dims, Axis::X, limit)
}

/// Solid voxels by majority vote of exact parity along x, y and z: robust to
/// holes (a voxel is wrong only if two of its three axis lines pass through
/// holes).
///
/// # Errors
/// As [`solid_voxels_parity_axis`].
pub fn solid_voxels_voting(
    mesh: &[FixedTriangle],
    dims: Dims,
    limit: MemoryLimit,
) -> Result<BitGrid> {
    let gx = solid_voxels_parity_axis(mesh, dims, Axis::X, limit)?;
    let gy = solid_voxels_parity_axis(mesh, dims, Axis::Y, limit)?;
    let gz = solid_voxels_parity_axis(mesh, dims, Axis::Z, limit)?;
    let mut out = BitGrid::new(dims, limit)?;
    let (wx, wy, wz) = (gx.words(), gy.words(), gz.words());
    for (wi, ((&a, &b), &c)) in wx.iter().zip(wy).zip(wz).enumerate() {
        let mut m = (a & b) | (a & c) | (b & c);
        while m != 0 {
            let bit = m.trailing_zeros() as usize;
            m &= m - 1;
            out.set_index(wi * 64 + bit, true);
        }
    }
    Ok(out)
}

/// The voxels of `solid` that are not in `surface`: inside seeds for
/// [`crate::topology::tunnels::closed_surface_tunnels`].
pub fn interior_seeds(solid: &BitGrid, surface: &BitGrid) -> Vec<Voxel> {
    solid.iter_ones().filter(|&v| !surface.get(v)).collect()
}
