//! Solid (inside) tests: which voxel centres lie inside a triangle mesh.
//!
//! * [`solid_interior`]: what `--mode solid` uses. With
//!   [`InsideTest::Winding`] (the default) a centre is inside iff the
//!   generalized winding number `w ≥ ½`, evaluated as an exact integer (the
//!   signed crossing count of the mesh closed by caps over its holes,
//!   [`crate::voxelize::caps`], [`crate::voxelize::fill`]) plus the caps'
//!   own winding number from a Barnes–Hut tree with rigorous error bounds
//!   ([`crate::voxelize::winding`]), decided by regions so that only bricks
//!   near the holes go down to single voxels; there the caps' far field is
//!   shared by the brick (a local expansion with a rigorous error bound,
//!   refined for its sub-cubes), the near field summed exactly in vector
//!   lanes, and the 2³ cubes with centres whose bound straddles ½ get a
//!   finer far field of their own, in lanes too. Where holes are wide, a
//!   second-order Taylor expansion of the mesh's own winding number per 4³
//!   box (smooth across the caps) decides most centres first. With [`InsideTest::Parity`]:
//!   exact crossing parity along x, for watertight meshes. Output in tiles.
//!
//! The references it is tested against:
//! * [`winding_number`]: the generalized winding number, the sum of the signed
//!   solid angles of the triangles (van Oosterom–Strackee) over 4π, in `f64`.
//!   For a closed, outward-oriented mesh it is 1 inside and 0 outside; for a
//!   mesh with holes it degrades smoothly. A centre is inside when
//!   `w ≥` [`WINDING_THRESHOLD`] (0.5). [`solid_voxels_winding`] applies it to
//!   every centre (O(voxels × triangles): a reference for small grids).
//! * [`solid_voxels_parity`]: exact crossing parity along axis-parallel lines
//!   through voxel centres, into a dense bit grid (an independent
//!   implementation of the parity rule).
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

use std::borrow::Cow;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Result, VoxkitError};
use crate::fixed::{ONE, to_f64};
use crate::grid::brick::BrickMask;
use crate::grid::{BitGrid, BrickGrid, Dims, MemoryLimit, Voxel};
use crate::voxelize::caps::Boundary;
use crate::voxelize::conservative::FixedTriangle;
use crate::voxelize::fill::{
    BrickRefiner, BrickRule, Chain, FillOutput, LineValue, NoRefiner, fill_interior,
};
use crate::voxelize::surface::{SurfaceTriangle, VOXEL_ONE};
use crate::voxelize::winding::{
    Estimate, FarField, LANES, LocalExpansion, NearLanes, NearNodes, ROUNDING_SLACK, RimTree,
    WindingTree, grid_point, soup_winding, triangle_meets_box,
};

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

/// The voxels of `solid` that are not in `surface`: inside seeds for
/// [`crate::topology::tunnels::closed_surface_tunnels`].
pub fn interior_seeds(solid: &BitGrid, surface: &BitGrid) -> Vec<Voxel> {
    solid.iter_ones().filter(|&v| !surface.get(v)).collect()
}

/// How solid mode decides which voxel centres are inside.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum InsideTest {
    /// The generalized winding number, `w ≥ ½` (robust to holes, flipped
    /// faces and overlaps): exact signed crossings of the mesh closed by caps
    /// plus the caps' own winding number, evaluated hierarchically.
    #[default]
    Winding,
    /// Crossing parity along x (exact; right for watertight meshes, whatever
    /// their orientation). Fastest.
    Parity,
}

impl InsideTest {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            InsideTest::Winding => "winding",
            InsideTest::Parity => "parity",
        }
    }
}

/// Counts of one interior fill.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolidStats {
    /// Cap triangles closing the mesh's boundary (0 for a closed mesh).
    pub caps: usize,
    /// Lattice-line crossings.
    pub crossings: u64,
    /// Bricks decided voxel by voxel (near holes).
    pub refined_bricks: usize,
    /// Bricks with another rule than "inside iff the crossing count ≥ 1".
    pub rule_bricks: usize,
    /// Winding-number evaluations at single points (caps or mesh).
    pub point_queries: u64,
    /// Winding-number bounds over boxes.
    pub box_queries: u64,
    /// Voxel centres off the surface with `|w − ½| <` [`AMBIGUITY_BAND`]
    /// (`w` as estimated for the decision, within its error bound).
    pub ambiguous: u64,
    /// Centres of refined bricks that the brick's far field and exact near
    /// field left undecided: their 2³ cube's own finer far field decides
    /// them, or the per-point path when they may lie in a cap's plane.
    pub straddling: u64,
    /// Centres of refined bricks decided from one value per 2³ cube and
    /// the rim's gradient bound (where the caps are large, see
    /// `LARGE_CAP_AREA`), without their own near-field sum.
    pub gradient_centres: u64,
    /// Centres of refined bricks decided from a second-order Taylor
    /// expansion of the mesh's own winding number about one centre of
    /// their 4³ box (`Classifier::centres_by_taylor`), without far or
    /// near field of their own.
    pub taylor_centres: u64,
    /// Wall time (µs) finding the boundary and the caps over it, with the
    /// rim's tree built beside the serial cycle search.
    pub caps_us: u64,
    /// Wall time (µs) building the caps' tree, with the closed soup written
    /// beside it.
    pub trees_us: u64,
    /// Wall time (µs) of the region octree (the caps' bounds over boxes).
    pub regions_us: u64,
    /// Time (µs, summed over threads) building the refined bricks' far
    /// fields (local expansions and near lists).
    pub far_field_us: u64,
    /// Time (µs, summed over threads) in the exact near field of the
    /// refined bricks' centres.
    pub near_field_us: u64,
    /// Time (µs, summed over threads) deciding the straddling centres
    /// (cube by cube, then one by one).
    pub refine_us: u64,
    /// Time (µs, summed over threads) in the Taylor expansions of the
    /// refined bricks, with the wall time listing the mesh's triangles
    /// near each refined brick.
    pub taylor_us: u64,
}

/// A progress callback for the refined bricks: `(done, total)`, called from
/// the worker threads.
pub type BrickProgress<'a> = dyn Fn(u64, u64) + Sync + 'a;

/// Opening ratios of the refined bricks' far field (node accepted when
/// farther than `(β + 1)(r + ρ)` from the box centre), tried in turn until
/// the far field's error bound over the brick is below [`LADDER_BAND`]:
/// small first, so that the near field summed in lanes stays short where
/// caps are small; larger where they are large, so that few centres are
/// left straddling ½. Chosen by measurement (docs/performance-notes.md,
/// issue 22, step 5): starting at 0.75 instead of 1.5 took the bunny with
/// 5% of its triangles deleted from 490 to 400 ms at `-r 128`; with the
/// third-order multipoles 0.5 suffices there (160 → 137 ms).
const BRICK_BETAS: [f64; 7] = [0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0];

/// The brick ladder stops once the far field's bound is below this: a
/// looser bound leaves the centres within it of ½ to the costlier cube by
/// cube path (the bunny with 40% deleted at `-r 128`: 275k straddling
/// centres at 0.1, 10k at 0.05).
const LADDER_BAND: f64 = 0.05;

/// The brick ladder's first stop: a brick's 4³ boxes are decided from a
/// far field within this until one leaves more than [`RETRY_CUBES`] of its
/// cubes straddling ½ (a looser bound's shorter near lists pay where few
/// centres are near ½: the bunny ×4 with 20% removed).
const LOOSE_BAND: f64 = 0.07;

/// A 4³ box that leaves more straddling cubes than this at [`LOOSE_BAND`]
/// sends its brick on up the ladder to [`LADDER_BAND`]: those cubes are
/// decided again, and the brick's remaining boxes start there (where
/// centres crowd near ½, as with 40% removed, the tight bound is cheaper).
const RETRY_CUBES: usize = 1;

