//! OME-Zarr 0.5 (Zarr v3) voxel stores, through the `zarrs` crate.
//!
//! A store is a directory (`out.zarr/`): a group whose `zarr.json` holds the
//! OME `multiscales` block and a `voxkit` block with the grid frame, and one
//! array per level (`0`, then `1`, `2`, … with `--pyramid`):
//!
//! - `uint8` 0/1 (zarr-python cannot read zarrs' `packbits`, neuroglancer
//!   has no bool), fill value 0, axes and dimension names `z, y, x` (so the
//!   array is x-fastest like voxkit's dense grids);
//! - `sharding_indexed` with 64³ inner chunks (8³ voxkit bricks) in 512³
//!   shards, inner codecs `bytes` + `zstd` level 3, index `bytes` + `crc32c`
//!   at the end of the shard;
//! - OME `scale` = the voxel size and `translation` = the world centre of
//!   voxel 0 (OME places voxel centres; voxkit's frame origin is voxel 0's
//!   min corner, so `translation = origin + h/2`), in z, y, x order.
//!
//! Level `l` is occupancy max-pooled by `2^l`: voxel `v` of level `l` is set
//! when any voxel of level 0 in `2^l v … 2^l v + 2^l - 1` is.
//!
//! # Writing
//! Shards are assembled from the grid's bricks ([`BrickGrid::brick_groups`]
//! in 512³ groups), one 64³ inner chunk at a time: each inner chunk with a
//! set voxel is filled from its bricks, encoded by the same codec chain the
//! array's metadata names (zarrs' `bytes` + `zstd`), and appended; the shard
//! index (offset, length per inner chunk, `u64::MAX` for empty ones) is
//! encoded by zarrs' `bytes` + `crc32c`. So memory is one 256 KiB chunk
//! buffer per worker plus the compressed shards in flight, never a dense
//! shard (128 MiB) or box. Each shard file is written atomically
//! ([`super::atomic_write`]: a temporary file renamed over the key), so a
//! killed writer leaves every shard either as it was or complete; a shard
//! whose voxels are all 0 is removed (Zarr's "missing = fill value").
//! zarrs' own decoder reads what this writes (tests compare).
//!
//! A whole store ([`write`](fn@write)) is built in a temporary directory beside the
//! target and renamed into place. Tiles ([`write_shards`]) write into a
//! store whose metadata [`create`] wrote once: tiles are whole shards, so
//! two tiles never write the same object and re-running a tile replaces its
//! shards by identical content.
//!
//! # Reading
//! [`read`] visits the shards present, in parallel. A store laid out as
//! [`write`](fn@write) lays it out (the same codecs and shapes) is read the way it was
//! written: the shard's index decoded by the same chain (its crc32c
//! checked), then only the inner chunks it lists, each decoded on its own
//! and turned into bricks, so memory is the compressed shard plus one 64³
//! chunk. Stores written by other tools (unsharded, other chunk shapes or
//! codecs, `bool` or any nonzero `uint8` as set) are read by zarrs one whole
//! chunk at a time, the chunk's size checked against the memory limit
//! first.
//!
//! [`ChunkReader`] reads a store of voxkit's layout without reading it
//! whole: the shards' indexes once, then any one inner chunk by a
//! positioned read of its bytes (the renderer's pages of a store too big
//! to load).

use std::num::NonZeroU64;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;
use zarrs::array::codec::{BytesCodec, Crc32cCodec, ZstdCodec};
use zarrs::array::{Array, ArrayBuilder, ArrayBytes, CodecChain, CodecOptions, FillValue};
use zarrs::filesystem::FilesystemStore;
use zarrs::group::{Group, GroupBuilder};
use zarrs::storage::ReadableStorageTraits;

use crate::error::{Result, VoxkitError};
use crate::grid::brick::{BRICK_EDGE, BrickMask, FULL_BRICK};
use crate::grid::{BrickGrid, Dims, GridFrame, MemoryLimit, Voxel};

/// Voxels along each edge of a shard (one stored object).
pub const SHARD_EDGE: u64 = 512;
/// Voxels along each edge of an inner chunk (8 bricks).
pub const CHUNK_EDGE: u64 = 64;
/// zstd level of the inner chunks.
const ZSTD_LEVEL: i32 = 3;
/// Inner chunks along each edge of a shard.
const CHUNKS_PER_SHARD: usize = (SHARD_EDGE / CHUNK_EDGE) as usize;
/// Bytes of one decoded inner chunk.
const CHUNK_BYTES: usize = (CHUNK_EDGE * CHUNK_EDGE * CHUNK_EDGE) as usize;
/// log2 of a shard's edge in bricks (512 / 8 = 64).
const SHARD_BRICK_SHIFT: u32 = 6;
/// The format version of the `voxkit` attribute block.
const VOXKIT_BLOCK_VERSION: u64 = 1;

/// Whether `path` names a Zarr store (extension `.zarr`, case-insensitive).
pub fn is_zarr_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case("zarr"))
}

/// A failure inside zarrs, as voxkit's error naming the store.
fn zerr(path: &Path, e: impl std::fmt::Display) -> VoxkitError {
    VoxkitError::invalid(format!("{}: {e}", path.display()))
}

/// The frame of pyramid level `level`: voxels `2^level` times larger, the
/// same min corner, extents rounded up.
pub fn level_frame(frame: &GridFrame, level: u32) -> GridFrame {
    let f = 1usize << level;
    GridFrame::new(
        frame.origin,
        frame.voxel_size * f as f64,
        frame.dims.map(|d| d.div_ceil(f)),
    )
}

/// Number of levels that `--pyramid` writes: halving until the largest
/// extent fits one inner chunk (at least 1, level 0 alone).
pub fn pyramid_levels(dims: Dims) -> u32 {
    let mut levels = 1;
    let mut m = dims.into_iter().max().unwrap_or(1);
    while m > CHUNK_EDGE as usize {
        m = m.div_ceil(2);
        levels += 1;
    }
    levels
}

