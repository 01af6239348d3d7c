//! Tiled runs into one OME-Zarr store: the plan and the tile, shared by the
//! command line (`voxkit voxelize … --tile-size N --plan | --tile I,J,K | --finish`)
//! and Python (`voxkit.distributed`, which maps tiles over Dask).
//!
//! - [`plan`] fits the grid (the same lattice options as a whole run),
//!   writes the store's metadata once ([`zarr::create`], recording
//!   `tile_size`) and lists the tiles whose box meets the mesh
//!   ([`plan_tiles`]);
//! - [`run_tile`] checks that the store was planned for the same grid and
//!   tile size, voxelizes the tile ([`voxelize_tile_among`]: exactly the whole
//!   run's voxels there) and writes its shards ([`zarr::write_shards`],
//!   removing its empty ones; never metadata). Tiles are whole shards, so
//!   tiles never write the same object, a re-run changes nothing, and a
//!   re-run of a killed tile repairs it. With a pyramid, a tile also
//!   writes the levels where it is still whole shards ([`tile_levels`]);
//! - [`finish`] (only for a store planned with a pyramid) max-pools the
//!   levels whose shards span several tiles, once every tile is done.
//!
//! Each returns the JSON object the CLI prints (keys in the CLI's docs).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Instant, SystemTime};

use glam::{DVec3, IVec3};

use crate::error::{Result, VoxkitError};
use crate::grid::GridFrame;
use crate::io::zarr::{self, ShardBox};
use crate::mesh::Mesh;
use crate::voxelize::pipeline::{
    QuantizedMesh, VoxelizeMode, VoxelizeOptions, estimate_bytes, quantize_mesh,
};
use crate::voxelize::surface::SurfaceTriangle;
use crate::voxelize::tile::{
    bin_triangles, check_tile_size, plan_tiles, tile_box, tile_counts, voxelize_tile_among,
};

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Peak resident set size in MiB (VmHWM), where `/proc` has it.
pub fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn check_store_path(store: &Path) -> Result<()> {
    if !zarr::is_zarr_path(store) {
        return Err(VoxkitError::invalid(format!(
            "{}: a tiled run writes a .zarr store",
            store.display()
        )));
    }
    Ok(())
}

/// Plans a tiled run of the mesh at `mesh_path` into `store`: fits the
/// grid, writes the store's metadata (replacing an existing store only if
/// `force`, and only a Zarr store) and returns `store`, `mesh`, `mode`,
/// `dims`, `voxel_size`, `origin`, `tile_size`, `tile_counts`, `tile_count`,
/// `tiles` (`[i, j, k]` sorted by k, j, i) and `triangles`.
pub fn plan(
    mesh_path: &Path,
    store: &Path,
    opts: &VoxelizeOptions,
    tile_size: u32,
    force: bool,
    pyramid: bool,
) -> Result<serde_json::Value> {
    check_tile_size(tile_size)?;
    check_store_path(store)?;
    zarr::check_replaceable(store, force, "plan it anew")?;
    if store.exists() {
        std::fs::remove_dir_all(store).map_err(|source| VoxkitError::Io {
            path: store.to_path_buf(),
            source,
        })?;
    }
    // Loaded, quantized and binned as a tile does: a process that plans and
    // then runs tiles (a Dask worker, or Python without a cluster) does it
    // once.
    let (loaded, _) = LoadedMesh::get(mesh_path)?;
    let frame = opts.lattice.fit(loaded.bounds)?;
    let (quantized, _) = loaded.quantized(&frame, opts.snap, tile_size);
    let tiles = plan_tiles(&quantized, frame.dims, tile_size, opts.mode);
    let levels = if pyramid {
        zarr::pyramid_levels(frame.dims)
    } else {
        1
    };
    zarr::create(store, &frame, levels, Some(u64::from(tile_size)))?;
    Ok(serde_json::json!({
        "store": store.display().to_string(),
        "mesh": mesh_path.display().to_string(),
        "mode": opts.mode.name(),
        "dims": frame.dims,
        "voxel_size": frame.voxel_size,
        "origin": frame.origin.to_array(),
        "tile_size": tile_size,
        "tile_counts": tile_counts(frame.dims, tile_size),
        "tile_count": tiles.len(),
        "tiles": tiles,
        "levels": levels,
        "tile_levels": tile_levels(tile_size, levels),
        "triangles": quantized.triangles.len(),
    }))
}