/// Voxels whose winding number lies within this of ½ are counted as
/// ambiguous ([`SolidStats::ambiguous`]): their verdict hangs on how the
/// holes are bridged.
pub const AMBIGUITY_BAND: f64 = 0.1;

/// Mean cap area (voxels²) from which refined bricks first try to decide
/// their 2³ cubes from one value each ([`Classifier::cubes_by_gradient`]):
/// caps larger than a brick's face (a scan's holes) leave most refined
/// centres far from ½ beside the ones near it, and one lane sum per 4³ box
/// decides them; where caps are small (holes everywhere, a few triangles
/// each) the rim's gradient bound is too large for it to pay, and the
/// extra sum per box cost Spot with 20% removed ~30% more wall time at
/// `-r 128` (docs/performance-notes.md, 2026-12-03).
const LARGE_CAP_AREA: f64 = 64.0;

/// Rims of up to this many segments let refined bricks try
/// [`Classifier::centres_by_taylor`] (with large caps): its gradient sums
/// every segment directly, at the eight boxes' expansion points of a brick
/// at once.
const TAYLOR_RIM_SEGMENTS: usize = 4096;

/// A 4³ box whose Taylor remainder bound `½ H r²` (`H` the rim's bound of
/// the second derivatives over its brick, else over the box; `r² = 12` for
/// the farthest centre) exceeds this is left to the far and near fields:
/// the expansion would decide few centres that the gradient path does not.
/// Chosen by measurement (the scanned bunny at `-r 1024`: 0.05 and 0.1
/// decided 1.00 and 1.25 M of its 2.04 M refined centres in times within
/// noise of each other; docs/performance-notes.md).
const TAYLOR_MAX_REMAINDER: f64 = 0.1;

/// Barnes–Hut opening ratios: boxes and first point estimates use the
/// first; points still undecided go on to the larger ones. With
/// third-order multipoles a node's truncation at these ratios is below
/// what second-order ones left at 3 and 6 (about 0.65 and 0.4 of it).
const BETAS: [f64; 2] = [2.5, 5.0];
/// Up to this many caps an undecided point is summed exactly at the end;
/// beyond, the last estimate stands (its error bound is far below the
/// ambiguity band, and `w` that close to ½ is a tie in all but name).
const EXACT_CAPS: usize = 512;

/// Centres on a cap whose mesh winding number is summed over every
/// triangle before a tree over the mesh is built: a million-triangle mesh
/// sums in ~20 ms a point and builds its tree in ~0.5 s and 300 MB (the
/// bunny split 16-fold with 20% removed has 2 such centres at `-r 64`).
const DIRECT_MESH_POINTS: u64 = 8;

/// The interior of a quantized mesh (triangles at [`VOXEL_ONE`] per voxel)
/// inside `[0, dims)`: the voxel centres the chosen test puts inside, as
/// tiles (whole bricks) and partial bricks. `degenerate` triangles take part
/// in the mesh's boundary only. `surface` (the voxels the caller adds
/// anyway) is left out of the ambiguity count, and refined bricks put its
/// voxels inside without deciding them.
///
/// With [`InsideTest::Winding`], a centre `q` is inside iff `w(q) ≥ ½` for
/// the generalized winding number `w = w_{S−S'} + w_{S'}`
/// ([`crate::voxelize::caps`]): the first term exactly, as the signed
/// crossing count of the closed chain ([`crate::voxelize::fill`]); the
/// second from a Barnes–Hut tree with rigorous error bounds
/// ([`crate::voxelize::winding`]), by regions: an octree over the grid stops
/// at the first box whose bound puts `m + w_{S'}` on one side of ½ for every
/// integer `m` (with [`AMBIGUITY_BAND`] to spare), so only bricks near the
/// caps go down to voxels. Those get the fast multipole treatment (see
/// [`BrickRefiner::refine`] of the classifier): per brick one far field, per
/// centre a polynomial and the exact near field, and the per-point tree walk
/// only where the bound straddles ½. Centres in `surface` are put inside
/// without a winding number (the caller adds them anyway). On a closed,
/// consistently oriented mesh there are no caps and the result is exact.
///
/// # Errors
/// [`VoxkitError::Unsupported`] for a triangle spanning 2^20 voxels or more.
///
/// ```
/// use glam::DVec3;
/// use voxkit::grid::BrickGrid;
/// use voxkit::voxelize::solid::{InsideTest, solid_interior};
/// // A box [0.5, 3.5]³ at 1/256 voxel with one face missing: still a box.
/// let m = voxkit::voxelize::shapes::IndexedMesh::cuboid(DVec3::splat(0.5), DVec3::splat(3.5)).without_face(0);
/// let tris: Vec<_> = m.to_fixed_triangles().unwrap().iter()
///     .map(|t| t.map(|p| p.map(|c| c >> 12))).collect();
/// let (g, stats) = solid_interior(&tris, &[], [5, 5, 5], InsideTest::Winding, &BrickGrid::new()).unwrap();
/// assert_eq!(g.count(), 27);
/// assert!(stats.caps > 0);
/// ```
pub fn solid_interior(
    triangles: &[SurfaceTriangle],
    degenerate: &[SurfaceTriangle],
    dims: Dims,
    test: InsideTest,
    surface: &BrickGrid,
) -> Result<(BrickGrid, SolidStats)> {
    solid_interior_in(triangles, degenerate, dims, test, surface, None, None)
}

/// [`solid_interior`] reporting the refined bricks as they are decided
/// (`progress(done, total)`, from the worker threads).
///
/// # Errors
/// As [`solid_interior`].
pub fn solid_interior_with_progress(
    triangles: &[SurfaceTriangle],
    degenerate: &[SurfaceTriangle],
    dims: Dims,
    test: InsideTest,
    surface: &BrickGrid,
    progress: Option<&BrickProgress<'_>>,
) -> Result<(BrickGrid, SolidStats)> {
    solid_interior_in(triangles, degenerate, dims, test, surface, None, progress)
}

/// A box of voxels `[min, max)` (x, y, z) whose corners are multiples of 8.
pub type BrickBox = (Voxel, Voxel);