/// The group's attributes: the OME 0.5 `multiscales` block over `levels`
/// levels and the `voxkit` block (grid frame of level 0 in x, y, z order,
/// plus `tile_size` when the store is written in tiles).
fn group_attributes(
    frame: &GridFrame,
    levels: u32,
    tile_size: Option<u64>,
) -> serde_json::Map<String, serde_json::Value> {
    let datasets: Vec<serde_json::Value> = (0..levels)
        .map(|l| {
            let f = level_frame(frame, l);
            let h = f.voxel_size;
            let c = f.origin + DVec3::splat(h / 2.0);
            serde_json::json!({
                "path": l.to_string(),
                "coordinateTransformations": [
                    {"type": "scale", "scale": [h, h, h]},
                    {"type": "translation", "translation": [c.z, c.y, c.x]},
                ],
            })
        })
        .collect();
    let axes: Vec<serde_json::Value> = ["z", "y", "x"]
        .iter()
        .map(|a| serde_json::json!({"name": a, "type": "space"}))
        .collect();
    let ome = serde_json::json!({
        "version": "0.5",
        "multiscales": [{
            "name": "voxels",
            "axes": axes,
            "datasets": datasets,
            "type": "max",
            "metadata": {"method": "occupancy max-pooled by 2 per level (voxkit)"},
        }],
    });
    let mut voxkit = serde_json::json!({
        "version": VOXKIT_BLOCK_VERSION,
        "origin": frame.origin.to_array(),
        "voxel_size": frame.voxel_size,
        "dims": frame.dims,
        "levels": levels,
        "values": "uint8 0/1, 1 = voxel set",
    });
    if let Some(t) = tile_size {
        voxkit["tile_size"] = t.into();
    }
    let mut attrs = serde_json::Map::new();
    attrs.insert("ome".into(), ome);
    attrs.insert("voxkit".into(), voxkit);
    attrs
}

/// The codec chain of the shard index (`bytes` little-endian + `crc32c`).
fn index_codecs() -> CodecChain {
    CodecChain::new(
        vec![],
        Arc::new(BytesCodec::little()),
        vec![Arc::new(Crc32cCodec::new())],
    )
}

/// The array of one level: shape `[nz, ny, nx]`, sharded as the module
/// docs say.
fn level_array(
    store: &Arc<FilesystemStore>,
    root: &Path,
    frame: &GridFrame,
    level: u32,
) -> Result<Array<FilesystemStore>> {
    let f = level_frame(frame, level);
    let [nx, ny, nz] = f.dims.map(|d| d as u64);
    let mut builder = ArrayBuilder::new(
        vec![nz, ny, nx],
        vec![SHARD_EDGE; 3],
        zarrs::array::data_type::uint8(),
        FillValue::from(0u8),
    );
    builder
        .subchunk_shape(vec![CHUNK_EDGE; 3])
        .bytes_to_bytes_codecs(vec![Arc::new(ZstdCodec::new(ZSTD_LEVEL, false))])
        .dimension_names(Some(["z", "y", "x"]));
    builder
        .build(store.clone(), &format!("/{level}"))
        .map_err(|e| zerr(root, e))
}

/// Opens the filesystem store at `root` (which must exist).
fn open_store(root: &Path) -> Result<Arc<FilesystemStore>> {
    FilesystemStore::new(root)
        .map(Arc::new)
        .map_err(|e| zerr(root, e))
}

/// Writes the metadata of a store for `frame` with `levels` levels into the
/// directory `root` (created if missing): the group `zarr.json` and each
/// level's array `zarr.json`. Shards are not touched. Tiled runs call this
/// once, before any tile ([`write_shards`] never writes metadata).
pub fn create(root: &Path, frame: &GridFrame, levels: u32, tile_size: Option<u64>) -> Result<()> {
    super::voxels::check_frame(frame)?;
    std::fs::create_dir_all(root).map_err(|source| VoxkitError::Io {
        path: root.to_path_buf(),
        source,
    })?;
    let store = open_store(root)?;
    let group = GroupBuilder::new()
        .attributes(group_attributes(frame, levels, tile_size))
        .build(store.clone(), "/")
        .map_err(|e| zerr(root, e))?;
    group.store_metadata().map_err(|e| zerr(root, e))?;
    for level in 0..levels {
        level_array(&store, root, frame, level)?
            .store_metadata()
            .map_err(|e| zerr(root, e))?;
    }
    Ok(())
}

/// What a shard writer did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShardStats {
    /// Shards written (holding at least one set voxel).
    pub shards: u64,
    /// Shards removed or left absent because all their voxels are 0.
    pub empty_shards: u64,
    /// Inner chunks written.
    pub chunks: u64,
    /// Encoded bytes written.
    pub bytes: u64,
}

/// Bit `i` of a byte → byte `i` (0 or 1) of a little-endian `u64`: one row
/// of 8 voxels of a brick mask as 8 bytes of the x-fastest chunk buffer.
const SPREAD: [u64; 256] = {
    let mut t = [0u64; 256];
    let mut b = 0;
    while b < 256 {
        let mut i = 0;
        while i < 8 {
            if b & (1 << i) != 0 {
                t[b] |= 1 << (8 * i);
            }
            i += 1;
        }
        b += 1;
    }
    t
};

/// Fills the zeroed 64³ buffer `buf` (z, y, x; x fastest) from the bricks of
/// one inner chunk (`base`: the chunk's first brick coordinate).
fn fill_chunk(buf: &mut [u8], bricks: &[(Voxel, &BrickMask)], base: Voxel) {
    let e = CHUNK_EDGE as usize;
    for (k, m) in bricks {
        let l = (*k - base) * BRICK_EDGE;
        let (lx, ly, lz) = (l.x as usize, l.y as usize, l.z as usize);
        for (dz, &word) in m.iter().enumerate() {
            if word == 0 {
                continue;
            }
            for dy in 0..8 {
                let row = SPREAD[((word >> (8 * dy)) & 0xff) as usize];
                let i = ((lz + dz) * e + ly + dy) * e + lx;
                buf[i..i + 8].copy_from_slice(&row.to_le_bytes());
            }
        }
    }
}

