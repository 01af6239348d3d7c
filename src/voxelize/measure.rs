//! Error measures of a voxelization against the exact conservative set of
//! the same fixed-point triangles (`voxkit voxelize --measure`).
//!
//! What [`measure_voxelization`] computes, precisely. The *reference mesh*
//! is the 1/256-voxel mesh ([`Voxelization::reference_mesh`]) — also for a
//! snapped run, so the measures include the snapping error; the tunnel
//! verdicts use the mesh that was voxelized (snapped or not), since
//! tunnel-freeness is a property of a voxelization of its own input.
//!
//! * **reference**: the exact conservative set ([`conservative_grid`]) of the
//!   quantized triangles (shifted to 2^-20, the same points) and polyline
//!   segments, restricted to the grid box (the restriction drops nothing:
//!   see [`conservative_grid`]);
//! * **missing** = |reference \ output|, **extra** = |output \ reference|;
//! * **distance** of an output voxel `v`: the Euclidean distance (in voxels,
//!   `f64`) from the centre of `v` to the nearest triangle or segment among
//!   those whose conservative set contains `v` or one of its 26 neighbours,
//!   i.e. that meet the closed block `[v − 3/2, v + 3/2]³`. Every triangle
//!   closer than 3/2 to the centre meets that block, so when the result is
//!   below 3/2 it *is* the distance to the whole surface. Voxels where it is
//!   3/2 or more (or with no such triangle) are at distance ≥ 3/2 from the
//!   surface; they are counted as `far_voxels` (interior voxels of a solid)
//!   and left out of max and mean. Every conservative voxel is within
//!   `√3/2` of the surface, so surface modes have no far voxels;
//! * **tunnels** (6 and 26) for closed meshes (every edge, keyed by its
//!   fixed-point endpoints, shared by an even number of triangles): inside
//!   seeds are the voxels inside by exact crossing parity that are not output
//!   voxels, and a tunnel is an N-path of empty voxels from the grid border
//!   to a seed ([`closed_surface_tunnels`]). Skipped with a note for open
//!   meshes or when the dense grids (six bits per grid voxel plus 12 bytes
//!   per seed) would exceed the memory limit.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Result, VoxkitError};
use crate::grid::brick::{BrickMask, FxHasher};
use crate::grid::{BitGrid, BrickGrid, Dims, GridFrame, MemoryLimit, Voxel};
use crate::mesh::Mesh;
use crate::metric::Connectivity;
use crate::topology::tunnels::closed_surface_tunnels;
use crate::voxelize::conservative::conservative_voxels;
use crate::voxelize::pipeline::{
    QuantizedMesh, SurfaceSegment, Voxelization, conservative_grid, quantize_mesh,
    segment_to_reference, to_reference,
};
use crate::voxelize::solid::{InsideTest, solid_interior};
use crate::voxelize::surface::{SurfaceTriangle, VOXEL_ONE};

/// The error measures of one voxelization (see the [module docs](self)).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ErrorMeasures {
    /// Voxels of the exact conservative reference.
    pub reference_voxels: u64,
    /// Reference voxels missing from the output.
    pub missing: u64,
    /// Output voxels not in the reference.
    pub extra: u64,
    /// Largest centre-to-surface distance over output voxels that are not far.
    pub max_distance: f64,
    /// Mean centre-to-surface distance over output voxels that are not far.
    pub mean_distance: f64,
    /// Output voxels at distance ≥ 3/2 from the surface.
    pub far_voxels: u64,
    /// Whether the mesh is closed (every edge shared by an even number of triangles).
    pub closed: bool,
    /// 6-tunnel verdict, when computed.
    pub tunnel6: Option<bool>,
    /// 26-tunnel verdict, when computed.
    pub tunnel26: Option<bool>,
    /// Why the tunnel verdicts were skipped, if they were.
    pub note: Option<String>,
}

/// Measures `v` (see the [module docs](self)); `limit` caps the dense grids
/// of the tunnel verdicts.
///
/// # Errors
/// Only from the solid fill (triangles spanning 2^20 voxels or more).
pub fn measure_voxelization(v: &Voxelization, limit: MemoryLimit) -> Result<ErrorMeasures> {
    measure_voxel_set(&v.grid, v.frame.dims, v.reference_mesh(), &v.mesh, limit)
}