/// [`solid_interior_with_progress`] restricted to the voxels of `region` (all of
/// `[0, dims)` when `None`), with the same verdict for each of them as the
/// whole run: `triangles`, `degenerate` and `dims` are the whole mesh's and
/// grid's. The caps come from the whole mesh's boundary and the winding
/// trees from all its triangles, so every winding evaluation is the same
/// computation as in the whole run; the octree is the whole grid's, with
/// the boxes that miss `region` left out (a box's verdict depends only on
/// the box and the trees); the crossing fill takes the closed chain's
/// triangles that can cross a line of `region` left of its far end, which
/// are all that the line values there count (a crossing counts for the
/// centres at or beyond it). Voxels outside `region` are dropped. The work
/// and memory of the fill and the octree follow the region (the trees, for
/// a mesh with holes, the whole mesh).
///
/// # Errors
/// As [`solid_interior`].
pub fn solid_interior_in(
    triangles: &[SurfaceTriangle],
    degenerate: &[SurfaceTriangle],
    dims: Dims,
    test: InsideTest,
    surface: &BrickGrid,
    region: Option<BrickBox>,
    progress: Option<&BrickProgress<'_>>,
) -> Result<(BrickGrid, SolidStats)> {
    for (i, t) in triangles.iter().enumerate() {
        for a in 0..3 {
            let mn = t.iter().map(|p| p[a]).min().unwrap_or(0);
            let mx = t.iter().map(|p| p[a]).max().unwrap_or(0);
            if mx - mn >= VOXEL_ONE << 20 {
                return Err(VoxkitError::Unsupported(format!(
                    "triangle {i} spans 2^20 voxels or more; the solid fill supports less"
                )));
            }
        }
    }
    let mut stats = SolidStats::default();
    let out = match test {
        InsideTest::Parity => fill_interior(
            (&*in_region_columns(triangles, region)).into(),
            dims,
            LineValue::Parity,
            &[],
            &NoRefiner,
            surface,
            0.0,
        ),
        InsideTest::Winding => {
            let t = std::time::Instant::now();
            let boundary = Boundary::of(triangles, degenerate);
            // The cycle search is serial: the rim's tree is built beside it.
            let (caps, rim) =
                rayon::join(|| boundary.caps(), || RimTree::from_edges(boundary.edges()));
            drop(boundary);
            stats.caps = caps.len();
            stats.caps_us = t.elapsed().as_micros() as u64;
            // The soup closed by its caps, reversed: read from the two slices
            // (a region keeps only the triangles whose crossings count in it).
            let own = in_region_columns(triangles, region);
            let caps_in = in_region_columns(&caps, region);
            let closed = Chain {
                triangles: &own,
                reversed: &caps_in,
            };
            if caps.is_empty() {
                fill_interior(
                    closed,
                    dims,
                    LineValue::Winding,
                    &[],
                    &NoRefiner,
                    surface,
                    AMBIGUITY_BAND,
                )
            } else {
                let t = std::time::Instant::now();
                let caps_tree = WindingTree::with_rim(&caps, rim);
                stats.trees_us = t.elapsed().as_micros() as u64;
                let ctx = Classifier {
                    caps: caps_tree,
                    large_caps: mean_area(&caps) >= LARGE_CAP_AREA,
                    triangles,
                    mesh: std::sync::OnceLock::new(),
                    direct_points: AtomicU64::new(0),
                    dims,
                    surface,
                    region,
                    points: AtomicU64::new(0),
                    boxes: AtomicU64::new(0),
                    far_ns: AtomicU64::new(0),
                    near_ns: AtomicU64::new(0),
                    slow_ns: AtomicU64::new(0),
                    slow_points: AtomicU64::new(0),
                    gradient_centres: AtomicU64::new(0),
                    taylor_centres: AtomicU64::new(0),
                    taylor_ns: AtomicU64::new(0),
                    mesh_bins: std::sync::OnceLock::new(),
                    bricks_done: AtomicU64::new(0),
                    bricks_total: AtomicU64::new(0),
                    progress,
                };
                let t = std::time::Instant::now();
                // The surface's brick index, which refined bricks look up,
                // built beside the octree rather than by the first refined
                // brick while the other threads wait for it.
                let (mut rules, _) = rayon::join(
                    || ctx.region_rules(Voxel::ZERO, top_size(dims), None),
                    || surface.brick(Voxel::ZERO).is_some(),
                );
                rules.sort_unstable_by_key(|(k, _)| (k.z, k.y, k.x));
                stats.regions_us = t.elapsed().as_micros() as u64;
                stats.rule_bricks = rules.len();
                stats.refined_bricks = rules
                    .iter()
                    .filter(|(_, r)| *r == BrickRule::Refine)
                    .count();
                ctx.bricks_total
                    .store(stats.refined_bricks as u64, Ordering::Relaxed);
                if ctx.large_caps && ctx.caps.rim_len() <= TAYLOR_RIM_SEGMENTS {
                    let t = std::time::Instant::now();
                    let refined = rules
                        .iter()
                        .filter(|(_, r)| *r == BrickRule::Refine)
                        .map(|(k, _)| *k)
                        .collect();
                    if let Some(bins) = MeshBins::new(triangles, refined) {
                        let _ = ctx.mesh_bins.set(bins);
                    }
                    ctx.taylor_ns
                        .fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
                }
                let out = fill_interior(
                    closed,
                    dims,
                    LineValue::Winding,
                    &rules,
                    &ctx,
                    surface,
                    AMBIGUITY_BAND,
                );
                stats.point_queries = ctx.points.load(Ordering::Relaxed);
                stats.box_queries = ctx.boxes.load(Ordering::Relaxed);
                stats.straddling = ctx.slow_points.load(Ordering::Relaxed);
                stats.gradient_centres = ctx.gradient_centres.load(Ordering::Relaxed);
                stats.taylor_centres = ctx.taylor_centres.load(Ordering::Relaxed);
                stats.taylor_us = ctx.taylor_ns.load(Ordering::Relaxed) / 1000;
                stats.far_field_us = ctx.far_ns.load(Ordering::Relaxed) / 1000;
                stats.near_field_us = ctx.near_ns.load(Ordering::Relaxed) / 1000;
                stats.refine_us = ctx.slow_ns.load(Ordering::Relaxed) / 1000;
                out
            }
        }
    };
    stats.crossings = out.crossings;
    stats.ambiguous = out.ambiguous;
    let mut grid = interior_grid(out);
    if let Some(r) = region {
        grid = crop(&grid, r);
    }
    Ok((grid, stats))
}

/// The triangles whose crossings can count in `region`: their (y, z) box
/// meets the region's lines and they start left of its far end (all of
/// them, borrowed, without a region).
fn in_region_columns(
    triangles: &[SurfaceTriangle],
    region: Option<BrickBox>,
) -> Cow<'_, [SurfaceTriangle]> {
    let Some((lo, hi)) = region else {
        return Cow::Borrowed(triangles);
    };
    let one = VOXEL_ONE;
    let in_column = |t: &&SurfaceTriangle| {
        let mn = |a: usize| t.iter().map(|p| p[a]).min().unwrap_or(0);
        let mx = |a: usize| t.iter().map(|p| p[a]).max().unwrap_or(0);
        mn(0) < i64::from(hi.x) * one
            && (1..3).all(|a| mx(a) >= i64::from(lo[a]) * one && mn(a) < i64::from(hi[a]) * one)
    };
    Cow::Owned(triangles.iter().filter(in_column).copied().collect())
}

/// The bricks of `grid` inside the box `region`, whose min corner is
/// brick-aligned and whose max corner is brick-aligned or the grid's own
/// edge (a tile cut at the grid: the bricks it ends in hold no voxel beyond
/// the grid, so they are kept whole).
pub fn crop(grid: &BrickGrid, (lo, hi): BrickBox) -> BrickGrid {
    let (blo, bhi) = (lo >> 3, (hi + Voxel::splat(7)) >> 3);
    let mut tiles = Vec::new();
    let (mut keys, mut masks) = (Vec::new(), Vec::new());
    for (k, m) in grid.bricks() {
        if k.cmpge(blo).all() && k.cmplt(bhi).all() {
            if grid.is_tile(k) {
                tiles.push(k);
            } else {
                keys.push(k);
                masks.push(*m);
            }
        }
    }
    BrickGrid::from_parts_tiled(keys, masks, tiles)
}

/// The fill's parts as a grid: whole bricks as tiles.
fn interior_grid(out: FillOutput) -> BrickGrid {
    BrickGrid::from_parts_tiled(out.keys, out.masks, out.tiles)
}

fn top_size(dims: Dims) -> i32 {
    (dims.iter().copied().max().unwrap_or(1).max(8) as u32).next_power_of_two() as i32
}

/// Whether an estimate of `w_{S'}` decides `m + w ≥ ½` for every integer `m`
/// over its whole interval: no `½ − m` lies in `[v − err, v + err]`.
fn decided(e: Estimate) -> bool {
    let lo = e.value - e.error - 0.5;
    let r = lo.rem_euclid(1.0);
    r > 0.0 && r + 2.0 * e.error < 1.0
}

fn centre_box(lo: Voxel, size: i32, dims: Dims) -> Option<(DVec3, DVec3)> {
    let hi = (lo + Voxel::splat(size - 1)).min(Voxel::new(
        dims[0] as i32 - 1,
        dims[1] as i32 - 1,
        dims[2] as i32 - 1,
    ));
    if hi.cmplt(lo).any() {
        return None;
    }
    Some((lo.as_dvec3(), hi.as_dvec3()))
}

