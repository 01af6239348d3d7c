use ndarray::{ArrayView3, ArrayViewMut3};

use super::{Dims, MemoryLimit, Voxel, cell_count, neighbour_slot};
use crate::error::Result;

/// A dense 3D grid of `T`, x fastest: `index = x + nx * (y + ny * z)`.
///
/// Besides checked access by coordinates it exposes the linear layout that
/// hot loops use: [`DenseGrid::linear_index`], the 26 precomputed
/// [`DenseGrid::neighbour_offset`]s, and unchecked access by linear index for
/// loops that have clipped their path to the grid once up front.
///
/// ```
/// use voxkit::grid::{DenseGrid, MemoryLimit};
/// let mut g = DenseGrid::new([4, 3, 2], 0u8, MemoryLimit::DEFAULT).unwrap();
/// let i = g.linear_index(glam::IVec3::new(1, 2, 1)).unwrap();
/// assert_eq!(i, 1 + 4 * (2 + 3 * 1));
/// // Step +x, -y by the precomputed offset.
/// let j = (i as isize + g.neighbour_offset(1, -1, 0)) as usize;
/// assert_eq!(g.voxel_of_index(j).to_array(), [2, 1, 1]);
/// g[j] = 7;
/// assert_eq!(g.get(glam::IVec3::new(2, 1, 1)), Some(&7));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct DenseGrid<T> {
    dims: Dims,
    data: Vec<T>,
    offsets: [isize; 27],
}

impl<T: Clone> DenseGrid<T> {
    /// A grid of `dims` filled with `fill`. Fails with
    /// [`crate::VoxkitError::Limits`] before allocating if the grid would
    /// exceed `limit`, and with [`crate::VoxkitError::Invalid`] for a zero or
    /// unindexable extent.
    pub fn new(dims: Dims, fill: T, limit: MemoryLimit) -> Result<Self> {
        let n = cell_count(dims)?;
        limit.check(
            &format!("dense grid {}x{}x{}", dims[0], dims[1], dims[2]),
            n as u128,
            std::mem::size_of::<T>().max(1) as u128,
        )?;
        Ok(Self::from_parts_unchecked(dims, vec![fill; n]))
    }
}

impl<T> DenseGrid<T> {
    /// Wraps existing x-fastest data. Fails if `data.len()` is not the cell
    /// count of `dims`.
    pub fn from_vec(dims: Dims, data: Vec<T>) -> Result<Self> {
        let n = cell_count(dims)?;
        if data.len() != n {
            return Err(crate::VoxkitError::invalid(format!(
                "grid data has {} cells, dimensions {dims:?} need {n}",
                data.len()
            )));
        }
        Ok(Self::from_parts_unchecked(dims, data))
    }

