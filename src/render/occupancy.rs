//! The ray caster's view of a sparse voxel grid: occupancy and proximity
//! flags in 8³ bricks, and a brick-level proximity cloud for skipping.
//!
//! Storage grows with the occupied surface, not with the bounding box:
//! - a dense table of one `u32` slot per 8³ brick (a 2048³ grid has 256³
//!   bricks: 64 MiB), slot 0 being the shared all-empty brick;
//! - per stored brick 128 bytes: the occupancy bitmask and the proximity
//!   bitmask (occupancy dilated by one voxel, Chebyshev: the adaptive ray's
//!   flags, Cohen-Or & Kaufman's "vicinity of an object"), both in the
//!   [`BrickGrid`] layout (word `lz`, bit `lx + 8 ly`). Bricks are stored
//!   where either mask is non-empty: the occupied bricks and the neighbours
//!   the dilation spills into. Every full brick (a tile of the grid, or a
//!   full mask) shares one slot whose masks are all ones, so a solid's
//!   interior costs the slot table's 4 bytes per brick and nothing more,
//!   and the walk reads it like any other brick;
//! - a proximity cloud (Cohen & Sheffer 1994) at brick granularity: per brick
//!   the Chebyshev distance, in bricks, to the nearest brick holding an
//!   occupied voxel (0 for those; saturated at 255), one byte per brick. A
//!   ray in a brick at distance `k ≥ 1` can jump the whole box of bricks
//!   within `k − 1` of it: nothing there is occupied, and shrunk by one voxel
//!   nothing is flagged either.

use glam::IVec3;

use crate::error::Result;
use crate::grid::brick::{BrickMask, FULL_BRICK};
use crate::grid::{BrickGrid, MemoryLimit, Voxel};

/// Largest grid side the ray caster takes: every in-grid segment is then
/// shorter than 2^15 voxels, where its O(1) jumps are exact in `i64`.
pub const MAX_RENDER_DIM: usize = 16384;

/// `x` bits of column `lx = 0` / `lx = 7` in a brick word (bit `lx + 8 ly`).
const X0: u64 = 0x0101_0101_0101_0101;
const X7: u64 = 0x8080_8080_8080_8080;

/// Slot of the shared full brick (occupancy and proximity all set): every
/// tile and every full mask of the grid.
pub(crate) const FULL_SLOT: u32 = 1;

/// Palette indices per stored brick (`lx + 8 ly + 64 lz`) and the palette.
pub(crate) type BrickColors = (Vec<[u8; 512]>, Box<[[u8; 4]; 256]>);

/// One brick's flags for the ray caster, in the [`BrickGrid`] mask layout
/// (word `lz`, bit `lx + 8 ly`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BrickFlags {
    /// Occupied voxels.
    pub occ: BrickMask,
    /// Proximity flags: the occupancy dilated by one voxel (Chebyshev).
    pub prox: BrickMask,
}

