//! Transient per-slab brick tables: where parallel surface voxelization
//! writes.
//!
//! The grid is cut into z-slabs of whole bricks, balanced by the expected
//! work of the triangles that reach them; each slab is filled by one task
//! with no synchronisation, since slabs are disjoint. Inside a slab a dense
//! table maps brick coordinates to slots in a brick arena, so setting a voxel
//! is an index computation, a table load and an OR — no hashing. The table
//! costs 4 bytes per 8³ brick of the slab's box (1/128 byte per voxel) and
//! lives only while voxelizing; the arena grows with occupied bricks.

use crate::grid::Voxel;

/// Edge length of a brick in voxels.
pub const BRICK: i32 = 8;
const _: () = assert!(BRICK == 8, "SlabBricks::set uses shifts by 3");

/// One 8³ brick as 8 words: bit `x + 8·y` of word `z` is voxel `(x, y, z)`.
pub type BrickBits = [u64; 8];

/// Occupied bricks as (min-corner voxel, bits), each brick once.
pub type BrickList = Vec<([i32; 3], BrickBits)>;

/// The bricks of one z-slab `[z0, z1)` of a grid with `dims`.
pub struct SlabBricks {
    dims: [i32; 3],
    z0: i32,
    z1: i32,
    /// Bricks per axis in this slab.
    nb: [usize; 3],
    /// Brick slot + 1, or 0 when the brick is empty.
    table: Vec<u32>,
    /// Brick coordinate and bits, in order of first touch.
    bricks: Vec<([i32; 3], BrickBits)>,
    /// Last brick written: (table cell, slot); cell `usize::MAX` = none.
    last: (usize, u32),
}

impl SlabBricks {
    /// An empty slab covering voxel layers `z0..z1` (multiples of [`BRICK`],
    /// except that `z1` may be the grid's end).
    pub fn new(dims: [i32; 3], z0: i32, z1: i32) -> Self {
        Self::with_table(dims, z0, z1, Vec::new())
    }

    /// [`SlabBricks::new`] reusing the table of a finished slab (see
    /// [`SlabBricks::finish`]), which must be all zeros: memory that is
    /// already mapped costs no page faults, where a fresh table of a 1024³
    /// grid's slab (about a megabyte) takes hundreds.
    pub fn with_table(dims: [i32; 3], z0: i32, z1: i32, mut table: Vec<u32>) -> Self {
        let nb = [
            (dims[0] as usize).div_ceil(BRICK as usize),
            (dims[1] as usize).div_ceil(BRICK as usize),
            ((z1 - z0) as usize).div_ceil(BRICK as usize),
        ];
        debug_assert!(
            table.iter().all(|&c| c == 0),
            "a reused table must be clear"
        );
        table.resize(nb[0] * nb[1] * nb[2], 0);
        SlabBricks {
            dims,
            z0,
            z1,
            nb,
            table,
            bricks: Vec::new(),
            last: (usize::MAX, 0),
        }
    }

    /// The occupied bricks (as [`SlabBricks::into_bricks`]) and the table,
    /// cleared for [`SlabBricks::with_table`] (only the cells of occupied
    /// bricks were written, so only those are reset).
    pub fn finish(mut self) -> (Vec<([i32; 3], BrickBits)>, Vec<u32>) {
        for (corner, _) in &self.bricks {
            let b =
                [corner[0] >> 3, corner[1] >> 3, (corner[2] - self.z0) >> 3].map(|c| c as usize);
            let cell = self.cell(b);
            self.table[cell] = 0;
        }
        (self.bricks, self.table)
    }

    /// Bytes this slab holds.
    pub fn heap_bytes(&self) -> usize {
        self.table.len() * 4 + self.bricks.capacity() * std::mem::size_of::<([i32; 3], BrickBits)>()
    }