/// How many levels of a `levels`-level store each tile writes itself: those
/// where a tile is still a whole number of shards (`tile_size >> level` a
/// multiple of 512: levels 0 and 1 for tiles of 1024). [`finish`] builds
/// the rest from the last of them.
pub fn tile_levels(tile_size: u32, levels: u32) -> u32 {
    (0..levels)
        .take_while(|&l| (tile_size >> l) > 0 && u64::from(tile_size >> l) % zarr::SHARD_EDGE == 0)
        .count() as u32
}

/// The shards of `level` that the voxel box `[lo, hi)` of level 0 covers.
fn level_shards(lo: IVec3, hi: IVec3, level: u32) -> ShardBox {
    let edge = zarr::SHARD_EDGE as i32;
    let f = 1i32 << level;
    // Level voxels: lo / f (exact: tiles are aligned) to ceil(hi / f).
    let l_lo = lo / f;
    let l_hi = (hi + IVec3::splat(f - 1)) / f;
    ShardBox {
        min: l_lo / edge,
        max: (l_hi + IVec3::splat(edge - 1)) / edge,
    }
}

/// Finishes a tiled run's pyramid (`--finish`, after every tile): the
/// levels a tile cannot write alone ([`tile_levels`]: their shards span
/// several tiles) are max-pooled from the last level the tiles wrote, read
/// back whole (64 times smaller than level 0 at tiles of 1024, in bricks:
/// its surface, not its box). Every shard of those levels is rewritten or
/// removed, so a re-run after tiles were re-run is exact. Returns `store`,
/// `levels`, `from_level`, `written_levels`, `voxels` (per level written),
/// `bytes`, `read_ms` and `write_ms`.
pub fn finish(store: &Path, limit: crate::grid::MemoryLimit) -> Result<serde_json::Value> {
    check_store_path(store)?;
    let info = zarr::info(store)?;
    let Some(tile_size) = info.tile_size else {
        return Err(VoxkitError::invalid(format!(
            "{} was not planned for tiles (--plan): nothing to finish",
            store.display()
        )));
    };
    let done = tile_levels(tile_size as u32, info.levels);
    let from = done.saturating_sub(1);
    let t = Instant::now();
    let mut voxels = Vec::new();
    let mut bytes = 0;
    let mut grid = if done < info.levels {
        zarr::read_level(store, from, limit)?.0
    } else {
        crate::grid::BrickGrid::new()
    };
    let read_ms = ms(t);
    let t = Instant::now();
    for level in done..info.levels {
        grid = zarr::max_pool(&grid);
        let dims = zarr::level_frame(&info.frame, level).dims;
        let all = ShardBox {
            min: IVec3::ZERO,
            max: IVec3::from_array(dims.map(|d| d.div_ceil(zarr::SHARD_EDGE as usize) as i32)),
        };
        bytes += zarr::write_shards(store, level, &grid, Some(all))?.bytes;
        voxels.push(grid.count());
    }
    Ok(serde_json::json!({
        "store": store.display().to_string(),
        "levels": info.levels,
        "from_level": from,
        "written_levels": (done..info.levels).collect::<Vec<u32>>(),
        "voxels": voxels,
        "bytes": bytes,
        "read_ms": read_ms,
        "write_ms": ms(t),
    }))
}

/// What identifies a mesh file's content without reading it: its path,
/// length and modification time.
#[derive(Clone, Debug, PartialEq, Eq)]
struct FileKey {
    path: PathBuf,
    len: u64,
    modified: Option<SystemTime>,
}

