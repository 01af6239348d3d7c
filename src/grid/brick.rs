//! Sparse occupancy in 8³ bricks: memory grows with the occupied bricks, not
//! with the bounding box.
//!
//! A brick is a 64-byte bitmask (`[u64; 8]`: word `lz`, bit `lx + 8 ly`)
//! stored in a dense `Vec`, found through a hash map from brick coordinate
//! (`voxel >> 3`, arithmetic, so negative voxels work) to slot. The map uses a
//! tiny local multiplicative hasher (FxHash-style) rather than SipHash: keys
//! are not attacker-controlled and hashing is on the hot path. Writers also
//! cache the last brick touched, so runs of nearby voxels (the usual case
//! for a voxelizer) skip the map entirely.
//!
//! A brick whose 512 voxels are all set may instead be a **tile** (as
//! OpenVDB's tiles are): one bit, not 64 bytes of ones. Tiles live in blocks
//! of 4³ bricks, one `u64` per block (bit `bx + 4 by + 16 bz` of the brick's
//! position in its block), in a second map keyed by block coordinate
//! (`brick >> 2`). A brick is never both a stored mask and a tile. Every
//! query treats a tile as the full mask [`FULL_BRICK`]; a stored mask that
//! happens to be full (filled voxel by voxel) means the same voxels, and
//! [`BrickGrid::compact_tiles`] turns such masks into tiles.
//!
//! Cost: about 64 bytes per stored mask plus ~20 bytes of map entry and key;
//! a brick holds up to 512 voxels. A tile costs 1/64 of a block entry
//! (~28 bytes with its map share): under half a byte per tile inside a solid,
//! ~28 bytes for an isolated one.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::OnceLock;

use super::{BitGrid, DenseGrid, Dims, MemoryLimit, Voxel};
use crate::error::{Result, VoxkitError};

/// Brick edge in voxels (8).
pub const BRICK_EDGE: i32 = 8;
/// log2 of [`BRICK_EDGE`].
pub const BRICK_SHIFT: u32 = 3;

/// One brick's occupancy: word `lz`, bit `lx + 8 * ly` (local coordinates
/// `0..8`).
pub type BrickMask = [u64; 8];

/// FxHash-style hasher: rotate, xor, multiply by a large odd constant.
#[derive(Default, Clone, Copy)]
pub struct FxHasher {
    hash: u64,
}

impl FxHasher {
    const K: u64 = 0x517c_c1b7_2722_0a95;
    #[inline(always)]
    fn add(&mut self, w: u64) {
        self.hash = (self.hash.rotate_left(5) ^ w).wrapping_mul(Self::K);
    }
}

impl Hasher for FxHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut b = [0u8; 8];
            b[..chunk.len()].copy_from_slice(chunk);
            self.add(u64::from_le_bytes(b));
        }
    }
    #[inline(always)]
    fn write_u32(&mut self, i: u32) {
        self.add(i as u64);
    }
    #[inline(always)]
    fn write_i32(&mut self, i: i32) {
        self.add(i as u32 as u64);
    }
    #[inline(always)]
    fn write_u64(&mut self, i: u64) {
        self.add(i);
    }
    #[inline(always)]
    fn finish(&self) -> u64 {
        // Fold the high bits down: hashbrown takes its bucket from the low
        // bits and its tag from the top 7.
        self.hash ^ (self.hash >> 29)
    }
}

type FxBuild = BuildHasherDefault<FxHasher>;

/// Brick coordinate → slot of `keys` (a repeated key keeps its last slot).
fn index_of(keys: &[Voxel]) -> HashMap<Voxel, u32, FxBuild> {
    let mut index = HashMap::with_capacity_and_hasher(keys.len(), FxBuild::default());
    for (s, k) in keys.iter().enumerate() {
        index.insert(*k, s as u32);
    }
    index
}

/// Brick coordinate of voxel `v`.
#[inline(always)]
pub fn brick_of(v: Voxel) -> Voxel {
    Voxel::new(v.x >> BRICK_SHIFT, v.y >> BRICK_SHIFT, v.z >> BRICK_SHIFT)
}

/// (word, bit) of voxel `v` inside its brick.
#[inline(always)]
fn local_bit(v: Voxel) -> (usize, u64) {
    let lx = (v.x & 7) as u32;
    let ly = (v.y & 7) as u32;
    let lz = (v.z & 7) as usize;
    (lz, 1u64 << (lx + 8 * ly))
}

/// All 512 voxels of a brick.
pub const FULL_BRICK: BrickMask = [u64::MAX; 8];

/// No voxel of a brick.
const EMPTY_BRICK: BrickMask = [0; 8];

/// log2 of the edge, in bricks, of a tile block (4).
const TILE_BLOCK_SHIFT: u32 = 2;

/// Block coordinate of brick `b` in the tile map.
#[inline(always)]
fn block_of(b: Voxel) -> Voxel {
    Voxel::new(
        b.x >> TILE_BLOCK_SHIFT,
        b.y >> TILE_BLOCK_SHIFT,
        b.z >> TILE_BLOCK_SHIFT,
    )
}

/// Bit of brick `b` in its tile block word: `bx + 4 by + 16 bz` (local).
#[inline(always)]
fn block_bit(b: Voxel) -> u64 {
    1u64 << ((b.x & 3) + 4 * (b.y & 3) + 16 * (b.z & 3))
}

/// Brick coordinates of the set bits of tile block `block`.
fn block_bricks(block: Voxel, mut bits: u64) -> impl Iterator<Item = Voxel> {
    let base = block * 4;
    std::iter::from_fn(move || {
        if bits == 0 {
            return None;
        }
        let i = bits.trailing_zeros() as i32;
        bits &= bits - 1;
        Some(base + Voxel::new(i & 3, (i >> 2) & 3, i >> 4))
    })
}

/// Bits of local layer 0 along each axis in a tile block word, and the
/// shift from one layer to the next.
const BLOCK_LAYER: [(u64, u32); 3] = [
    (0x1111_1111_1111_1111, 1),
    (0x000F_000F_000F_000F, 4),
    (0xFFFF, 16),
];

