//! The ray caster's view of a voxel store read on demand: a Zarr store's
//! 64³ chunks become render pages when a ray first reaches them, so a
//! render reads only the bricks its rays reach, and a store bigger than
//! memory renders in the memory those bricks take.
//!
//! What is known before any chunk is decoded is which chunks are stored
//! (the shards' indexes, [`ChunkReader`]). From that alone:
//! - a coarse proximity cloud over chunks: per chunk the Chebyshev
//!   distance, in chunks, to the nearest stored one. A brick of an absent
//!   chunk at coarse distance `K ≥ 1` lies inside a box of `2K − 1` chunks
//!   per side that holds no voxel, so its cloud value is at least one more
//!   than its distance, in bricks, to that box's faces;
//! - the exact bounds of the occupied voxels, from the chunks of the
//!   outermost stored layers on each side (decoded, and dropped).
//!
//! The chunks within one chunk of a stored one (the stored ones and their
//! halo, where proximity flags and short cloud values spill) get pages.
//! A page is built when a ray first asks for one of its chunk's bricks,
//! from a 10³-brick box: the chunk's bricks and a ring of one brick taken
//! from its stored neighbours (decoded once each and kept). Its bricks'
//! occupancy and proximity masks are the dilation
//! [`OccupancyGrid`](super::OccupancyGrid) computes, so the flags are
//! identical. Its cloud value per brick is the exact Chebyshev distance to
//! the occupied bricks of the box, capped by what lies beyond it: the
//! distance to each stored neighbour's box, and one more than the distance
//! to the faces of the 3×3×3 chunks. Every cloud value is a lower bound on
//! the in-memory grid's, and a lower bound only skips less: every pixel
//! equals the in-memory render's (tests compare).
//!
//! Pages and decoded chunks are built once (`OnceLock`) by whichever thread
//! reaches them first; the others wait for that one. Their bytes are
//! counted against the memory limit as they are built; past it, or on a
//! read error, the store records the failure, hands out a full brick (the
//! ray ends at once) and the render that asked returns the error
//! ([`PagedOccupancy::failure`]) instead of an image. Nothing is
//! evicted: the memory is what one render's rays reached.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

use glam::IVec3;

use super::occupancy::{BrickFlags, RenderBricks, chessboard_distance, dilate};
use crate::error::{Result, VoxkitError};
use crate::grid::brick::{BrickMask, FULL_BRICK};
use crate::grid::{MemoryLimit, Voxel};
use crate::io::zarr::ChunkReader;

/// Bricks along each edge of a chunk.
const CB: i32 = 8;
/// Bricks in a chunk.
const CHUNK_BRICKS: usize = 512;

/// The flags every brick of an absent chunk has.
static EMPTY_FLAGS: BrickFlags = BrickFlags {
    occ: [0; 8],
    prox: [0; 8],
};
/// Handed out after a failure: the ray ends at once.
static STOP_FLAGS: BrickFlags = BrickFlags {
    occ: FULL_BRICK,
    prox: FULL_BRICK,
};

/// One decoded chunk's occupancy.
struct RawChunk {
    /// Per local brick (`bx + 8 by + 64 bz`): 1 + its entry in `masks`, or
    /// 0 when empty.
    slot: [u16; CHUNK_BRICKS],
    masks: Vec<BrickMask>,
}

impl RawChunk {
    fn mask(&self, l: usize) -> Option<&BrickMask> {
        let s = self.slot[l];
        (s != 0).then(|| &self.masks[s as usize - 1])
    }

    fn bytes(&self) -> u64 {
        (std::mem::size_of::<Self>() + self.masks.capacity() * 64) as u64
    }
}

/// One stored chunk's render page.
struct Page {
    /// Per local brick: its entry in `flags` (0 the empty brick, 1 the full
    /// one, then bricks with flags of their own).
    slot: [u16; CHUNK_BRICKS],
    cloud: [u8; CHUNK_BRICKS],
    flags: Vec<BrickFlags>,
}

