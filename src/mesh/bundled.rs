//! The meshes compiled into the binary, so that `voxkit demo`, `voxkit
//! report` and the stability suite run from any directory: Spot (Keenan
//! Crane, CC0) and the Stanford bunny (courtesy of the Stanford Computer
//! Graphics Laboratory); sources in `data/SOURCES.md`.

use super::Mesh;
use super::obj::parse_str;
use crate::error::Result;

const SPOT_OBJ: &str = include_str!("../../data/meshes/obj/spot.obj");
const BUNNY_OBJ: &str = include_str!("../../data/meshes/obj/stanford-bunny.obj");

/// Spot, the cow (5,856 triangles, closed), as `data/meshes/obj/spot.obj`.
///
/// ```
/// let spot = voxkit::mesh::bundled::spot().unwrap();
/// assert_eq!(spot.triangles.len(), 5856);
/// ```
pub fn spot() -> Result<Mesh> {
    parse_str(SPOT_OBJ, "spot.obj (bundled)")
}

/// The Stanford bunny as scanned (with its holes), as
/// `data/meshes/obj/stanford-bunny.obj`.
pub fn bunny() -> Result<Mesh> {
    parse_str(BUNNY_OBJ, "stanford-bunny.obj (bundled)")
}
