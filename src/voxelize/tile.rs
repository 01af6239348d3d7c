//! Tiles: one box of a grid voxelized alone, with exactly the voxels the
//! whole-grid run makes there.
//!
//! A tiled run fixes the lattice and the grid first (`--voxel-size H
//! --origin X,Y,Z` fitted over the mesh,
//! [`Lattice::fit`](crate::voxelize::pipeline::Lattice::fit)) and cuts the grid
//! into cubes of `tile_size` voxels (a multiple of 512 in a store, so that a
//! tile is a whole number of Zarr shards; any multiple of 8 here). The mesh is quantized in the *whole* grid's
//! frame (the same fixed-point vertices, clamped to the same box), and then
//! each mode is reproduced on the tile:
//!
//! - **thin, thick** (and solid's surface): each triangle's voxels are its
//!   own (lattice-line crossings), so the tile takes the triangles whose box,
//!   one voxel wider, meets the tile, shifts them by a whole number of
//!   bricks (integer fixed-point offsets: the kernel's arithmetic is the
//!   same) and voxelizes them in the tile's box widened by 8 voxels where the
//!   tile is not at the grid's edge. The kernel clamps crossings outside its
//!   box onto the box's faces: at the grid's own faces it does so in the
//!   whole run too, and elsewhere they land in the margin, which is cropped.
//! - **conservative**: per-triangle sets, cut to the box (as the whole run
//!   cuts at the grid).
//! - **solid**: the surface as above, plus [`solid_interior_in`] over the
//!   tile (the same crossing counts and winding evaluations as the whole
//!   run, restricted to the tile).
//! - **polylines**: the segments meeting the tile, in the whole grid, cut.
//!
//! So the union of the tiles is the whole run, voxel for voxel; the tests
//! compare merged tiles with whole runs on meshes crossing and lying on
//! tile faces.

use rayon::prelude::*;

use crate::error::{Result, VoxkitError};
use crate::grid::{BrickGrid, GridFrame, Voxel};
use crate::voxelize::pipeline::{
    QuantizedMesh, SurfaceSegment, VoxelizeMode, VoxelizeOptions, bricks_to_grid,
    conservative_grid, polyline_voxels, surface_bricks, to_reference,
};
use crate::voxelize::solid::{BrickBox, SolidStats, crop, solid_interior_in};
use crate::voxelize::surface::{SurfaceMode, SurfaceTriangle, VOXEL_ONE};

/// Voxels of margin around a tile's box for the surface kernels (one brick).
const MARGIN: i32 = 8;

/// The box of tile `tile` (`[min, max)` in voxels, cut at the grid).
pub fn tile_box(tile: [u32; 3], tile_size: u32, dims: [usize; 3]) -> BrickBox {
    let lo = Voxel::from_array(tile.map(|t| (t * tile_size) as i32));
    let hi = Voxel::new(
        (lo.x + tile_size as i32).min(dims[0] as i32),
        (lo.y + tile_size as i32).min(dims[1] as i32),
        (lo.z + tile_size as i32).min(dims[2] as i32),
    );
    (lo, hi)
}

/// Tiles along each axis.
pub fn tile_counts(dims: [usize; 3], tile_size: u32) -> [u32; 3] {
    dims.map(|d| d.div_ceil(tile_size as usize) as u32)
}

/// Checks a store's tile size: a positive multiple of 512.
pub fn check_tile_size(tile_size: u32) -> Result<()> {
    if tile_size == 0 || !tile_size.is_multiple_of(512) {
        return Err(VoxkitError::invalid(format!(
            "tile size {tile_size} must be a positive multiple of 512 (one Zarr shard)"
        )));
    }
    Ok(())
}

/// The voxel box `[lo, hi]` (inclusive) a fixed-point point set can reach:
/// its box widened by one voxel (every voxel a triangle or segment gives
/// meets its closed box, so this is a safe superset).
fn reach(points: &[[i64; 3]]) -> (Voxel, Voxel) {
    let v = |c: i64| (c.div_euclid(VOXEL_ONE)) as i32;
    let mut lo = Voxel::splat(i32::MAX);
    let mut hi = Voxel::splat(i32::MIN);
    for p in points {
        let q = Voxel::new(v(p[0]), v(p[1]), v(p[2]));
        lo = lo.min(q);
        hi = hi.max(q);
    }
    (lo - Voxel::splat(1), hi + Voxel::splat(2))
}