impl Page {
    fn bytes(&self) -> u64 {
        (std::mem::size_of::<Self>() + self.flags.capacity() * 128) as u64
    }
}

/// Where [`PagedOccupancy::locate`] found a brick.
#[derive(Clone, Copy, Debug)]
pub struct PagedBrick<'a> {
    flags: &'a BrickFlags,
    cloud: u8,
}

/// A voxel store's render structure, read chunk by chunk as rays reach it
/// (the scheme is described in `render/paged.rs`).
pub struct PagedOccupancy {
    reader: ChunkReader,
    dims: [i32; 3],
    cdims: [i32; 3],
    /// Per chunk (x fastest): 1 + its entry in `near`, or 0 for a chunk
    /// farther than one chunk from every stored one.
    chunk_slot: Vec<u32>,
    /// Per chunk: Chebyshev distance in chunks to the nearest stored one.
    coarse: Vec<u8>,
    /// The chunks within one chunk of a stored one (the stored ones
    /// included): their bricks may hold voxels or proximity flags.
    near: Vec<Voxel>,
    /// Stored chunks in the store.
    stored: usize,
    /// Per entry of `near`: its decoded occupancy (stored chunks only).
    raw: Vec<OnceLock<Box<RawChunk>>>,
    /// Per entry of `near`: its page.
    pages: Vec<OnceLock<Box<Page>>>,
    bounds: Option<(Voxel, Voxel)>,
    limit: MemoryLimit,
    /// Bytes of the tables built when opened.
    fixed_bytes: u64,
    /// Bytes of the decoded chunks and pages built since.
    loaded_bytes: AtomicU64,
    chunks_decoded: AtomicU64,
    /// Chunks decoded (and dropped) to find the bounds.
    bounds_chunks: AtomicU64,
    pages_built: AtomicU64,
    failure: Mutex<Option<VoxkitError>>,
}

impl std::fmt::Debug for PagedOccupancy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PagedOccupancy")
            .field("dims", &self.dims)
            .field("stored_chunks", &self.stored)
            .field("chunks_decoded", &self.chunks_decoded())
            .field("pages_built", &self.pages_built())
            .finish()
    }
}