/// Encodes one shard from its bricks (all inside shard `shard`, any order):
/// `None` when no voxel is set.
fn encode_shard(
    bricks: &mut [(Voxel, &BrickMask)],
    shard: Voxel,
    index: &CodecChain,
    stats: &mut ShardStats,
) -> Result<Option<Vec<u8>>> {
    use zarrs::array::ArrayToBytesCodecTraits;
    let chunk_of = |k: Voxel| -> usize {
        let c: Voxel = (k >> 3) & 7;
        (c.z as usize * CHUNKS_PER_SHARD + c.y as usize) * CHUNKS_PER_SHARD + c.x as usize
    };
    bricks.sort_unstable_by_key(|(k, _)| chunk_of(*k));
    let n_chunks = CHUNKS_PER_SHARD.pow(3);
    let mut offsets = vec![u64::MAX; 2 * n_chunks];
    let mut out: Vec<u8> = Vec::new();
    let mut buf = vec![0u8; CHUNK_BYTES];
    // The inner chain (`bytes` on uint8, then `zstd` at ZSTD_LEVEL without
    // checksum: level_array) is the zstd frame of the chunk's bytes; one
    // compression context serves the whole shard.
    let zstd_err = |e: std::io::Error| VoxkitError::invalid(format!("encoding a zarr chunk: {e}"));
    let mut zstd = zstd::bulk::Compressor::new(ZSTD_LEVEL).map_err(zstd_err)?;
    zstd.include_checksum(false).map_err(zstd_err)?;
    let shard_base = shard << SHARD_BRICK_SHIFT;
    let mut start = 0;
    while start < bricks.len() {
        let c = chunk_of(bricks[start].0);
        let end = start + bricks[start..].partition_point(|(k, _)| chunk_of(*k) == c);
        let group = &bricks[start..end];
        start = end;
        let base = shard_base
            + Voxel::new(
                (c % CHUNKS_PER_SHARD) as i32,
                (c / CHUNKS_PER_SHARD % CHUNKS_PER_SHARD) as i32,
                (c / CHUNKS_PER_SHARD / CHUNKS_PER_SHARD) as i32,
            ) * 8;
        buf.fill(0);
        fill_chunk(&mut buf, group, base);
        let encoded = zstd.compress(&buf).map_err(zstd_err)?;
        offsets[2 * c] = out.len() as u64;
        offsets[2 * c + 1] = encoded.len() as u64;
        out.extend_from_slice(&encoded);
        stats.chunks += 1;
    }
    if out.is_empty() {
        return Ok(None);
    }
    let index_bytes: Vec<u8> = offsets.iter().flat_map(|o| o.to_ne_bytes()).collect();
    let index_shape = [
        NonZeroU64::new(CHUNKS_PER_SHARD as u64).expect("8 > 0"),
        NonZeroU64::new(CHUNKS_PER_SHARD as u64).expect("8 > 0"),
        NonZeroU64::new(CHUNKS_PER_SHARD as u64).expect("8 > 0"),
        NonZeroU64::new(2).expect("2 > 0"),
    ];
    let encoded_index = index
        .encode(
            ArrayBytes::new_flen(index_bytes),
            &index_shape,
            &zarrs::array::data_type::uint64(),
            &FillValue::from(u64::MAX),
            &CodecOptions::default(),
        )
        .map_err(|e| VoxkitError::invalid(format!("encoding a zarr shard index: {e}")))?;
    out.extend_from_slice(&encoded_index);
    Ok(Some(out))
}

/// The file of shard `s` (voxel shard coordinates x, y, z) of `level`.
fn shard_path(root: &Path, level: u32, s: Voxel) -> PathBuf {
    // The default chunk key encoding with "/": `<level>/c/<z>/<y>/<x>`.
    root.join(level.to_string())
        .join("c")
        .join(s.z.to_string())
        .join(s.y.to_string())
        .join(s.x.to_string())
}

/// A box of shards (inclusive min, exclusive max; x, y, z).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShardBox {
    /// First shard.
    pub min: Voxel,
    /// One past the last shard.
    pub max: Voxel,
}

impl ShardBox {
    /// Whether shard `s` lies in the box.
    pub fn contains(&self, s: Voxel) -> bool {
        (0..3).all(|a| s[a] >= self.min[a] && s[a] < self.max[a])
    }

    /// The shards of the box.
    pub fn iter(&self) -> impl Iterator<Item = Voxel> + '_ {
        (self.min.z..self.max.z).flat_map(move |z| {
            (self.min.y..self.max.y)
                .flat_map(move |y| (self.min.x..self.max.x).map(move |x| Voxel::new(x, y, z)))
        })
    }
}

/// Shards staged before one filesystem sync (bounded so that a whole
/// store's temporary files never pile up).
const SHARDS_PER_SYNC: usize = 256;

/// Writes the shards of `grid` (voxels of `level`, inside `dims`) that lie
/// in `shards` (every shard of the grid when `None`), each atomically (a
/// reader sees a shard whole, old or new; durable when this returns); with
/// a box, the box's shards that hold no voxel are removed, so re-running a
/// tile repairs whatever an earlier, killed run left. Never writes
/// metadata. Shards are encoded in parallel on the rayon pool.
pub fn write_shards(
    root: &Path,
    level: u32,
    grid: &BrickGrid,
    shards: Option<ShardBox>,
) -> Result<ShardStats> {
    let groups: Vec<(Voxel, Vec<(Voxel, &BrickMask)>)> = grid
        .brick_groups(SHARD_BRICK_SHIFT)
        .filter(|(s, _)| shards.is_none_or(|b| b.contains(*s)))
        .collect();
    // Shards are encoded and staged in parallel, then committed a batch at
    // a time: one filesystem sync per batch instead of an fsync per shard
    // (super::commit_staged), renames after it.
    let mut total = ShardStats::default();
    let mut done = std::collections::HashSet::new();
    let mut groups = groups;
    while !groups.is_empty() {
        let batch: Vec<_> = groups.drain(..groups.len().min(SHARDS_PER_SYNC)).collect();
        let written: Vec<Result<(Voxel, ShardStats, Option<super::StagedFile>)>> = batch
            .into_par_iter()
            .map(|(s, mut bricks)| {
                let mut st = ShardStats::default();
                let bytes = encode_shard(&mut bricks, s, &index_codecs(), &mut st)?;
                let path = shard_path(root, level, s);
                // A killed run may have left its temporary file of this shard.
                super::remove_temp_files(&path, super::process_gone);
                let staged = match bytes {
                    Some(b) => {
                        st.shards = 1;
                        st.bytes = b.len() as u64;
                        if let Some(dir) = path.parent() {
                            std::fs::create_dir_all(dir).map_err(|source| VoxkitError::Io {
                                path: dir.to_path_buf(),
                                source,
                            })?;
                        }
                        Some(super::stage_file(&path, |w| Ok(w.write_all(&b)?))?)
                    }
                    None => {
                        st.empty_shards = 1;
                        remove_if_present(&path)?;
                        None
                    }
                };
                Ok((s, st, staged))
            })
            .collect();
        let mut staged = Vec::new();
        for r in written {
            let (s, st, f) = r?;
            done.insert(s);
            total.shards += st.shards;
            total.empty_shards += st.empty_shards;
            total.chunks += st.chunks;
            total.bytes += st.bytes;
            staged.extend(f);
        }
        super::commit_staged(staged)?;
    }
    if let Some(b) = shards {
        for s in b.iter().filter(|s| !done.contains(s)) {
            let path = shard_path(root, level, s);
            super::remove_temp_files(&path, super::process_gone);
            remove_if_present(&path)?;
            total.empty_shards += 1;
        }
    }
    Ok(total)
}