/// Hashbrown's table bytes for a map of `capacity` (as reported by
/// `HashMap::capacity`) with entries of `entry` bytes: buckets of one entry
/// and one control byte, plus a group of trailing control bytes.
fn table_bytes(capacity: usize, entry: usize) -> usize {
    if capacity == 0 {
        return 0;
    }
    let buckets = if capacity < 8 {
        capacity + 1
    } else {
        capacity / 7 * 8
    };
    buckets * (entry + 1) + 16
}

/// A sparse set of voxels in 8³ bricks, wholly set bricks optionally as
/// tiles (see the [module docs](self)). Any `i32` voxel coordinates are
/// allowed; grids and writers decide what is in range.
///
/// ```
/// use glam::IVec3;
/// use voxkit::grid::BrickGrid;
/// let mut g = BrickGrid::new();
/// assert!(g.insert(IVec3::new(3, -9, 100)));
/// assert!(!g.insert(IVec3::new(3, -9, 100))); // already set
/// g.insert(IVec3::new(4, -9, 100));           // same brick
/// g.insert(IVec3::new(8, 0, 0));              // another brick
/// assert_eq!((g.count(), g.brick_count()), (3, 2));
/// assert!(g.contains(IVec3::new(4, -9, 100)));
/// assert_eq!(g.bounds(), Some((IVec3::new(3, -9, 0), IVec3::new(8, 0, 100))));
/// // Iteration is deterministic: bricks in (z, y, x) order, x fastest inside.
/// let v: Vec<_> = g.iter().collect();
/// assert_eq!(v[0], IVec3::new(8, 0, 0));
/// // A tile: the 512 voxels of brick (0, 0, -1) as one flag.
/// g.insert_tile(IVec3::new(0, 0, -1));
/// assert!(g.contains(IVec3::new(7, 7, -8)));
/// assert_eq!((g.count(), g.brick_count(), g.tile_count()), (515, 3, 1));
/// ```
#[derive(Clone, Default)]
pub struct BrickGrid {
    /// Brick coordinate → slot, built on first use: a grid assembled from
    /// unique bricks and then only iterated or written out (the surface
    /// voxelizer's result) never pays for it.
    slots: OnceLock<HashMap<Voxel, u32, FxBuild>>,
    keys: Vec<Voxel>,
    masks: Vec<BrickMask>,
    /// Tiles: block coordinate (`brick >> 2`) → one bit per brick of the
    /// block ([`block_bit`]). No word is zero; no tile is also in `keys`.
    tiles: HashMap<Voxel, u64, FxBuild>,
    /// Last brick touched by a write: (brick coordinate, slot of a mask).
    last: Option<(Voxel, u32)>,
}

impl std::fmt::Debug for BrickGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BrickGrid")
            .field("bricks", &self.brick_count())
            .field("tiles", &self.tile_count())
            .field("voxels", &self.count())
            .field("bounds", &self.bounds())
            .finish()
    }
}

impl PartialEq for BrickGrid {
    /// Same set of voxels: storage order does not matter, and a tile equals
    /// a stored full mask.
    fn eq(&self, other: &Self) -> bool {
        // Stored bricks are never empty, so equal sets occupy equal bricks.
        self.brick_count() == other.brick_count()
            && self.bricks().all(|(k, m)| other.brick(k) == Some(m))
    }
}

impl Eq for BrickGrid {}

impl BrickGrid {
    /// An empty grid.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty grid with room for `bricks` stored masks.
    pub fn with_capacity(bricks: usize) -> Self {
        BrickGrid {
            slots: OnceLock::from(HashMap::with_capacity_and_hasher(
                bricks,
                FxBuild::default(),
            )),
            keys: Vec::with_capacity(bricks),
            masks: Vec::with_capacity(bricks),
            tiles: HashMap::default(),
            last: None,
        }
    }

    /// Slot of the mask of brick `b`, creating an empty mask if needed;
    /// `None` if `b` is a tile.
    #[inline]
    fn slot_or_insert(&mut self, b: Voxel) -> Option<usize> {
        if let Some((lb, s)) = self.last
            && lb == b
        {
            return Some(s as usize);
        }
        if self.is_tile(b) {
            return None;
        }
        let next = self.keys.len() as u32;
        let s = *self.index_mut().entry(b).or_insert(next);
        if s == next {
            self.keys.push(b);
            self.masks.push(EMPTY_BRICK);
        }
        self.last = Some((b, s));
        Some(s as usize)
    }

    /// Drops the mask in slot `s` (the last slot moves into it).
    fn release_slot(&mut self, s: usize) {
        let b = self.keys[s];
        self.index_mut().remove(&b);
        self.keys.swap_remove(s);
        self.masks.swap_remove(s);
        if s < self.keys.len() {
            let moved = self.keys[s];
            self.index_mut().insert(moved, s as u32);
        }
        self.last = None;
    }

    /// Clears tile `b`; returns whether it was a tile.
    fn remove_tile(&mut self, b: Voxel) -> bool {
        let block = block_of(b);
        let Some(word) = self.tiles.get_mut(&block) else {
            return false;
        };
        let was = *word & block_bit(b) != 0;
        *word &= !block_bit(b);
        if *word == 0 {
            self.tiles.remove(&block);
        }
        was
    }

    /// Sets voxel `v`; returns true if it was not set before. A voxel of a
    /// tile is already set. A mask filled this way stays a mask (see
    /// [`BrickGrid::compact_tiles`]).
    #[inline]
    pub fn insert(&mut self, v: Voxel) -> bool {
        let Some(s) = self.slot_or_insert(brick_of(v)) else {
            return false;
        };
        let (w, m) = local_bit(v);
        let word = &mut self.masks[s][w];
        let was = *word & m != 0;
        *word |= m;
        !was
    }

    /// Clears voxel `v`; returns true if it was set. A brick that becomes
    /// empty is released; a tile becomes a stored mask of the other 511
    /// voxels.
    pub fn remove(&mut self, v: Voxel) -> bool {
        let b = brick_of(v);
        let (w, m) = local_bit(v);
        if let Some(&s) = self.index().get(&b) {
            let s = s as usize;
            let was = self.masks[s][w] & m != 0;
            self.masks[s][w] &= !m;
            if self.masks[s] == EMPTY_BRICK {
                self.release_slot(s);
            }
            return was;
        }
        if !self.remove_tile(b) {
            return false;
        }
        let s = self.slot_or_insert(b).expect("no longer a tile");
        self.masks[s] = FULL_BRICK;
        self.masks[s][w] &= !m;
        true
    }