    fn from_parts_unchecked(dims: Dims, data: Vec<T>) -> Self {
        let (sx, sy, sz) = (1isize, dims[0] as isize, (dims[0] * dims[1]) as isize);
        let mut offsets = [0isize; 27];
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    offsets[neighbour_slot(dx, dy, dz)] =
                        dx as isize * sx + dy as isize * sy + dz as isize * sz;
                }
            }
        }
        DenseGrid {
            dims,
            data,
            offsets,
        }
    }

    /// Extents `[nx, ny, nz]`.
    #[inline]
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// Number of cells.
    #[inline]
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Always false: a grid has at least one cell.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Index strides `[1, nx, nx * ny]` of the three axes.
    #[inline]
    pub fn strides(&self) -> [isize; 3] {
        [
            self.offsets[neighbour_slot(1, 0, 0)],
            self.offsets[neighbour_slot(0, 1, 0)],
            self.offsets[neighbour_slot(0, 0, 1)],
        ]
    }

    /// Signed change of the linear index for the move `(dx, dy, dz)`, each
    /// component in `-1..=1` (precomputed; `(0,0,0)` gives 0).
    #[inline(always)]
    pub fn neighbour_offset(&self, dx: i32, dy: i32, dz: i32) -> isize {
        self.offsets[neighbour_slot(dx, dy, dz)]
    }

    /// The whole 27-entry offset table, indexed by
    /// [`super::neighbour_slot`].
    #[inline]
    pub fn neighbour_offsets(&self) -> &[isize; 27] {
        &self.offsets
    }

    /// Whether `v` lies inside the grid.
    #[inline]
    pub fn contains(&self, v: Voxel) -> bool {
        v.x >= 0
            && v.y >= 0
            && v.z >= 0
            && (v.x as usize) < self.dims[0]
            && (v.y as usize) < self.dims[1]
            && (v.z as usize) < self.dims[2]
    }

    /// Linear index of `v`, or `None` outside the grid.
    #[inline]
    pub fn linear_index(&self, v: Voxel) -> Option<usize> {
        self.contains(v).then(|| self.linear_index_unchecked(v))
    }

    /// Linear index of `v` without checking that it lies inside; the result is
    /// meaningless (but harmless: no memory is touched) if it does not.
    #[inline(always)]
    pub fn linear_index_unchecked(&self, v: Voxel) -> usize {
        (v.x as usize).wrapping_add(
            self.dims[0]
                .wrapping_mul((v.y as usize).wrapping_add(self.dims[1].wrapping_mul(v.z as usize))),
        )
    }

    /// Coordinates of the voxel at linear index `i` (`i < len()`).
    #[inline]
    pub fn voxel_of_index(&self, i: usize) -> Voxel {
        let x = i % self.dims[0];
        let yz = i / self.dims[0];
        Voxel::new(
            x as i32,
            (yz % self.dims[1]) as i32,
            (yz / self.dims[1]) as i32,
        )
    }

    /// Cell at `v`, or `None` outside the grid.
    #[inline]
    pub fn get(&self, v: Voxel) -> Option<&T> {
        self.linear_index(v).map(|i| &self.data[i])
    }

    /// Mutable cell at `v`, or `None` outside the grid.
    #[inline]
    pub fn get_mut(&mut self, v: Voxel) -> Option<&mut T> {
        self.linear_index(v).map(move |i| &mut self.data[i])
    }

    /// The cells in x-fastest order.
    #[inline]
    pub fn as_slice(&self) -> &[T] {
        &self.data
    }

    /// The cells in x-fastest order, mutable.
    #[inline]
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Consumes the grid, returning its x-fastest cells.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }

    /// Zero-copy ndarray view with axes `[z, y, x]` (standard C order over
    /// the x-fastest layout), so `view[[z, y, x]]` is voxel `(x, y, z)`.
    ///
    /// ```
    /// use voxkit::grid::{DenseGrid, MemoryLimit};
    /// let mut g = DenseGrid::new([3, 2, 2], 0u16, MemoryLimit::DEFAULT).unwrap();
    /// *g.get_mut(glam::IVec3::new(2, 1, 0)).unwrap() = 5;
    /// assert_eq!(g.view()[[0, 1, 2]], 5);
    /// assert_eq!(g.view().shape(), &[2, 2, 3]);
    /// ```
    pub fn view(&self) -> ArrayView3<'_, T> {
        let [nx, ny, nz] = self.dims;
        ArrayView3::from_shape((nz, ny, nx), &self.data).expect("length checked at construction")
    }

    /// Zero-copy mutable ndarray view with axes `[z, y, x]`.
    pub fn view_mut(&mut self) -> ArrayViewMut3<'_, T> {
        let [nx, ny, nz] = self.dims;
        ArrayViewMut3::from_shape((nz, ny, nx), &mut self.data)
            .expect("length checked at construction")
    }
}

impl<T> std::ops::Index<usize> for DenseGrid<T> {
    type Output = T;
    #[inline(always)]
    fn index(&self, i: usize) -> &T {
        &self.data[i]
    }
}

impl<T> std::ops::IndexMut<usize> for DenseGrid<T> {
    #[inline(always)]
    fn index_mut(&mut self, i: usize) -> &mut T {
        &mut self.data[i]
    }
}