/// The octree over the grid that finds each brick's rule, and the refiner
/// of the bricks it leaves undecided.
struct Classifier<'a> {
    /// The caps `S'`.
    caps: WindingTree,
    /// Whether the caps are large ([`LARGE_CAP_AREA`]): refined bricks
    /// then try [`Classifier::cubes_by_gradient`] first.
    large_caps: bool,
    /// The mesh `S` itself: it decides centres lying exactly on a cap (its
    /// winding number is continuous across the caps).
    mesh: std::sync::OnceLock<WindingTree>,
    /// `S`'s triangles, for `mesh`: built on first use (few meshes have a
    /// centre on a cap, and the tree over a large mesh costs tens of ms),
    /// and only once [`DIRECT_MESH_POINTS`] centres have been summed
    /// directly.
    triangles: &'a [SurfaceTriangle],
    /// Centres on a cap summed over `triangles` directly so far.
    direct_points: AtomicU64,
    dims: Dims,
    surface: &'a BrickGrid,
    /// Only boxes meeting this region are classified (see
    /// [`solid_interior_in`]).
    region: Option<BrickBox>,
    points: AtomicU64,
    boxes: AtomicU64,
    /// Time (ns, summed over threads) in the far field, the near field and
    /// the per-point path of the refined bricks.
    far_ns: AtomicU64,
    near_ns: AtomicU64,
    slow_ns: AtomicU64,
    /// Centres the brick's bounds left to the per-point path.
    slow_points: AtomicU64,
    /// Centres decided by [`Classifier::cubes_by_gradient`].
    gradient_centres: AtomicU64,
    /// Centres decided by [`Classifier::centres_by_taylor`], and the time
    /// spent there.
    taylor_centres: AtomicU64,
    taylor_ns: AtomicU64,
    /// The mesh's triangles near each refined brick, for
    /// [`Classifier::centres_by_taylor`]: set when the caps are large and
    /// their rim short enough for it to pay.
    mesh_bins: std::sync::OnceLock<MeshBins>,
    bricks_done: AtomicU64,
    bricks_total: AtomicU64,
    progress: Option<&'a BrickProgress<'a>>,
}

impl Classifier<'_> {
    /// `w_{S'}` at a voxel centre, or `None` on a cap.
    fn cap_point(&self, q: DVec3) -> Option<f64> {
        // Coarse first, then finer; exact only where the bound still
        // straddles a threshold and the caps are few.
        let mut last = 0.0;
        for beta in BETAS {
            match self.caps_point(q, beta) {
                Some(e) if decided(e) => return Some(e.value),
                Some(e) => last = e.value,
                None => return None,
            }
        }
        if self.caps.len() > EXACT_CAPS {
            return Some(last);
        }
        self.caps_point(q, f64::INFINITY).map(|e| e.value)
    }

    /// The mesh's own winding number at a centre (1 on the mesh itself).
    fn mesh_winding(&self, q: DVec3) -> f64 {
        // On the mesh itself the voxel is a surface voxel: solid either way.
        if self.mesh.get().is_none()
            && self.direct_points.fetch_add(1, Ordering::Relaxed) < DIRECT_MESH_POINTS
        {
            return soup_winding(self.triangles, q).unwrap_or(1.0);
        }
        let mesh = self.mesh.get_or_init(|| WindingTree::new(self.triangles));
        let mut last = 1.0;
        for beta in BETAS {
            match mesh.point(q, beta) {
                Some(e) if (e.value - 0.5).abs() > e.error => return e.value,
                Some(e) => last = e.value,
                None => return 1.0,
            }
        }
        last
    }

    /// Rules for the bricks of the cube `[lo, lo + size)` (size a power of
    /// two, at least 8): nothing where the default holds, `Uniform` where
    /// the caps' bound decides, `Refine` for the rest. `bound`: the cube's
    /// bound of the caps' winding number when its parent found it
    /// ([`Classifier::child_bounds`]), else it is found here.
    fn region_rules(
        &self,
        lo: Voxel,
        size: i32,
        bound: Option<Option<Estimate>>,
    ) -> Vec<(Voxel, BrickRule)> {
        let Some((blo, bhi)) = centre_box(lo, size, self.dims) else {
            return Vec::new();
        };
        if let Some((rlo, rhi)) = self.region
            && (lo.cmpge(rhi).any() || (lo + Voxel::splat(size)).cmple(rlo).any())
        {
            return Vec::new();
        }
        match bound.unwrap_or_else(|| self.caps_bound(blo, bhi)) {
            Some(e) if decided(e) => {
                if e.value.abs() < 0.5 - AMBIGUITY_BAND {
                    return Vec::new();
                }
                let (mut b0, mut b1): (Voxel, Voxel) = (blo.as_ivec3() >> 3, bhi.as_ivec3() >> 3);
                if let Some((rlo, rhi)) = self.region {
                    b0 = b0.max(rlo >> 3);
                    // The region's max corner may be the grid's edge.
                    b1 = b1.min(((rhi + Voxel::splat(7)) >> 3) - Voxel::ONE);
                }
                let mut out = Vec::new();
                for bz in b0.z..=b1.z {
                    for by in b0.y..=b1.y {
                        for bx in b0.x..=b1.x {
                            out.push((Voxel::new(bx, by, bz), BrickRule::Uniform(e.value)));
                        }
                    }
                }
                return out;
            }
            _ if size == 8 => return vec![(lo >> 3i32, BrickRule::Refine)],
            _ => {}
        }
        let half = size / 2;
        // Large caps (a scan's few wide holes): the children in one pass
        // from their parent's far field. Small ones (holes everywhere) walk
        // the tree per child: with thousands of small caps a box's near list
        // holds many leaves, and summing them in lanes cost more than eight
        // walks from the children's centres (the regions phase of the bunny
        // with 20% removed at 128: 55–60 ms against 31–47).
        let bounds = self
            .large_caps
            .then(|| self.child_bounds(lo, half, (blo, bhi)))
            .map_or([None; 8], |b| b.map(Some));
        let children: Vec<(Voxel, Option<Option<Estimate>>)> = (0..8)
            .map(|c| (lo + cube_offset(c) * (half / 2), bounds[c]))
            .collect();
        if size >= 64 {
            children
                .into_par_iter()
                .flat_map_iter(|(c, b)| self.region_rules(c, half, b))
                .collect()
        } else {
            children
                .into_iter()
                .flat_map(|(c, b)| self.region_rules(c, half, b))
                .collect()
        }
    }

    /// [`Classifier::caps_bound`] for the eight children (side `half`) of
    /// the cube at `lo` whose centres span `[blo, bhi]`, in one pass: the
    /// caps' far field over the parent as a local expansion, its near
    /// leaves summed at the eight children's centres in lanes, and each
    /// child's variation bounded by its half-diagonal times the rim's
    /// gradient bound over it. A child that a cap meets, or whose centre
    /// may lie in a cap's plane, gets `None`, as do children outside the
    /// grid.
    fn child_bounds(
        &self,
        lo: Voxel,
        half: i32,
        (blo, bhi): (DVec3, DVec3),
    ) -> [Option<Estimate>; 8] {
        let mut boxes = [None; 8];
        let mut q = [(blo + bhi) * 0.5; LANES];
        for (c, (b, qc)) in boxes.iter_mut().zip(&mut q).enumerate() {
            let Some((clo, chi)) = centre_box(lo + cube_offset(c) * (half / 2), half, self.dims)
            else {
                continue;
            };
            self.boxes.fetch_add(1, Ordering::Relaxed);
            if !self.caps.meets_box(clo, chi) {
                *qc = (clo + chi) * 0.5;
                *b = Some((clo, chi));
            }
        }
        if boxes.iter().all(Option::is_none) {
            return [None; 8];
        }
        let far = self.caps.far_field(blo, bhi, BETAS[0]);
        let sums = self.caps.near_lanes(&far.near, &q);
        std::array::from_fn(|c| {
            let (clo, chi) = boxes[c]?;
            if sums.flat[c] {
                return None;
            }
            let rho = (chi - clo).length() * 0.5;
            let mut error = far.local.error + sums.error[c] + ROUNDING_SLACK;
            if rho > 0.0 {
                error += rho * self.caps.gradient_bound(clo, chi);
            }
            Some(Estimate {
                value: far.local.eval(q[c]) + sums.sum[c],
                error,
            })
        })
    }
}