    /// Sets (`on`) or clears voxel `v`.
    #[inline]
    pub fn set(&mut self, v: Voxel, on: bool) {
        if on {
            self.insert(v);
        } else {
            self.remove(v);
        }
    }

    /// Whether voxel `v` is set.
    #[inline]
    pub fn contains(&self, v: Voxel) -> bool {
        let (w, m) = local_bit(v);
        self.brick(brick_of(v)).is_some_and(|b| b[w] & m != 0)
    }

    /// The mask of brick `b` (brick coordinates), if it is occupied: the
    /// stored mask, or [`FULL_BRICK`] for a tile.
    #[inline]
    pub fn brick(&self, b: Voxel) -> Option<&BrickMask> {
        if !self.keys.is_empty()
            && let Some(&s) = self.index().get(&b)
        {
            return Some(&self.masks[s as usize]);
        }
        self.is_tile(b).then_some(&FULL_BRICK)
    }

    /// ORs a whole mask into brick `b` (brick coordinates). An all-zero mask
    /// stores nothing; a brick that ends up full becomes a tile.
    pub fn or_brick(&mut self, b: Voxel, mask: &BrickMask) {
        if *mask == EMPTY_BRICK {
            return;
        }
        if *mask == FULL_BRICK {
            self.insert_tile(b);
            return;
        }
        let Some(s) = self.slot_or_insert(b) else {
            return; // a tile: already full
        };
        let m = &mut self.masks[s];
        for (d, w) in m.iter_mut().zip(mask) {
            *d |= w;
        }
        if *m == FULL_BRICK {
            self.release_slot(s);
            *self.tiles.entry(block_of(b)).or_insert(0) |= block_bit(b);
        }
    }

    /// Makes brick `b` (brick coordinates) a tile: all 512 voxels set, one
    /// bit of storage. A stored mask of `b` is dropped.
    ///
    /// ```
    /// use voxkit::grid::{BrickGrid, Voxel};
    /// let mut g = BrickGrid::new();
    /// g.insert(Voxel::new(9, 0, 0)); // brick (1, 0, 0)
    /// g.insert_tile(Voxel::new(1, 0, 0));
    /// assert_eq!((g.brick_count(), g.tile_count(), g.count()), (1, 1, 512));
    /// assert!(g.is_tile(Voxel::new(1, 0, 0)));
    /// ```
    pub fn insert_tile(&mut self, b: Voxel) {
        if !self.keys.is_empty()
            && let Some(&s) = self.index().get(&b)
        {
            self.release_slot(s as usize);
        }
        *self.tiles.entry(block_of(b)).or_insert(0) |= block_bit(b);
    }

    /// Whether brick `b` (brick coordinates) is a tile. A stored mask that
    /// is full is not a tile (it holds the same voxels; see
    /// [`BrickGrid::compact_tiles`]).
    #[inline]
    pub fn is_tile(&self, b: Voxel) -> bool {
        !self.tiles.is_empty()
            && self
                .tiles
                .get(&block_of(b))
                .is_some_and(|&w| w & block_bit(b) != 0)
    }

    /// Number of tiles.
    pub fn tile_count(&self) -> usize {
        self.tiles.values().map(|w| w.count_ones() as usize).sum()
    }