impl FileKey {
    fn of(path: &Path) -> Result<FileKey> {
        let meta = std::fs::metadata(path).map_err(|source| VoxkitError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(FileKey {
            path: std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
            len: meta.len(),
            modified: meta.modified().ok(),
        })
    }
}

/// A mesh as a tile needs it: its bounds (to fit the frame), its size (for
/// the memory estimate), and its quantization in the last frame asked for
/// with its triangles binned by tile.
///
/// A process that runs many tiles of one mesh (a Dask worker) keeps the
/// last one here, so that it parses and quantizes the file once, not once
/// per tile (docs/scale-out.md). The key is the file's path, length and
/// modification time; a file rewritten in place within the clock's
/// resolution, with the same length, would be missed, which a planned run
/// (whose mesh does not change under it) never does. A CLI tile is its own
/// process and loads the mesh once anyway.
struct LoadedMesh {
    key: FileKey,
    bounds: (DVec3, DVec3),
    mesh_bytes: u64,
    mesh: Arc<Mesh>,
    quantized: Mutex<Option<Prepared>>,
}

/// The triangles (indices) that can reach each tile.
type TileBins = std::collections::HashMap<[u32; 3], Vec<u32>>;

/// A mesh quantized in `frame` (with `snap`) and binned by tiles of
/// `tile_size`.
struct Prepared {
    frame: GridFrame,
    snap: bool,
    tile_size: u32,
    quantized: Arc<QuantizedMesh>,
    bins: Arc<TileBins>,
}

/// The last mesh a tile of this process loaded.
static LAST_MESH: Mutex<Option<Arc<LoadedMesh>>> = Mutex::new(None);

impl LoadedMesh {
    /// The mesh at `path` and whether it was cached: the cached one if the
    /// file is unchanged, else loaded (and cached in place of the last).
    fn get(path: &Path) -> Result<(Arc<LoadedMesh>, bool)> {
        let key = FileKey::of(path)?;
        let mut last = LAST_MESH.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(m) = last.as_ref().filter(|m| m.key == key) {
            return Ok((Arc::clone(m), true));
        }
        // Drop the previous mesh before loading the next (peak memory).
        *last = None;
        let mesh = Mesh::load(path)?;
        let loaded = Arc::new(LoadedMesh {
            key,
            bounds: mesh.bounds(),
            mesh_bytes: (24 * mesh.positions.len() + 12 * mesh.triangles.len()) as u64,
            mesh: Arc::new(mesh),
            quantized: Mutex::new(None),
        });
        *last = Some(Arc::clone(&loaded));
        Ok((loaded, false))
    }