impl PagedOccupancy {
    /// The render structure of a store's level read through `reader`:
    /// the chunk tables and the exact occupied bounds (decoding only the
    /// outermost stored layers). `limit` caps everything it will hold,
    /// the pages built while rendering included.
    ///
    /// ```
    /// use glam::{DVec3, IVec3};
    /// use voxkit::camera::Camera;
    /// use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
    /// use voxkit::io::zarr::{self, ChunkReader};
    /// use voxkit::render::{render_grid, GridTransform, OccupancyGrid, PagedOccupancy, RenderOptions};
    /// let dir = std::env::temp_dir().join(format!("voxkit-paged-doc-{}", std::process::id()));
    /// let grid: BrickGrid = (0..90).map(|i| IVec3::new(i, 40, 2 * i % 70)).collect();
    /// let frame = GridFrame::new(DVec3::ZERO, 1.0, [100, 80, 70]);
    /// let store = dir.join("g.zarr");
    /// zarr::write(&store, &grid, &frame, true, 1).unwrap();
    /// let reader = ChunkReader::open(&store, 0, MemoryLimit::DEFAULT).unwrap().unwrap();
    /// let paged = PagedOccupancy::new(reader, MemoryLimit::DEFAULT).unwrap();
    /// let occ = OccupancyGrid::new(&grid, frame.dims, MemoryLimit::DEFAULT).unwrap();
    /// let xf = GridTransform::from_frame(&frame).unwrap();
    /// let cam = Camera::perspective(DVec3::new(50.0, 140.0, 160.0), DVec3::new(50.0, 40.0, 35.0), DVec3::Y, 40.0);
    /// let opts = RenderOptions { width: 64, height: 48, ..RenderOptions::default() };
    /// let (a, _) = render_grid(&paged, &xf, &cam, &opts).unwrap();
    /// let (b, _) = render_grid(&occ, &xf, &cam, &opts).unwrap();
    /// assert_eq!((a.hit, a.color), (b.hit, b.color));
    /// assert!(paged.chunks_decoded() <= 4);
    /// std::fs::remove_dir_all(&dir).unwrap();
    /// ```
    pub fn new(reader: ChunkReader, limit: MemoryLimit) -> Result<Self> {
        let dims = reader.frame().dims;
        if dims.iter().any(|&d| d > super::MAX_RENDER_DIM) {
            return Err(VoxkitError::Unsupported(format!(
                "render: grid {dims:?}: each side must be at most {} voxels",
                super::MAX_RENDER_DIM
            )));
        }
        let cdims = reader.chunk_dims();
        let cells: u128 = cdims.iter().map(|&c| c as u128).product();
        let stored = reader.present_chunks().count();
        // The near chunks are at most 27 per stored one.
        let near_max = (stored as u128 * 27).min(cells);
        let fixed = cells * 5 + near_max * (12 + 32) + reader.heap_bytes() as u128;
        limit.check("the render's chunk tables", fixed, 1)?;
        let cindex = |c: Voxel| (c.x + cdims[0] * (c.y + cdims[1] * c.z)) as usize;
        let mut chunk_slot = vec![0u32; cells as usize];
        for c in reader.present_chunks() {
            chunk_slot[cindex(c)] = 1;
        }
        let coarse = chessboard_distance(cdims, |i| chunk_slot[i] != 0);
        let mut near = Vec::new();
        for z in 0..cdims[2] {
            for y in 0..cdims[1] {
                for x in 0..cdims[0] {
                    let c = Voxel::new(x, y, z);
                    let i = cindex(c);
                    chunk_slot[i] = 0;
                    if coarse[i] <= 1 {
                        near.push(c);
                        chunk_slot[i] = near.len() as u32;
                    }
                }
            }
        }
        let n = near.len();
        let mut paged = PagedOccupancy {
            reader,
            dims: dims.map(|d| d as i32),
            cdims,
            chunk_slot,
            coarse,
            near,
            stored,
            raw: (0..n).map(|_| OnceLock::new()).collect(),
            pages: (0..n).map(|_| OnceLock::new()).collect(),
            bounds: None,
            limit,
            fixed_bytes: fixed as u64,
            loaded_bytes: AtomicU64::new(0),
            chunks_decoded: AtomicU64::new(0),
            bounds_chunks: AtomicU64::new(0),
            pages_built: AtomicU64::new(0),
            failure: Mutex::new(None),
        };
        paged.bounds = paged.find_bounds()?;
        Ok(paged)
    }

    /// The exact bounds of the occupied voxels: on each side of each axis,
    /// the outermost layer of stored chunks whose voxels are not all 0
    /// gives the extreme coordinate. Those chunks are decoded here (in
    /// parallel) and dropped: the rays decode what they reach.
    fn find_bounds(&self) -> Result<Option<(Voxel, Voxel)>> {
        use rayon::prelude::*;
        let stored: Vec<Voxel> = self
            .near
            .iter()
            .copied()
            .filter(|&c| self.coarse[self.chunk_index(c)] == 0)
            .collect();
        let mut lo = IVec3::ZERO;
        let mut hi = IVec3::ZERO;
        for axis in 0..3 {
            for high in [false, true] {
                let mut layers: Vec<i32> = stored.iter().map(|c| c[axis]).collect();
                layers.sort_unstable();
                layers.dedup();
                if high {
                    layers.reverse();
                }
                let mut found = None;
                for layer in layers {
                    let ends: Vec<Option<i32>> = stored
                        .par_iter()
                        .filter(|c| c[axis] == layer)
                        .map(|&c| -> Result<Option<i32>> {
                            let bricks = self.reader.read_chunk(c)?;
                            self.bounds_chunks.fetch_add(1, Ordering::Relaxed);
                            let ends = bricks.iter().map(|&(l, m)| {
                                let (a, b) = mask_bounds(&m);
                                let base = c[axis] * 64 + local_brick(l as usize)[axis] * 8;
                                base + if high { b[axis] } else { a[axis] }
                            });
                            Ok(if high { ends.max() } else { ends.min() })
                        })
                        .collect::<Result<_>>()?;
                    let ends = ends.into_iter().flatten();
                    found = if high { ends.max() } else { ends.min() };
                    if found.is_some() {
                        break;
                    }
                }
                let Some(e) = found else {
                    return Ok(None);
                };
                if high {
                    hi[axis] = e;
                } else {
                    lo[axis] = e;
                }
            }
        }
        Ok(Some((lo, hi)))
    }