    /// The tiles' brick coordinates, in storage order (not sorted).
    pub fn tiles(&self) -> impl Iterator<Item = Voxel> + '_ {
        self.tiles.iter().flat_map(|(&k, &w)| block_bricks(k, w))
    }

    /// Turns every stored mask that is full into a tile, and gives the
    /// freed mask storage back when that is most of it. Readers call this
    /// so that a solid read back is as small as the solid written.
    pub fn compact_tiles(&mut self) {
        if !self.masks.contains(&FULL_BRICK) {
            return;
        }
        let mut k = 0;
        for s in 0..self.keys.len() {
            if self.masks[s] == FULL_BRICK {
                let b = self.keys[s];
                *self.tiles.entry(block_of(b)).or_insert(0) |= block_bit(b);
            } else {
                self.keys[k] = self.keys[s];
                self.masks[k] = self.masks[s];
                k += 1;
            }
        }
        self.keys.truncate(k);
        self.masks.truncate(k);
        if 2 * k < self.masks.capacity() {
            self.keys.shrink_to_fit();
            self.masks.shrink_to_fit();
        }
        self.slots = OnceLock::new();
        self.last = None;
    }

    /// The brick index, built from `keys` on first use.
    #[inline]
    fn index(&self) -> &HashMap<Voxel, u32, FxBuild> {
        self.slots.get_or_init(|| index_of(&self.keys))
    }

    /// The brick index for changes, built from `keys` on first use.
    #[inline]
    fn index_mut(&mut self) -> &mut HashMap<Voxel, u32, FxBuild> {
        self.slots.get_or_init(|| index_of(&self.keys));
        self.slots.get_mut().expect("initialised on the line above")
    }

    /// A grid taking over parallel arrays of brick coordinates and masks
    /// that the caller guarantees to hold every brick exactly once and no
    /// empty mask (checked in debug builds): no pass over the bricks, and
    /// the index is built only if a lookup or change needs it. Full masks
    /// stay stored masks.
    pub(crate) fn from_unique_parts(keys: Vec<Voxel>, masks: Vec<BrickMask>) -> Self {
        assert_eq!(keys.len(), masks.len(), "one mask per brick coordinate");
        debug_assert!(!masks.contains(&EMPTY_BRICK), "an empty brick mask");
        debug_assert_eq!(index_of(&keys).len(), keys.len(), "a repeated brick");
        BrickGrid {
            slots: OnceLock::new(),
            keys,
            masks,
            tiles: HashMap::default(),
            last: None,
        }
    }

    /// A grid from bricks given as (brick coordinate, mask), each brick at
    /// most once (a repeated brick is merged, just more slowly); empty masks
    /// are dropped and full ones become tiles. Cheaper than
    /// [`BrickGrid::or_brick`] one at a time: the brick arrays are taken
    /// over and the index is built in one pass.
    pub fn from_bricks(bricks: impl IntoIterator<Item = (Voxel, BrickMask)>) -> Self {
        let (keys, masks): (Vec<Voxel>, Vec<BrickMask>) = bricks.into_iter().unzip();
        Self::from_parts(keys, masks)
    }

    /// [`BrickGrid::from_bricks`] from parallel arrays of brick coordinates
    /// and masks (taken over, not copied, when no mask is empty or full).
    ///
    /// ```
    /// use voxkit::grid::{BrickGrid, Voxel};
    /// let g = BrickGrid::from_parts(vec![Voxel::new(0, 0, 1)], vec![[1, 0, 0, 0, 0, 0, 0, 0]]);
    /// assert!(g.contains(Voxel::new(0, 0, 8)));
    /// assert_eq!(g.count(), 1);
    /// ```
    pub fn from_parts(keys: Vec<Voxel>, masks: Vec<BrickMask>) -> Self {
        Self::from_parts_tiled(keys, masks, Vec::new())
    }

    /// Keys and masks (as [`BrickGrid::from_parts`]) plus whole bricks as
    /// tiles (brick coordinates). A mask that is full becomes a tile; a key
    /// present both as a mask and a tile is a tile; repeated keys are
    /// merged; empty masks are dropped. Keys may come in any order.
    ///
    /// ```
    /// use voxkit::grid::{BrickGrid, Voxel};
    /// use voxkit::grid::brick::FULL_BRICK;
    /// let b = |x, y, z| Voxel::new(x, y, z);
    /// let one = [1, 0, 0, 0, 0, 0, 0, 0]; // voxel (0, 0, 0) of its brick
    /// let g = BrickGrid::from_parts_tiled(
    ///     vec![b(5, 0, 0), b(0, 0, 0), b(-1, 2, 3)],
    ///     vec![one, FULL_BRICK, one],
    ///     vec![b(5, 0, 0), b(7, 7, 7)],
    /// );
    /// // (0,0,0) was a full mask, (5,0,0) a mask and a tile: both are tiles.
    /// assert_eq!((g.brick_count(), g.tile_count()), (4, 3));
    /// assert!(g.is_tile(b(0, 0, 0)) && g.is_tile(b(5, 0, 0)) && !g.is_tile(b(-1, 2, 3)));
    /// assert_eq!(g.count(), 3 * 512 + 1);
    /// assert_eq!(g.brick(b(7, 7, 7)), Some(&FULL_BRICK));
    /// assert!(g.contains(Voxel::new(63, 56, 60)) && g.contains(Voxel::new(-8, 16, 24)));
    /// ```
    pub fn from_parts_tiled(
        mut keys: Vec<Voxel>,
        mut masks: Vec<BrickMask>,
        tiles: Vec<Voxel>,
    ) -> Self {
        assert_eq!(keys.len(), masks.len(), "one mask per brick coordinate");
        let mut blocks: HashMap<Voxel, u64, FxBuild> = HashMap::default();
        for b in tiles.into_iter().chain(
            keys.iter()
                .zip(&masks)
                .filter(|(_, m)| **m == FULL_BRICK)
                .map(|(k, _)| *k),
        ) {
            *blocks.entry(block_of(b)).or_insert(0) |= block_bit(b);
        }
        let tiled = |b: Voxel| {
            blocks
                .get(&block_of(b))
                .is_some_and(|&w| w & block_bit(b) != 0)
        };
        // Keep the masks that are neither empty nor tiles, in place.
        let mut k = 0;
        for s in 0..keys.len() {
            if masks[s] != EMPTY_BRICK && !tiled(keys[s]) {
                if k != s {
                    keys[k] = keys[s];
                    masks[k] = masks[s];
                }
                k += 1;
            }
        }
        keys.truncate(k);
        masks.truncate(k);
        let mut slots = HashMap::with_capacity_and_hasher(keys.len(), FxBuild::default());
        let mut g = BrickGrid {
            tiles: blocks,
            ..BrickGrid::new()
        };
        for (s, k) in keys.iter().enumerate() {
            if slots.insert(*k, s as u32).is_some() {
                // A repeat: fall back to merging (rare by contract).
                return keys.into_iter().zip(masks).fold(g, |mut g, (k, m)| {
                    g.or_brick(k, &m);
                    g
                });
            }
        }
        g.slots = OnceLock::from(slots);
        g.keys = keys;
        g.masks = masks;
        g
    }

    /// The set cells of the box `0..dims`, built brick by brick from rows of
    /// eight voxels along x: bit `i` of `row(v)` says whether voxel
    /// `v + (i, 0, 0)` is set (`v.x` is a multiple of 8; bits at `x ≥ nx`
    /// are ignored). Full bricks become tiles, so the grid never holds a
    /// full mask and memory stays with the result.
    ///
    /// ```
    /// use voxkit::grid::{BrickGrid, Voxel};
    /// // The half-space x < 12 of a 20×16×8 box.
    /// let g = BrickGrid::from_x_rows([20, 16, 8], |v| [0xff, 0x0f, 0][v.x as usize / 8]);
    /// assert_eq!((g.count(), g.tile_count()), (12 * 16 * 8, 2));
    /// assert!(g.contains(Voxel::new(11, 15, 7)) && !g.contains(Voxel::new(12, 0, 0)));
    /// ```
    pub fn from_x_rows(dims: Dims, mut row: impl FnMut(Voxel) -> u8) -> BrickGrid {
        let bdims = dims.map(|d| d.div_ceil(8));
        let (mut keys, mut masks, mut tiles) = (Vec::new(), Vec::new(), HashMap::default());
        for bz in 0..bdims[2] {
            for by in 0..bdims[1] {
                for bx in 0..bdims[0] {
                    let keep: u8 = if 8 * bx + 8 <= dims[0] {
                        0xff
                    } else {
                        (1u8 << (dims[0] - 8 * bx)) - 1
                    };
                    let mut m = EMPTY_BRICK;
                    for (lz, word) in m.iter_mut().enumerate().take(dims[2] - 8 * bz) {
                        for ly in 0..8.min(dims[1] - 8 * by) {
                            let v = Voxel::new(
                                (8 * bx) as i32,
                                (8 * by + ly) as i32,
                                (8 * bz + lz) as i32,
                            );
                            *word |= u64::from(row(v) & keep) << (8 * ly);
                        }
                    }
                    let b = Voxel::new(bx as i32, by as i32, bz as i32);
                    if m == FULL_BRICK {
                        *tiles.entry(block_of(b)).or_insert(0) |= block_bit(b);
                    } else if m != EMPTY_BRICK {
                        keys.push(b);
                        masks.push(m);
                    }
                }
            }
        }
        let mut g = BrickGrid::from_unique_parts(keys, masks);
        g.tiles = tiles;
        g
    }

    /// Number of set voxels (512 per tile).
    pub fn count(&self) -> u64 {
        self.masks
            .iter()
            .flat_map(|m| m.iter())
            .map(|w| w.count_ones() as u64)
            .sum::<u64>()
            + 512 * self.tile_count() as u64
    }

    /// Whether no voxel is set.
    pub fn is_empty(&self) -> bool {
        // Bricks are released when they empty, and `or_brick` of zero
        // stores nothing, so a stored brick is never empty.
        self.keys.is_empty() && self.tiles.is_empty()
    }

    /// Number of occupied bricks: stored masks plus tiles (each brick is
    /// one or the other).
    pub fn brick_count(&self) -> usize {
        self.keys.len() + self.tile_count()
    }

    /// Number of stored masks (occupied bricks that are not tiles).
    pub fn mask_count(&self) -> usize {
        self.keys.len()
    }

    /// Heap bytes in use: masks and keys at their capacity, and the brick
    /// and tile maps' tables at theirs (hashbrown: one entry and one control
    /// byte per bucket).
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.masks.capacity() * size_of::<BrickMask>()
            + self.keys.capacity() * size_of::<Voxel>()
            + self
                .slots
                .get()
                .map_or(0, |m| table_bytes(m.capacity(), size_of::<(Voxel, u32)>()))
            + table_bytes(self.tiles.capacity(), size_of::<(Voxel, u64)>())
    }

    /// Occupied bricks as (brick coordinate, mask) in storage order (not
    /// sorted; see [`BrickGrid::sorted_bricks_iter`]): the stored masks, then
    /// the tiles, each borrowing [`FULL_BRICK`].
    pub fn bricks(&self) -> impl Iterator<Item = (Voxel, &BrickMask)> + '_ {
        self.keys
            .iter()
            .copied()
            .zip(&self.masks)
            .chain(self.tiles().map(|b| (b, &FULL_BRICK)))
    }

    /// Occupied bricks sorted by brick coordinate in (z, y, x) order, tiles
    /// as [`FULL_BRICK`]. Copies 76 bytes per brick, tiles included: prefer
    /// [`BrickGrid::sorted_bricks_iter`].
    pub fn sorted_bricks(&self) -> Vec<(Voxel, BrickMask)> {
        self.sorted_bricks_iter().map(|(k, m)| (k, *m)).collect()
    }

    /// Occupied bricks sorted by brick coordinate in (z, y, x) order,
    /// borrowed (tiles as [`FULL_BRICK`]). Holds one z layer of bricks at a
    /// time (see [`BrickGrid::brick_layers`]).
    pub fn sorted_bricks_iter(&self) -> impl Iterator<Item = (Voxel, &BrickMask)> + '_ {
        self.brick_layers(2).flat_map(|(_, mut layer)| {
            layer.sort_unstable_by_key(|(k, _)| (k.y, k.x));
            layer
        })
    }

    /// The occupied bricks one layer at a time along `axis` (0 = x, 1 = y,
    /// 2 = z), layers in increasing brick coordinate, empty layers left out:
    /// each item is the layer's brick coordinate along `axis` and its bricks
    /// (tiles as [`FULL_BRICK`]) in no particular order. Memory: 4 bytes per
    /// stored mask and 24 per tile block for the order, plus one layer's
    /// list, never a list of all tiles. Writers stream slabs from this.
    ///
    /// # Panics
    /// If `axis > 2`.
    ///
    /// ```
    /// use voxkit::grid::{BrickGrid, Voxel};
    /// let mut g = BrickGrid::new();
    /// g.insert(Voxel::new(0, 0, 20)); // brick z = 2
    /// g.insert_tile(Voxel::new(3, 0, -1));
    /// let layers: Vec<(i32, usize)> = g.brick_layers(2).map(|(z, l)| (z, l.len())).collect();
    /// assert_eq!(layers, vec![(-1, 1), (2, 1)]);
    /// ```
    pub fn brick_layers(
        &self,
        axis: usize,
    ) -> impl Iterator<Item = (i32, Vec<(Voxel, &BrickMask)>)> + '_ {
        assert!(axis < 3, "axis {axis} is not 0, 1 or 2");
        let keys = &self.keys;
        let mut order: Vec<u32> = (0..keys.len() as u32).collect();
        order.sort_unstable_by_key(|&s| {
            let k = keys[s as usize];
            (k[axis], k.z, k.y, k.x)
        });
        let mut blocks: Vec<(Voxel, u64)> = self.tiles.iter().map(|(&k, &w)| (k, w)).collect();
        blocks.sort_unstable_by_key(|(k, _)| (k[axis], k.z, k.y, k.x));
        let (layer_bits, layer_shift) = BLOCK_LAYER[axis];
        let mut next_mask = 0;
        // Blocks `group..group_end` share the block coordinate along `axis`;
        // `local` is the next of their four brick layers to look at.
        let (mut group, mut group_end, mut local) = (0, 0, 0u32);
        std::iter::from_fn(move || {
            let tile_layer = loop {
                if group >= blocks.len() {
                    break None;
                }
                if group_end <= group {
                    let c = blocks[group].0[axis];
                    group_end = group + blocks[group..].partition_point(|(k, _)| k[axis] == c);
                    local = 0;
                }
                if local == 4 {
                    group = group_end;
                    continue;
                }
                let sel = layer_bits << (layer_shift * local);
                if blocks[group..group_end].iter().any(|(_, w)| w & sel != 0) {
                    break Some(blocks[group].0[axis] * 4 + local as i32);
                }
                local += 1;
            };
            let mask_layer = order.get(next_mask).map(|&s| keys[s as usize][axis]);
            let c = match (mask_layer, tile_layer) {
                (None, None) => return None,
                (Some(a), None) | (None, Some(a)) => a,
                (Some(a), Some(b)) => a.min(b),
            };
            let mut layer = Vec::new();
            while let Some(&s) = order.get(next_mask)
                && keys[s as usize][axis] == c
            {
                layer.push((keys[s as usize], &self.masks[s as usize]));
                next_mask += 1;
            }
            if tile_layer == Some(c) {
                let sel = layer_bits << (layer_shift * local);
                for &(k, w) in &blocks[group..group_end] {
                    layer.extend(block_bricks(k, w & sel).map(|b| (b, &FULL_BRICK)));
                }
                local += 1;
            }
            Some((c, layer))
        })
    }

    /// The occupied bricks in cubic groups of `2^shift` bricks per side
    /// (`shift ≥ 2`), groups in (z, y, x) order of their coordinate
    /// (`brick >> shift`), empty groups left out: each item is the group
    /// coordinate and its bricks (tiles as [`FULL_BRICK`]) sorted by (z, y,
    /// x). Memory as [`BrickGrid::brick_layers`], with one group's list.
    /// The .vox writer streams its 256³ models (`shift` 5) from this.
    ///
    /// # Panics
    /// If `shift < 2` or `shift > 31`.
    pub fn brick_groups(
        &self,
        shift: u32,
    ) -> impl Iterator<Item = (Voxel, Vec<(Voxel, &BrickMask)>)> + '_ {
        assert!(
            (TILE_BLOCK_SHIFT..32).contains(&shift),
            "group shift {shift}"
        );
        let group_of = move |k: Voxel, s: u32| {
            let g = Voxel::new(k.x >> s, k.y >> s, k.z >> s);
            (g.z, g.y, g.x)
        };
        let keys = &self.keys;
        let mut order: Vec<u32> = (0..keys.len() as u32).collect();
        order.sort_unstable_by_key(|&s| group_of(keys[s as usize], shift));
        // Blocks nest in groups: a block's group is `block >> (shift - 2)`.
        let bshift = shift - TILE_BLOCK_SHIFT;
        let mut blocks: Vec<(Voxel, u64)> = self.tiles.iter().map(|(&k, &w)| (k, w)).collect();
        blocks.sort_unstable_by_key(|(k, _)| group_of(*k, bshift));
        let (mut i, mut j) = (0, 0);
        std::iter::from_fn(move || {
            let a = order.get(i).map(|&s| group_of(keys[s as usize], shift));
            let b = blocks.get(j).map(|(k, _)| group_of(*k, bshift));
            let g = match (a, b) {
                (None, None) => return None,
                (Some(a), None) | (None, Some(a)) => a,
                (Some(a), Some(b)) => a.min(b),
            };
            let mut list = Vec::new();
            while let Some(&s) = order.get(i)
                && group_of(keys[s as usize], shift) == g
            {
                list.push((keys[s as usize], &self.masks[s as usize]));
                i += 1;
            }
            while let Some(&(k, w)) = blocks.get(j)
                && group_of(k, bshift) == g
            {
                list.extend(block_bricks(k, w).map(|b| (b, &FULL_BRICK)));
                j += 1;
            }
            list.sort_unstable_by_key(|(k, _)| (k.z, k.y, k.x));
            Some((Voxel::new(g.2, g.1, g.0), list))
        })
    }

    /// Iterates over the set voxels in a deterministic order: bricks sorted
    /// by (z, y, x) brick coordinate; inside a brick, x fastest, then y, then z.
    pub fn iter(&self) -> impl Iterator<Item = Voxel> + '_ {
        self.sorted_bricks_iter().flat_map(|(k, m)| {
            let base = k * BRICK_EDGE;
            mask_voxels(*m).map(move |l| base + l)
        })
    }

    /// Adds every voxel of `other` (set union); tiles of `other` stay tiles.
    ///
    /// ```
    /// use voxkit::grid::{BrickGrid, Voxel};
    /// let mut a = BrickGrid::new();
    /// a.insert(Voxel::new(1, 2, 3));
    /// let mut b = BrickGrid::new();
    /// b.insert_tile(Voxel::ZERO);
    /// b.insert(Voxel::new(40, 0, 0));
    /// a.union_with(&b);
    /// assert_eq!(a.count(), 512 + 1);
    /// assert!(a.is_tile(Voxel::ZERO));
    /// ```
    pub fn union_with(&mut self, other: &BrickGrid) {
        // Tiles a block word at a time, then one pass dropping the masks
        // they cover: a solid's interior is mostly tiles, and a lookup per
        // tile was most of the union (`docs/performance-notes.md`).
        let mut covered = false;
        for (&block, &w) in &other.tiles {
            let word = self.tiles.entry(block).or_insert(0);
            covered |= w & !*word != 0;
            *word |= w;
        }
        if covered && !self.keys.is_empty() {
            self.drop_tiled_masks();
        }
        self.index_mut().reserve(other.keys.len());
        for (k, m) in other.keys.iter().zip(&other.masks) {
            self.or_brick(*k, m);
        }
    }

    /// Drops the stored masks of bricks that are tiles (keeping the others
    /// in order), so that no tile is also in `keys`.
    fn drop_tiled_masks(&mut self) {
        let mut k = 0;
        for s in 0..self.keys.len() {
            let b = self.keys[s];
            let tiled = self
                .tiles
                .get(&block_of(b))
                .is_some_and(|&w| w & block_bit(b) != 0);
            if !tiled {
                self.keys[k] = b;
                self.masks[k] = self.masks[s];
                k += 1;
            }
        }
        if k == self.keys.len() {
            return;
        }
        self.keys.truncate(k);
        self.masks.truncate(k);
        self.slots = OnceLock::new();
        self.last = None;
    }

    /// The union of several grids (e.g. per-thread results), in input order.
    pub fn merge<I: IntoIterator<Item = BrickGrid>>(grids: I) -> BrickGrid {
        let mut it = grids.into_iter();
        let mut acc = it.next().unwrap_or_default();
        for g in it {
            // Fold the smaller into the larger.
            if g.brick_count() > acc.brick_count() {
                let small = std::mem::replace(&mut acc, g);
                acc.union_with(&small);
            } else {
                acc.union_with(&g);
            }
        }
        acc
    }

    /// Inclusive voxel bounds `(min, max)` of the set voxels, or `None` when
    /// empty.
    pub fn bounds(&self) -> Option<(Voxel, Voxel)> {
        let mut lo = Voxel::MAX;
        let mut hi = Voxel::MIN;
        for (k, m) in self.keys.iter().zip(&self.masks) {
            if *m == EMPTY_BRICK {
                continue;
            }
            let base = *k * BRICK_EDGE;
            let (mlo, mhi) = mask_bounds(m);
            lo = lo.min(base + mlo);
            hi = hi.max(base + mhi);
        }
        for (&block, &w) in &self.tiles {
            for b in block_bricks(block, w) {
                lo = lo.min(b * BRICK_EDGE);
                hi = hi.max(b * BRICK_EDGE + Voxel::splat(BRICK_EDGE - 1));
            }
        }
        (lo.x <= hi.x).then_some((lo, hi))
    }

    /// Checks that every set voxel lies in `0..dims`; names the bounds
    /// otherwise.
    pub fn check_inside(&self, dims: Dims) -> Result<()> {
        if let Some((lo, hi)) = self.bounds() {
            let inside =
                lo.cmpge(Voxel::ZERO).all() && (0..3).all(|a| (hi[a] as i64) < dims[a] as i64);
            if !inside {
                return Err(VoxkitError::invalid(format!(
                    "voxels span {lo}..={hi}, outside the grid 0..{dims:?}"
                )));
            }
        }
        Ok(())
    }

    /// Calls `row(v, bits)` for every non-empty row of eight voxels along x
    /// of every occupied brick: bit `i` is voxel `v + (i, 0, 0)`.
    fn for_each_x_row(&self, mut row: impl FnMut(Voxel, u8)) {
        for (k, m) in self.bricks() {
            let base = k * BRICK_EDGE;
            for (lz, &w) in m.iter().enumerate() {
                if w == 0 {
                    continue;
                }
                for ly in 0..8 {
                    let bits = (w >> (8 * ly)) as u8;
                    if bits != 0 {
                        row(base + Voxel::new(0, ly, lz as i32), bits);
                    }
                }
            }
        }
    }

    /// A dense bit grid of `dims` holding these voxels; checked against
    /// `limit` before allocating. Voxels outside `0..dims` are an error.
    pub fn to_bit_grid(&self, dims: Dims, limit: MemoryLimit) -> Result<BitGrid> {
        self.check_inside(dims)?;
        let mut g = BitGrid::new(dims, limit)?;
        self.for_each_x_row(|v, bits| {
            let i = g.linear_index(v).expect("checked inside");
            g.or_byte(i, bits);
        });
        Ok(g)
    }

    /// The set voxels of a bit grid (full bricks as tiles).
    pub fn from_bit_grid(g: &BitGrid) -> BrickGrid {
        let dims = g.dims();
        BrickGrid::from_x_rows(dims, |v| {
            g.byte_at(v.x as usize + dims[0] * (v.y as usize + dims[1] * v.z as usize))
        })
    }

    /// A dense `u8` grid of `dims` (1 = set, 0 = empty), checked against
    /// `limit` before allocating. Voxels outside `0..dims` are an error.
    pub fn to_dense_u8(&self, dims: Dims, limit: MemoryLimit) -> Result<DenseGrid<u8>> {
        self.check_inside(dims)?;
        let mut g = DenseGrid::new(dims, 0u8, limit)?;
        self.for_each_x_row(|v, mut bits| {
            let i = g.linear_index_unchecked(v);
            if bits == 0xff {
                g.as_mut_slice()[i..i + 8].fill(1);
                return;
            }
            while bits != 0 {
                g[i + bits.trailing_zeros() as usize] = 1;
                bits &= bits - 1;
            }
        });
        Ok(g)
    }

    /// The voxels of a dense grid whose cells satisfy `occupied` (full
    /// bricks as tiles).
    pub fn from_dense<T>(g: &DenseGrid<T>, mut occupied: impl FnMut(&T) -> bool) -> BrickGrid {
        let [nx, ny, _] = g.dims();
        let cells = g.as_slice();
        BrickGrid::from_x_rows(g.dims(), |v| {
            let i = v.x as usize + nx * (v.y as usize + ny * v.z as usize);
            let n = (nx - v.x as usize).min(8);
            (0..n).fold(0u8, |r, x| r | (u8::from(occupied(&cells[i + x])) << x))
        })
    }

    /// Set voxels in storage order (cheaper than [`BrickGrid::iter`]; the
    /// order depends on insertion history).
    pub fn iter_unordered(&self) -> impl Iterator<Item = Voxel> + '_ {
        self.bricks().flat_map(|(k, m)| {
            let base = k * BRICK_EDGE;
            mask_voxels(*m).map(move |l| base + l)
        })
    }
}

