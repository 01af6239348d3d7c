//! Lattice triangles.
//!
//! * [`index`] — Kahan–Kelsen constant-time indexing of the lattice points of a
//!   closed lattice triangle: count, `point(i)`, `index_of(p)`, uniform sampling,
//!   index-range (parallel) enumeration. Cost: `O(bits)` setup, `O(1)` per point.
//! * [`mesh_index`] — one global index over many triangles (prefix sum +
//!   binary search), for load-balanced parallel enumeration.
//! * [`lattice_scan`] — scanline enumeration of the same points: the baseline
//!   (`O(rows + points)`) and a second oracle.
//!
//! Source: S. Kahan and P. Kelsen, *Constant Time Parallel Indexing of Points
//! in a Triangle*.

pub mod index;
pub mod lattice_scan;
pub mod mesh_index;

pub use index::{COORD_LIMIT, LatticePoint, Points, TriangleIndex, TriangleShape};
pub use lattice_scan::ScanlineLattice;
pub use mesh_index::MeshIndex;