    fn chunk_index(&self, c: Voxel) -> usize {
        (c.x + self.cdims[0] * (c.y + self.cdims[1] * c.z)) as usize
    }

    /// Records the first failure; later ones are dropped.
    fn fail(&self, e: VoxkitError) {
        let mut f = self.failure.lock().unwrap_or_else(|p| p.into_inner());
        f.get_or_insert(e);
    }

    /// Counts `bytes` more against the limit: false (and the failure
    /// recorded) when they do not fit.
    fn charge(&self, bytes: u64) -> bool {
        let total = self.loaded_bytes.fetch_add(bytes, Ordering::Relaxed) + bytes;
        match self.limit.check(
            "the store's chunks the rays reach",
            u128::from(total + self.fixed_bytes),
            1,
        ) {
            Ok(()) => true,
            Err(e) => {
                self.fail(e);
                false
            }
        }
    }

    /// The decoded occupancy of near chunk `i` (a stored one).
    fn raw(&self, i: usize) -> &RawChunk {
        self.raw[i].get_or_init(|| {
            let mut raw = Box::new(RawChunk {
                slot: [0; CHUNK_BRICKS],
                masks: Vec::new(),
            });
            match self.reader.read_chunk(self.near[i]) {
                Ok(bricks) => {
                    for (l, m) in bricks {
                        raw.masks.push(m);
                        raw.slot[l as usize] = raw.masks.len() as u16;
                    }
                }
                Err(e) => self.fail(e),
            }
            self.chunks_decoded.fetch_add(1, Ordering::Relaxed);
            if !self.charge(raw.bytes()) {
                raw.masks = Vec::new();
                raw.slot = [0; CHUNK_BRICKS];
            }
            raw
        })
    }

    /// The occupancy mask of brick `b` (global brick coordinates), decoding
    /// its chunk if needed; empty outside the grid.
    fn occupancy_of(&self, b: IVec3) -> BrickMask {
        let c = b.div_euclid(IVec3::splat(CB));
        if (0..3).any(|k| c[k] < 0 || c[k] >= self.cdims[k]) {
            return [0; 8];
        }
        let ci = self.chunk_index(c);
        match self.chunk_slot[ci] {
            _ if self.coarse[ci] != 0 => [0; 8],
            s => {
                let l = b - c * CB;
                self.raw(s as usize - 1)
                    .mask((l.x + CB * (l.y + CB * l.z)) as usize)
                    .copied()
                    .unwrap_or([0; 8])
            }
        }
    }