/// Local coordinates (each in `0..8`) of the set bits of a brick mask, x
/// fastest, then y, then z.
///
/// ```
/// use voxkit::grid::brick::mask_voxels;
/// let mut m = [0u64; 8];
/// m[2] = 1 << (3 + 8 * 5); // voxel (3, 5, 2)
/// assert_eq!(mask_voxels(m).map(|v| v.to_array()).collect::<Vec<_>>(), vec![[3, 5, 2]]);
/// ```
pub fn mask_voxels(mask: BrickMask) -> impl Iterator<Item = Voxel> {
    (0..8).flat_map(move |z| {
        let mut bits = mask[z];
        std::iter::from_fn(move || {
            if bits == 0 {
                return None;
            }
            let b = bits.trailing_zeros() as i32;
            bits &= bits - 1;
            Some(Voxel::new(b & 7, b >> 3, z as i32))
        })
    })
}

/// Inclusive local bounds of a non-empty mask.
fn mask_bounds(m: &BrickMask) -> (Voxel, Voxel) {
    let zs: Vec<usize> = (0..8).filter(|&z| m[z] != 0).collect();
    let all = m.iter().fold(0u64, |a, w| a | w);
    // Rows (y) present: any bit in byte y; columns (x): OR the 8 bytes.
    let rows: u8 = (0..8).fold(0, |r, y| r | (((all >> (8 * y)) as u8 != 0) as u8) << y);
    let cols: u8 = (0..8).fold(0, |c, y| c | (all >> (8 * y)) as u8);
    (
        Voxel::new(
            cols.trailing_zeros() as i32,
            rows.trailing_zeros() as i32,
            zs[0] as i32,
        ),
        Voxel::new(
            7 - cols.leading_zeros() as i32,
            7 - rows.leading_zeros() as i32,
            zs[zs.len() - 1] as i32,
        ),
    )
}