/// Removes a file that may be missing.
fn remove_if_present(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(VoxkitError::Io {
            path: path.to_path_buf(),
            source: e,
        }),
        _ => Ok(()),
    }
}

/// Occupancy max-pooled by 2: voxel `v` of the result is set when any of
/// `2v … 2v + 1` is set in `grid`. Brick by brick: each brick of `grid`
/// lands in one octant (4³ voxels) of brick `k >> 1`.
pub fn max_pool(grid: &BrickGrid) -> BrickGrid {
    let mut out: std::collections::HashMap<Voxel, BrickMask> = std::collections::HashMap::new();
    for (k, m) in grid.bricks() {
        let dst = out.entry(k >> 1).or_insert([0; 8]);
        let off = (k & 1) * 4;
        for (z, &word) in m.iter().enumerate() {
            if word == 0 {
                continue;
            }
            for y in 0..8usize {
                let row = (word >> (8 * y)) & 0xff;
                if row == 0 {
                    continue;
                }
                // Pairs of x → 4 bits.
                let mut pooled = 0u64;
                for x in 0..4 {
                    if row & (3 << (2 * x)) != 0 {
                        pooled |= 1 << x;
                    }
                }
                let (pz, py) = (off.z as usize + z / 2, off.y as usize + y / 2);
                dst[pz] |= pooled << (off.x as usize + 8 * py);
            }
        }
    }
    BrickGrid::from_bricks(out)
}

/// Writes `grid` in `frame` as a whole store at `path` (a directory):
/// built beside the target under a temporary name and renamed into place,
/// so a failure leaves no partial store. An existing store is replaced only
/// if `overwrite`, and only if it is a Zarr store (has a `zarr.json`):
/// voxkit never deletes a directory it did not write. `levels` ≥ 1 (level 0
/// alone, or a pyramid).
pub fn write(
    path: &Path,
    grid: &BrickGrid,
    frame: &GridFrame,
    overwrite: bool,
    levels: u32,
) -> Result<ShardStats> {
    check_replaceable(path, overwrite, "overwrite")?;
    let tmp = super::temp_path(path);
    let cleanup = RemoveDirOnDrop(Some(tmp.clone()));
    create(&tmp, frame, levels.max(1), None)?;
    let mut stats = write_shards(&tmp, 0, grid, None)?;
    let mut pooled: Option<BrickGrid> = None;
    for level in 1..levels {
        let next = max_pool(pooled.as_ref().unwrap_or(grid));
        let st = write_shards(&tmp, level, &next, None)?;
        stats.shards += st.shards;
        stats.chunks += st.chunks;
        stats.bytes += st.bytes;
        pooled = Some(next);
    }
    let io_err = |source| VoxkitError::Io {
        path: path.to_path_buf(),
        source,
    };
    if path.exists() {
        // Swap: the old store moves aside, the new one in, the old one goes.
        let old = super::temp_path(path);
        std::fs::rename(path, &old).map_err(io_err)?;
        std::fs::rename(&tmp, path).map_err(io_err)?;
        let _ = std::fs::remove_dir_all(&old);
    } else {
        std::fs::rename(&tmp, path).map_err(io_err)?;
    }
    std::mem::forget(cleanup);
    Ok(stats)
}

/// Whether `path` may be (re)written as a store: it does not exist, or
/// `overwrite` and it is a Zarr store (has a `zarr.json`): voxkit never
/// replaces a directory it did not write. `verb` names what `--force` does
/// in the refusal ("overwrite", "plan it anew").
pub(crate) fn check_replaceable(path: &Path, overwrite: bool, verb: &str) -> Result<()> {
    if !path.exists() {
        return Ok(());
    }
    if !overwrite {
        return Err(VoxkitError::invalid(format!(
            "{} exists (use --force to {verb})",
            path.display()
        )));
    }
    if !path.join("zarr.json").is_file() {
        return Err(VoxkitError::invalid(format!(
            "{} exists and is not a Zarr store: not replacing it",
            path.display()
        )));
    }
    Ok(())
}

/// Removes the directory it holds when dropped (a store being built).
struct RemoveDirOnDrop(Option<PathBuf>);

impl Drop for RemoveDirOnDrop {
    fn drop(&mut self) {
        if let Some(p) = self.0.take() {
            let _ = std::fs::remove_dir_all(p);
        }
    }
}

/// What a store records: the frame of level 0 and the number of levels.
#[derive(Clone, Debug, PartialEq)]
pub struct StoreInfo {
    /// Level 0's frame.
    pub frame: GridFrame,
    /// Levels present in the multiscales list.
    pub levels: u32,
    /// The tile size recorded by a tiled run's plan.
    pub tile_size: Option<u64>,
}

/// Reads a store's frame: the `voxkit` block when present, else the OME
/// `scale` and `translation` of level 0 (isotropic scale only); the extents
/// are always the array's shape.
pub fn info(path: &Path) -> Result<StoreInfo> {
    let store = open_store(path)?;
    let group = Group::open(store.clone(), "/").map_err(|e| zerr(path, e))?;
    let array = Array::open(store, "/0").map_err(|e| zerr(path, e))?;
    let shape = array.shape();
    if shape.len() != 3 {
        return Err(VoxkitError::Unsupported(format!(
            "{}: array 0 has {} dimensions, expected 3 (z, y, x)",
            path.display(),
            shape.len()
        )));
    }
    let dims: Dims = [shape[2], shape[1], shape[0]].map(|d| d as usize);
    let attrs = group.attributes();
    let f64s = |v: Option<&serde_json::Value>, n: usize| -> Option<Vec<f64>> {
        let a = v?.as_array()?;
        let out: Vec<f64> = a.iter().filter_map(serde_json::Value::as_f64).collect();
        (out.len() == n && a.len() == n).then_some(out)
    };
    if let Some(vk) = attrs.get("voxkit") {
        let origin = f64s(vk.get("origin"), 3);
        let h = vk.get("voxel_size").and_then(serde_json::Value::as_f64);
        if let (Some(o), Some(h)) = (origin, h) {
            let frame = GridFrame::new(DVec3::new(o[0], o[1], o[2]), h, dims);
            super::voxels::check_frame(&frame).map_err(|e| zerr(path, e))?;
            let levels = vk
                .get("levels")
                .and_then(serde_json::Value::as_u64)
                .unwrap_or(1) as u32;
            let tile_size = vk.get("tile_size").and_then(serde_json::Value::as_u64);
            return Ok(StoreInfo {
                frame,
                levels,
                tile_size,
            });
        }
    }
    // Another tool's store: OME level 0's transformations, z, y, x order.
    let ome = attrs.get("ome").unwrap_or(&serde_json::Value::Null);
    let ms = ome
        .get("multiscales")
        .or_else(|| attrs.get("multiscales"))
        .and_then(|m| m.get(0));
    let mut h = 1.0;
    let mut t = [0.0; 3];
    let mut levels = 1;
    if let Some(ms) = ms {
        levels = ms
            .get("datasets")
            .and_then(serde_json::Value::as_array)
            .map_or(1, |d| d.len().max(1) as u32);
        let ds0 = ms.get("datasets").and_then(|d| d.get(0));
        for tr in ds0
            .and_then(|d| d.get("coordinateTransformations"))
            .and_then(serde_json::Value::as_array)
            .into_iter()
            .flatten()
        {
            match tr.get("type").and_then(serde_json::Value::as_str) {
                Some("scale") => {
                    if let Some(s) = f64s(tr.get("scale"), 3) {
                        if s[0] != s[1] || s[1] != s[2] {
                            return Err(VoxkitError::Unsupported(format!(
                                "{}: anisotropic scale {s:?}: voxkit grids have cubic voxels",
                                path.display()
                            )));
                        }
                        h = s[0];
                    }
                }
                Some("translation") => {
                    if let Some(s) = f64s(tr.get("translation"), 3) {
                        t = [s[0], s[1], s[2]];
                    }
                }
                _ => {}
            }
        }
    }
    // OME translates voxel centres; the frame's origin is voxel 0's corner.
    let origin = DVec3::new(t[2], t[1], t[0]) - DVec3::splat(h / 2.0);
    let frame = GridFrame::new(origin, h, dims);
    super::voxels::check_frame(&frame).map_err(|e| zerr(path, e))?;
    Ok(StoreInfo {
        frame,
        levels,
        tile_size: None,
    })
}

