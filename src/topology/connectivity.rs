//! N-connectivity of a voxel path.

use crate::grid::Voxel;
use crate::metric::{Connectivity, adjacent};

/// The first index `i` such that `path[i]` and `path[i + 1]` are not distinct
/// N-neighbours (so a repeated voxel is a break too), or `None` if every
/// consecutive pair is N-adjacent. Paths of 0 or 1 voxels have no break.
///
/// ```
/// use glam::IVec3;
/// use voxkit::topology::connectivity_break;
/// use voxkit::Connectivity;
/// let p = [IVec3::new(0, 0, 0), IVec3::new(1, 0, 0), IVec3::new(2, 1, 0)];
/// assert_eq!(connectivity_break(&p, Connectivity::Six), Some(1));
/// assert_eq!(connectivity_break(&p, Connectivity::Eighteen), None);
/// ```
pub fn connectivity_break(path: &[Voxel], conn: Connectivity) -> Option<usize> {
    path.windows(2).position(|w| !adjacent(w[0], w[1], conn))
}

/// Whether every consecutive pair of `path` is a pair of distinct
/// N-neighbours (see [`connectivity_break`]).
///
/// ```
/// use glam::IVec3;
/// use voxkit::topology::is_connected_path;
/// use voxkit::Connectivity;
/// let p = [IVec3::ZERO, IVec3::new(1, 1, 1)];
/// assert!(is_connected_path(&p, Connectivity::TwentySix));
/// assert!(!is_connected_path(&p, Connectivity::Eighteen));
/// ```
pub fn is_connected_path(path: &[Voxel], conn: Connectivity) -> bool {
    connectivity_break(path, conn).is_none()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::IVec3;

    #[test]
    fn trivial_paths_are_connected() {
        for conn in [
            Connectivity::Six,
            Connectivity::Eighteen,
            Connectivity::TwentySix,
        ] {
            assert!(is_connected_path(&[], conn));
            assert!(is_connected_path(&[IVec3::new(5, -3, 2)], conn));
        }
    }

    #[test]
    fn repeated_voxel_is_a_break() {
        let p = [IVec3::ZERO, IVec3::X, IVec3::X, IVec3::new(2, 0, 0)];
        assert_eq!(connectivity_break(&p, Connectivity::TwentySix), Some(1));
    }

    #[test]
    fn break_index_is_first() {
        let p = [
            IVec3::ZERO,
            IVec3::new(1, 1, 0),
            IVec3::new(2, 2, 1),
            IVec3::new(3, 2, 1),
        ];
        assert_eq!(connectivity_break(&p, Connectivity::Six), Some(0));
        assert_eq!(connectivity_break(&p, Connectivity::Eighteen), Some(1));
        assert_eq!(connectivity_break(&p, Connectivity::TwentySix), None);
    }
}