impl Extend<Voxel> for BrickGrid {
    /// Sets many voxels (the last-brick cache makes runs of nearby voxels cheap).
    fn extend<I: IntoIterator<Item = Voxel>>(&mut self, iter: I) {
        for v in iter {
            self.insert(v);
        }
    }
}

impl FromIterator<Voxel> for BrickGrid {
    fn from_iter<I: IntoIterator<Item = Voxel>>(iter: I) -> Self {
        let mut g = BrickGrid::new();
        g.extend(iter);
        g
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn unique_parts_build_their_index_on_first_lookup_or_change() {
        let b = |x, y, z| Voxel::new(x, y, z);
        let one = [1, 0, 0, 0, 0, 0, 0, 0];
        let keys = vec![b(0, 0, 0), b(-1, 2, 3), b(4, 0, 0)];
        let fresh = || BrickGrid::from_unique_parts(keys.clone(), vec![one; 3]);
        // Lookups.
        let g = fresh();
        assert!(g.slots.get().is_none());
        assert!(g.contains(Voxel::new(-8, 16, 24)) && !g.contains(Voxel::new(1, 0, 0)));
        assert!(g.slots.get().is_some());
        // Changes: an insert into a stored brick must not add a second copy,
        // a removal that empties a brick must keep the others findable.
        let mut g = fresh();
        assert!(g.insert(Voxel::new(1, 0, 0)));
        assert_eq!((g.brick_count(), g.count()), (3, 4));
        let mut g = fresh();
        assert!(g.remove(Voxel::new(0, 0, 0)));
        assert_eq!(g.brick_count(), 2);
        assert!(g.contains(Voxel::new(32, 0, 0)) && g.contains(Voxel::new(-8, 16, 24)));
        // Iteration and counts need no index.
        let g = fresh();
        assert_eq!(g.iter().count(), 3);
        assert!(g.slots.get().is_none());
    }

    #[test]
    fn from_bricks_equals_inserting_and_merges_repeats() {
        let full = [u64::MAX; 8];
        let one = [1, 0, 0, 0, 0, 0, 0, 0];
        let two = [2, 0, 0, 0, 0, 0, 0, 0];
        let b = |x, y, z| Voxel::new(x, y, z);
        let g =
            BrickGrid::from_bricks([(b(0, 0, 0), one), (b(-1, 2, 3), full), (b(5, 5, 5), [0; 8])]);
        assert_eq!((g.brick_count(), g.count()), (2, 513));
        assert!(g.contains(Voxel::new(0, 0, 0)) && g.contains(Voxel::new(-8, 16, 24)));
        let mut want = BrickGrid::new();
        want.or_brick(b(0, 0, 0), &one);
        want.or_brick(b(-1, 2, 3), &full);
        assert_eq!(g, want);
        // A repeated brick is merged, not duplicated.
        let g = BrickGrid::from_bricks([(b(1, 1, 1), one), (b(2, 2, 2), one), (b(1, 1, 1), two)]);
        assert_eq!((g.brick_count(), g.count()), (2, 3));
        assert_eq!(g.brick(b(1, 1, 1)), Some(&[3, 0, 0, 0, 0, 0, 0, 0]));
    }

    /// A grid of random masks, full masks and tiles over a few blocks (so
    /// that the two grids of a union share bricks and blocks).
    fn random_grid(rng: &mut impl rand::Rng) -> BrickGrid {
        let mut g = BrickGrid::new();
        for _ in 0..rng.random_range(0..40) {
            let b = Voxel::new(
                rng.random_range(-4..8),
                rng.random_range(-4..4),
                rng.random_range(0..4),
            );
            match rng.random_range(0..4) {
                0 => g.insert_tile(b),
                1 => g.or_brick(b, &FULL_BRICK),
                _ => g.or_brick(
                    b,
                    &std::array::from_fn(|_| rng.random::<u64>() & rng.random::<u64>()),
                ),
            }
        }
        g
    }

    #[test]
    fn union_is_the_set_union_and_keeps_the_grid_whole() {
        use rand::SeedableRng;
        use std::collections::BTreeSet;
        let key = |v: Voxel| (v.z, v.y, v.x);
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        for _ in 0..300 {
            let (mut a, b) = (random_grid(&mut rng), random_grid(&mut rng));
            // Half the time with the index built before the union.
            if rng.random() {
                a.contains(Voxel::ZERO);
            }
            let want: BTreeSet<_> = a.iter().chain(b.iter()).map(key).collect();
            a.union_with(&b);
            let got: BTreeSet<_> = a.iter().map(key).collect();
            assert_eq!(got, want);
            assert_eq!(a.count(), want.len() as u64);
            // No tile is also stored, and every stored brick is findable.
            for (s, &k) in a.keys.iter().enumerate() {
                assert!(!a.is_tile(k), "a tile also stored");
                assert_eq!(a.index().get(&k), Some(&(s as u32)));
            }
            assert!(a.tiles.values().all(|&w| w != 0));
            // Changes after the union see every brick.
            let v = Voxel::new(rng.random_range(-32..64), rng.random_range(-32..32), 5);
            let was = a.contains(v);
            assert_eq!(a.remove(v), was);
            assert!(!a.contains(v));
        }
    }
}