impl Classifier<'_> {
    fn caps_point(&self, q: DVec3, beta: f64) -> Option<Estimate> {
        self.points.fetch_add(1, Ordering::Relaxed);
        self.caps.point(q, beta)
    }

    fn caps_bound(&self, lo: DVec3, hi: DVec3) -> Option<Estimate> {
        self.boxes.fetch_add(1, Ordering::Relaxed);
        self.caps.bound(lo, hi, BETAS[0])
    }
}

impl BrickRefiner for Classifier<'_> {
    /// A brick the region octree left undecided, by the fast multipole
    /// scheme: the caps' far field over the brick as one local expansion
    /// (one tree traversal per brick), refined for its 4³ and 2³ sub-cubes
    /// from the parent's near list only (a dual-tree traversal with the
    /// brick's octree as the target tree), and the near field of each 2³
    /// cube summed exactly for its 8 centres in vector lanes. A centre whose
    /// `m + w_{S'}` is more than the accumulated error bound from ½ is
    /// decided there. A 2³ cube with centres whose bound straddles ½ gets
    /// its own far field at the point path's larger opening ratios, summed
    /// in lanes again ([`Classifier::straddling_cube`]); only centres that
    /// may lie in a cap's plane, and with few caps the last ties, go one by
    /// one to [`Classifier::cap_point`].
    fn refine(&self, key: Voxel, m: &[Option<i32>; 512]) -> (BrickMask, u64) {
        let lo = key * 8;
        let Some((blo, bhi)) = centre_box(lo, 8, self.dims) else {
            return ([0u64; 8], 0);
        };
        // The surface's mask, looked up once rather than per centre.
        let mut out = BrickOut {
            surface: self.surface.brick(key).copied().unwrap_or_default(),
            ..BrickOut::default()
        };
        // Centres the caller adds anyway (its surface) need no winding
        // number; `left` holds the line values of those still to decide.
        let mut left = *m;
        for (i, v) in left.iter_mut().enumerate() {
            if v.is_some() && out.on_surface(i) {
                out.mask[i / 64] |= 1 << (i % 64);
                *v = None;
            }
        }
        if let Some(bins) = self.mesh_bins.get() {
            let t = std::time::Instant::now();
            let decided = self.centres_by_taylor(lo, bins.of(key), m, &mut left, &mut out);
            self.taylor_centres.fetch_add(decided, Ordering::Relaxed);
            self.taylor_ns
                .fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
            if left.iter().all(Option::is_none) {
                self.brick_done();
                return (out.mask, out.ambiguous);
            }
        }
        let m = &left;
        let t = std::time::Instant::now();
        // The opening ratio grows until the far field's bound over the brick
        // is below [`LOOSE_BAND`], then for the cubes left straddling ½ until
        // it is below [`LADDER_BAND`]: where caps are large (holes
        // everywhere) a loose bound leaves most centres straddling, and a
        // longer near list in lanes costs less than deciding them cube by
        // cube; where few centres are near ½ the loose bound's shorter lists
        // pay.
        let mut rung = 0;
        let ladder = |rung: &mut usize, far: &mut FarField, band: f64| {
            while far.local.error > band && *rung + 1 < BRICK_BETAS.len() {
                *rung += 1;
                *far = self
                    .caps
                    .far_field_keeping(blo, bhi, BRICK_BETAS[*rung], NearNodes::Coarse);
            }
        };
        let mut far = self
            .caps
            .far_field_keeping(blo, bhi, BRICK_BETAS[0], NearNodes::Coarse);
        ladder(&mut rung, &mut far, LOOSE_BAND);
        // Tight once a 4³ box has shown that this brick's centres crowd near
        // ½ (or already so): from then on `far` serves the other boxes.
        let mut tight = far.local.error <= LADDER_BAND;
        let mut t_far = t.elapsed();
        let mut scratch = CubeScratch::default();
        for c in 0..8 {
            let before = out.pending.len();
            let beta = BRICK_BETAS[rung];
            t_far += self.box_cubes(lo, c, &far, beta, None, m, &mut out, &mut scratch);
            if !tight && out.pending.len() - before > RETRY_CUBES {
                let t_ladder = std::time::Instant::now();
                ladder(&mut rung, &mut far, LADDER_BAND);
                t_far += t_ladder.elapsed();
                let redo: Vec<Straddling> = out.pending.drain(before..).collect();
                let beta = BRICK_BETAS[rung];
                t_far += self.box_cubes(lo, c, &far, beta, Some(&redo), m, &mut out, &mut scratch);
                tight = true;
            }
        }
        let bb = BRICK_BETAS[rung];
        let t_near = t.elapsed();
        let straddling: usize = out
            .pending
            .iter()
            .map(|c| c.open.iter().filter(|&&o| o).count())
            .sum();
        let on_planes = out.slow.len();
        for cube in std::mem::take(&mut out.pending) {
            self.straddling_cube(lo, bb, cube, m, &mut out);
        }
        for (i, mv, tried) in std::mem::take(&mut out.slow) {
            let q = (lo + slot_voxel(i)).as_dvec3();
            // Centres whose lanes ran through the point path's ratios go
            // straight to the exact sum; the rest (maybe on a cap's plane)
            // take the point path from its first ratio.
            let cap = if tried {
                self.caps_point(q, f64::INFINITY).map(|e| e.value)
            } else {
                self.cap_point(q)
            };
            let w = match cap {
                Some(v) => mv as f64 + v,
                None => self.mesh_winding(q),
            };
            out.set(i, w);
        }
        let t_all = t.elapsed();
        self.far_ns
            .fetch_add(t_far.as_nanos() as u64, Ordering::Relaxed);
        self.near_ns
            .fetch_add((t_near - t_far).as_nanos() as u64, Ordering::Relaxed);
        self.slow_ns
            .fetch_add((t_all - t_near).as_nanos() as u64, Ordering::Relaxed);
        self.slow_points
            .fetch_add((straddling + on_planes) as u64, Ordering::Relaxed);
        self.brick_done();
        (out.mask, out.ambiguous)
    }
}

