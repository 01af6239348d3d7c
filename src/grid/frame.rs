use glam::DVec3;

use super::{Dims, Voxel};

/// Ties grid space to world space.
///
/// `origin` is the world position of the *min corner* of voxel `(0, 0, 0)`,
/// `voxel_size` the edge length `h` of a voxel, `dims` the extents in voxels.
/// World `w` maps to grid `(w - origin) / h - 0.5`, so voxel centres sit on
/// integer grid coordinates. This matches binvox's `translate`/`scale`
/// (`translate = origin`, `scale = max(dims) * h`).
///
/// ```
/// use glam::DVec3;
/// use voxkit::grid::GridFrame;
/// let frame = GridFrame::new(DVec3::new(1.0, 0.0, 0.0), 0.5, [4, 4, 4]);
/// // The min corner of voxel (0,0,0) is at grid -0.5; its centre at 0.
/// assert_eq!(frame.world_to_grid(DVec3::new(1.25, 0.25, 0.25)), DVec3::ZERO);
/// assert_eq!(frame.voxel_of_world(DVec3::new(1.26, 0.74, 0.25)).to_array(), [0, 1, 0]);
/// assert_eq!(frame.grid_to_world(DVec3::ZERO), DVec3::new(1.25, 0.25, 0.25));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridFrame {
    /// World position of the min corner of voxel (0, 0, 0).
    pub origin: DVec3,
    /// Edge length of a voxel in world units.
    pub voxel_size: f64,
    /// Extents in voxels.
    pub dims: Dims,
}

impl GridFrame {
    /// A frame with the given origin, voxel size and extents.
    pub fn new(origin: DVec3, voxel_size: f64, dims: Dims) -> Self {
        GridFrame {
            origin,
            voxel_size,
            dims,
        }
    }

    /// World point → grid-space point (voxel centres at integers).
    #[inline]
    pub fn world_to_grid(&self, w: DVec3) -> DVec3 {
        (w - self.origin) / self.voxel_size - DVec3::splat(0.5)
    }

    /// Grid-space point → world point.
    #[inline]
    pub fn grid_to_world(&self, g: DVec3) -> DVec3 {
        (g + DVec3::splat(0.5)) * self.voxel_size + self.origin
    }

    /// The voxel containing a world point: `floor(world_to_grid(w) + 0.5)`.
    #[inline]
    pub fn voxel_of_world(&self, w: DVec3) -> Voxel {
        let g = self.world_to_grid(w) + DVec3::splat(0.5);
        g.floor().as_ivec3()
    }

    /// World position of a voxel's centre.
    #[inline]
    pub fn voxel_center_world(&self, v: Voxel) -> DVec3 {
        self.grid_to_world(v.as_dvec3())
    }

    /// Whether a voxel lies inside `0..dims` on every axis.
    #[inline]
    pub fn contains(&self, v: Voxel) -> bool {
        (0..3).all(|a| v[a] >= 0 && (v[a] as i64) < self.dims[a] as i64)
    }
}
