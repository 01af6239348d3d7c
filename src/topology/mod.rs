//! Topology oracles: the exact judges that line and voxelization algorithms
//! are tested against.
//!
//! - [`connectivity`]: is a voxel path N-connected ([`is_connected_path`],
//!   [`connectivity_break`])?
//! - [`containment`]: does a closed segment touch a closed voxel cube
//!   ([`segment_touches_voxel`])? Does the union of a set of closed cubes
//!   cover a segment ([`covers_segment`], [`containment_gap`])? Which voxels
//!   does a segment touch ([`touched_voxels`], a brute-force reference for
//!   short segments)?
//!
//! Everything here is decided exactly, in integers: segments are given in
//! fixed point ([`crate::fixed`], `FRAC_BITS` = 20) and parameters along a
//! segment are rationals compared by cross-multiplication in `i128`. The code
//! favours obvious correctness over speed, but nothing is quadratic in the
//! length of a path: connectivity is linear, containment is `O(n log n)`.
//!
//! ```
//! use glam::IVec3;
//! use voxkit::fixed::ONE;
//! use voxkit::topology::{covers_segment, is_connected_path, touched_voxels};
//! use voxkit::Connectivity;
//! // From the centre of voxel (0,0,0) to the centre of (1,1,0): the segment
//! // passes through the shared edge at (0.5, 0.5, 0), so it touches 4 voxels.
//! let (a, b) = ([0, 0, 0], [ONE, ONE, 0]);
//! let touched = touched_voxels(a, b).unwrap();
//! assert_eq!(touched.len(), 4);
//! // The two end voxels alone cover it (closed cubes meet at the edge) ...
//! let ends = [IVec3::new(0, 0, 0), IVec3::new(1, 1, 0)];
//! assert!(covers_segment(a, b, &ends));
//! // ... but they are not a 6-connected path.
//! assert!(!is_connected_path(&ends, Connectivity::Six));
//! ```

pub mod connectivity;
pub mod containment;

pub use connectivity::{connectivity_break, is_connected_path};
pub use containment::{
    ContainmentGap, Rational, TOUCHED_VOXELS_MAX_BOX, containment_gap, covers_segment,
    first_untouched, segment_touches_voxel, segment_voxel_interval, touched_voxels,
};