impl Classifier<'_> {
    /// Counts a refined brick as decided and reports progress.
    fn brick_done(&self) {
        let done = self.bricks_done.fetch_add(1, Ordering::Relaxed) + 1;
        if let Some(p) = self.progress {
            p(done, self.bricks_total.load(Ordering::Relaxed));
        }
    }

    /// Decides centres of the brick at `brick_lo` (`left` their line
    /// values, `None` once decided) from second-order Taylor expansions of
    /// the mesh's own winding number `w_S = m + w_{S'}`, one about a centre
    /// `c` of each 4³ box. Across a cap `w_{S'}` jumps by one and `m` by
    /// minus one, so `w_S` is smooth wherever the mesh `S` itself is not: if
    /// no triangle of `near` (the mesh's triangles near the brick) meets the
    /// box, `w_S(q) = w_S(c) + ∇w_S(c)·(q − c) + R` with
    /// `|R| ≤ ½ H |q − c|²`, `H` the rim's bound of the second derivatives
    /// over the brick ([`RimTree::hessian_bound`]). `w_S(c)` is `m(c)` plus
    /// the caps' sum at `c` (the eight boxes' in one call of the lane
    /// kernel, with a far field where the caps are many), `∇w_S(c)` the
    /// rim's Biot–Savart field summed exactly ([`RimTree::gradient_lanes`]).
    /// A centre is decided when its value lies farther from ½ than the sum
    /// of the bounds, so the verdict is the exact one; the others are left
    /// to the far and near fields. Where a scan's holes are wide, `H` is
    /// small over most of the band of centres near ½ that the cube paths
    /// sum one by one. Returns the number decided.
    fn centres_by_taylor(
        &self,
        brick_lo: Voxel,
        near: &[u32],
        m: &[Option<i32>; 512],
        left: &mut [Option<i32>; 512],
        out: &mut BrickOut,
    ) -> u64 {
        let Some((blo, bhi)) = centre_box(brick_lo, 8, self.dims) else {
            return 0;
        };
        // A box's centres lie within √12 of its expansion point. The
        // brick's bound serves every box when it is small enough; else each
        // box tries its own.
        let within = |hessian: f64| 0.5 * hessian * 12.0 <= TAYLOR_MAX_REMAINDER;
        let brick_hessian = Some(self.caps.hessian_bound(blo, bhi)).filter(|&h| within(h));
        let slot = |v: Voxel| {
            let l = v - brick_lo;
            (l.x + 8 * l.y + 64 * l.z) as usize
        };
        let triangles: Vec<[DVec3; 3]> = near
            .iter()
            .map(|&t| self.triangles[t as usize].map(grid_point))
            .filter(|t| triangle_meets_box(t, blo, bhi))
            .collect();
        // Each 4³ box with centres to decide and no triangle of the mesh:
        // its centres' box and expansion point.
        let mut boxes = [None; LANES];
        let mut points = [(blo + bhi) * 0.5; LANES];
        for (g, (b, point)) in boxes.iter_mut().zip(&mut points).enumerate() {
            let g = g as i32;
            let lo1 = brick_lo + Voxel::new(g & 1, (g >> 1) & 1, g >> 2) * 4;
            let Some((lo, hi)) = centre_box(lo1, 4, self.dims) else {
                continue;
            };
            let centre = (lo1 + Voxel::splat(2)).min(hi.as_ivec3());
            *point = centre.as_dvec3();
            let open = box_voxels(lo, hi).any(|v| left[slot(v)].is_some());
            if !open
                || m[slot(centre)].is_none()
                || triangles.iter().any(|t| triangle_meets_box(t, lo, hi))
            {
                continue;
            }
            let hessian = brick_hessian
                .or_else(|| Some(self.caps.hessian_bound(lo, hi)).filter(|&h| within(h)));
            if let Some(hessian) = hessian {
                *b = Some((lo, hi, hessian));
            }
        }
        if boxes.iter().all(Option::is_none) {
            return 0;
        }
        // The caps' sum at the eight points: every cap in lanes where they
        // are few, else a far field over the brick and its near leaves.
        let beta = if self.caps.len() <= EXACT_CAPS {
            f64::INFINITY
        } else {
            BETAS[1]
        };
        let far = self.caps.far_field(blo, bhi, beta);
        let sums = self.caps.near_lanes(&far.near, &points);
        let gradients = self.caps.rim_gradient_lanes(&points);
        let mut decided = 0;
        for g in 0..LANES {
            let (Some((lo, hi, hessian)), Some((gradient, gradient_error))) =
                (boxes[g], gradients[g])
            else {
                continue;
            };
            let c = points[g];
            let Some(mc) = m[slot(c.as_ivec3())] else {
                continue;
            };
            if sums.flat[g] {
                continue;
            }
            let w0 = mc as f64 + far.local.eval(c) + sums.sum[g];
            let e0 = far.local.error + sums.error[g] + ROUNDING_SLACK;
            for v in box_voxels(lo, hi) {
                let i = slot(v);
                if left[i].is_none() {
                    continue;
                }
                let d = v.as_dvec3() - c;
                let r2 = d.length_squared();
                let w = w0 + gradient.dot(d);
                // `|d| ≤ √12 < 3.47`: the gradient's rounding needs no root
                // per centre.
                let error = e0 + 3.47 * gradient_error + 0.5 * hessian * r2;
                if (w - 0.5).abs() > error {
                    out.set(i, w);
                    left[i] = None;
                    decided += 1;
                }
            }
        }
        decided
    }
}

/// The voxels of the box of centres `[lo, hi]`.
fn box_voxels(lo: DVec3, hi: DVec3) -> impl Iterator<Item = Voxel> {
    let (lo, hi) = (lo.as_ivec3(), hi.as_ivec3());
    (lo.z..=hi.z).flat_map(move |z| {
        (lo.y..=hi.y).flat_map(move |y| (lo.x..=hi.x).map(move |x| Voxel::new(x, y, z)))
    })
}

/// Largest bounding box (in bricks) of the refined bricks for which
/// [`MeshBins`] is built: one bit per brick, 8 MiB at most.
const MESH_BINS_BITS: i64 = 1 << 26;

/// The mesh's triangles whose bounding box meets each refined brick's box
/// of centres, as lists per brick (keys in `(z, y, x)` order).
struct MeshBins {
    keys: Vec<Voxel>,
    starts: Vec<u32>,
    triangles: Vec<u32>,
}

impl MeshBins {
    /// The lists for bricks `keys` (in `(z, y, x)` order) over `triangles`;
    /// `None` when the keys' bounding box holds more than
    /// [`MESH_BINS_BITS`] bricks (or there are none). A triangle spanning
    /// more bricks than there are keys is matched against every key instead
    /// of looking up the bricks it spans.
    fn new(triangles: &[SurfaceTriangle], keys: Vec<Voxel>) -> Option<Self> {
        let order = |k: &Voxel| (k.z, k.y, k.x);
        let brick = 8 * VOXEL_ONE;
        // The keys as bits over their bounding box: most triangles are far
        // from every refined brick, and a bit costs less than a search.
        let kmin = keys.iter().fold(Voxel::MAX, |a, k| a.min(*k));
        let kmax = keys.iter().fold(Voxel::MIN, |a, k| a.max(*k));
        let extent = (kmax - kmin + Voxel::ONE).max(Voxel::ZERO).as_i64vec3();
        let bits = extent.x * extent.y * extent.z;
        if keys.is_empty() || bits > MESH_BINS_BITS {
            return None;
        }
        let bit = |k: Voxel| {
            let l = (k - kmin).as_i64vec3();
            (l.x + extent.x * (l.y + extent.y * l.z)) as usize
        };
        let mut occupied = vec![0u64; (bits as usize).div_ceil(64)];
        for k in &keys {
            occupied[bit(*k) / 64] |= 1 << (bit(*k) % 64);
        }
        let pairs_of = |(i, t): (usize, &SurfaceTriangle), out: &mut Vec<(u32, u32)>| {
            // Bricks whose centres `[8k, 8k + 7]` the triangle's box may meet
            // (one more below than needed, for the floor), among the keys'.
            let span = |a: usize| {
                let mn = t.iter().map(|p| p[a]).min().unwrap_or(0);
                let mx = t.iter().map(|p| p[a]).max().unwrap_or(0);
                (
                    ((mn - 7 * VOXEL_ONE).div_euclid(brick) as i32).max(kmin[a]),
                    (mx.div_euclid(brick) as i32).min(kmax[a]),
                )
            };
            let (x, y, z) = (span(0), span(1), span(2));
            if x.0 > x.1 || y.0 > y.1 || z.0 > z.1 {
                return;
            }
            let count = [x, y, z]
                .iter()
                .map(|(a, b)| (i64::from(*b) - i64::from(*a) + 1) as u64)
                .product::<u64>();
            let inside = |k: &Voxel| {
                (x.0..=x.1).contains(&k.x)
                    && (y.0..=y.1).contains(&k.y)
                    && (z.0..=z.1).contains(&k.z)
            };
            if count > keys.len() as u64 {
                for (j, k) in keys.iter().enumerate() {
                    if inside(k) {
                        out.push((j as u32, i as u32));
                    }
                }
                return;
            }
            for kz in z.0..=z.1 {
                for ky in y.0..=y.1 {
                    for kx in x.0..=x.1 {
                        let b = bit(Voxel::new(kx, ky, kz));
                        if occupied[b / 64] & (1 << (b % 64)) == 0 {
                            continue;
                        }
                        if let Ok(j) = keys.binary_search_by_key(&(kz, ky, kx), order) {
                            out.push((j as u32, i as u32));
                        }
                    }
                }
            }
        };
        let mut pairs: Vec<(u32, u32)> = triangles
            .par_iter()
            .enumerate()
            .fold(Vec::new, |mut acc, it| {
                pairs_of(it, &mut acc);
                acc
            })
            .flatten_iter()
            .collect();
        pairs.par_sort_unstable();
        let mut starts = vec![0u32; keys.len() + 1];
        for &(j, _) in &pairs {
            starts[j as usize + 1] += 1;
        }
        for j in 0..keys.len() {
            starts[j + 1] += starts[j];
        }
        let triangles = pairs.into_iter().map(|(_, t)| t).collect();
        Some(MeshBins {
            keys,
            starts,
            triangles,
        })
    }