/// Whether the reach `r` meets the box `[lo, hi)`.
fn meets(r: (Voxel, Voxel), (lo, hi): BrickBox) -> bool {
    r.0.cmplt(hi).all() && r.1.cmpge(lo).all()
}

/// The tiles (sorted by z, y, x) that can hold voxels of `mode`: those whose
/// box meets the reach of a triangle or segment of `mesh`; for
/// [`VoxelizeMode::Solid`], every tile of the grid, since the interior fills
/// tiles that no triangle reaches (the grid is fitted to the mesh, so these
/// are the tiles of its bounding box).
pub fn plan_tiles(
    mesh: &QuantizedMesh,
    dims: [usize; 3],
    tile_size: u32,
    mode: VoxelizeMode,
) -> Vec<[u32; 3]> {
    let n = tile_counts(dims, tile_size);
    if mode == VoxelizeMode::Solid {
        let mut all = Vec::new();
        for z in 0..n[2] {
            for y in 0..n[1] {
                for x in 0..n[0] {
                    all.push([x, y, z]);
                }
            }
        }
        return all;
    }
    let mut hit = std::collections::BTreeSet::new();
    let segs = mesh.segments.iter().map(|s| reach(s));
    for r in mesh.triangles.iter().map(|t| reach(t)).chain(segs) {
        for_tiles_reached(r, n, tile_size, |[x, y, z]| {
            hit.insert([z, y, x]);
        });
    }
    hit.into_iter().map(|[z, y, x]| [x, y, z]).collect()
}

/// Calls `f` with every tile (of `n` tiles of `tile_size`) that the reach
/// `(lo, hi)` (inclusive voxels) meets.
fn for_tiles_reached(
    (lo, hi): (Voxel, Voxel),
    n: [u32; 3],
    tile_size: u32,
    mut f: impl FnMut([u32; 3]),
) {
    let t = |c: i32, a: usize| (c.max(0) as u32 / tile_size).min(n[a] - 1);
    for z in t(lo.z, 2)..=t(hi.z, 2) {
        for y in t(lo.y, 1)..=t(hi.y, 1) {
            for x in t(lo.x, 0)..=t(hi.x, 0) {
                f([x, y, z]);
            }
        }
    }
}

/// For each tile, the triangles of `mesh` (indices, ascending) whose reach
/// meets it: one pass over the mesh, so that a process voxelizing many
/// tiles of one mesh ([`voxelize_tile_among`]) does not scan every triangle
/// for every tile.
pub fn bin_triangles(
    mesh: &QuantizedMesh,
    dims: [usize; 3],
    tile_size: u32,
) -> std::collections::HashMap<[u32; 3], Vec<u32>> {
    let n = tile_counts(dims, tile_size);
    let mut bins: std::collections::HashMap<[u32; 3], Vec<u32>> = Default::default();
    for (i, t) in mesh.triangles.iter().enumerate() {
        for_tiles_reached(reach(&t[..]), n, tile_size, |k| {
            bins.entry(k).or_default().push(i as u32)
        });
    }
    bins
}

/// What one tile's voxelization did.
#[derive(Clone, Debug, Default)]
pub struct TileStats {
    /// Triangles that reach the tile.
    pub triangles: usize,
    /// Segments that reach the tile.
    pub segments: usize,
    /// The solid fill's counts.
    pub solid: Option<SolidStats>,
}

/// The voxels of tile `tile` of the whole-grid run of `mesh` (quantized in
/// `frame`, the whole grid's) with `opts`' mode: see the module docs.
pub fn voxelize_tile(
    mesh: &QuantizedMesh,
    frame: &GridFrame,
    opts: &VoxelizeOptions,
    tile: [u32; 3],
    tile_size: u32,
) -> Result<(BrickGrid, TileStats)> {
    voxelize_tile_among(mesh, None, frame, opts, tile, tile_size)
}

