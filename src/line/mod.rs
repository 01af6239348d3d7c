//! Exact 3D lines (Cohen-Or & Kaufman, *3D Line Voxelization and Connectivity
//! Control*, 1997), for integer and sub-voxel (fixed-point) endpoints.
//!
//! | algorithm | connectivity | voxels | source |
//! |---|---|---|---|
//! | [`Line26`] | 26 | `d26 + 1` (integer endpoints) | Fig. 4, midpoint, count-down |
//! | [`Line18`] | 18 | 26-line with corner moves split | paper's remark on 18-lines |
//! | [`Tripod6`] | 6, containment | `1 + Σ|V1ᵢ − V0ᵢ|` | Fig. 6, tripod |
//! | [`AdaptiveRay`], [`adaptive_walk`] | 26 ↔ 6 by proximity flags | | eqs. 9–13 |
//!
//! Every algorithm is a small `Copy` stepping state (`Mid26State`,
//! `TripodState`) over an integer type chosen once per segment (`i64` when the
//! segment is shorter than 2^20 voxels per axis, `i128` otherwise; see
//! [`segment`]), wrapped by an iterator and by a grid walk ([`walk_mut`],
//! [`walk`](fn@walk)) that clips once and moves a linear index by neighbour offsets.
//!
//! Conventions: voxel = closed unit cube centred on an integer point; a point
//! `p` lies in voxel `floor(p + 1/2)`. Ties (lines through voxel edges and
//! corners, column centres exactly between two voxels) follow the world-shift
//! rule documented in [`segment`]: the tripod's voxel set is the same for
//! `a→b` and `b→a`.
//!
//! Cost: O(1) set-up, then O(1) per voxel: two or three sign tests and a few
//! additions per step (branch-free sign masks in the grid walks). On narrow
//! frames (no axis longer than 2^20 voxels) the set-up is `i64`,
//! straight-line and division-free (`LeanFrame`): start states from products
//! that are exact because the result is bounded (see [`segment`]), the
//! 26-line's first and last column centres by three comparisons. Longer
//! segments use the general `i128` formulas; tests pin both against each
//! other. With AVX2 (detected at run time) the iterators' `fold` and the
//! walks run the columns of lines shorter than 256 voxels eight at a time
//! (`lanes`); a line wholly inside the grid is walked without clipping.

pub mod adaptive;
pub mod amanatides_woo;
pub mod clip;
mod lanes;
pub mod line18;
pub mod line26;
pub mod line2d;
pub mod segment;
pub mod tripod6;
pub mod walk;

#[cfg(test)]
mod fast_tests;

pub use adaptive::{AdaptiveRay, OCCUPIED, PROXIMITY, RayMode, adaptive_walk, set_proximity_flags};
pub use clip::GridBox;
pub use line18::Line18;
pub use line26::{Line26, Mid26State};
pub use segment::{DecisionInt, Segment};
pub use tripod6::{Tripod6, TripodState};
pub use walk::{WalkOutcome, walk, walk_mut};