    /// The triangles listed for brick `key` (none for a brick not listed).
    fn of(&self, key: Voxel) -> &[u32] {
        match self
            .keys
            .binary_search_by_key(&(key.z, key.y, key.x), |k| (k.z, k.y, k.x))
        {
            Ok(j) => &self.triangles[self.starts[j] as usize..self.starts[j + 1] as usize],
            Err(_) => &[],
        }
    }
}

impl Classifier<'_> {
    /// The 2³ cubes of the 4³ box `c` (0..8) of the brick at `lo` from the
    /// brick's far field `far` (opening ratio `beta`): the 4³ and 2³ splits
    /// (each sub-cube re-expands its parent's quadratic about its own
    /// centre and accepts more nodes), then each cube's near leaves summed
    /// in lanes and its centres decided ([`Classifier::near_cube`]). With
    /// `only`, just those straddling cubes, whose open lanes are decided
    /// again. Returns the time spent in the splits.
    #[allow(clippy::too_many_arguments)]
    fn box_cubes(
        &self,
        lo: Voxel,
        c: i32,
        far: &FarField,
        beta: f64,
        only: Option<&[Straddling]>,
        m: &[Option<i32>; 512],
        out: &mut BrickOut,
        scratch: &mut CubeScratch,
    ) -> std::time::Duration {
        let t = std::time::Instant::now();
        let CubeScratch {
            near1,
            near2,
            cubes,
        } = scratch;
        near1.clear();
        near2.clear();
        cubes.clear();
        let lo1 = lo + Voxel::new(c & 1, (c >> 1) & 1, c >> 2) * 4;
        let Some((b1lo, b1hi)) = centre_box(lo1, 4, self.dims) else {
            return t.elapsed();
        };
        // A box whose centres are all decided (by a Taylor expansion, or
        // the surface) needs no far field.
        let open = |g: usize| {
            cube_lanes(lo, lo1 + cube_offset(g))
                .0
                .map(|i| m[i].is_some())
        };
        if only.is_none() && !(0..8).any(|g| open(g).contains(&true)) {
            return t.elapsed();
        }
        let mut l1 = far.local.recentred((b1lo + b1hi) * 0.5);
        self.caps.split(
            &far.near,
            b1lo,
            b1hi,
            beta,
            NearNodes::Coarse,
            &mut l1,
            near1,
        );
        let decided;
        let m = if self.large_caps && only.is_none() {
            decided = self.cubes_by_gradient(lo, lo1, (b1lo, b1hi), &l1, near1, m, out);
            &decided
        } else {
            m
        };
        for g in 0..8 {
            let lo2 = lo1 + cube_offset(g);
            if only.is_none() && cube_lanes(lo, lo2).0.iter().all(|&i| m[i].is_none()) {
                // Decided by the gradient, or nothing to decide.
                continue;
            }
            let Some((b2lo, b2hi)) = centre_box(lo2, 2, self.dims) else {
                continue;
            };
            let redo = only.map(|cubes| cubes.iter().find(|c| c.lo2 == lo2));
            if matches!(redo, Some(None)) {
                continue;
            }
            let mut l2 = l1.recentred((b2lo + b2hi) * 0.5);
            let start = near2.len();
            self.caps
                .split(near1, b2lo, b2hi, beta, NearNodes::Leaves, &mut l2, near2);
            cubes.push((lo2, l2, start..near2.len(), redo.flatten().copied()));
        }
        let far_time = t.elapsed();
        for (lo2, local, range, redo) in cubes.drain(..) {
            let near = &near2[range];
            match redo {
                None => self.near_cube(lo, lo2, &local, near, m, out),
                Some(cube) => {
                    let (_, q) = cube_lanes(lo, lo2);
                    let sums = self.caps.near_lanes(near, &q);
                    let rest = self.decide_lanes(lo, cube, m, &local, sums, out);
                    if rest.open.contains(&true) {
                        out.pending.push(rest);
                    }
                }
            }
        }
        far_time
    }
}

impl Classifier<'_> {
    /// Decides the centres of the 4³ box at `lo1` (its centres spanning
    /// `[b1lo, b1hi]`, in the brick at `brick_lo`) if no cap meets it, one value per
    /// 2³ cube: off the caps `w_{S'}` is smooth, so over a cube it lies
    /// within `ρ·G` of its value at the cube's centre (`ρ` the cube's
    /// half-diagonal, `G` the rim's bound of `|∇w_{S'}|` over the box,
    /// [`RimTree::gradient_bound`]). The eight cubes' centres are summed
    /// in one call of the lane kernel with the box's near list (`near1`,
    /// far field `l1`), where each cube would otherwise take its own. A
    /// centre is decided only when `m + w_{S'}` lies more than
    /// [`AMBIGUITY_BAND`] plus the error from ½, so the voxels and the
    /// ambiguity count are those of the cube path. Returns `m` with the
    /// decided centres cleared (the cube path passes over them); the
    /// surface's centres are left to it.
    #[allow(clippy::too_many_arguments)]
    fn cubes_by_gradient(
        &self,
        brick_lo: Voxel,
        lo1: Voxel,
        (b1lo, b1hi): (DVec3, DVec3),
        l1: &LocalExpansion,
        near1: &[u32],
        m: &[Option<i32>; 512],
        out: &mut BrickOut,
    ) -> [Option<i32>; 512] {
        let mut left = *m;
        let surface = out.surface;
        let open = |i: usize| m[i].is_some() && !in_mask(&surface, i);
        let mut q = [(b1lo + b1hi) * 0.5; LANES];
        let mut cubes = [None; LANES];
        for (g, cube) in cubes.iter_mut().enumerate() {
            let lo2 = lo1 + cube_offset(g);
            if let Some((b2lo, b2hi)) = centre_box(lo2, 2, self.dims) {
                q[g] = (b2lo + b2hi) * 0.5;
                let slots = cube_lanes(brick_lo, lo2).0;
                if slots.iter().any(|&i| open(i)) {
                    *cube = Some((slots, (b2hi - b2lo).length() * 0.5));
                }
            }
        }
        if cubes.iter().all(Option::is_none) || self.caps.meets_box(b1lo, b1hi) {
            return left;
        }
        let sums = self.caps.near_lanes(near1, &q);
        // `G` only once some centre could be decided without it.
        let (mut gradient, mut decided) = (None, 0);
        for (g, cube) in cubes.iter().enumerate() {
            let Some((slots, rho)) = *cube else { continue };
            if sums.flat[g] {
                continue;
            }
            let v = l1.eval(q[g]) + sums.sum[g];
            let margin =
                |mv: i32, error: f64| ((mv as f64 + v) - 0.5).abs() > AMBIGUITY_BAND + error;
            let error = l1.error + sums.error[g] + ROUNDING_SLACK;
            if !slots
                .iter()
                .any(|&i| open(i) && margin(m[i].unwrap_or(0), error))
            {
                continue;
            }
            let g_bound = *gradient.get_or_insert_with(|| self.caps.gradient_bound(b1lo, b1hi));
            let error = error + rho * g_bound;
            for i in slots {
                if let Some(mv) = m[i]
                    && open(i)
                    && margin(mv, error)
                {
                    if mv as f64 + v > 0.5 {
                        out.mask[i / 64] |= 1 << (i % 64);
                    }
                    left[i] = None;
                    decided += 1;
                }
            }
        }
        self.gradient_centres.fetch_add(decided, Ordering::Relaxed);
        left
    }
}

