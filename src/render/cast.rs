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
use crate::line::line26::{Mid26State, Moves, Plan26};
use crate::line::segment::{Frame, Segment};
use crate::line::tripod6::{JUMP_MAX_DELTA, JUMP_MAX_EXTENT, TripodState};

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

/// What the generic walk needs from a ray kind's stepping state.
trait Stepper {
    /// Whether a voxel's proximity flag matters (the adaptive ray).
    const READS_FLAGS: bool;
    /// One step out of the current voxel (not the last); the local move mask.
    fn step(&mut self, flagged: bool) -> usize;
    /// Whether a jump may be tried now (the adaptive ray: in 26 mode).
    fn may_jump(&self) -> bool;
    /// O(1) jump past the local box `[c, c + h]` of the current voxel `c`;
    /// the local moves, or `None`.
    fn jump(&mut self, h: [i64; 3], c: [i64; 3]) -> Option<[i64; 3]>;
    /// A token that changes when the stepping mode changes.
    fn mode(&self) -> bool;
}

/// The tripod 6-ray on its bare decision variables.
struct Six {
    s: TripodState<i64>,
    end: [i64; 3],
}

impl Stepper for Six {
    const READS_FLAGS: bool = false;
    #[inline(always)]
    fn step(&mut self, _: bool) -> usize {
        1 << self.s.step()
    }
    #[inline(always)]
    fn may_jump(&self) -> bool {
        true
    }
    #[inline(always)]
    fn jump(&mut self, h: [i64; 3], c: [i64; 3]) -> Option<[i64; 3]> {
        let h: [i64; 3] =
            std::array::from_fn(|k| h[k].clamp(0, JUMP_MAX_EXTENT).min(self.end[k] - c[k]));
        if (0..3).all(|k| c[k] + h[k] == self.end[k]) {
            return None;
        }
        Some(self.s.exit_box(h))
    }
    #[inline(always)]
    fn mode(&self) -> bool {
        false
    }
}

/// The adaptive ray (and, for lines whose 26-line middle is too short to
/// matter, nothing else): the line engine's adaptive core.
struct Adaptive(Core);

impl Stepper for Adaptive {
    const READS_FLAGS: bool = true;
    #[inline(always)]
    fn step(&mut self, flagged: bool) -> usize {
        self.0.step_on(flagged)
    }
    #[inline(always)]
    fn may_jump(&self) -> bool {
        self.0.mode == RayMode::TwentySix
    }
    #[inline(always)]
    fn jump(&mut self, h: [i64; 3], _: [i64; 3]) -> Option<[i64; 3]> {
        self.0.jump(h)
    }
    #[inline(always)]
    fn mode(&self) -> bool {
        self.0.mode == RayMode::TwentySix
    }
}

/// The 26-ray: the plan's prefix and suffix moves around the middle
/// columns, which step on the bare midpoint variables.
struct TwentySix {
    pre: Moves,
    pre_i: usize,
    mid: Mid26State<i64>,
    mid_left: u64,
    post: Moves,
    post_i: usize,
}

impl Stepper for TwentySix {
    const READS_FLAGS: bool = false;
    #[inline(always)]
    fn step(&mut self, _: bool) -> usize {
        if self.mid_left > 0 && self.pre_i == self.pre.len {
            self.mid_left -= 1;
            self.mid.step()
        } else if self.pre_i < self.pre.len {
            self.pre_i += 1;
            self.pre.m[self.pre_i - 1] as usize
        } else {
            self.post_i += 1;
            self.post.m[self.post_i - 1] as usize
        }
    }
    #[inline(always)]
    fn may_jump(&self) -> bool {
        self.pre_i == self.pre.len && self.mid_left > 0
    }
    #[inline(always)]
    fn jump(&mut self, h: [i64; 3], _: [i64; 3]) -> Option<[i64; 3]> {
        let h = h.map(|x| x.clamp(0, JUMP_MAX_EXTENT));
        let d = self.mid.jump_box(h, self.mid_left);
        if d[0] == 0 {
            return None;
        }
        self.mid_left -= d[0] as u64;
        Some(d)
    }
    #[inline(always)]
    fn mode(&self) -> bool {
        false
    }
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
    if f.d[0] > JUMP_MAX_DELTA {
        // Longer than any grid the renderer accepts: the general core.
        return walk(
            occ,
            &f,
            Adaptive(Core::at_tripod_in(&f, [0; 3])),
            kind,
            false,
            n,
        );
    }
    match kind {
        RayKind::Six => {
            let s = Six {
                s: TripodState::at(&f, [0; 3]),
                end: f.end,
            };
            walk(occ, &f, s, kind, skip, n)
        }
        RayKind::TwentySix => {
            let plan = Plan26::new(&f);
            let s = TwentySix {
                pre: plan.pre,
                pre_i: 0,
                mid: Mid26State::at(&f, plan.mid_start),
                mid_left: plan.mid,
                post: plan.post,
                post_i: 0,
            };
            walk(occ, &f, s, kind, skip, n)
        }
        _ => walk(
            occ,
            &f,
            Adaptive(Core::at_tripod_in(&f, [0; 3])),
            kind,
            skip,
            n,
        ),
    }
}

/// The walk of one exact ray from the segment's start voxel: per brick,
/// jump its empty box when the cloud allows, else visit voxel by voxel.
#[inline(always)]
fn walk<S: Stepper>(
    occ: &OccupancyGrid,
    f: &Frame,
    mut s: S,
    kind: RayKind,
    skip: bool,
    n: &mut CastCounters,
) -> Option<IVec3> {
    let steps = f.mask_steps();
    let te = f.tripod_steps() as i64;
    let v0 = f.voxel_world([0; 3]);
    let local = |v: IVec3| -> [i64; 3] {
        std::array::from_fn(|j| f.sign[j] * i64::from(v[f.perm[j]] - v0[f.perm[j]]))
    };
    let mut v = v0;
    let mut t = 0i64;
    // The adaptive ray must not jump into flags: a box one voxel smaller.
    let margin = i32::from(kind == RayKind::Adaptive);
    loop {
        let b = v >> 3;
        let bi = occ.brick_index(b);
        let k = occ.dist[bi];
        if skip
            && k >= 1
            && s.may_jump()
            && let Some((lo, hi)) = empty_box(b, k, margin, v)
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
            if let Some(d) = s.jump(h, local(v)) {
                n.jumps += 1;
                for (j, &dj) in d.iter().enumerate() {
                    v += steps[1 << j] * dj as i32;
                    t += dj;
                }
                if t > te {
                    return None;
                }
                continue;
            }
        }
        let flags = &occ.bricks[occ.slot[bi] as usize];
        // A switch to 26 mode in a jumpable brick hands back to the jump test.
        let jumpable = skip && k >= 1 && S::READS_FLAGS;
        loop {
            let (w, bit) = word_bit(v);
            n.visited += 1;
            if flags.occ[w] >> bit & 1 == 1 {
                return Some(v);
            }
            if t >= te {
                return None;
            }
            let flag = S::READS_FLAGS && flags.prox[w] >> bit & 1 == 1;
            let was = s.mode();
            let mask = s.step(flag);
            v += steps[mask];
            t += i64::from(mask.count_ones());
            if v >> 3 != b || (jumpable && was != s.mode()) {
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