/// Reads level 0 of the store at `path` as bricks, with its frame. `limit`
/// caps the sparse result (one brick per 8³ block of the box, checked
/// before reading).
pub fn read(path: &Path, limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
    read_level(path, 0, limit)
}

/// Reads level `level` of the store at `path` (see [`read`]); the frame
/// returned is that level's. A panic inside zarrs (a damaged shard) becomes
/// [`VoxkitError::Invalid`].
pub fn read_level(path: &Path, level: u32, limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
    let name = path.display().to_string();
    crate::guard::contain(&name, "zarrs", || read_level_unguarded(path, level, limit))?
}

/// [`read_level`] without the panic guard.
fn read_level_unguarded(
    path: &Path,
    level: u32,
    limit: MemoryLimit,
) -> Result<(BrickGrid, GridFrame)> {
    let meta = info(path)?;
    let store = open_store(path)?;
    let array = Array::open(store.clone(), &format!("/{level}")).map_err(|e| zerr(path, e))?;
    let shape = array.shape().to_vec();
    if shape.len() != 3 {
        return Err(VoxkitError::Unsupported(format!(
            "{}: array {level} has {} dimensions, expected 3",
            path.display(),
            shape.len()
        )));
    }
    let dt = array.data_type();
    if *dt != zarrs::array::data_type::uint8() && *dt != zarrs::array::data_type::bool() {
        return Err(VoxkitError::Unsupported(format!(
            "{}: data type {} (voxkit reads uint8 or bool occupancy)",
            path.display(),
            dt.name_v3().unwrap_or_default()
        )));
    }
    let dims: Dims = [shape[2], shape[1], shape[0]].map(|d| d as usize);
    let frame = GridFrame::new(
        meta.frame.origin,
        meta.frame.voxel_size * (1u64 << level) as f64,
        dims,
    );
    let grid_shape = array.chunk_grid_shape().to_vec();
    let own = own_layout(&array, &level_array(&store, path, &meta.frame, level)?);
    let storage = array.storage();
    // The chunks (shards) present, found by key before anything is decoded.
    let mut present = Vec::new();
    for z in 0..grid_shape[0] {
        for y in 0..grid_shape[1] {
            for x in 0..grid_shape[2] {
                let key = array.chunk_key(&[z, y, x]);
                if storage.size_key(&key).map_err(|e| zerr(path, e))?.is_some() {
                    present.push([z, y, x]);
                }
            }
        }
    }
    if !own {
        // A chunk of another tool's store is decoded whole: cap it first.
        let chunk: u128 = array
            .chunk_shape(&[0, 0, 0])
            .map_or(0, |c| c.iter().map(|n| u128::from(n.get())).product());
        limit.check(&format!("a chunk of {}", path.display()), chunk, 1)?;
    }
    // The grid's size shows only as shards decode: bricks are counted as
    // they come and the read stops at the limit (overshooting by at most a
    // shard per thread), rather than charging the bounding box, which for
    // a surface in a 16384³ store is almost all empty.
    let bricks_read = std::sync::atomic::AtomicU64::new(0);
    let what = format!("reading {}", path.display());
    let decoded: Vec<Result<ShardVoxels>> = present
        .into_par_iter()
        .map(|idx| {
            let mut parts = Vec::new();
            let mut loose = BrickGrid::new();
            let mut take = |origin: [u64; 3], cshape: &[u64], bytes: &[u8]| {
                chunk_to_bricks(origin, cshape, &shape, bytes, &mut parts, &mut loose);
            };
            if own {
                let s = Voxel::new(idx[2] as i32, idx[1] as i32, idx[0] as i32);
                read_own_shard(&shard_path(path, level, s), s, &mut take)?;
            } else {
                let bytes: Vec<u8> = array
                    .retrieve_chunk_opt(&idx, &CodecOptions::default())
                    .map_err(|e| zerr(path, e))?;
                let subset = array.chunk_subset(&idx).map_err(|e| zerr(path, e))?;
                let (start, cs) = (subset.start(), subset.shape());
                take([start[0], start[1], start[2]], cs, &bytes);
            }
            let n = (parts.len() + loose.brick_count()) as u64;
            let total = bricks_read.fetch_add(n, std::sync::atomic::Ordering::Relaxed) + n;
            limit.check(&what, u128::from(total), 96)?;
            Ok((parts, loose))
        })
        .collect();
    let mut parts = Vec::new();
    let mut loose = BrickGrid::new();
    for d in decoded {
        let (p, l) = d?;
        parts.extend(p);
        loose.union_with(&l);
    }
    let mut grid = BrickGrid::from_bricks(parts);
    grid.union_with(&loose);
    grid.compact_tiles();
    Ok((grid, frame))
}

/// One shard's voxels as read: brick-aligned chunks as whole bricks, others
/// voxel by voxel.
type ShardVoxels = (Vec<(Voxel, BrickMask)>, BrickGrid);