    /// The page of near chunk `i`.
    fn page(&self, i: usize) -> &Page {
        self.pages[i].get_or_init(|| {
            let c = self.near[i];
            let base = c * CB;
            // The chunk's bricks and a ring of one brick around them (from
            // the stored neighbours): a 10³ box, x fastest.
            const M: i32 = CB + 2;
            let lo = base - 1;
            let at = |b: IVec3| ((b.x - lo.x) + M * ((b.y - lo.y) + M * (b.z - lo.z))) as usize;
            let mut occ = vec![[0u64; 8]; (M * M * M) as usize];
            // Brick boxes of the stored neighbours (not c itself).
            let mut others: Vec<(IVec3, IVec3)> = Vec::new();
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let d = IVec3::new(dx, dy, dz);
                        let n = c + d;
                        if (0..3).any(|k| n[k] < 0 || n[k] >= self.cdims[k]) {
                            continue;
                        }
                        let ni = self.chunk_index(n);
                        if self.coarse[ni] != 0 {
                            continue;
                        }
                        let (nlo, nhi) = (n * CB, n * CB + (CB - 1));
                        if d != IVec3::ZERO {
                            others.push((nlo, nhi));
                        }
                        let raw = self.raw(self.chunk_slot[ni] as usize - 1);
                        // The part of n inside the box.
                        let (blo, bhi) = (nlo.max(lo), nhi.min(lo + (M - 1)));
                        for z in blo.z..=bhi.z {
                            for y in blo.y..=bhi.y {
                                for x in blo.x..=bhi.x {
                                    let b = IVec3::new(x, y, z);
                                    let l = b - nlo;
                                    if let Some(m) =
                                        raw.mask((l.x + CB * (l.y + CB * l.z)) as usize)
                                    {
                                        occ[at(b)] = *m;
                                    }
                                }
                            }
                        }
                    }
                }
            }
            let occ_at = |b: IVec3| -> BrickMask { occ[at(b)] };
            let dist = chessboard_distance([M; 3], |j| !mask_empty(&occ[j]));
            let mut page = Box::new(Page {
                slot: [0; CHUNK_BRICKS],
                cloud: [0; CHUNK_BRICKS],
                flags: vec![EMPTY_FLAGS, STOP_FLAGS],
            });
            let bdims = self.dims.map(|d| (d + 7) >> 3);
            let (far_lo, far_hi) = (base - CB, base + (2 * CB - 1));
            for l in 0..CHUNK_BRICKS {
                let b = base + local_brick(l);
                // Occupied bricks outside the box lie in a stored neighbour
                // (at least as far as its box) or beyond the 3×3×3 chunks
                // (at least one more than the distance to their faces).
                let mut beyond = (b - far_lo).min(far_hi - b).min_element() + 1;
                for &(nlo, nhi) in &others {
                    let gap = (nlo - b).max(b - nhi).max(IVec3::ZERO).max_element();
                    beyond = beyond.min(gap);
                }
                page.cloud[l] = dist[at(b)].min(beyond.min(255) as u8);
                if (0..3).any(|k| b[k] >= bdims[k]) {
                    continue;
                }
                let m = occ_at(b);
                if m == FULL_BRICK {
                    page.slot[l] = 1;
                    continue;
                }
                // Flags only near occupied bricks (cloud 0 or 1 here).
                if dist[at(b)] > 1 {
                    continue;
                }
                let prox = dilate(b, &occ_at);
                if !mask_empty(&prox) || !mask_empty(&m) {
                    page.flags.push(BrickFlags { occ: m, prox });
                    page.slot[l] = (page.flags.len() - 1) as u16;
                }
            }
            self.pages_built.fetch_add(1, Ordering::Relaxed);
            if !self.charge(page.bytes()) {
                page.slot = [1; CHUNK_BRICKS];
                page.flags.truncate(2);
            }
            page
        })
    }

    /// Chunks decoded so far (a page needs its neighbours decoded too).
    pub fn chunks_decoded(&self) -> u64 {
        self.chunks_decoded.load(Ordering::Relaxed)
    }

    /// Chunks decoded when opened, to find the exact bounds (the outermost
    /// stored layers on each side; not kept).
    pub fn bounds_chunks(&self) -> u64 {
        self.bounds_chunks.load(Ordering::Relaxed)
    }

    /// Pages built so far (chunks some ray reached).
    pub fn pages_built(&self) -> u64 {
        self.pages_built.load(Ordering::Relaxed)
    }

    /// Chunks the store holds.
    pub fn stored_chunks(&self) -> usize {
        self.stored
    }

    /// Grid extents in voxels.
    pub fn dims(&self) -> [usize; 3] {
        self.dims.map(|d| d as usize)
    }

    /// Inclusive bounds of the occupied voxels.
    pub fn bounds(&self) -> Option<(Voxel, Voxel)> {
        self.bounds
    }

    /// Bytes held: the chunk tables and indexes, and every chunk decoded
    /// and page built so far.
    pub fn heap_bytes(&self) -> u64 {
        self.fixed_bytes + self.loaded_bytes.load(Ordering::Relaxed)
    }

    /// The failure recorded while building pages (a read error, or the
    /// memory limit reached), if any; a render that saw one is not an
    /// image of the store. [`render_grid_window`](super::render_grid_window)
    /// returns it instead of the image.
    pub fn failure(&self) -> Result<()> {
        // Kept: later renders fail too (the pages handed out stop rays).
        let f = self.failure.lock().unwrap_or_else(|p| p.into_inner());
        f.as_ref().map_or(Ok(()), |e| Err(e.clone()))
    }
}

