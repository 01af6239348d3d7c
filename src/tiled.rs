//! Tiled runs into one OME-Zarr store: the plan and the tile, shared by the
//! command line (`voxkit voxelize … --tile-size N --plan | --tile I,J,K`)
//! and Python (`voxkit.distributed`, which maps tiles over Dask).
//!
//! - [`plan`] fits the grid (the same lattice options as a whole run),
//!   writes the store's metadata once ([`zarr::create`], recording
//!   `tile_size`) and lists the tiles whose box meets the mesh
//!   ([`plan_tiles`]);
//! - [`run_tile`] checks that the store was planned for the same grid and
//!   tile size, voxelizes the tile ([`voxelize_tile`]: exactly the whole
//!   run's voxels there) and writes its shards ([`zarr::write_shards`],
//!   removing its empty ones; never metadata). Tiles are whole shards, so
//!   tiles never write the same object, a re-run changes nothing, and a
//!   re-run of a killed tile repairs it.
//!
//! Both return the JSON object the CLI prints (keys in the CLI's docs).

use std::path::Path;
use std::time::Instant;

use glam::IVec3;

use crate::error::{Result, VoxkitError};
use crate::io::zarr::{self, ShardBox};
use crate::mesh::Mesh;
use crate::voxelize::pipeline::{VoxelizeOptions, estimate_bytes, quantize_mesh};
use crate::voxelize::tile::{check_tile_size, plan_tiles, tile_box, tile_counts, voxelize_tile};

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
) -> Result<serde_json::Value> {
    check_tile_size(tile_size)?;
    check_store_path(store)?;
    if store.exists() {
        if !force {
            return Err(VoxkitError::invalid(format!(
                "{} exists (use --force to plan it anew)",
                store.display()
            )));
        }
        if !store.join("zarr.json").is_file() {
            return Err(VoxkitError::invalid(format!(
                "{} exists and is not a Zarr store: not replacing it",
                store.display()
            )));
        }
        std::fs::remove_dir_all(store).map_err(|source| VoxkitError::Io {
            path: store.to_path_buf(),
            source,
        })?;
    }
    let mesh = Mesh::load(mesh_path)?;
    let frame = opts.lattice.fit(mesh.bounds())?;
    let quantized = quantize_mesh(&mesh, &frame, opts.snap);
    let tiles = plan_tiles(&quantized, frame.dims, tile_size, opts.mode);
    zarr::create(store, &frame, 1, Some(u64::from(tile_size)))?;
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
        "triangles": quantized.triangles.len(),
    }))
}

/// Voxelizes tile `tile` of the mesh at `mesh_path` into the planned
/// `store` and returns `store`, `mesh`, `mode`, `tile`, `tile_size`,
/// `voxels`, `triangles` (those reaching the tile), `segments`, `shards`,
/// `empty_shards`, `chunks`, `bytes`, `estimated_mib` (the tile's memory
/// estimate, checked against `opts.limit` before voxelizing: the loaded
/// and quantized mesh plus the kernels' estimate over the tile's box),
/// `load_ms`, `voxelize_ms`, `write_ms` and `peak_rss_mib`.
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
    let mesh = Mesh::load(mesh_path)?;
    let load_ms = ms(t);
    let t = Instant::now();
    let frame = opts.lattice.fit(mesh.bounds())?;
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
    let quantized = quantize_mesh(&mesh, &frame, opts.snap);
    let (lo, hi) = tile_box(tile, tile_size, frame.dims);
    // Memory: the mesh as loaded and quantized, plus the kernels' estimate
    // over the tile's box widened by a brick on each side (the surface is
    // capped by the box's bricks).
    let box_dims = (hi - lo + IVec3::splat(16)).to_array().map(|d| d as usize);
    let mesh_bytes = (24 * mesh.positions.len() + 12 * mesh.triangles.len()) as u64
        + 72 * (quantized.triangles.len() + quantized.degenerate.len()) as u64;
    let estimated = mesh_bytes
        + estimate_bytes(
            &quantized.triangles,
            quantized.segments.len(),
            box_dims,
            opts.mode,
        );
    opts.limit.check(
        &format!("voxelizing tile {tile:?} of {:?}", frame.dims),
        u128::from(estimated),
        1,
    )?;
    drop(mesh);
    let (grid, stats) = voxelize_tile(&quantized, &frame, opts, tile, tile_size)?;
    drop(quantized);
    let voxelize_ms = ms(t);
    let t = Instant::now();
    let edge = zarr::SHARD_EDGE as i32;
    let shards = ShardBox {
        min: lo / edge,
        max: (hi + IVec3::splat(edge - 1)) / edge,
    };
    let written = zarr::write_shards(store, 0, &grid, Some(shards))?;
    let write_ms = ms(t);
    Ok(serde_json::json!({
        "store": store.display().to_string(),
        "mesh": mesh_path.display().to_string(),
        "mode": opts.mode.name(),
        "tile": tile,
        "tile_size": tile_size,
        "voxels": grid.count(),
        "triangles": stats.triangles,
        "segments": stats.segments,
        "shards": written.shards,
        "empty_shards": written.empty_shards,
        "chunks": written.chunks,
        "bytes": written.bytes,
        "estimated_mib": estimated as f64 / (1u64 << 20) as f64,
        "load_ms": load_ms,
        "voxelize_ms": voxelize_ms,
        "write_ms": write_ms,
        "peak_rss_mib": peak_rss_mib(),
    }))
}