    /// Sets voxel `v`, first **clamping** each coordinate into `0..dims`;
    /// the clamped voxel is then set if its z lies in this slab (otherwise
    /// it belongs to another slab, which sets it).
    ///
    /// Why clamp rather than drop: with the fitting rule every mesh point
    /// lies in `[-1/2, dims - 1/2]` per axis, so a crossing voxel outside
    /// `0..dims` can only come from a crossing on the grid box's face (grid
    /// coordinate `dims - 1/2` rounds to `dims` by `floor(t + 1/2)`, and a
    /// body-diagonal line can leave by one more). Such a point also lies in
    /// the closed cube of the clamped voxel on the box face, so the clamped
    /// voxel still touches the surface, and a surface lying exactly on the
    /// max face keeps its voxels instead of losing them (see
    /// [`crate::mesh`]'s "closed at its max faces" rule).
    #[inline(always)]
    pub fn set(&mut self, v: Voxel) {
        let x = v.x.clamp(0, self.dims[0] - 1);
        let y = v.y.clamp(0, self.dims[1] - 1);
        let z = v.z.clamp(0, self.dims[2] - 1);
        if z < self.z0 || z >= self.z1 {
            return;
        }
        self.set_inside(Voxel::new(x, y, z));
    }

    /// Whether the voxel box `lo..=hi` lies inside the grid and this slab,
    /// so that [`SlabBricks::set_inside`] may set any voxel of it.
    #[inline]
    pub fn holds(&self, lo: [i32; 3], hi: [i32; 3]) -> bool {
        lo[0] >= 0
            && lo[1] >= 0
            && lo[2] >= self.z0
            && hi[0] < self.dims[0]
            && hi[1] < self.dims[1]
            && hi[2] < self.z1
    }

    /// Whether the voxel box `lo..=hi` lies inside the grid (in z too, but
    /// not necessarily in this slab): what [`SlabBricks::merge`] needs.
    #[inline]
    pub fn holds_in_grid(&self, lo: [i32; 3], hi: [i32; 3]) -> bool {
        (0..3).all(|a| lo[a] >= 0 && hi[a] < self.dims[a])
    }

    /// Sets voxel `v`, which the caller knows lies inside the grid and this
    /// slab (a box accepted by [`SlabBricks::holds`]): [`SlabBricks::set`]
    /// without the clamping and the slab test. A voxel outside still cannot
    /// corrupt memory (indices are checked), but may be set in a wrong brick.
    #[inline(always)]
    pub fn set_inside(&mut self, v: Voxel) {
        debug_assert!(self.holds(v.to_array(), v.to_array()), "{v} outside");
        let (x, y, z) = (v.x as u32, v.y as u32, (v.z - self.z0) as u32);
        // All three are non-negative here: shifts and masks, not signed division.
        let (bx, by, bz) = ((x >> 3) as usize, (y >> 3) as usize, (z >> 3) as usize);
        let cell = self.cell([bx, by, bz]);
        // Consecutive crossings mostly share a brick: the table and the
        // arena's growth are off the hot path.
        if cell != self.last.0 {
            self.switch_brick(cell, [bx, by, bz]);
        }
        let bits = &mut self.bricks[self.last.1 as usize - 1].1;
        bits[(z & 7) as usize] |= 1u64 << ((x & 7) | ((y & 7) << 3));
    }

    /// The table cell of brick coordinates `b` within the slab.
    #[inline(always)]
    fn cell(&self, b: [usize; 3]) -> usize {
        b[0] + self.nb[0] * (b[1] + self.nb[1] * b[2])
    }

    /// Makes `cell` (brick coordinates `b` within the slab) the current
    /// brick, allocating it on first touch.
    #[inline(never)]
    fn switch_brick(&mut self, cell: usize, b: [usize; 3]) {
        // The table index is in range: 0 ≤ x < dims[0] ≤ nb[0]·BRICK, etc.
        let mut slot = self.table[cell];
        if slot == 0 {
            self.bricks.push((
                [
                    b[0] as i32 * BRICK,
                    b[1] as i32 * BRICK,
                    b[2] as i32 * BRICK + self.z0,
                ],
                [0; 8],
            ));
            slot = self.bricks.len() as u32;
            self.table[cell] = slot;
        }
        self.last = (cell, slot);
    }