/// Measures any voxel set `grid` (inside `0..dims`) against the exact
/// conservative set of `reference`, with tunnel verdicts against the inside
/// of `voxelized` (the mesh the set was made from; pass `reference` again
/// when there is no other). This is how another tool's output is measured
/// ([`measure_external`]).
///
/// ```
/// use voxkit::grid::{BrickGrid, MemoryLimit, Voxel};
/// use voxkit::voxelize::measure::measure_voxel_set;
/// use voxkit::voxelize::pipeline::QuantizedMesh;
/// use voxkit::voxelize::surface::VOXEL_ONE;
/// // A triangle in the plane z = 1 (grid space) inside a 4³ grid.
/// let (o, z) = (VOXEL_ONE, VOXEL_ONE);
/// let mesh = QuantizedMesh {
///     triangles: vec![[[0, 0, z], [3 * o, 0, z], [0, 3 * o, z]]],
///     ..Default::default()
/// };
/// let mut grid = BrickGrid::new();
/// grid.insert(Voxel::new(0, 0, 1));
/// grid.insert(Voxel::new(3, 3, 3)); // far from the triangle
/// let m = measure_voxel_set(&grid, [4, 4, 4], &mesh, &mesh, MemoryLimit::default()).unwrap();
/// // The 10 lattice points with i + j ≤ 3, plus (2,2), (3,1) and (1,3), whose
/// // closed cubes the hypotenuse x + y = 3 touches at a corner.
/// assert_eq!(m.reference_voxels, 13);
/// assert_eq!((m.missing, m.extra, m.far_voxels), (12, 1, 1));
/// assert_eq!(m.max_distance, 0.0);
/// ```
///
/// # Errors
/// Only from the solid fill (triangles spanning 2^20 voxels or more).
pub fn measure_voxel_set(
    grid: &BrickGrid,
    dims: Dims,
    reference_mesh: &QuantizedMesh,
    voxelized: &QuantizedMesh,
    limit: MemoryLimit,
) -> Result<ErrorMeasures> {
    let rm = reference_mesh;
    let mut reference = conservative_grid(rm.triangles.par_iter().map(to_reference), dims);
    reference.union_with(&conservative_grid(
        rm.segments.par_iter().map(segment_to_reference),
        dims,
    ));
    let (mut missing, mut extra) = (0, 0);
    for (b, m) in reference.bricks() {
        let o = grid.brick(b).copied().unwrap_or([0; 8]);
        missing += (0..8)
            .map(|w| (m[w] & !o[w]).count_ones() as u64)
            .sum::<u64>();
    }
    for (b, o) in grid.bricks() {
        let m = reference.brick(b).copied().unwrap_or([0; 8]);
        extra += (0..8)
            .map(|w| (o[w] & !m[w]).count_ones() as u64)
            .sum::<u64>();
    }
    let (max_distance, mean_distance, far_voxels) =
        distances(grid, &reference, &rm.triangles, &rm.segments);
    let mut out = ErrorMeasures {
        reference_voxels: reference.count(),
        missing,
        extra,
        max_distance,
        mean_distance,
        far_voxels,
        closed: is_closed(&voxelized.triangles, &voxelized.degenerate),
        ..Default::default()
    };
    drop(reference);
    if !out.closed {
        out.note = Some("mesh is not closed: no inside to tunnel into".into());
        return Ok(out);
    }
    let n = dims.iter().map(|&d| d as u128).product::<u128>();
    if limit.check("tunnel check", n.div_ceil(8), 6).is_err() {
        out.note = Some(format!(
            "tunnel check skipped: dense grids need {} bytes, limit {}",
            6 * n.div_ceil(8),
            limit.bytes
        ));
        return Ok(out);
    }
    let occ = grid.to_bit_grid(dims, limit)?;
    let seeds = {
        // Closed: exact parity is the inside test.
        let (solid, _) = solid_interior(
            &voxelized.triangles,
            &voxelized.degenerate,
            dims,
            InsideTest::Parity,
            grid,
        )?;
        let interior = solid.count().saturating_sub(grid.count());
        if limit
            .check(
                "tunnel seeds",
                interior as u128,
                12 + 6 * n.div_ceil(8) / n.max(1),
            )
            .is_err()
        {
            out.note = Some(format!(
                "tunnel check skipped: {interior} inside seeds exceed the memory limit"
            ));
            return Ok(out);
        }
        inside_seeds(&solid, &occ)
    };
    out.tunnel6 = Some(closed_surface_tunnels(&occ, Connectivity::Six, &seeds)?.tunnel);
    out.tunnel26 = Some(closed_surface_tunnels(&occ, Connectivity::TwentySix, &seeds)?.tunnel);
    if seeds.is_empty() {
        out.note = Some("no inside voxel off the surface: nothing to tunnel into".into());
    }
    Ok(out)
}

