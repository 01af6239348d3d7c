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
//! Cost: about 64 bytes per brick plus ~20 bytes of map entry and key; a brick
//! holds up to 512 voxels.

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

/// A sparse set of voxels in 8³ bricks. Any `i32` voxel coordinates are
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
/// ```
#[derive(Clone, Default)]
pub struct BrickGrid {
    /// Brick coordinate → slot, built on first use: a grid assembled from
    /// unique bricks and then only iterated or written out (the surface
    /// voxelizer's result) never pays for it.
    slots: OnceLock<HashMap<Voxel, u32, FxBuild>>,
    keys: Vec<Voxel>,
    masks: Vec<BrickMask>,
    /// Last brick touched by a write: (brick coordinate, slot).
    last: Option<(Voxel, u32)>,
}

impl std::fmt::Debug for BrickGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BrickGrid")
            .field("bricks", &self.brick_count())
            .field("voxels", &self.count())
            .field("bounds", &self.bounds())
            .finish()
    }
}

impl PartialEq for BrickGrid {
    /// Same set of voxels (storage order does not matter).
    fn eq(&self, other: &Self) -> bool {
        self.keys.len() == other.keys.len()
            && self
                .keys
                .iter()
                .zip(&self.masks)
                .all(|(k, m)| other.brick(*k) == Some(m))
    }
}

impl Eq for BrickGrid {}

impl BrickGrid {
    /// An empty grid.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty grid with room for `bricks` bricks.
    pub fn with_capacity(bricks: usize) -> Self {
        BrickGrid {
            slots: OnceLock::from(HashMap::with_capacity_and_hasher(
                bricks,
                FxBuild::default(),
            )),
            keys: Vec::with_capacity(bricks),
            masks: Vec::with_capacity(bricks),
            last: None,
        }
    }

    /// Slot of brick `b`, creating an empty brick if needed.
    #[inline]
    fn slot_or_insert(&mut self, b: Voxel) -> usize {
        if let Some((lb, s)) = self.last
            && lb == b
        {
            return s as usize;
        }
        let next = self.keys.len() as u32;
        let s = *self.index_mut().entry(b).or_insert(next);
        if s == next {
            self.keys.push(b);
            self.masks.push([0; 8]);
        }
        self.last = Some((b, s));
        s as usize
    }

    /// Sets voxel `v`; returns true if it was not set before.
    #[inline]
    pub fn insert(&mut self, v: Voxel) -> bool {
        let s = self.slot_or_insert(brick_of(v));
        let (w, m) = local_bit(v);
        let word = &mut self.masks[s][w];
        let was = *word & m != 0;
        *word |= m;
        !was
    }