/// What the ray caster reads of a voxel grid: per brick, its proximity
/// cloud value and its flags, located once per brick; per hit voxel, the
/// shading inputs. [`OccupancyGrid`] holds all of it in memory;
/// [`PagedOccupancy`](super::PagedOccupancy) reads a store's chunks as rays
/// reach them. One walk ([`render_grid_window`](super::render_grid_window))
/// serves both, monomorphized.
pub trait RenderBricks: Sync {
    /// Where a brick's entries are, found once per brick visit.
    type At<'a>: Copy
    where
        Self: 'a;
    /// Grid extents in voxels.
    fn grid_dims(&self) -> [i32; 3];
    /// Inclusive bounds of the occupied voxels (`None`: nothing occupied).
    fn occupied_bounds(&self) -> Option<(Voxel, Voxel)>;
    /// Locates brick `b` (inside the grid).
    fn locate(&self, b: IVec3) -> Self::At<'_>;
    /// The proximity cloud at a located brick: a lower bound on the
    /// Chebyshev distance, in bricks, to the nearest brick holding an
    /// occupied voxel (0 for those; a smaller value only skips less).
    fn cloud<'a>(&'a self, at: Self::At<'a>) -> u8;
    /// The flags of a located brick (exact: they decide pixels).
    fn flags<'a>(&'a self, at: Self::At<'a>) -> &'a BrickFlags;
    /// Whether the renders so far read the grid as it is: a structure that
    /// builds its bricks while rendering reports here what went wrong
    /// (and every image rendered since is void).
    fn health(&self) -> Result<()> {
        Ok(())
    }
    /// RGBA of occupied voxel `v`, or `None` without colours.
    fn voxel_color(&self, _v: Voxel) -> Option<[u8; 4]> {
        None
    }
    /// The occupancy mask of brick `b` (any coordinates: empty outside the
    /// grid).
    fn occupancy_mask(&self, b: IVec3) -> BrickMask {
        let d = self.grid_dims();
        let inside = (0..3).all(|k| b[k] >= 0 && b[k] < (d[k] + 7) >> 3);
        if inside {
            self.flags(self.locate(b)).occ
        } else {
            [0; 8]
        }
    }
    /// The proximity cloud of every brick (x fastest), where the structure
    /// holds it; `None` where bricks are read only as rays reach them (a
    /// frame then casts every ray).
    fn resident_clouds(&self) -> Option<&[u8]> {
        None
    }
    /// Whether `v` lies in the grid.
    #[inline(always)]
    fn contains_voxel(&self, v: Voxel) -> bool {
        let d = self.grid_dims();
        (0..3).all(|k| v[k] >= 0 && v[k] < d[k])
    }
}

impl RenderBricks for OccupancyGrid {
    type At<'a> = usize;
    #[inline(always)]
    fn grid_dims(&self) -> [i32; 3] {
        self.dims
    }
    fn occupied_bounds(&self) -> Option<(Voxel, Voxel)> {
        self.bounds
    }
    #[inline(always)]
    fn locate(&self, b: IVec3) -> usize {
        self.brick_index(b)
    }
    #[inline(always)]
    fn cloud(&self, at: usize) -> u8 {
        self.dist[at]
    }
    #[inline(always)]
    fn flags(&self, at: usize) -> &BrickFlags {
        &self.bricks[self.slot[at] as usize]
    }
    fn voxel_color(&self, v: Voxel) -> Option<[u8; 4]> {
        self.color(v)
    }
    fn resident_clouds(&self) -> Option<&[u8]> {
        Some(&self.dist)
    }
}

/// Occupancy, proximity flags, colours and the brick proximity cloud of a
/// voxel grid, for rendering (the layout is described in `render/occupancy.rs`).
#[derive(Clone, Debug)]
pub struct OccupancyGrid {
    pub(crate) dims: [i32; 3],
    /// Bricks per axis (`ceil(dims / 8)`).
    pub(crate) bdims: [i32; 3],
    pub(crate) slot: Vec<u32>,
    /// Slot 0: the shared empty brick; slot [`FULL_SLOT`]: the shared full
    /// brick; then one per brick with its own flags.
    pub(crate) bricks: Vec<BrickFlags>,
    /// Bricks in the shared full slot.
    full_bricks: usize,
    /// Per brick: Chebyshev distance in bricks to the nearest occupied one.
    pub(crate) dist: Vec<u8>,
    /// Per stored brick, per voxel (`lx + 8 ly + 64 lz`): palette index.
    pub(crate) colors: Option<BrickColors>,
    /// Occupied voxels.
    pub(crate) voxels: u64,
    /// Inclusive bounds of the occupied voxels (empty grid: `None`).
    pub(crate) bounds: Option<(Voxel, Voxel)>,
}