/// Measures another tool's voxels against `mesh` (world space) on that
/// tool's lattice: voxel `(i, j, k)` is the cube `[origin + i·h, origin +
/// (i+1)·h]` per axis (`origin` = world min corner of voxel 0, `h` =
/// `voxel_size`; indices may be negative). The frame is widened to hold every
/// voxel and the mesh with one voxel to spare, so nothing is clipped; the
/// mesh is quantized to 1/256 voxel in that frame (the reference surface of
/// [`measure_voxelization`]). Returns the measures and the widened frame.
///
/// # Errors
/// A non-finite or non-positive voxel size or origin, an empty mesh, a grid
/// larger than `limit` allows, or the solid fill's errors.
pub fn measure_external(
    mesh: &Mesh,
    origin: DVec3,
    voxel_size: f64,
    voxels: &[[i64; 3]],
    limit: MemoryLimit,
) -> Result<(ErrorMeasures, GridFrame)> {
    if !(voxel_size.is_finite() && voxel_size > 0.0 && origin.is_finite()) {
        return Err(VoxkitError::invalid(format!(
            "measure: voxel size {voxel_size} and origin {origin} must be finite, size > 0"
        )));
    }
    if mesh.triangles.is_empty() && mesh.polylines.is_empty() {
        return Err(VoxkitError::invalid(
            "measure: the mesh has no triangles or polylines",
        ));
    }
    let probe = GridFrame::new(origin, voxel_size, [1, 1, 1]);
    let (blo, bhi) = mesh.bounds();
    let (glo, ghi) = (probe.world_to_grid(blo), probe.world_to_grid(bhi));
    let mut lo = [0i64; 3];
    let mut hi = [0i64; 3];
    for a in 0..3 {
        lo[a] = (glo[a] + 0.5).floor() as i64 - 1;
        hi[a] = (ghi[a] + 0.5).floor() as i64 + 1;
    }
    for v in voxels {
        for a in 0..3 {
            lo[a] = lo[a].min(v[a]);
            hi[a] = hi[a].max(v[a]);
        }
    }
    let dims: [usize; 3] = std::array::from_fn(|a| (hi[a] - lo[a] + 1) as usize);
    if dims.iter().any(|&d| d > i32::MAX as usize / 2) {
        return Err(VoxkitError::invalid(format!(
            "measure: the voxels and the mesh span {dims:?} voxels, too many"
        )));
    }
    limit.check(
        "measure grid",
        dims.iter()
            .map(|&d| d as u128)
            .product::<u128>()
            .div_ceil(8),
        6,
    )?;
    let frame = GridFrame::new(
        origin + DVec3::new(lo[0] as f64, lo[1] as f64, lo[2] as f64) * voxel_size,
        voxel_size,
        dims,
    );
    let mut grid = BrickGrid::new();
    for v in voxels {
        grid.insert(Voxel::new(
            (v[0] - lo[0]) as i32,
            (v[1] - lo[1]) as i32,
            (v[2] - lo[2]) as i32,
        ));
    }
    let q = quantize_mesh(mesh, &frame, false);
    let m = measure_voxel_set(&grid, dims, &q, &q, limit)?;
    Ok((m, frame))
}

fn inside_seeds(solid: &BrickGrid, occ: &BitGrid) -> Vec<Voxel> {
    solid.iter().filter(|&v| !occ.get(v)).collect()
}

/// Whether every edge (by fixed-point endpoints) of `kept` and `degenerate`
/// triangles together is used an even number of times: closed, possibly
/// with several sheets meeting at an edge. Degenerate triangles count: a
/// collinear one pairs the edges of its neighbours (zero-length edges of
/// coincident vertices pair with themselves).
pub fn is_closed(kept: &[SurfaceTriangle], degenerate: &[SurfaceTriangle]) -> bool {
    let tris = kept;
    let mut edges: Vec<([i64; 3], [i64; 3])> = kept
        .iter()
        .chain(degenerate)
        .flat_map(|t| {
            (0..3).map(move |k| {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if a <= b { (a, b) } else { (b, a) }
            })
        })
        .collect();
    edges.par_sort_unstable();
    !tris.is_empty() && edges.chunk_by(|a, b| a == b).all(|c| c.len() % 2 == 0)
}

/// Rank index of the voxels of the bricks of a brick grid that `near`
/// accepts: voxel → position in a compact array (brick base + popcount rank
/// inside the brick). `left_out` counts the voxels of the other bricks.
struct VoxelIndex {
    bricks: HashMap<Voxel, (usize, BrickMask), std::hash::BuildHasherDefault<FxHasher>>,
    len: usize,
    left_out: u64,
}