/// Whether `array` is stored the way [`write`](fn@write) stores it (the codecs of
/// `ours`, the array [`level_array`] describes): then its shards are read
/// by [`read_own_shard`], one listed inner chunk at a time.
fn own_layout(array: &Array<FilesystemStore>, ours: &Array<FilesystemStore>) -> bool {
    let codecs = |a: &Array<FilesystemStore>| {
        serde_json::to_value(a.metadata())
            .ok()
            .and_then(|m| m.get("codecs").cloned())
    };
    let chunks = |a: &Array<FilesystemStore>| a.chunk_shape(&[0, 0, 0]).ok();
    codecs(array).is_some() && codecs(array) == codecs(ours) && chunks(array) == chunks(ours)
}

/// Bytes of a shard's encoded index: (offset, length) as `u64` for each
/// inner chunk, then the crc32c checksum.
const INDEX_BYTES: usize = CHUNKS_PER_SHARD * CHUNKS_PER_SHARD * CHUNKS_PER_SHARD * 16 + 4;

/// Reads one shard that [`write`](fn@write) wrote (`file`, shard `s`), handing each
/// inner chunk its index lists to `take` (origin z, y, x; shape; bytes):
/// the index's checksum is checked and every listed range must lie inside
/// the file, so a torn or damaged shard is an error naming it, never a
/// wrong read. Missing: nothing (a tile may be removing it).
fn read_own_shard(
    file: &Path,
    s: Voxel,
    take: &mut impl FnMut([u64; 3], &[u64], &[u8]),
) -> Result<()> {
    let bytes = match std::fs::read(file) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(source) => {
            return Err(VoxkitError::Io {
                path: file.to_path_buf(),
                source,
            });
        }
    };
    let damaged = |what: &str| damaged_shard(file, what);
    let Some(body_len) = bytes.len().checked_sub(INDEX_BYTES) else {
        return Err(damaged("shorter than its index"));
    };
    let entries = decode_shard_index(&bytes[body_len..]).map_err(|e| damaged(&e))?;
    // The inner chain is a zstd frame of the chunk's bytes (level_array):
    // one decompression context and one buffer serve the whole shard, as
    // one compression context does in encode_shard.
    let mut zstd = zstd::bulk::Decompressor::new().map_err(|e| damaged(&format!("zstd: {e}")))?;
    let mut decoded = Vec::with_capacity(CHUNK_BYTES);
    let base = [s.z, s.y, s.x].map(|c| c as u64 * SHARD_EDGE);
    for (c, e) in entries.chunks_exact(2).enumerate() {
        let (offset, len) = (e[0], e[1]);
        if offset == u64::MAX && len == u64::MAX {
            continue;
        }
        let range = offset
            .checked_add(len)
            .filter(|&end| end <= body_len as u64)
            .map(|end| offset as usize..end as usize)
            .ok_or_else(|| damaged(&format!("inner chunk {c} lies outside the file")))?;
        decode_chunk(&mut zstd, &bytes[range], &mut decoded)
            .map_err(|e| damaged(&format!("inner chunk {c}: {e}")))?;
        let (cz, cy, cx) = (
            c / (CHUNKS_PER_SHARD * CHUNKS_PER_SHARD),
            c / CHUNKS_PER_SHARD % CHUNKS_PER_SHARD,
            c % CHUNKS_PER_SHARD,
        );
        let origin = [
            base[0] + cz as u64 * CHUNK_EDGE,
            base[1] + cy as u64 * CHUNK_EDGE,
            base[2] + cx as u64 * CHUNK_EDGE,
        ];
        take(origin, &[CHUNK_EDGE; 3], &decoded);
    }
    Ok(())
}

/// The error for a shard that cannot be what its writer wrote.
fn damaged_shard(file: &Path, what: &str) -> VoxkitError {
    VoxkitError::invalid(format!(
        "{}: damaged shard ({what}); re-run the tile or voxelization that wrote it",
        file.display()
    ))
}

/// Decodes a shard's index (the last [`INDEX_BYTES`] of the file) by the
/// chain that wrote it, checking its crc32c: (offset, length) per inner
/// chunk, `u64::MAX` twice for an absent one.
fn decode_shard_index(tail: &[u8]) -> std::result::Result<Vec<u64>, String> {
    use zarrs::array::ArrayToBytesCodecTraits;
    let n = NonZeroU64::new(CHUNKS_PER_SHARD as u64).expect("8 > 0");
    let index_shape = [n, n, n, NonZeroU64::new(2).expect("2 > 0")];
    let index = index_codecs()
        .decode(
            std::borrow::Cow::Borrowed(tail),
            &index_shape,
            &zarrs::array::data_type::uint64(),
            &FillValue::from(u64::MAX),
            &CodecOptions::default(),
        )
        .and_then(|b| Ok(b.into_fixed()?.into_owned()))
        .map_err(|e| format!("index: {e}"))?;
    Ok(index
        .chunks_exact(8)
        .map(|w| u64::from_ne_bytes(w.try_into().expect("8 bytes")))
        .collect())
}

/// Decodes one inner chunk (a zstd frame of its 64³ bytes) into `out`.
fn decode_chunk(
    zstd: &mut zstd::bulk::Decompressor<'_>,
    frame: &[u8],
    out: &mut Vec<u8>,
) -> std::result::Result<(), String> {
    out.clear();
    if out.capacity() < CHUNK_BYTES {
        out.reserve_exact(CHUNK_BYTES);
    }
    // Capacity CHUNK_BYTES: a frame decoding to more is an error.
    zstd.decompress_to_buffer(frame, out)
        .map_err(|e| e.to_string())?;
    if out.len() != CHUNK_BYTES {
        return Err(format!("decodes to {} bytes", out.len()));
    }
    Ok(())
}

/// Random access to the 64³ inner chunks of one level of a store laid out
/// as [`write`](fn@write) lays it out, for readers that decode only what they need
/// (the renderer's [`PagedOccupancy`](crate::render::PagedOccupancy)):
/// every shard's index is read once when opened (the file's tail only, in
/// parallel), so which chunks hold voxels is known before any is decoded;
/// then [`ChunkReader::read_chunk`] decodes one chunk from a positioned
/// read of its bytes.
#[derive(Debug)]
pub struct ChunkReader {
    root: PathBuf,
    level: u32,
    frame: GridFrame,
    /// Shards per axis (x, y, z).
    shards: [i32; 3],
    /// Per shard (x fastest): 1 + its entry in `indexes`, or 0 if absent.
    shard_slot: Vec<u32>,
    indexes: Vec<ShardIndex>,
}