/// Buffers reused by the 4³ boxes of a brick ([`Classifier::box_cubes`]):
/// the box's near nodes, its cubes' near leaves, and the cubes (lowest
/// voxel, expansion, range of `near2`, the straddling cube being decided
/// again).
#[derive(Default)]
struct CubeScratch {
    near1: Vec<u32>,
    near2: Vec<u32>,
    cubes: Vec<(
        Voxel,
        LocalExpansion,
        std::ops::Range<usize>,
        Option<Straddling>,
    )>,
}

/// What deciding one refined brick produces, and the work it leaves.
#[derive(Default)]
struct BrickOut {
    /// The brick's inside centres so far.
    mask: BrickMask,
    /// The brick's surface voxels (set by the caller anyway).
    surface: BrickMask,
    /// Centres counted in [`SolidStats::ambiguous`].
    ambiguous: u64,
    /// Centres for the per-point path: (slot, line value, whether the
    /// point path's opening ratios were tried in lanes already).
    slow: Vec<(usize, i32, bool)>,
    /// 2³ cubes with centres the brick's bound left undecided.
    pending: Vec<Straddling>,
}

impl BrickOut {
    /// Records centre `i` of the brick with winding number `w`.
    fn set(&mut self, i: usize, w: f64) {
        if w >= 0.5 {
            self.mask[i / 64] |= 1 << (i % 64);
        }
        if (w - 0.5).abs() < AMBIGUITY_BAND && !self.on_surface(i) {
            self.ambiguous += 1;
        }
    }

    /// Whether centre `i` of the brick is a surface voxel.
    #[inline]
    fn on_surface(&self, i: usize) -> bool {
        in_mask(&self.surface, i)
    }
}

/// Whether slot `i` is set in a brick mask.
#[inline]
fn in_mask(mask: &BrickMask, i: usize) -> bool {
    mask[i / 64] & (1 << (i % 64)) != 0
}

/// The centres of a 2³ cube that [`Classifier::refine`] could not decide
/// from the brick's far field.
#[derive(Clone, Copy)]
struct Straddling {
    /// The cube's lowest voxel.
    lo2: Voxel,
    /// Lanes still undecided.
    open: [bool; LANES],
    /// Their estimates so far.
    last: [f64; LANES],
}

/// The brick slots and centres of the 2³ cube at `lo2` in lane order.
fn cube_lanes(brick_lo: Voxel, lo2: Voxel) -> ([usize; LANES], [DVec3; LANES]) {
    let slots: [usize; LANES] = std::array::from_fn(|k| {
        let l = lo2 - brick_lo + Voxel::new(k as i32 & 1, (k as i32 >> 1) & 1, k as i32 >> 2);
        (l.x + 8 * l.y + 64 * l.z) as usize
    });
    let q = slots.map(|i| (brick_lo + slot_voxel(i)).as_dvec3());
    (slots, q)
}

/// The mean area of `triangles` in voxels².
fn mean_area(triangles: &[SurfaceTriangle]) -> f64 {
    let one = VOXEL_ONE as f64;
    let total: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / one);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    total / triangles.len().max(1) as f64
}

/// The lowest voxel of 2³ cube `g` (0..8) of a 4³ box, from the box's.
fn cube_offset(g: usize) -> Voxel {
    Voxel::new(g as i32 & 1, (g as i32 >> 1) & 1, g as i32 >> 2) * 2
}

/// The offset in its brick of slot `i` (`x + 8y + 64z`).
fn slot_voxel(i: usize) -> Voxel {
    Voxel::new((i % 8) as i32, (i / 8 % 8) as i32, (i / 64) as i32)
}

impl Classifier<'_> {
    /// Decides the 2³ cube at `lo2` of the brick at `brick_lo` from its far
    /// field `local` and its near leaves: centres that may lie in a cap's
    /// plane go to `out.slow`, and a cube with centres the bound leaves
    /// undecided to `out.pending`.
    fn near_cube(
        &self,
        brick_lo: Voxel,
        lo2: Voxel,
        local: &LocalExpansion,
        near: &[u32],
        m: &[Option<i32>; 512],
        out: &mut BrickOut,
    ) {
        let (slots, q) = cube_lanes(brick_lo, lo2);
        // Centres the caller adds anyway (its surface) need no winding number.
        let mut cube = Straddling {
            lo2,
            open: [false; LANES],
            last: [0.0; LANES],
        };
        for k in 0..LANES {
            if m[slots[k]].is_some() {
                if out.on_surface(slots[k]) {
                    out.mask[slots[k] / 64] |= 1 << (slots[k] % 64);
                } else {
                    cube.open[k] = true;
                }
            }
        }
        if !cube.open.contains(&true) {
            return;
        }
        let sums = self.caps.near_lanes(near, &q);
        let rest = self.decide_lanes(brick_lo, cube, m, local, sums, out);
        if rest.open.contains(&true) {
            out.pending.push(rest);
        }
    }

    /// Decides the centres of a 2³ cube that straddle ½ within the brick's
    /// bound: the cube's own far field at the point path's opening ratios,
    /// its near leaves in lanes again (one traversal and one lane sum for
    /// the cube, not one walk per centre). Centres still within the bound
    /// after the finest ratio get exact sums when the caps are few (via
    /// `out.slow`), else the last estimate, as the point path does.
    fn straddling_cube(
        &self,
        brick_lo: Voxel,
        brick_beta: f64,
        mut cube: Straddling,
        m: &[Option<i32>; 512],
        out: &mut BrickOut,
    ) {
        let Some((lo, hi)) = centre_box(cube.lo2, 2, self.dims) else {
            return;
        };
        let (slots, q) = cube_lanes(brick_lo, cube.lo2);
        for beta in BETAS.into_iter().filter(|&b| b > brick_beta) {
            let far = self.caps.far_field(lo, hi, beta);
            let sums = self.caps.near_lanes(&far.near, &q);
            cube = self.decide_lanes(brick_lo, cube, m, &far.local, sums, out);
            if !cube.open.contains(&true) {
                return;
            }
        }
        for k in 0..LANES {
            if !cube.open[k] {
                continue;
            }
            let Some(mv) = m[slots[k]] else { continue };
            if self.caps.len() <= EXACT_CAPS {
                out.slow.push((slots[k], mv, true));
            } else {
                out.set(slots[k], cube.last[k]);
            }
        }
    }

    /// Decides the open lanes of `cube` from a far field `local` and a near
    /// sum ([`WindingTree::near_lanes`]): lanes the
    /// bound decides are set, lanes that may lie in a cap's plane go to
    /// `out.slow`; returns the cube with the lanes still open and their
    /// estimates.
    fn decide_lanes(
        &self,
        brick_lo: Voxel,
        cube: Straddling,
        m: &[Option<i32>; 512],
        local: &LocalExpansion,
        near: NearLanes,
        out: &mut BrickOut,
    ) -> Straddling {
        let (slots, q) = cube_lanes(brick_lo, cube.lo2);
        let mut rest = Straddling {
            open: [false; LANES],
            ..cube
        };
        for k in 0..LANES {
            if !cube.open[k] {
                continue;
            }
            let Some(mv) = m[slots[k]] else { continue };
            let w = mv as f64 + local.eval(q[k]) + near.sum[k];
            let error = local.error + near.error[k] + ROUNDING_SLACK;
            if near.flat[k] {
                out.slow.push((slots[k], mv, false));
            } else if (w - 0.5).abs() > error {
                out.set(slots[k], w);
            } else {
                rest.open[k] = true;
                rest.last[k] = w;
            }
        }
        rest
    }
}