impl VoxelIndex {
    fn new(g: &BrickGrid, near: impl Fn(Voxel) -> bool) -> Self {
        let mut bricks = HashMap::default();
        let (mut len, mut left_out) = (0, 0);
        for (b, m) in g.bricks() {
            let n = m.iter().map(|w| w.count_ones() as usize).sum::<usize>();
            if near(b) {
                bricks.insert(b, (len, *m));
                len += n;
            } else {
                left_out += n as u64;
            }
        }
        VoxelIndex {
            bricks,
            len,
            left_out,
        }
    }

    fn get(&self, v: Voxel) -> Option<usize> {
        let (base, m) = self.bricks.get(&(v >> 3))?;
        let (lx, ly, lz) = ((v.x & 7) as u32, (v.y & 7) as u32, (v.z & 7) as usize);
        let bit = lx + 8 * ly;
        if m[lz] >> bit & 1 == 0 {
            return None;
        }
        let below: u32 = m[..lz].iter().map(|w| w.count_ones()).sum();
        Some(base + (below + (m[lz] & ((1u64 << bit) - 1)).count_ones()) as usize)
    }
}

fn to_dvec(p: [i64; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / VOXEL_ONE as f64
}

/// `(max, mean, far)` of the output voxels' distances (module docs).
/// Only voxels within one voxel of a `reference` voxel can get a distance,
/// so only bricks within one brick of a reference brick are indexed; the
/// voxels of the others (a solid's interior) are far without a slot each.
fn distances(
    grid: &BrickGrid,
    reference: &BrickGrid,
    tris: &[SurfaceTriangle],
    segs: &[SurfaceSegment],
) -> (f64, f64, u64) {
    let index = VoxelIndex::new(grid, |b| {
        (0..27).any(|i| {
            reference
                .brick(b + Voxel::new(i % 3 - 1, i / 3 % 3 - 1, i / 9 - 1))
                .is_some()
        })
    });
    let best: Vec<AtomicU64> = (0..index.len)
        .map(|_| AtomicU64::new(f64::INFINITY.to_bits()))
        .collect();
    let visit = |reference: crate::voxelize::conservative::FixedTriangle,
                 dist: &dyn Fn(DVec3) -> f64| {
        let Ok(it) = conservative_voxels(&reference) else {
            return;
        };
        let mut near: Vec<Voxel> = Vec::new();
        for w in it {
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        near.push(w + Voxel::new(dx, dy, dz));
                    }
                }
            }
        }
        near.sort_unstable_by_key(|p| (p.z, p.y, p.x));
        near.dedup();
        for u in near {
            if let Some(i) = index.get(u) {
                // Non-negative f64s order like their bit patterns.
                best[i].fetch_min(dist(u.as_dvec3()).to_bits(), Ordering::Relaxed);
            }
        }
    };
    tris.par_iter().for_each(|t| {
        let [a, b, c] = t.map(to_dvec);
        visit(to_reference(t), &|p| point_triangle_distance(p, a, b, c));
    });
    segs.par_iter().for_each(|s| {
        let [a, b] = s.map(to_dvec);
        visit(segment_to_reference(s), &|p| {
            point_segment_distance(p, a, b)
        });
    });
    let (mut max, mut sum, mut n, mut far) = (0f64, 0f64, 0u64, index.left_out);
    for d in &best {
        let d = f64::from_bits(d.load(Ordering::Relaxed));
        // At 3/2 or more the candidates may miss a nearer triangle outside
        // the block; the true distance is ≥ 3/2 either way: far.
        if d < 1.5 {
            max = max.max(d);
            sum += d;
            n += 1;
        } else {
            far += 1;
        }
    }
    (max, if n > 0 { sum / n as f64 } else { 0.0 }, far)
}

/// Distance from `p` to segment `ab` (f64).
pub fn point_segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.length_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + t * ab - p).length()
}

/// Distance from `p` to the closed triangle `abc` (f64; Ericson's
/// closest-point regions, exact up to rounding for non-degenerate triangles).
///
/// ```
/// use glam::DVec3;
/// use voxkit::voxelize::measure::point_triangle_distance;
/// let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
/// assert_eq!(point_triangle_distance(DVec3::new(0.25, 0.25, 2.0), a, b, c), 2.0);
/// assert_eq!(point_triangle_distance(DVec3::new(2.0, 0.0, 0.0), a, b, c), 1.0);
/// ```
pub fn point_triangle_distance(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return point_segment_distance(p, a, b);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return point_segment_distance(p, a, c);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return point_segment_distance(p, b, c);
    }
    let denom = va + vb + vc;
    if denom <= 0.0 {
        // Degenerate: the nearest of the three edges.
        return point_segment_distance(p, a, b)
            .min(point_segment_distance(p, b, c))
            .min(point_segment_distance(p, a, c));
    }
    let (v, w) = (vb / denom, vc / denom);
    (a + ab * v + ac * w - p).length()
}