/// One present shard's index.
#[derive(Debug)]
struct ShardIndex {
    shard: Voxel,
    /// Bytes before the index: every listed range must end inside them.
    body_len: u64,
    /// (offset, length) per inner chunk, z-major (`cx + 8 cy + 64 cz`).
    entries: Vec<[u64; 2]>,
}

/// Inner chunks along each edge of a shard.
pub const CHUNKS_PER_SHARD_EDGE: i32 = CHUNKS_PER_SHARD as i32;

impl ChunkReader {
    /// Opens level `level` of the store at `path` for chunk reads, or
    /// `None` when the store is not laid out as voxkit writes it (read it
    /// whole with [`read_level`]). `limit` caps the shard table and the
    /// indexes (checked before reading them).
    pub fn open(path: &Path, level: u32, limit: MemoryLimit) -> Result<Option<ChunkReader>> {
        let name = path.display().to_string();
        crate::guard::contain(&name, "zarrs", || Self::open_unguarded(path, level, limit))?
    }

    fn open_unguarded(path: &Path, level: u32, limit: MemoryLimit) -> Result<Option<ChunkReader>> {
        let meta = info(path)?;
        if level >= meta.levels.max(1) && level > 0 {
            return Err(VoxkitError::invalid(format!(
                "{}: level {level} is not in the store ({} levels)",
                path.display(),
                meta.levels
            )));
        }
        let store = open_store(path)?;
        let array = Array::open(store.clone(), &format!("/{level}")).map_err(|e| zerr(path, e))?;
        if !own_layout(&array, &level_array(&store, path, &meta.frame, level)?) {
            return Ok(None);
        }
        let frame = level_frame(&meta.frame, level);
        let shards = frame.dims.map(|d| d.div_ceil(SHARD_EDGE as usize) as i32);
        let n: u128 = shards.iter().map(|&s| s as u128).product();
        limit.check(&format!("the shard table of {}", path.display()), n, 4)?;
        let all: Vec<Voxel> = (0..shards[2])
            .flat_map(|z| {
                (0..shards[1]).flat_map(move |y| (0..shards[0]).map(move |x| Voxel::new(x, y, z)))
            })
            .collect();
        let read = |s: Voxel| -> Result<Option<ShardIndex>> {
            use std::os::unix::fs::FileExt;
            let file = shard_path(path, level, s);
            let io = |source| VoxkitError::Io {
                path: file.clone(),
                source,
            };
            let f = match std::fs::File::open(&file) {
                Ok(f) => f,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
                Err(e) => return Err(io(e)),
            };
            let len = f.metadata().map_err(io)?.len();
            let damaged = |what: &str| damaged_shard(&file, what);
            let Some(body_len) = len.checked_sub(INDEX_BYTES as u64) else {
                return Err(damaged("shorter than its index"));
            };
            let mut tail = vec![0u8; INDEX_BYTES];
            f.read_exact_at(&mut tail, body_len).map_err(io)?;
            let flat = decode_shard_index(&tail).map_err(|e| damaged(&e))?;
            let entries: Vec<[u64; 2]> = flat.chunks_exact(2).map(|e| [e[0], e[1]]).collect();
            for (c, e) in entries.iter().enumerate() {
                let absent = e[0] == u64::MAX && e[1] == u64::MAX;
                if !absent && e[0].checked_add(e[1]).is_none_or(|end| end > body_len) {
                    return Err(damaged(&format!("inner chunk {c} lies outside the file")));
                }
            }
            Ok(Some(ShardIndex {
                shard: s,
                body_len,
                entries,
            }))
        };
        let found: Vec<Option<ShardIndex>> =
            all.par_iter().map(|&s| read(s)).collect::<Result<_>>()?;
        let mut shard_slot = vec![0u32; n as usize];
        let mut indexes = Vec::new();
        for (i, ix) in found.into_iter().enumerate() {
            if let Some(ix) = ix {
                indexes.push(ix);
                shard_slot[i] = indexes.len() as u32;
            }
        }
        limit.check(
            &format!("the shard indexes of {}", path.display()),
            (indexes.len() as u128) * (INDEX_BYTES as u128) + n * 4,
            1,
        )?;
        Ok(Some(ChunkReader {
            root: path.to_path_buf(),
            level,
            frame,
            shards,
            shard_slot,
            indexes,
        }))
    }

    /// The level's frame.
    pub fn frame(&self) -> &GridFrame {
        &self.frame
    }

    /// Chunks per axis (x, y, z) covering the level's extents.
    pub fn chunk_dims(&self) -> [i32; 3] {
        self.frame
            .dims
            .map(|d| d.div_ceil(CHUNK_EDGE as usize) as i32)
    }

    /// Bytes held (shard table and indexes).
    pub fn heap_bytes(&self) -> usize {
        self.shard_slot.capacity() * 4 + self.indexes.len() * (INDEX_BYTES + 64)
    }

    /// The index entry of chunk `c` (chunk coordinates x, y, z), if listed.
    fn entry(&self, c: Voxel) -> Option<(&ShardIndex, usize)> {
        let d = self.chunk_dims();
        if (0..3).any(|k| c[k] < 0 || c[k] >= d[k]) {
            return None;
        }
        let s = c / CHUNKS_PER_SHARD_EDGE;
        let si = (s.x + self.shards[0] * (s.y + self.shards[1] * s.z)) as usize;
        let slot = self.shard_slot[si];
        if slot == 0 {
            return None;
        }
        let ix = &self.indexes[slot as usize - 1];
        let l = c - s * CHUNKS_PER_SHARD_EDGE;
        let k = (l.x + CHUNKS_PER_SHARD_EDGE * (l.y + CHUNKS_PER_SHARD_EDGE * l.z)) as usize;
        let e = ix.entries[k];
        (e != [u64::MAX; 2]).then_some((ix, k))
    }

    /// Whether chunk `c` is stored (an absent chunk is all 0).
    pub fn is_present(&self, c: Voxel) -> bool {
        self.entry(c).is_some()
    }

