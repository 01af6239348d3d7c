//! Casting one discrete ray through an [`OccupancyGrid`] to its first
//! occupied voxel, for each ray kind, with or without skipping.
//!
//! Every kind walks the same fixed-point [`Segment`] (the pixel ray clipped
//! to the padded grid box), so the images differ only by the algorithms.
//! The exact kinds share one stepping state (the adaptive ray's core):
//! the 6-ray is the core with every voxel flagged, the 26-ray with none,
//! the adaptive ray with the grid's proximity flags. The segment was clipped
//! (in `f64`, once per pixel) strictly inside the box of the occupied
//! voxels, so its whole path is in the grid: a ray ends when its tripod
//! index (sum of local coordinates) reaches the end voxel's, with no bounds
//! check; the voxel is tracked in world coordinates, and the brick's flags
//! are looked up once per brick.
//!
//! Skipping (Cohen & Sheffer's proximity clouds at brick granularity): in a
//! brick whose cloud value is `k ≥ 1`, the box of bricks within `k − 1` is
//! free of occupied voxels, and shrunk by one voxel free of flags; the ray
//! jumps to where it would first leave that box, in O(1), in exactly the
//! state stepping would reach (the 6- and 26-rays in the empty box, the
//! adaptive ray in the flag-free box and only in 26 mode, where stepping
//! would stay in 26 mode). So skipping changes no pixel.

use glam::{DVec3, IVec3};

use crate::line::adaptive::{Core, RayMode};
use crate::line::amanatides_woo::AwStepper;
use crate::line::segment::{Frame, Segment};

use super::RayKind;
use super::occupancy::{OccupancyGrid, word_bit};

/// Counters of one ray (summed over an image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct CastCounters {
    /// Voxels whose flags were read.
    pub visited: u64,
    /// Jumps over empty boxes of bricks.
    pub jumps: u64,
}

/// The first occupied voxel along `seg` for `kind`, or `None`.
pub(crate) fn first_hit(
    occ: &OccupancyGrid,
    seg: &Segment,
    kind: RayKind,
    skip: bool,
    n: &mut CastCounters,
) -> Option<IVec3> {
    match kind {
        RayKind::AmanatidesWoo => first_hit_aw(occ, seg, skip, n),
        _ => first_hit_exact(occ, seg, kind, skip, n),
    }
}

/// The world box of bricks within `k − 1` of brick `b`, shrunk by `margin`
/// voxels, if it contains `v`.
#[inline(always)]
fn empty_box(b: IVec3, k: u8, margin: i32, v: IVec3) -> Option<(IVec3, IVec3)> {
    let r = i32::from(k) - 1;
    let lo = (b - r) * 8 + margin;
    let hi = (b + r + 1) * 8 - 1 - margin;
    (v.cmpge(lo).all() && v.cmple(hi).all()).then_some((lo, hi))
}

fn first_hit_exact(
    occ: &OccupancyGrid,
    seg: &Segment,
    kind: RayKind,
    skip: bool,
    n: &mut CastCounters,
) -> Option<IVec3> {
    let f = Frame::new(seg);
    // The segment lies in the grid: its whole path is in-grid.
    debug_assert!(occ.in_grid(seg.start_voxel()) && occ.in_grid(seg.end_voxel()));
    let te = f.tripod_steps() as i64;
    let mut core = match kind {
        RayKind::TwentySix => Core::at_26_start(&f),
        _ => Core::at_tripod_in(&f, [0; 3]),
    };
    let steps = f.mask_steps();
    let mut v = f.voxel_world(core.c);
    let mut t: i64 = core.c.iter().sum();
    let margin = i32::from(kind == RayKind::Adaptive);
    loop {
        if t > te {
            return None;
        }
        let b = v >> 3;
        let bi = occ.brick_index(b);
        let k = occ.dist[bi];
        if skip
            && k >= 1
            && (kind != RayKind::Adaptive || core.mode == RayMode::TwentySix)
            && let Some((lo, hi)) = empty_box(b, k, margin, v)
        {
            {
                // Extent of the box ahead of v along each local axis.
                let h: [i64; 3] = std::array::from_fn(|j| {
                    let w = f.perm[j];
                    i64::from(if f.sign[j] > 0 {
                        hi[w] - v[w]
                    } else {
                        v[w] - lo[w]
                    })
                });
                if core.jump(h).is_some() {
                    n.jumps += 1;
                    v = f.voxel_world(core.c);
                    t = core.c.iter().sum();
                    continue;
                }
            }
        }
        let flags = &occ.bricks[occ.slot[bi] as usize];
        // Whether a switch to 26 mode should hand back to the jump test.
        let jumpable = skip && k >= 1 && kind == RayKind::Adaptive;
        loop {
            let (w, bit) = word_bit(v);
            n.visited += 1;
            if flags.occ[w] >> bit & 1 == 1 {
                return Some(v);
            }
            if t >= te {
                return None;
            }
            let flag = match kind {
                RayKind::Six => true,
                RayKind::TwentySix => false,
                _ => flags.prox[w] >> bit & 1 == 1,
            };
            let was = core.mode;
            let mask = core.step_on(flag);
            v += steps[mask];
            t += i64::from(mask.count_ones());
            if t > te {
                return None;
            }
            if v >> 3 != b || (jumpable && was != core.mode) {
                break;
            }
        }
    }
}

fn first_hit_aw(
    occ: &OccupancyGrid,
    seg: &Segment,
    skip: bool,
    n: &mut CastCounters,
) -> Option<IVec3> {
    let [a, b] = [seg.a(), seg.b()].map(|p| DVec3::from_array(p.map(crate::fixed::to_f64)));
    let mut s = AwStepper::new(a, b).ok()?;
    loop {
        let v = s.voxel();
        let bk = v >> 3;
        let bi = occ.brick_index(bk);
        let k = occ.dist[bi];
        if skip
            && k >= 1
            && let Some((lo, hi)) = empty_box(bk, k, 0, v)
        {
            {
                if !s.jump_past_box(lo, hi) {
                    return None;
                }
                n.jumps += 1;
                continue;
            }
        }
        let flags = &occ.bricks[occ.slot[bi] as usize];
        loop {
            let v = s.voxel();
            let (w, bit) = word_bit(v);
            n.visited += 1;
            if flags.occ[w] >> bit & 1 == 1 {
                return Some(v);
            }
            if !s.step() {
                return None;
            }
            if s.voxel() >> 3 != bk {
                break;
            }
        }
    }
}