/// Whether a mask has no voxel (an OR of its words: array equality
/// compiles to a `memcmp` call).
#[inline(always)]
fn mask_empty(m: &BrickMask) -> bool {
    m.iter().fold(0, |a, &w| a | w) == 0
}

/// Inclusive bounds of the voxels of a non-empty brick mask, in the
/// brick's local coordinates.
fn mask_bounds(m: &BrickMask) -> (IVec3, IVec3) {
    let mut lo = IVec3::splat(7);
    let mut hi = IVec3::ZERO;
    let mut rows = 0u64;
    for (z, &w) in m.iter().enumerate() {
        if w != 0 {
            lo.z = lo.z.min(z as i32);
            hi.z = hi.z.max(z as i32);
            rows |= w;
        }
    }
    // Bit lx + 8 ly: y from the lowest and highest set bits, x from the
    // columns folded over the rows.
    lo.y = (rows.trailing_zeros() / 8) as i32;
    hi.y = (63 - rows.leading_zeros()) as i32 / 8;
    let cols = (0..8).fold(0u64, |a, y| a | (rows >> (8 * y)) & 0xff);
    lo.x = cols.trailing_zeros() as i32;
    hi.x = 63 - cols.leading_zeros() as i32;
    (lo, hi)
}

/// Brick coordinates inside a chunk of local index `bx + 8 by + 64 bz`.
#[inline(always)]
fn local_brick(l: usize) -> IVec3 {
    let l = l as i32;
    IVec3::new(l & 7, (l >> 3) & 7, l >> 6)
}

impl RenderBricks for PagedOccupancy {
    type At<'a> = PagedBrick<'a>;

    #[inline(always)]
    fn grid_dims(&self) -> [i32; 3] {
        self.dims
    }

    fn occupied_bounds(&self) -> Option<(Voxel, Voxel)> {
        self.bounds
    }

    #[inline]
    fn locate(&self, b: IVec3) -> PagedBrick<'_> {
        let c = b >> 3;
        let ci = self.chunk_index(c);
        match self.chunk_slot[ci] {
            0 => {
                // K ≥ 2: inside the empty box of chunks within K − 1 of c,
                // one more than the distance to its faces, in bricks.
                let k = i32::from(self.coarse[ci]);
                let lo = (c - (k - 1)) * CB;
                let hi = (c + k) * CB - 1;
                let face = (b - lo).min(hi - b).min_element();
                PagedBrick {
                    flags: &EMPTY_FLAGS,
                    cloud: (face + 1).min(255) as u8,
                }
            }
            s => {
                let page = self.page(s as usize - 1);
                let l = b & 7;
                let l = (l.x + CB * (l.y + CB * l.z)) as usize;
                PagedBrick {
                    flags: &page.flags[page.slot[l] as usize],
                    cloud: page.cloud[l],
                }
            }
        }
    }

    #[inline(always)]
    fn cloud<'a>(&'a self, at: PagedBrick<'a>) -> u8 {
        at.cloud
    }

    #[inline(always)]
    fn flags<'a>(&'a self, at: PagedBrick<'a>) -> &'a BrickFlags {
        at.flags
    }

    fn health(&self) -> Result<()> {
        self.failure()
    }

    fn occupancy_mask(&self, b: IVec3) -> BrickMask {
        // Shading reads neighbours: decode their chunk, not its page.
        self.occupancy_of(b)
    }
}