    /// The stored chunks, shard by shard.
    pub fn present_chunks(&self) -> impl Iterator<Item = Voxel> + '_ {
        self.indexes.iter().flat_map(|ix| {
            ix.entries
                .iter()
                .enumerate()
                .filter(|(_, e)| **e != [u64::MAX; 2])
                .map(|(k, _)| {
                    let k = k as i32;
                    let e = CHUNKS_PER_SHARD_EDGE;
                    ix.shard * e + Voxel::new(k % e, k / e % e, k / (e * e))
                })
        })
    }

    /// The occupied bricks of chunk `c`: (local brick index
    /// `bx + 8 by + 64 bz` inside the chunk, mask), empty for an absent
    /// chunk. Voxels beyond the level's extents are not set.
    pub fn read_chunk(&self, c: Voxel) -> Result<Vec<(u16, BrickMask)>> {
        use std::os::unix::fs::FileExt;
        let Some((ix, k)) = self.entry(c) else {
            return Ok(Vec::new());
        };
        let [offset, len] = ix.entries[k];
        let file = shard_path(&self.root, self.level, ix.shard);
        let damaged = |what: String| damaged_shard(&file, &what);
        let io = |source| VoxkitError::Io {
            path: file.clone(),
            source,
        };
        // The file may have been rewritten since its index was read.
        let f = std::fs::File::open(&file).map_err(io)?;
        if f.metadata().map_err(io)?.len() != ix.body_len + INDEX_BYTES as u64 {
            return Err(damaged("changed while being read".into()));
        }
        let mut frame = vec![0u8; len as usize];
        f.read_exact_at(&mut frame, offset).map_err(io)?;
        thread_local! {
            static DECODER: std::cell::RefCell<Option<(zstd::bulk::Decompressor<'static>, Vec<u8>)>> =
                const { std::cell::RefCell::new(None) };
        }
        DECODER.with(|d| {
            let mut d = d.borrow_mut();
            if d.is_none() {
                let z =
                    zstd::bulk::Decompressor::new().map_err(|e| damaged(format!("zstd: {e}")))?;
                *d = Some((z, Vec::with_capacity(CHUNK_BYTES)));
            }
            let (zstd, buf) = d.as_mut().expect("just set");
            decode_chunk(zstd, &frame, buf)
                .map_err(|e| damaged(format!("inner chunk {k}: {e}")))?;
            let origin = [c.z, c.y, c.x].map(|v| v as u64 * CHUNK_EDGE);
            let [nx, ny, nz] = self.frame.dims.map(|d| d as u64);
            let mut parts = Vec::new();
            let mut loose = BrickGrid::new();
            chunk_to_bricks(
                origin,
                &[CHUNK_EDGE; 3],
                &[nz, ny, nx],
                buf,
                &mut parts,
                &mut loose,
            );
            debug_assert_eq!(loose.brick_count(), 0, "64³ chunks are brick-aligned");
            let base = c * 8;
            Ok(parts
                .into_iter()
                .map(|(b, m)| {
                    let l = b - base;
                    ((l.x + 8 * l.y + 64 * l.z) as u16, m)
                })
                .collect())
        })
    }
}

/// Bit `i` set where `row[i]` (at most 8 bytes) is nonzero: the row read
/// as one word, each byte's "nonzero" moved to its top bit without carries
/// between bytes, and the eight top bits gathered by one multiplication.
#[inline]
fn nonzero_bits(row: &[u8]) -> u8 {
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    let w = match <[u8; 8]>::try_from(row) {
        Ok(b) => u64::from_le_bytes(b),
        Err(_) => row.iter().rev().fold(0u64, |a, &b| a << 8 | u64::from(b)),
    };
    if w == 0 {
        return 0;
    }
    let top = (((w & LOW7) + LOW7) | w) & !LOW7;
    ((top >> 7).wrapping_mul(0x0102_0408_1020_4080) >> 56) as u8
}

/// Adds the set voxels of one decoded chunk (`origin` and `cshape` in z, y,
/// x; `bytes` x-fastest, any nonzero byte set) to the result: bricks
/// directly when the chunk is brick-aligned, voxel by voxel otherwise.
/// Voxels beyond the array's `shape` are ignored.
fn chunk_to_bricks(
    origin: [u64; 3],
    cshape: &[u64],
    shape: &[u64],
    bytes: &[u8],
    parts: &mut Vec<(Voxel, BrickMask)>,
    loose: &mut BrickGrid,
) {
    let [z0, y0, x0] = origin;
    if (0..3).any(|a| origin[a] >= shape[a]) {
        return;
    }
    let (sz, sy, sx) = (cshape[0], cshape[1], cshape[2]);
    // Extents inside the array.
    let (ez, ey, ex) = (
        sz.min(shape[0] - z0),
        sy.min(shape[1] - y0),
        sx.min(shape[2] - x0),
    );
    let aligned = origin.iter().all(|o| o % 8 == 0);
    let at = |z: u64, y: u64, x: u64| ((z * sy + y) * sx + x) as usize;
    if !aligned {
        for z in 0..ez {
            for y in 0..ey {
                for x in 0..ex {
                    if bytes[at(z, y, x)] != 0 {
                        loose.insert(Voxel::new(
                            (x0 + x) as i32,
                            (y0 + y) as i32,
                            (z0 + z) as i32,
                        ));
                    }
                }
            }
        }
        return;
    }
    let (bz, by, bx) = (ez.div_ceil(8), ey.div_ceil(8), ex.div_ceil(8));
    for kz in 0..bz {
        for ky in 0..by {
            for kx in 0..bx {
                let mut m: BrickMask = [0; 8];
                for dz in 0..8.min(ez - 8 * kz) {
                    for dy in 0..8.min(ey - 8 * ky) {
                        let (z, y, x) = (8 * kz + dz, 8 * ky + dy, 8 * kx);
                        let n = 8.min(ex - x) as usize;
                        let row = &bytes[at(z, y, x)..at(z, y, x) + n];
                        m[dz as usize] |= u64::from(nonzero_bits(row)) << (8 * dy);
                    }
                }
                if m.iter().fold(0, |a, &w| a | w) != 0 {
                    let k = Voxel::new(
                        ((x0 >> 3) + kx) as i32,
                        ((y0 >> 3) + ky) as i32,
                        ((z0 >> 3) + kz) as i32,
                    );
                    parts.push((k, if m == FULL_BRICK { FULL_BRICK } else { m }));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    /// The word trick agrees with a byte loop on rows of every length and
    /// bytes of every kind (0, 1, 0x7f, 0x80, 0xff, anything).
    #[test]
    fn nonzero_bits_matches_a_byte_loop() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..20_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let n = (state % 9) as usize;
            let row: Vec<u8> = (0..n)
                .map(|i| match (state >> (6 * i + 3)) % 5 {
                    0 | 1 => 0,
                    2 => 1,
                    3 => [0x80, 0xff, 0x7f][(state >> i) as usize % 3],
                    _ => (state >> (7 * i)) as u8,
                })
                .collect();
            let want = row
                .iter()
                .enumerate()
                .fold(0u8, |a, (i, &b)| a | u8::from(b != 0) << i);
            assert_eq!(super::nonzero_bits(&row), want, "{row:?}");
        }
    }
}