    /// ORs the non-empty bricks of `staged`, placed at `origin`, that lie in
    /// this slab into it, and clears all of them; the voxel box given to
    /// [`BrickBox::place`] must have been accepted by
    /// [`SlabBricks::holds_in_grid`]. Bricks outside the slab belong to
    /// another slab, which sets them itself (slabs are whole bricks).
    #[inline]
    pub fn merge(&mut self, staged: &mut BrickBox, origin: [i32; 3]) {
        let (lo, hi) = staged.used;
        for bz in lo[2]..=hi[2] {
            let z = origin[2] + BRICK * bz as i32;
            let in_slab = z >= self.z0 && z < self.z1;
            for by in lo[1]..=hi[1] {
                for bx in lo[0]..=hi[0] {
                    let bits = &mut staged.bricks[(bx | by << 2 | bz << 4) & 63];
                    if !in_slab {
                        *bits = [0; 8];
                        continue;
                    }
                    if bits.iter().fold(0, |acc, w| acc | w) == 0 {
                        continue;
                    }
                    let b = [
                        ((origin[0] >> 3) as usize) + bx,
                        ((origin[1] >> 3) as usize) + by,
                        ((z - self.z0) >> 3) as usize,
                    ];
                    let cell = self.cell(b);
                    if cell != self.last.0 {
                        self.switch_brick(cell, b);
                    }
                    let dst = &mut self.bricks[self.last.1 as usize - 1].1;
                    for (d, w) in dst.iter_mut().zip(bits.iter_mut()) {
                        *d |= *w;
                        *w = 0;
                    }
                }
            }
        }
    }

    /// Whether voxel `v` is set.
    pub fn get(&self, v: Voxel) -> bool {
        let inside = v.x >= 0
            && v.y >= 0
            && v.z >= self.z0
            && v.x < self.dims[0]
            && v.y < self.dims[1]
            && v.z < self.z1;
        if !inside {
            return false;
        }
        let (x, y, z) = (v.x, v.y, v.z - self.z0);
        let cell = self.cell([x, y, z].map(|c| (c / BRICK) as usize));
        match self.table[cell] {
            0 => false,
            slot => {
                self.bricks[slot as usize - 1].1[(z % BRICK) as usize]
                    >> ((x % BRICK) + BRICK * (y % BRICK))
                    & 1
                    != 0
            }
        }
    }

    /// The occupied bricks: min-corner voxel and bits.
    pub fn into_bricks(self) -> Vec<([i32; 3], BrickBits)> {
        self.bricks
    }

    /// The occupied bricks, borrowed.
    pub fn bricks(&self) -> &[([i32; 3], BrickBits)] {
        &self.bricks
    }
}

/// Bricks per axis of a [`BrickBox`].
const BOX_BRICKS: i32 = 4;

/// A brick-aligned box of 4×4×4 bricks (32³ voxels) where the crossings of
/// one triangle are staged before [`SlabBricks::merge`] ORs them into the
/// slab.
///
/// Why: a triangle of the bunny at 1024³ has about 52 crossings (17 per
/// axis family) spread over one to four bricks, and its families visit them
/// in turn. Setting
/// them in the slab one by one costs a brick lookup per crossing and a
/// mispredicted brick switch for about a third of them; in the box a
/// crossing is a few shifts and an OR into a 4 KiB array that stays in L1,
/// and the slab sees one lookup per touched brick.
pub struct BrickBox {
    bricks: [BrickBits; 64],
    /// Bricks that may hold bits: min and max brick per axis, box-relative.
    used: ([usize; 3], [usize; 3]),
}

impl Default for BrickBox {
    fn default() -> Self {
        Self::new()
    }
}

impl BrickBox {
    /// An empty box.
    pub fn new() -> Self {
        BrickBox {
            bricks: [[0; 8]; 64],
            used: ([0; 3], [0; 3]),
        }
    }

