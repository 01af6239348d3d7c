//! Mesh voxelization.
//!
//! Modes (see DESIGN.md): *thin* (6-tunnel-free), *thick* (26-tunnel-free),
//! *conservative* (exactly the voxels whose closed cube meets the surface) and
//! *solid* (surface plus interior). The fast voxelizers are built on the line
//! engine and triangle indexing; this module also holds the **exact
//! references** they are judged by:
//!
//! | module | what |
//! |---|---|
//! | [`conservative`] | exact triangle–box test (integer separating axes), per-triangle and mesh-level conservative sets |
//! | [`solid`] | solid mode's interior (winding number or parity, in tiles) and its references: brute-force winding number, dense axis parity |
//! | [`caps`] | a mesh's boundary chain and the fans that close its holes |
//! | [`fill`] | signed crossings along x-lines per brick layer → tiles and masks |
//! | [`winding`] | Barnes–Hut winding numbers with rigorous error bounds; rim gradient bounds |
//! | [`expansion`] | third-order multipoles of triangle clusters and local (Taylor) expansions of the winding number over a box, with rigorous error bounds |
//! | [`pipeline`] | mesh → brick grid: fitting, quantization, memory estimate, the four modes, polylines |
//! | [`measure`] | error measures against the exact conservative set: missing/extra, distances, tunnels |
//! | [`shapes`] | closed test meshes (UV sphere, torus, box) with rotations and offsets |
//! | [`tile`] | one tile of a grid alone, voxel for voxel as in the whole run (tiled Zarr output) |
//! | [`snapped`] | thin/thick surfaces for lattice-snapped vertices by Kahan–Kelsen indexing, split evenly by a prefix sum |
//!
//! Meshes are triangle soups in grid space with fixed-point vertices
//! ([`conservative::FixedTriangle`], 2^-20 voxel, `|x| ≤ 2^30` voxels). Voxel
//! `(i, j, k)` is the closed unit cube centred on the integer point `(i, j, k)`.
//! Tunnel checks for the results live in [`crate::topology::tunnels`].

pub mod caps;
pub mod conservative;
pub mod expansion;
pub mod fill;
pub mod measure;
pub mod pipeline;
pub mod shapes;
pub mod slab;
pub mod snapped;
pub mod solid;
pub mod surface;
pub mod tile;
pub mod winding;
