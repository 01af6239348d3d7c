//! Mesh voxelization.
pub mod slab;
pub mod surface;
