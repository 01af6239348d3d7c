//! Mesh voxelization.
pub mod surface;