impl OccupancyGrid {
    /// Builds the render structure of `grid` (every voxel inside `dims`).
    /// `limit` caps the dense brick tables (checked before allocating).
    ///
    /// ```
    /// use glam::IVec3;
    /// use voxkit::grid::{BrickGrid, MemoryLimit};
    /// use voxkit::render::OccupancyGrid;
    /// let g: BrickGrid = [IVec3::new(3, 4, 5)].into_iter().collect();
    /// let occ = OccupancyGrid::new(&g, [40, 40, 40], MemoryLimit::DEFAULT).unwrap();
    /// assert!(occ.is_occupied(IVec3::new(3, 4, 5)));
    /// assert!(occ.is_flagged(IVec3::new(4, 5, 6)));   // a diagonal neighbour
    /// assert!(!occ.is_flagged(IVec3::new(5, 4, 5))); // two voxels away
    /// assert_eq!(occ.brick_distance(IVec3::new(35, 0, 0)), 4);
    /// ```
    pub fn new(grid: &BrickGrid, dims: [usize; 3], limit: MemoryLimit) -> Result<Self> {
        if dims.iter().any(|&d| d == 0 || d > MAX_RENDER_DIM) {
            return Err(crate::error::VoxkitError::Unsupported(format!(
                "render: grid {dims:?}: each side must be in 1..={MAX_RENDER_DIM} voxels"
            )));
        }
        grid.check_inside(dims)?;
        let bdims = dims.map(|d| d.div_ceil(8) as i32);
        let cells: u128 = bdims.iter().map(|&b| b as u128).product();
        // Slot and cloud per brick, and the cloud's padded working copy.
        limit.check("render brick tables", cells, 6)?;
        let n = cells as usize;
        let bindex = |b: IVec3| (b.x + bdims[0] * (b.y + bdims[1] * b.z)) as usize;
        let inside = |b: IVec3| (0..3).all(|k| b[k] >= 0 && b[k] < bdims[k]);

        // Occupancy masks in a dense slot table first. Full bricks (tiles
        // and full masks) share one slot: their flags are full too, since
        // the dilation of a full brick covers it.
        let mut slot = vec![0u32; n];
        let mut bricks = vec![
            BrickFlags::default(),
            BrickFlags {
                occ: FULL_BRICK,
                prox: FULL_BRICK,
            },
        ];
        let mut full_bricks = 0;
        for (b, m) in grid.bricks() {
            if *m == FULL_BRICK {
                slot[bindex(b)] = FULL_SLOT;
                full_bricks += 1;
                continue;
            }
            if m.iter().all(|&w| w == 0) {
                continue;
            }
            slot[bindex(b)] = bricks.len() as u32;
            bricks.push(BrickFlags {
                occ: *m,
                prox: [0; 8],
            });
        }
        let own_bricks = bricks.len() - 2;
        limit.check(
            "render bricks",
            (own_bricks as u128) * 27 + cells,
            std::mem::size_of::<BrickFlags>() as u128,
        )?;
        // Targets of the dilation: the occupied bricks and their neighbours,
        // except full ones (already flagged everywhere), so the interior of
        // a solid adds no work and no storage.
        let mut targets: Vec<IVec3> = Vec::with_capacity(own_bricks * 4);
        let mut seen = vec![false; n];
        for (b, _) in grid.bricks() {
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let t = b + IVec3::new(dx, dy, dz);
                        if inside(t)
                            && slot[bindex(t)] != FULL_SLOT
                            && !std::mem::replace(&mut seen[bindex(t)], true)
                        {
                            targets.push(t);
                        }
                    }
                }
            }
        }
        drop(seen);
        let occ_at = |b: IVec3| -> BrickMask {
            if inside(b) {
                bricks[slot[bindex(b)] as usize].occ
            } else {
                [0; 8]
            }
        };
        let prox: Vec<(IVec3, BrickMask)> = targets
            .iter()
            .map(|&t| (t, dilate(t, &occ_at)))
            .filter(|(_, p)| p.iter().any(|&w| w != 0))
            .collect();
        for (t, p) in prox {
            let i = bindex(t);
            if slot[i] == 0 {
                slot[i] = bricks.len() as u32;
                bricks.push(BrickFlags {
                    occ: [0; 8],
                    prox: p,
                });
            } else {
                bricks[slot[i] as usize].prox = p;
            }
        }
        let dist = chessboard_distance(bdims, |i| {
            let s = slot[i] as usize;
            s != 0 && bricks[s].occ.iter().any(|&w| w != 0)
        });
        Ok(OccupancyGrid {
            dims: dims.map(|d| d as i32),
            bdims,
            slot,
            bricks,
            full_bricks,
            dist,
            colors: None,
            voxels: grid.count(),
            bounds: grid.bounds(),
        })
    }

    /// Attaches colours: a palette index per occupied voxel and the RGBA
    /// palette (MagicaVoxel files). Voxels without an entry get index 0.
    ///
    /// Colours are per slot, so full bricks keep sharing theirs only where
    /// every voxel has one and the same colour (as in the files voxkit
    /// writes); any other full brick gets a slot of its own.
    pub fn set_colors(&mut self, voxels: &[(Voxel, u8)], palette: [[u8; 4]; 256]) {
        let in_full = |o: &Self, v: Voxel| o.in_grid(v) && o.slot_of(v) == FULL_SLOT;
        let shared = voxels
            .iter()
            .find(|&&(v, _)| in_full(self, v))
            .map_or(0, |&(_, c)| c);
        // Which voxels of each shared brick have the shared colour (only
        // needed when that colour is not the 0 of voxels without one).
        let mut covered: std::collections::HashMap<usize, BrickMask> = Default::default();
        let unshare = |o: &mut Self, i: usize| {
            o.slot[i] = o.bricks.len() as u32;
            o.bricks.push(o.bricks[FULL_SLOT as usize]);
            o.full_bricks -= 1;
        };
        for &(v, c) in voxels {
            if in_full(self, v) {
                let i = self.brick_index(v >> 3);
                if c != shared {
                    unshare(self, i);
                } else if shared != 0 {
                    let (w, bit) = word_bit(v);
                    covered.entry(i).or_default()[w] |= 1 << bit;
                }
            }
        }
        if shared != 0 {
            for i in 0..self.slot.len() {
                if self.slot[i] == FULL_SLOT && covered.get(&i) != Some(&FULL_BRICK) {
                    unshare(self, i);
                }
            }
        }
        let mut per_brick = vec![[0u8; 512]; self.bricks.len()];
        per_brick[FULL_SLOT as usize] = [shared; 512];
        for &(v, c) in voxels {
            if !self.in_grid(v) {
                continue;
            }
            let s = self.slot_of(v) as usize;
            if s != 0 && s != FULL_SLOT as usize {
                per_brick[s][local_index(v)] = c;
            }
        }
        self.colors = Some((per_brick, Box::new(palette)));
    }

    /// Grid extents in voxels.
    pub fn dims(&self) -> [usize; 3] {
        self.dims.map(|d| d as usize)
    }

    /// Occupied voxels.
    pub fn voxel_count(&self) -> u64 {
        self.voxels
    }

    /// Inclusive bounds of the occupied voxels.
    pub fn bounds(&self) -> Option<(Voxel, Voxel)> {
        self.bounds
    }

    /// Bytes held by the render structures (slot table, stored bricks,
    /// proximity cloud, colours).
    pub fn heap_bytes(&self) -> usize {
        self.slot.capacity() * 4
            + self.bricks.capacity() * std::mem::size_of::<BrickFlags>()
            + self.dist.capacity()
            + self
                .colors
                .as_ref()
                .map_or(0, |(c, _)| c.capacity() * 512 + 1024)
    }

    /// Bricks with flags of their own (occupied or flagged, not full): 128
    /// bytes each. Full bricks share one slot ([`OccupancyGrid::full_bricks`]).
    pub fn stored_bricks(&self) -> usize {
        self.bricks.len() - 2
    }

    /// Full bricks (the grid's tiles and full masks), all sharing one slot.
    pub fn full_bricks(&self) -> usize {
        self.full_bricks
    }

    #[inline(always)]
    pub(crate) fn in_grid(&self, v: Voxel) -> bool {
        (0..3).all(|k| v[k] >= 0 && v[k] < self.dims[k])
    }

    #[inline(always)]
    pub(crate) fn brick_index(&self, b: IVec3) -> usize {
        (b.x + self.bdims[0] * (b.y + self.bdims[1] * b.z)) as usize
    }

    #[inline(always)]
    fn slot_of(&self, v: Voxel) -> u32 {
        self.slot[self.brick_index(v >> 3)]
    }

    /// Whether voxel `v` (any coordinates) is occupied.
    pub fn is_occupied(&self, v: Voxel) -> bool {
        self.in_grid(v) && {
            let (w, bit) = word_bit(v);
            self.bricks[self.slot_of(v) as usize].occ[w] >> bit & 1 == 1
        }
    }

    /// Whether voxel `v` carries a proximity flag (within Chebyshev
    /// distance 1 of an occupied voxel).
    pub fn is_flagged(&self, v: Voxel) -> bool {
        self.in_grid(v) && {
            let (w, bit) = word_bit(v);
            self.bricks[self.slot_of(v) as usize].prox[w] >> bit & 1 == 1
        }
    }

    /// The smooth normal at occupied voxel `v` (a plane fitted to the
    /// surface voxels within 3 of it, `render::normal`), unit length and
    /// facing `toward` (grid space).
    pub fn smooth_normal(&self, v: Voxel, toward: glam::DVec3) -> glam::DVec3 {
        super::normal::Moments::around(v, |b| self.occupancy_mask(b)).normal(toward)
    }

    /// The proximity cloud's value at the brick of voxel `v`.
    pub fn brick_distance(&self, v: Voxel) -> u8 {
        self.dist[self.brick_index(v >> 3)]
    }

    /// RGBA of occupied voxel `v`: its palette colour, or `None` without
    /// colours.
    pub fn color(&self, v: Voxel) -> Option<[u8; 4]> {
        let (per_brick, palette) = self.colors.as_ref()?;
        let s = self.slot_of(v) as usize;
        Some(palette[per_brick[s][local_index(v)] as usize])
    }
}

