use super::{Dims, MemoryLimit, Voxel, cell_count};
use crate::error::Result;

/// A bit-packed occupancy grid with the same x-fastest layout as
/// [`super::DenseGrid`]: bit `index = x + nx * (y + ny * z)` of a `u64` array.
///
/// ```
/// use voxkit::grid::{BitGrid, MemoryLimit};
/// let mut g = BitGrid::new([70, 2, 1], MemoryLimit::DEFAULT).unwrap();
/// g.set(glam::IVec3::new(65, 1, 0), true);
/// assert!(g.get(glam::IVec3::new(65, 1, 0)));
/// assert!(!g.get(glam::IVec3::new(64, 1, 0)));
/// assert!(!g.get(glam::IVec3::new(-1, 0, 0)));  // outside reads as empty
/// assert_eq!(g.count_ones(), 1);
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BitGrid {
    dims: Dims,
    len: usize,
    words: Vec<u64>,
}

impl BitGrid {
    /// An empty grid of `dims`, checked against `limit` before allocating.
    pub fn new(dims: Dims, limit: MemoryLimit) -> Result<Self> {
        let len = cell_count(dims)?;
        let n_words = len.div_ceil(64);
        limit.check(
            &format!("bit grid {}x{}x{}", dims[0], dims[1], dims[2]),
            n_words as u128,
            8,
        )?;
        Ok(BitGrid {
            dims,
            len,
            words: vec![0; n_words],
        })
    }

    /// Extents `[nx, ny, nz]`.
    #[inline]
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// Number of cells (bits in use).
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always false: a grid has at least one cell.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Linear index of `v`, or `None` outside.
    #[inline]
    pub fn linear_index(&self, v: Voxel) -> Option<usize> {
        let inside = v.x >= 0
            && v.y >= 0
            && v.z >= 0
            && (v.x as usize) < self.dims[0]
            && (v.y as usize) < self.dims[1]
            && (v.z as usize) < self.dims[2];
        inside.then(|| v.x as usize + self.dims[0] * (v.y as usize + self.dims[1] * v.z as usize))
    }

    /// Whether voxel `v` is set; voxels outside the grid read as unset.
    #[inline]
    pub fn get(&self, v: Voxel) -> bool {
        self.linear_index(v).is_some_and(|i| self.get_index(i))
    }

    /// Sets or clears voxel `v`; returns false (and does nothing) outside.
    #[inline]
    pub fn set(&mut self, v: Voxel, on: bool) -> bool {
        match self.linear_index(v) {
            Some(i) => {
                self.set_index(i, on);
                true
            }
            None => false,
        }
    }

    /// Bit at linear index `i` (`i < len()`, else panics).
    #[inline(always)]
    pub fn get_index(&self, i: usize) -> bool {
        (self.words[i >> 6] >> (i & 63)) & 1 != 0
    }

    /// Sets or clears the bit at linear index `i` (`i < len()`, else panics).
    #[inline(always)]
    pub fn set_index(&mut self, i: usize, on: bool) {
        let w = &mut self.words[i >> 6];
        let m = 1u64 << (i & 63);
        if on { *w |= m } else { *w &= !m }
    }

    /// ORs `bits` into the eight bits at linear index `i..i + 8` (bit `k`
    /// of `bits` is index `i + k`); every set bit must be below `len()`.
    #[inline]
    pub(crate) fn or_byte(&mut self, i: usize, bits: u8) {
        debug_assert!(bits == 0 || i + 8 - (bits.leading_zeros() as usize) <= self.len);
        let (w, o) = (i >> 6, i & 63);
        self.words[w] |= u64::from(bits) << o;
        if o > 56 {
            let high = u64::from(bits) >> (64 - o);
            if high != 0 {
                self.words[w + 1] |= high;
            }
        }
    }

    /// The eight bits at linear index `i..i + 8` (bit `k` is index
    /// `i + k`; indices past `len()` read as 0). `i < len()`.
    #[inline]
    pub(crate) fn byte_at(&self, i: usize) -> u8 {
        let (w, o) = (i >> 6, i & 63);
        let mut bits = self.words[w] >> o;
        if o > 56
            && let Some(next) = self.words.get(w + 1)
        {
            bits |= next << (64 - o);
        }
        bits as u8
    }

    /// Number of set voxels.
    pub fn count_ones(&self) -> u64 {
        self.words.iter().map(|w| w.count_ones() as u64).sum()
    }

    /// The packed words (bit `i` of the grid is bit `i % 64` of word `i / 64`;
    /// bits past `len()` are zero).
    pub fn words(&self) -> &[u64] {
        &self.words
    }

    /// Iterates over the set voxels in x-fastest order.
    pub fn iter_ones(&self) -> impl Iterator<Item = Voxel> + '_ {
        let [nx, ny, _] = self.dims;
        self.words.iter().enumerate().flat_map(move |(wi, &w)| {
            let mut bits = w;
            std::iter::from_fn(move || {
                if bits == 0 {
                    return None;
                }
                let b = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let i = wi * 64 + b;
                Some(Voxel::new(
                    (i % nx) as i32,
                    ((i / nx) % ny) as i32,
                    (i / (nx * ny)) as i32,
                ))
            })
        })
    }
}