    /// The mesh quantized in `frame` and its triangles binned by tiles of
    /// `tile_size` (cached for the last frame, snap and tile size).
    fn quantized(
        &self,
        frame: &GridFrame,
        snap: bool,
        tile_size: u32,
    ) -> (Arc<QuantizedMesh>, Arc<TileBins>) {
        let mut q = self.quantized.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = q.as_ref()
            && p.frame == *frame
            && p.snap == snap
            && p.tile_size == tile_size
        {
            return (Arc::clone(&p.quantized), Arc::clone(&p.bins));
        }
        *q = None;
        let quantized = Arc::new(quantize_mesh(&self.mesh, frame, snap));
        let bins = Arc::new(bin_triangles(&quantized, frame.dims, tile_size));
        *q = Some(Prepared {
            frame: *frame,
            snap,
            tile_size,
            quantized: Arc::clone(&quantized),
            bins: Arc::clone(&bins),
        });
        (quantized, bins)
    }
}

/// Voxelizes tile `tile` of the mesh at `mesh_path` into the planned
/// `store` and returns `store`, `mesh`, `mode`, `tile`, `tile_size`,
/// `voxels`, `triangles` (those reaching the tile), `segments`, `shards`,
/// `empty_shards`, `chunks`, `bytes`, `estimated_mib` (the tile's memory
/// estimate, checked against `opts.limit` before voxelizing: the loaded
/// and quantized mesh plus the kernels' estimate over the tile's box),
/// `mesh_cached` (this process had loaded the same file for an earlier
/// tile and kept it), `load_ms`, `voxelize_ms`, `write_ms` and
/// `peak_rss_mib`.
pub fn run_tile(
    mesh_path: &Path,
    store: &Path,
    opts: &VoxelizeOptions,
    tile_size: u32,
    tile: [u32; 3],
) -> Result<serde_json::Value> {
    check_tile_size(tile_size)?;
    check_store_path(store)?;
    let info = zarr::info(store)
        .map_err(|e| VoxkitError::invalid(format!("{e} (plan the store first: --plan)")))?;
    let t = Instant::now();
    let (loaded, mesh_cached) = LoadedMesh::get(mesh_path)?;
    let load_ms = ms(t);
    let t = Instant::now();
    let frame = opts.lattice.fit(loaded.bounds)?;
    if info.frame != frame || info.tile_size != Some(u64::from(tile_size)) {
        return Err(VoxkitError::invalid(format!(
            "{} was planned for grid {:?} at {} from {:?} with tiles of {:?}; this run is {:?} at {} from {:?} with tiles of {tile_size}: use the plan's lattice and tile size",
            store.display(),
            info.frame.dims,
            info.frame.voxel_size,
            info.frame.origin.to_array(),
            info.tile_size,
            frame.dims,
            frame.voxel_size,
            frame.origin.to_array(),
        )));
    }
    let n = tile_counts(frame.dims, tile_size);
    if (0..3).any(|a| tile[a] >= n[a]) {
        return Err(VoxkitError::invalid(format!(
            "tile {tile:?} is outside the grid's {n:?} tiles of {tile_size}"
        )));
    }
    let (quantized, bins) = loaded.quantized(&frame, opts.snap, tile_size);
    let (lo, hi) = tile_box(tile, tile_size, frame.dims);
    // Memory: the mesh as loaded, quantized and binned, plus the kernels'
    // estimate for the tile's own triangles (its bin) over the tile's box
    // widened by a brick on each side (the surface is capped by the box's
    // bricks); solid's winding structures cover the whole mesh. Computed
    // from the bin, not the mesh: a tile's cost follows its own surface.
    let box_dims = (hi - lo + IVec3::splat(16)).to_array().map(|d| d as usize);
    let candidates = bins.get(&tile).map_or(&[][..], |b| &b[..]);
    let mut estimated = loaded.mesh_bytes
        + 72 * (quantized.triangles.len() + quantized.degenerate.len()) as u64
        + 4 * bins.values().map(|b| b.len() as u64).sum::<u64>();
    let own: Vec<SurfaceTriangle> = candidates
        .iter()
        .map(|&i| quantized.triangles[i as usize])
        .collect();
    estimated += estimate_bytes(&own, quantized.segments.len(), box_dims, opts.mode);
    drop(own);
    if opts.mode == VoxelizeMode::Solid {
        estimated += 200 * quantized.triangles.len() as u64;
    }
    opts.limit.check(
        &format!("voxelizing tile {tile:?} of {:?}", frame.dims),
        u128::from(estimated),
        1,
    )?;
    let (grid, stats) =
        voxelize_tile_among(&quantized, Some(candidates), &frame, opts, tile, tile_size)?;
    drop(quantized);
    let voxels = grid.count();
    let voxelize_ms = ms(t);
    let t = Instant::now();
    let edge = zarr::SHARD_EDGE as i32;
    let shards = ShardBox {
        min: lo / edge,
        max: (hi + IVec3::splat(edge - 1)) / edge,
    };
    let mut written = zarr::write_shards(store, 0, &grid, Some(shards))?;
    // The pyramid levels whose shards still lie inside this tile alone.
    let mut pooled = grid;
    for level in 1..tile_levels(tile_size, info.levels) {
        pooled = zarr::max_pool(&pooled);
        let st = zarr::write_shards(store, level, &pooled, Some(level_shards(lo, hi, level)))?;
        written.bytes += st.bytes;
    }
    let write_ms = ms(t);
    Ok(serde_json::json!({
        "store": store.display().to_string(),
        "mesh": mesh_path.display().to_string(),
        "mode": opts.mode.name(),
        "tile": tile,
        "tile_size": tile_size,
        "voxels": voxels,
        "triangles": stats.triangles,
        "segments": stats.segments,
        "shards": written.shards,
        "empty_shards": written.empty_shards,
        "chunks": written.chunks,
        "bytes": written.bytes,
        "estimated_mib": estimated as f64 / (1u64 << 20) as f64,
        "mesh_cached": mesh_cached,
        "load_ms": load_ms,
        "voxelize_ms": voxelize_ms,
        "write_ms": write_ms,
        "peak_rss_mib": peak_rss_mib(),
    }))
}