/// Word and bit of voxel `v` in its brick's masks.
#[inline(always)]
pub(crate) fn word_bit(v: Voxel) -> (usize, u32) {
    ((v.z & 7) as usize, ((v.x & 7) + 8 * (v.y & 7)) as u32)
}

/// The in-brick index `lx + 8 ly + 64 lz` of voxel `v`: the bricks' bit
/// order and the volume bricks' sample order.
#[inline(always)]
pub(crate) fn local_index(v: Voxel) -> usize {
    ((v.x & 7) + 8 * (v.y & 7) + 64 * (v.z & 7)) as usize
}

/// The occupancy of the 3×3×3 bricks around `t`, dilated by one voxel
/// (Chebyshev) and restricted to `t`: separable, x then y then z, each pass
/// pulling the facing column, row or layer of the neighbour bricks.
pub(crate) fn dilate(t: IVec3, occ_at: &impl Fn(IVec3) -> BrickMask) -> BrickMask {
    let dx = |b: IVec3| -> BrickMask {
        let (l, m, r) = (occ_at(b - IVec3::X), occ_at(b), occ_at(b + IVec3::X));
        std::array::from_fn(|z| {
            let w = m[z];
            w | ((w << 1) & !X0) | ((w >> 1) & !X7) | ((l[z] & X7) >> 7) | ((r[z] & X0) << 7)
        })
    };
    let dy = |b: IVec3| -> BrickMask {
        let (lo, m, hi) = (dx(b - IVec3::Y), dx(b), dx(b + IVec3::Y));
        std::array::from_fn(|z| {
            let w = m[z];
            w | (w << 8) | (w >> 8) | (lo[z] >> 56) | (hi[z] << 56)
        })
    };
    let (below, m, above) = (dy(t - IVec3::Z), dy(t), dy(t + IVec3::Z));
    std::array::from_fn(|z| {
        let prev = if z == 0 { below[7] } else { m[z - 1] };
        let next = if z == 7 { above[0] } else { m[z + 1] };
        m[z] | prev | next
    })
}