/// [`voxelize_tile`], looking for the tile's triangles among `candidates`
/// only (indices into `mesh.triangles`: the tile's bin of
/// [`bin_triangles`], a superset of them) instead of among all.
pub fn voxelize_tile_among(
    mesh: &QuantizedMesh,
    candidates: Option<&[u32]>,
    frame: &GridFrame,
    opts: &VoxelizeOptions,
    tile: [u32; 3],
    tile_size: u32,
) -> Result<(BrickGrid, TileStats)> {
    if tile_size == 0 || !tile_size.is_multiple_of(8) {
        return Err(VoxkitError::invalid(format!(
            "tile size {tile_size} must be a positive multiple of 8 (whole bricks)"
        )));
    }
    let dims = frame.dims;
    let n = tile_counts(dims, tile_size);
    if (0..3).any(|a| tile[a] >= n[a]) {
        return Err(VoxkitError::invalid(format!(
            "tile {tile:?} is outside the grid's {n:?} tiles of {tile_size}"
        )));
    }
    let region = tile_box(tile, tile_size, dims);
    let mut stats = TileStats::default();
    let tris: Vec<SurfaceTriangle> = match candidates {
        Some(c) => c
            .iter()
            .map(|&i| mesh.triangles[i as usize])
            .filter(|t| meets(reach(&t[..]), region))
            .collect(),
        None => mesh
            .triangles
            .par_iter()
            .filter(|t| meets(reach(&t[..]), region))
            .copied()
            .collect(),
    };
    stats.triangles = tris.len();
    let kk = opts.snap && opts.kahan_kelsen;
    let mut grid = match opts.mode {
        VoxelizeMode::Thin => surface_in(&tris, region, dims, SurfaceMode::Thin, kk)?,
        VoxelizeMode::Thick => surface_in(&tris, region, dims, SurfaceMode::Thick, kk)?,
        VoxelizeMode::Conservative => {
            let (lo, hi) = region;
            let shift = lo.to_array().map(|c| i64::from(c) * VOXEL_ONE);
            let local = (hi - lo).to_array().map(|d| d as usize);
            let g = conservative_grid(
                tris.par_iter()
                    .map(|t| to_reference(&t.map(|p| [0, 1, 2].map(|a| p[a] - shift[a])))),
                local,
            );
            shift_grid(&g, lo)
        }
        VoxelizeMode::Solid => {
            let surface = surface_in(&tris, region, dims, SurfaceMode::Thin, kk)?;
            drop(tris);
            let (inside, s) = solid_interior_in(
                &mesh.triangles,
                &mesh.degenerate,
                dims,
                opts.inside,
                &surface,
                Some(region),
                None,
            )?;
            stats.solid = Some(s);
            let mut g = surface;
            g.union_with(&inside);
            g
        }
    };
    let segs: Vec<SurfaceSegment> = mesh
        .segments
        .iter()
        .filter(|s| meets(reach(&s[..]), region))
        .copied()
        .collect();
    stats.segments = segs.len();
    if !segs.is_empty() {
        grid.union_with(&crop(&polyline_voxels(&segs, opts.mode, dims)?, region));
    }
    Ok((grid, stats))
}

/// Thin or thick surface voxels of `tris` inside `region` (see the module
/// docs: shifted into the region widened by [`MARGIN`] inside the grid,
/// then cropped).
fn surface_in(
    tris: &[SurfaceTriangle],
    region: BrickBox,
    dims: [usize; 3],
    mode: SurfaceMode,
    kahan_kelsen: bool,
) -> Result<BrickGrid> {
    let (lo, hi) = region;
    let grid_hi = Voxel::new(dims[0] as i32, dims[1] as i32, dims[2] as i32);
    let ext_lo = (lo - Voxel::splat(MARGIN)).max(Voxel::ZERO);
    let ext_hi = (hi + Voxel::splat(MARGIN)).min(grid_hi);
    let shift = ext_lo.to_array().map(|c| i64::from(c) * VOXEL_ONE);
    let local: Vec<SurfaceTriangle> = tris
        .iter()
        .map(|t| t.map(|p| [0, 1, 2].map(|a| p[a] - shift[a])))
        .collect();
    let g = bricks_to_grid(surface_bricks(
        &local,
        (ext_hi - ext_lo).to_array(),
        mode,
        kahan_kelsen,
    )?);
    Ok(crop(&shift_grid(&g, ext_lo), region))
}

/// `grid` moved by `by` voxels (a multiple of 8 on every axis).
fn shift_grid(grid: &BrickGrid, by: Voxel) -> BrickGrid {
    let b = by >> 3;
    let (mut keys, mut masks, mut tiles) = (Vec::new(), Vec::new(), Vec::new());
    for (k, m) in grid.bricks() {
        if grid.is_tile(k) {
            tiles.push(k + b);
        } else {
            keys.push(k + b);
            masks.push(*m);
        }
    }
    BrickGrid::from_parts_tiled(keys, masks, tiles)
}
