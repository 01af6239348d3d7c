//! # voxkit
//!
//! Discrete 3D lines, voxelization and discrete ray casting, exact where the
//! mathematics allows it.
//!
//! | module | what |
//! |---|---|
//! | [`camera`] | perspective / orthographic camera shared by the rasterizer and the ray caster |
//! | [`grid`] | dense grid with pointer-offset stepping, bit grid, world↔grid frame |
//! | [`fixed`] | fixed-point sub-voxel coordinates |
//! | [`guard`] | panic containment at reader boundaries: a dependency's panic becomes a typed error |
//! | [`line`](mod@line) | 3D lines (26, 18, tripod 6, Amanatides–Woo, adaptive) and 2D lines |
//! | [`metric`] | the discrete distances d6, d18, d26 |
//! | [`render`] | the discrete ray caster: 6 / 26 / adaptive / Amanatides–Woo rays, empty-space skipping |
//! | [`report`] | speed against error: the line measurements `voxkit demo` prints, and the full report `voxkit report` writes |
//! | [`stability`] | the numerical-stability suite: hard inputs against exact oracles |
//! | [`topology`] | oracles: connectivity, containment, touching |
//! | [`io`] | atomic file writes; voxel files: binvox, MagicaVoxel .vox, .npy, NRRD |
//! | [`mesh`] | triangle meshes + polylines; OBJ, glTF 2.0, PLY, STL and OFF loaders; grid fitting |
//! | [`triangle`] | Kahan–Kelsen triangle point indexing and 2D rasterization |
//! | [`voxelize`] | mesh voxelization and its exact references (conservative, solid) |
//! | [`cli`] | the `voxkit` command line |
//!
//! # In five lines
//!
//! Load a mesh, voxelize it thin, check exactly that no 6-connected path of
//! empty voxels crosses the surface, and write a `.binvox` (README's example):
//!
//! ```
//! # fn main() -> voxkit::Result<()> {
//! use voxkit::{grid::MemoryLimit, mesh::Mesh, voxelize::{measure::measure_voxelization, pipeline::*}};
//! let mesh = Mesh::load("data/meshes/obj/spot.obj".as_ref())?;
//! let v = voxelize_mesh(&mesh, &VoxelizeOptions::new(128, VoxelizeMode::Thin))?;
//! assert_eq!(measure_voxelization(&v, MemoryLimit::DEFAULT)?.tunnel6, Some(false)); // exact tunnel check
//! # let dir = std::env::temp_dir().join(format!("voxkit-lib-doc-{}", std::process::id()));
//! # std::fs::create_dir_all(&dir).unwrap();
//! # let path = dir.join("spot.binvox");
//! voxkit::io::write_voxels(&path, &v.grid, &v.frame, true)?;
//! # std::fs::remove_dir_all(&dir).unwrap();
//! # Ok(())
//! # }
//! ```
//!
//! Sources: D. Cohen-Or and A. Kaufman, *3D Line Voxelization and Connectivity
//! Control*, IEEE CG&A 17(6), 1997; J. Amanatides and A. Woo, *A Fast Voxel
//! Traversal Algorithm for Ray Tracing*, Eurographics 1987; W. Kahan and
//! J. Kelsen (Kahan–Kelsen), constant-time indexing of the lattice points of
//! a triangle; J. Pineda, *A Parallel Algorithm for Polygon Rasterization*,
//! SIGGRAPH 1988.

#![warn(missing_docs)]

pub mod alloc;
pub mod camera;
pub mod cli;
pub mod error;
pub mod fixed;
#[doc(hidden)]
pub mod fuzz_entry;
pub mod grid;
pub mod guard;
mod hint;
pub mod io;
pub mod line;
pub mod mesh;
pub mod metric;
pub mod render;
pub mod report;
pub mod stability;
pub mod tiled;
pub mod topology;
pub mod triangle;
pub mod voxelize;

pub use error::{Result, VoxkitError};
pub use metric::Connectivity;