    /// Clears voxel `v`; returns true if it was set. A brick that becomes
    /// empty is released.
    pub fn remove(&mut self, v: Voxel) -> bool {
        let b = brick_of(v);
        let Some(&s) = self.index().get(&b) else {
            return false;
        };
        let s = s as usize;
        let (w, m) = local_bit(v);
        let was = self.masks[s][w] & m != 0;
        self.masks[s][w] &= !m;
        if self.masks[s] == [0; 8] {
            self.index_mut().remove(&b);
            self.keys.swap_remove(s);
            self.masks.swap_remove(s);
            if s < self.keys.len() {
                let moved = self.keys[s];
                self.index_mut().insert(moved, s as u32);
            }
            self.last = None;
        }
        was
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

    /// The mask of brick `b` (brick coordinates), if it is stored.
    #[inline]
    pub fn brick(&self, b: Voxel) -> Option<&BrickMask> {
        self.index().get(&b).map(|&s| &self.masks[s as usize])
    }

    /// ORs a whole mask into brick `b` (brick coordinates). An all-zero mask
    /// stores nothing.
    pub fn or_brick(&mut self, b: Voxel, mask: &BrickMask) {
        if *mask == [0; 8] {
            return;
        }
        let s = self.slot_or_insert(b);
        for (d, m) in self.masks[s].iter_mut().zip(mask) {
            *d |= m;
        }
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
    /// the index is built only if a lookup or change needs it.
    pub(crate) fn from_unique_parts(keys: Vec<Voxel>, masks: Vec<BrickMask>) -> Self {
        assert_eq!(keys.len(), masks.len(), "one mask per brick coordinate");
        debug_assert!(!masks.contains(&[0; 8]), "an empty brick mask");
        debug_assert_eq!(index_of(&keys).len(), keys.len(), "a repeated brick");
        BrickGrid {
            slots: OnceLock::new(),
            keys,
            masks,
            last: None,
        }
    }

    /// A grid from bricks given as (brick coordinate, mask), each brick at
    /// most once (a repeated brick is merged, just more slowly); empty masks
    /// are dropped. Cheaper than [`BrickGrid::or_brick`] one at a time: the
    /// brick arrays are taken over and the index is built in one pass.
    pub fn from_bricks(bricks: impl IntoIterator<Item = (Voxel, BrickMask)>) -> Self {
        let (keys, masks): (Vec<Voxel>, Vec<BrickMask>) = bricks.into_iter().unzip();
        Self::from_parts(keys, masks)
    }

    /// [`BrickGrid::from_bricks`] from parallel arrays of brick coordinates
    /// and masks (taken over, not copied, when no mask is empty).
    ///
    /// ```
    /// use voxkit::grid::{BrickGrid, Voxel};
    /// let g = BrickGrid::from_parts(vec![Voxel::new(0, 0, 1)], vec![[1, 0, 0, 0, 0, 0, 0, 0]]);
    /// assert!(g.contains(Voxel::new(0, 0, 8)));
    /// assert_eq!(g.count(), 1);
    /// ```
    pub fn from_parts(mut keys: Vec<Voxel>, mut masks: Vec<BrickMask>) -> Self {
        assert_eq!(keys.len(), masks.len(), "one mask per brick coordinate");
        if masks.contains(&[0; 8]) {
            let mut k = 0;
            for s in 0..keys.len() {
                if masks[s] != [0; 8] {
                    keys[k] = keys[s];
                    masks[k] = masks[s];
                    k += 1;
                }
            }
            keys.truncate(k);
            masks.truncate(k);
        }
        let mut slots = HashMap::with_capacity_and_hasher(keys.len(), FxBuild::default());
        let mut g = BrickGrid::new();
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

    /// Number of set voxels.
    pub fn count(&self) -> u64 {
        self.masks
            .iter()
            .flat_map(|m| m.iter())
            .map(|w| w.count_ones() as u64)
            .sum()
    }

    /// Whether no voxel is set.
    pub fn is_empty(&self) -> bool {
        // Bricks are released when they empty, except through `or_brick` of
        // zero (which stores nothing), so a stored brick is never empty.
        self.keys.is_empty()
    }

    /// Number of stored bricks.
    pub fn brick_count(&self) -> usize {
        self.keys.len()
    }

    /// Approximate heap bytes in use (masks, keys, and the map's table at
    /// its current capacity).
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.masks.capacity() * size_of::<BrickMask>()
            + self.keys.capacity() * size_of::<Voxel>()
            // hashbrown: key + value + 1 control byte per bucket.
            + self.slots.get().map_or(0, HashMap::capacity) * (size_of::<Voxel>() + size_of::<u32>() + 1)
    }

    /// Stored bricks as (brick coordinate, mask), in storage order (not
    /// sorted; see [`BrickGrid::sorted_bricks`]).
    pub fn bricks(&self) -> impl Iterator<Item = (Voxel, &BrickMask)> + '_ {
        self.keys.iter().copied().zip(&self.masks)
    }

    /// Slot numbers of the bricks sorted by brick coordinate in (z, y, x)
    /// order.
    fn sorted_slots(&self) -> Vec<u32> {
        let mut order: Vec<u32> = (0..self.keys.len() as u32).collect();
        order.sort_unstable_by_key(|&s| {
            let k = self.keys[s as usize];
            (k.z, k.y, k.x)
        });
        order
    }

    /// Stored bricks sorted by brick coordinate in (z, y, x) order.
    pub fn sorted_bricks(&self) -> Vec<(Voxel, BrickMask)> {
        self.sorted_slots()
            .into_iter()
            .map(|s| (self.keys[s as usize], self.masks[s as usize]))
            .collect()
    }

    /// Iterates over the set voxels in a deterministic order: bricks sorted
    /// by (z, y, x) brick coordinate; inside a brick, x fastest, then y, then z.
    pub fn iter(&self) -> impl Iterator<Item = Voxel> + '_ {
        self.sorted_slots().into_iter().flat_map(move |s| {
            let base = self.keys[s as usize] * BRICK_EDGE;
            let mask = self.masks[s as usize];
            mask_voxels(mask).map(move |l| base + l)
        })
    }

    /// Adds every voxel of `other` (set union), brick by brick.
    pub fn union_with(&mut self, other: &BrickGrid) {
        self.index_mut().reserve(other.keys.len());
        for (k, m) in other.bricks() {
            self.or_brick(k, m);
        }
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
        for (k, m) in self.bricks() {
            if *m == [0; 8] {
                continue;
            }
            let base = k * BRICK_EDGE;
            let (mlo, mhi) = mask_bounds(m);
            lo = lo.min(base + mlo);
            hi = hi.max(base + mhi);
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

    /// A dense bit grid of `dims` holding these voxels; checked against
    /// `limit` before allocating. Voxels outside `0..dims` are an error.
    pub fn to_bit_grid(&self, dims: Dims, limit: MemoryLimit) -> Result<BitGrid> {
        self.check_inside(dims)?;
        let mut g = BitGrid::new(dims, limit)?;
        for v in self.iter_unordered() {
            g.set(v, true);
        }
        Ok(g)
    }

    /// The set voxels of a bit grid.
    pub fn from_bit_grid(g: &BitGrid) -> BrickGrid {
        let mut b = BrickGrid::new();
        b.extend(g.iter_ones());
        b
    }

    /// A dense `u8` grid of `dims` (1 = set, 0 = empty), checked against
    /// `limit` before allocating. Voxels outside `0..dims` are an error.
    pub fn to_dense_u8(&self, dims: Dims, limit: MemoryLimit) -> Result<DenseGrid<u8>> {
        self.check_inside(dims)?;
        let mut g = DenseGrid::new(dims, 0u8, limit)?;
        for v in self.iter_unordered() {
            let i = g.linear_index_unchecked(v);
            g[i] = 1;
        }
        Ok(g)
    }

    /// The voxels of a dense grid whose cells satisfy `occupied`.
    pub fn from_dense<T>(g: &DenseGrid<T>, mut occupied: impl FnMut(&T) -> bool) -> BrickGrid {
        let mut b = BrickGrid::new();
        for (i, c) in g.as_slice().iter().enumerate() {
            if occupied(c) {
                b.insert(g.voxel_of_index(i));
            }
        }
        b
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
}