/// Exact Chebyshev (chessboard) distance, in cells, from every cell of a
/// `dims` grid to the nearest cell where `seed(index)` holds, saturated at
/// 255: the two-pass raster chamfer with the 26-neighbourhood and unit
/// weights, which is exact for the chessboard metric (every shortest
/// chessboard path is monotone, so the forward pass sees its first half and
/// the backward pass the rest; Rosenfeld & Pfaltz 1966).
pub(crate) fn chessboard_distance(dims: [i32; 3], seed: impl Fn(usize) -> bool) -> Vec<u8> {
    let [nx, ny, nz] = dims.map(|d| d as usize);
    // Computed in a copy padded by one cell of 255 on every side, so no
    // neighbour needs a bounds test; the passes read fixed offsets.
    let (px, py) = (nx + 2, ny + 2);
    let mut p = vec![255u8; px * py * (nz + 2)];
    let at = |x: usize, y: usize, z: usize| x + 1 + px * (y + 1 + py * (z + 1));
    let mut i = 0;
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if seed(i) {
                    p[at(x, y, z)] = 0;
                }
                i += 1;
            }
        }
    }
    // The 13 neighbours that precede a cell in raster order (z, y, x), as
    // offsets in the padded copy.
    let mut before = Vec::new();
    for dz in -1..=1isize {
        for dy in -1..=1isize {
            for dx in -1..=1isize {
                if (dz, dy, dx) < (0, 0, 0) {
                    before.push(dx + px as isize * (dy + py as isize * dz));
                }
            }
        }
    }
    let relax = |p: &mut Vec<u8>, c: usize, offsets: &[isize]| {
        let mut best = p[c];
        if best != 0 {
            for &o in offsets {
                best = best.min(p[c.wrapping_add_signed(o)].saturating_add(1));
            }
            p[c] = best;
        }
    };
    for z in 0..nz {
        for y in 0..ny {
            let row = at(0, y, z);
            for c in row..row + nx {
                relax(&mut p, c, &before);
            }
        }
    }
    let after: Vec<isize> = before.iter().map(|o| -o).collect();
    for z in (0..nz).rev() {
        for y in (0..ny).rev() {
            let row = at(0, y, z);
            for c in (row..row + nx).rev() {
                relax(&mut p, c, &after);
            }
        }
    }
    let mut d = Vec::with_capacity(nx * ny * nz);
    for z in 0..nz {
        for y in 0..ny {
            let row = at(0, y, z);
            d.extend_from_slice(&p[row..row + nx]);
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Proximity flags equal a brute-force one-voxel dilation, brick
    /// borders included; the proximity cloud equals brute-force Chebyshev
    /// distances between bricks.
    #[test]
    fn flags_and_cloud_match_brute_force() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for dims in [[1, 1, 1], [9, 17, 8], [30, 21, 25]] {
            let mut g = BrickGrid::new();
            let mut set = Vec::new();
            for _ in 0..(dims.iter().product::<usize>() / 300).max(1) {
                let v = IVec3::new(
                    rng.random_range(0..dims[0] as i32),
                    rng.random_range(0..dims[1] as i32),
                    rng.random_range(0..dims[2] as i32),
                );
                g.insert(v);
                set.push(v);
            }
            let occ = OccupancyGrid::new(&g, dims, MemoryLimit::DEFAULT).unwrap();
            for z in -1..dims[2] as i32 + 1 {
                for y in -1..dims[1] as i32 + 1 {
                    for x in -1..dims[0] as i32 + 1 {
                        let v = IVec3::new(x, y, z);
                        let near = set.iter().any(|s| (*s - v).abs().max_element() <= 1);
                        let inside = occ.in_grid(v);
                        assert_eq!(occ.is_flagged(v), near && inside, "{v} in {dims:?}");
                        assert_eq!(occ.is_occupied(v), set.contains(&v) && inside);
                        if inside {
                            let b: IVec3 = v >> 3i32;
                            let want = set
                                .iter()
                                .map(|s: &IVec3| ((*s >> 3i32) - b).abs().max_element())
                                .min()
                                .unwrap()
                                .min(255) as u8;
                            assert_eq!(occ.brick_distance(v), want, "{v}");
                        }
                    }
                }
            }
        }
    }

    /// With tiles (sharing the full slot) beside empty, partial and other
    /// full bricks: occupancy, flags and the cloud still equal brute force
    /// over the grid's voxels, and only the non-full bricks take slots.
    #[test]
    fn tiles_share_the_full_slot_and_flags_match_brute_force() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let dims = [37, 26, 30];
        let mut g = BrickGrid::new();
        for b in [
            [0, 0, 0],
            [1, 0, 0],
            [3, 2, 1],
            [2, 1, 2],
            [0, 2, 2],
            [3, 0, 2],
        ] {
            g.insert_tile(IVec3::from_array(b));
        }
        for _ in 0..300 {
            g.insert(IVec3::new(
                rng.random_range(0..37),
                rng.random_range(0..26),
                rng.random_range(0..30),
            ));
        }
        // A full brick stored as a mask shares the slot as well.
        for i in 0..512 {
            g.insert(IVec3::new(8 + i % 8, 16 + i / 8 % 8, i / 64));
        }
        assert_eq!(
            (g.tile_count(), g.brick(IVec3::new(1, 2, 0))),
            (6, Some(&FULL_BRICK))
        );
        let occ = OccupancyGrid::new(&g, dims, MemoryLimit::DEFAULT).unwrap();
        let full = g.bricks().filter(|(_, m)| **m == FULL_BRICK).count();
        assert!(full >= 7);
        assert_eq!(occ.full_bricks(), full);
        assert!(
            occ.bricks[..2]
                == [
                    BrickFlags::default(),
                    BrickFlags {
                        occ: FULL_BRICK,
                        prox: FULL_BRICK
                    }
                ]
        );
        assert!(occ.bricks[2..].iter().all(|b| b.occ != FULL_BRICK));
        let voxels: Vec<IVec3> = g.iter().collect();
        for z in -1..dims[2] as i32 + 1 {
            for y in -1..dims[1] as i32 + 1 {
                for x in -1..dims[0] as i32 + 1 {
                    let v = IVec3::new(x, y, z);
                    let inside = occ.in_grid(v);
                    let near = (0..27)
                        .any(|i| g.contains(v + IVec3::new(i % 3 - 1, i / 3 % 3 - 1, i / 9 - 1)));
                    assert_eq!(occ.is_flagged(v), near && inside, "{v}");
                    assert_eq!(occ.is_occupied(v), g.contains(v) && inside, "{v}");
                    if inside {
                        let b: IVec3 = v >> 3i32;
                        let want = voxels
                            .iter()
                            .map(|s: &IVec3| ((*s >> 3i32) - b).abs().max_element())
                            .min()
                            .unwrap()
                            .min(255) as u8;
                        assert_eq!(occ.brick_distance(v), want, "{v}");
                    }
                }
            }
        }
    }
}