    /// The box origin (min corner voxel) that holds the voxel box
    /// `lo..=hi`, if it fits; the box, which must be empty (new or just
    /// merged), is then ready for [`BrickBox::set`] with that origin.
    #[inline]
    pub fn place(&mut self, lo: [i32; 3], hi: [i32; 3]) -> Option<[i32; 3]> {
        let origin = lo.map(|c| c & !(BRICK - 1));
        if (0..3).any(|a| hi[a] - origin[a] >= BOX_BRICKS * BRICK) {
            return None;
        }
        self.used = (
            std::array::from_fn(|a| ((lo[a] - origin[a]) >> 3) as usize),
            std::array::from_fn(|a| ((hi[a] - origin[a]) >> 3) as usize),
        );
        Some(origin)
    }

    /// Widens the used part of a box placed at `origin` to also hold the
    /// voxel box `lo..=hi`, if the box covers it; false (and unchanged)
    /// otherwise. The box's staged bits stay: crossings of several
    /// triangles accumulate until the next [`SlabBricks::merge`].
    #[inline]
    pub fn extend(&mut self, origin: [i32; 3], lo: [i32; 3], hi: [i32; 3]) -> bool {
        if (0..3).any(|a| lo[a] < origin[a] || hi[a] - origin[a] >= BOX_BRICKS * BRICK) {
            return false;
        }
        for a in 0..3 {
            self.used.0[a] = self.used.0[a].min(((lo[a] - origin[a]) >> 3) as usize);
            self.used.1[a] = self.used.1[a].max(((hi[a] - origin[a]) >> 3) as usize);
        }
        true
    }

    /// The box's words: word `8·brick + (z & 7)`, brick `bx | by << 2 |
    /// bz << 4` (box-relative brick coordinates), bit `(x & 7) | (y & 7) << 3`.
    #[inline(always)]
    pub fn words_mut(&mut self) -> &mut [u64; 512] {
        let words: &mut [u64] = self.bricks.as_flattened_mut();
        words.try_into().expect("64 bricks of 8 words")
    }

    /// Sets voxel `v` of a box placed at `origin`; `v` must lie in a voxel
    /// box given to [`BrickBox::place`] or [`BrickBox::extend`]. A voxel outside cannot
    /// corrupt memory (the index is masked) but lands in a wrong place.
    #[inline(always)]
    pub fn set(&mut self, origin: [i32; 3], v: Voxel) {
        let x = (v.x - origin[0]) as u32;
        let y = (v.y - origin[1]) as u32;
        let z = (v.z - origin[2]) as u32;
        debug_assert!(
            x < 32 && y < 32 && z < 32,
            "{v} outside the box at {origin:?}"
        );
        let brick = ((x >> 3) | (y >> 3) << 2 | (z >> 3) << 4) as usize & 63;
        self.bricks[brick][(z & 7) as usize] |= 1u64 << ((x & 7) | (y & 7) << 3);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_clamps_into_the_grid_and_respects_the_slab() {
        let dims = [10, 9, 20];
        let mut s = SlabBricks::new(dims, 8, 20);
        // Beyond the max faces (and below 0 in x, y): clamped to the border.
        s.set(Voxel::new(10, 9, 20));
        s.set(Voxel::new(-1, 4, 21));
        // z below the grid clamps to 0, which is another slab's: ignored here.
        s.set(Voxel::new(3, 3, -1));
        assert!(s.get(Voxel::new(9, 8, 19)));
        assert!(s.get(Voxel::new(0, 4, 19)));
        let n: u32 = s
            .bricks()
            .iter()
            .map(|(_, b)| b.iter().map(|w| w.count_ones()).sum::<u32>())
            .sum();
        assert_eq!(n, 2);
        let mut first = SlabBricks::new(dims, 0, 8);
        first.set(Voxel::new(3, 3, -1));
        assert!(first.get(Voxel::new(3, 3, 0)));
    }
}
