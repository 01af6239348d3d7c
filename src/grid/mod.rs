//! Voxel grids: the dense grid that line walks and ray casts step through,
//! a bit-packed occupancy grid, and the frame that ties grid space to world
//! space.
//!
//! # Conventions
//! Voxel `(i, j, k)` is the closed unit cube centred on the integer point
//! `(i, j, k)` of grid space; a grid-space point `p` belongs to voxel
//! `floor(p + 0.5)`. Dense storage is x-fastest:
//! `index = x + nx * (y + ny * z)`.
//!
//! # Pointer-offset stepping
//! [`DenseGrid::neighbour_offset`] gives the signed change of the linear index
//! for each of the 26 neighbour moves. Hot loops clip their segment to the grid
//! box once and then move a linear index by these offsets: no bounds check and
//! no 3D→1D recomputation per voxel.

mod bits;
pub mod brick;
mod dense;
mod frame;
pub mod volume;

pub use bits::BitGrid;
pub use brick::BrickGrid;
pub use dense::DenseGrid;
pub use frame::GridFrame;
pub use volume::{AnatomicalSpace, ScalarType, ScalarVolume, VolumeData, VolumeFrame};

use crate::error::{Result, VoxkitError};

/// Integer voxel coordinates in grid space.
pub type Voxel = glam::IVec3;

/// Grid extents `[nx, ny, nz]` in voxels.
pub type Dims = [usize; 3];

/// A cap on the bytes a grid may allocate. Checked before allocating, so an
/// oversized request fails with [`VoxkitError::Limits`] instead of aborting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryLimit {
    /// Maximum number of bytes.
    pub bytes: u64,
}

impl MemoryLimit {
    /// The default limit: 4 GiB.
    pub const DEFAULT: MemoryLimit = MemoryLimit { bytes: 4 << 30 };

    /// A limit of `bytes` bytes.
    pub const fn new(bytes: u64) -> Self {
        MemoryLimit { bytes }
    }

    /// Checks that `count` elements of `elem_bytes` bytes each fit, naming
    /// `what` in the error otherwise.
    pub fn check(&self, what: &str, count: u128, elem_bytes: u128) -> Result<()> {
        let needed = count.saturating_mul(elem_bytes);
        if needed > self.bytes as u128 {
            return Err(VoxkitError::Limits {
                what: what.to_string(),
                needed,
                limit: self.bytes,
            });
        }
        Ok(())
    }
}

impl Default for MemoryLimit {
    fn default() -> Self {
        MemoryLimit::DEFAULT
    }
}

/// Number of cells of a grid with extents `dims`, or an error if a side is
/// zero or the product overflows.
pub(crate) fn cell_count(dims: Dims) -> Result<usize> {
    if dims.contains(&0) {
        return Err(VoxkitError::invalid(format!(
            "grid dimensions must be positive, got {dims:?}"
        )));
    }
    let total = (dims[0] as u128) * (dims[1] as u128) * (dims[2] as u128);
    // Every linear index and every signed offset must fit an isize.
    if total > isize::MAX as u128 / 2 || dims.iter().any(|&d| d > i32::MAX as usize) {
        return Err(VoxkitError::invalid(format!(
            "grid dimensions {dims:?} are too large to index"
        )));
    }
    Ok(total as usize)
}

/// Index into the 27-entry neighbour table for a move `(dx, dy, dz)` with each
/// component in `-1..=1`: `(dx + 1) + 3 (dy + 1) + 9 (dz + 1)`.
#[inline(always)]
pub const fn neighbour_slot(dx: i32, dy: i32, dz: i32) -> usize {
    ((dx + 1) + 3 * (dy + 1) + 9 * (dz + 1)) as usize
}
