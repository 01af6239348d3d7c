//! Closed test meshes: UV sphere, torus and box, with rotations and offsets.
//!
//! Every generator returns an [`IndexedMesh`] whose triangles are oriented
//! outward (counter-clockwise seen from outside), share vertices by index and
//! so stay exactly watertight after conversion to fixed point
//! ([`IndexedMesh::to_fixed_triangles`] converts each vertex once). Meant for
//! voxelizer tests and benches: generated spheres and tori at many sizes,
//! rotations and sub-voxel offsets.
//!
//! ```
//! use glam::{DQuat, DVec3};
//! use voxkit::voxelize::shapes::IndexedMesh;
//! let m = IndexedMesh::torus(DVec3::ZERO, 10.0, 3.0, 24, 12)
//!     .transformed(DQuat::from_rotation_x(0.3), DVec3::new(20.25, 20.5, 20.0));
//! assert_eq!(m.faces.len(), 2 * 24 * 12);
//! let tris = m.to_fixed_triangles().unwrap();
//! assert_eq!(tris.len(), m.faces.len());
//! ```

use glam::{DQuat, DVec3};

use crate::error::{Result, VoxkitError};
use crate::fixed::point_to_fixed;
use crate::voxelize::conservative::FixedTriangle;

/// A triangle mesh as a vertex list and index triples (grid-space units).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IndexedMesh {
    /// Vertex positions.
    pub vertices: Vec<DVec3>,
    /// Triangles as indices into `vertices`, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
}

impl IndexedMesh {
    /// A UV sphere: `rings ≥ 2` latitude bands, `segments ≥ 3` longitudes
    /// (clamped up to those minima). Poles on the z axis.
    pub fn uv_sphere(center: DVec3, radius: f64, rings: u32, segments: u32) -> Self {
        let (rings, segs) = (rings.max(2), segments.max(3));
        let mut vertices = vec![center + DVec3::new(0.0, 0.0, radius)];
        for i in 1..rings {
            let theta = std::f64::consts::PI * i as f64 / rings as f64;
            for j in 0..segs {
                let phi = std::f64::consts::TAU * j as f64 / segs as f64;
                vertices.push(
                    center
                        + radius
                            * DVec3::new(
                                theta.sin() * phi.cos(),
                                theta.sin() * phi.sin(),
                                theta.cos(),
                            ),
                );
            }
        }
        let south = vertices.len() as u32;
        vertices.push(center - DVec3::new(0.0, 0.0, radius));
        let ring = |i: u32, j: u32| 1 + (i - 1) * segs + j % segs;
        let mut faces = Vec::new();
        for j in 0..segs {
            faces.push([0, ring(1, j), ring(1, j + 1)]);
        }
        for i in 1..rings - 1 {
            for j in 0..segs {
                let (a, b) = (ring(i, j), ring(i, j + 1));
                let (c, d) = (ring(i + 1, j), ring(i + 1, j + 1));
                faces.push([a, c, d]);
                faces.push([a, d, b]);
            }
        }
        for j in 0..segs {
            faces.push([south, ring(rings - 1, j + 1), ring(rings - 1, j)]);
        }
        IndexedMesh { vertices, faces }
    }

    /// A torus around the z axis: tube centre circle of radius `major`, tube
    /// radius `minor < major`, `n_major × n_minor` quads (each at least 3).
    pub fn torus(center: DVec3, major: f64, minor: f64, n_major: u32, n_minor: u32) -> Self {
        let (nu, nv) = (n_major.max(3), n_minor.max(3));
        let mut vertices = Vec::with_capacity((nu * nv) as usize);
        for i in 0..nu {
            let u = std::f64::consts::TAU * i as f64 / nu as f64;
            for j in 0..nv {
                let v = std::f64::consts::TAU * j as f64 / nv as f64;
                let rr = major + minor * v.cos();
                vertices.push(center + DVec3::new(rr * u.cos(), rr * u.sin(), minor * v.sin()));
            }
        }
        let id = |i: u32, j: u32| (i % nu) * nv + j % nv;
        let mut faces = Vec::with_capacity((2 * nu * nv) as usize);
        for i in 0..nu {
            for j in 0..nv {
                // ∂u × ∂v points outward, so (u, u+1, v+1) is counter-clockwise.
                faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        IndexedMesh { vertices, faces }
    }

    /// An axis-aligned box with corners `min` and `max` (12 triangles).
    pub fn cuboid(min: DVec3, max: DVec3) -> Self {
        let corner = |i: u32| {
            DVec3::new(
                if i & 1 != 0 { max.x } else { min.x },
                if i & 2 != 0 { max.y } else { min.y },
                if i & 4 != 0 { max.z } else { min.z },
            )
        };
        let vertices = (0..8).map(corner).collect();
        // Corner index = x + 2y + 4z; quads counter-clockwise from outside.
        let quads: [[u32; 4]; 6] = [
            [0, 4, 6, 2], // -x
            [1, 3, 7, 5], // +x
            [0, 1, 5, 4], // -y
            [2, 6, 7, 3], // +y
            [0, 2, 3, 1], // -z
            [4, 5, 7, 6], // +z
        ];
        let faces = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        IndexedMesh { vertices, faces }
    }

    /// The mesh rotated by `rotation` about the grid origin, then moved by `offset`.
    pub fn transformed(&self, rotation: DQuat, offset: DVec3) -> Self {
        IndexedMesh {
            vertices: self
                .vertices
                .iter()
                .map(|&v| rotation * v + offset)
                .collect(),
            faces: self.faces.clone(),
        }
    }

    /// The mesh with face `index` removed (a hole), for robustness tests.
    pub fn without_face(&self, index: usize) -> Self {
        let mut m = self.clone();
        if index < m.faces.len() {
            m.faces.remove(index);
        }
        m
    }

    /// Axis-aligned bounds `(min, max)` of the vertices.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.vertices.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(a, b), &v| (a.min(v), b.max(v)),
        )
    }

    /// Triangles in fixed point; each vertex is converted once, so shared
    /// vertices stay bit-identical (watertight stays watertight).
    ///
    /// # Errors
    /// [`VoxkitError::Invalid`] for a non-finite or out-of-range vertex or a
    /// face index out of range.
    pub fn to_fixed_triangles(&self) -> Result<Vec<FixedTriangle>> {
        let fixed: Vec<_> = self
            .vertices
            .iter()
            .map(|v| point_to_fixed(v.to_array()))
            .collect::<Result<_>>()?;
        self.faces
            .iter()
            .enumerate()
            .map(|(f, idx)| {
                let get = |i: u32| {
                    fixed.get(i as usize).copied().ok_or_else(|| {
                        VoxkitError::invalid(format!("face {f}: vertex index {i} out of range"))
                    })
                };
                Ok([get(idx[0])?, get(idx[1])?, get(idx[2])?])
            })
            .collect()
    }
}

/// A uniformly distributed rotation from three uniforms in `[0, 1)`
/// (Shoemake's method), so seeded tests draw rotations without a matrix library.
///
/// ```
/// use voxkit::voxelize::shapes::random_rotation;
/// let q = random_rotation([0.3, 0.7, 0.1]);
/// assert!((q.length() - 1.0).abs() < 1e-12);
/// ```
pub fn random_rotation(u: [f64; 3]) -> DQuat {
    let (a, b) = ((1.0 - u[0]).sqrt(), u[0].sqrt());
    let (t1, t2) = (std::f64::consts::TAU * u[1], std::f64::consts::TAU * u[2]);
    DQuat::from_xyzw(a * t1.sin(), a * t1.cos(), b * t2.sin(), b * t2.cos()).normalize()
}
