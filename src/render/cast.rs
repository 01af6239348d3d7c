//! Casting one discrete ray through a grid's render bricks ([`RenderBricks`]) to its first
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

use crate::line::amanatides_woo::AwStepper;
use crate::line::line26::{Mid26State, Moves, Plan26};
use crate::line::segment::{Frame, Segment};
use crate::line::tripod6::{JUMP_MAX_DELTA, TripodState};

use super::RayKind;
use super::occupancy::{RenderBricks, word_bit};

/// Counters of one ray (summed over an image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct CastCounters {
    /// Voxels whose flags were read.
    pub visited: u64,
    /// Jumps over empty boxes of bricks.
    pub jumps: u64,
}

/// The first occupied voxel along `seg` for `kind`, or `None`.
pub(crate) fn first_hit<G: RenderBricks>(
    occ: &G,
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
        self.s.exit_box_before(h, c, self.end)
    }
    #[inline(always)]
    fn mode(&self) -> bool {
        false
    }
}

/// The adaptive ray on bare states: the tripod variables in 6 mode, the
/// midpoint variables in 26 mode, switching exactly as the line engine's
/// adaptive core does (26→6 at a flagged voxel; 6→26 at an unflagged voxel
/// whose next tripod step is major, not in the last two columns), with the
/// 26-line's suffix moves (its plan) built only if a ray gets there. Pinned
/// to the core by `lean_adaptive_equals_core`.
pub(crate) struct Adaptive<'f> {
    f: &'f Frame,
    twenty_six: bool,
    tri: TripodState<i64>,
    mid: Mid26State<i64>,
    mid_left: u64,
    /// Local voxel.
    c: [i64; 3],
    post: Option<(Moves, usize)>,
}

impl<'f> Adaptive<'f> {
    pub(crate) fn new(f: &'f Frame) -> Self {
        Adaptive {
            f,
            twenty_six: false,
            tri: TripodState::at(f, [0; 3]),
            mid: Mid26State::at(f, [0; 3]),
            mid_left: 0,
            c: [0; 3],
            post: None,
        }
    }
}

impl Stepper for Adaptive<'_> {
    const READS_FLAGS: bool = true;
    #[inline(always)]
    fn step(&mut self, flagged: bool) -> usize {
        let mask = if self.twenty_six {
            if flagged {
                self.twenty_six = false;
                self.tri = TripodState::at(self.f, self.c);
                1 << self.tri.step()
            } else if self.mid_left > 0 {
                self.mid_left -= 1;
                self.mid.step()
            } else {
                let f = self.f;
                let (moves, i) = self.post.get_or_insert_with(|| (Plan26::new(f).post, 0));
                *i += 1;
                moves.m[*i - 1] as usize
            }
        } else if !flagged && self.c[0] <= self.f.end[0] - 2 && self.tri.next_is_major() {
            self.twenty_six = true;
            self.mid = Mid26State::at(self.f, self.c);
            self.mid_left = (self.f.end[0] - 2 - self.c[0]) as u64;
            self.post = None;
            self.mid.step()
        } else {
            1 << self.tri.step()
        };
        self.c[0] += (mask & 1) as i64;
        self.c[1] += (mask >> 1 & 1) as i64;
        self.c[2] += (mask >> 2 & 1) as i64;
        mask
    }
    #[inline(always)]
    fn may_jump(&self) -> bool {
        self.twenty_six && self.mid_left > 0
    }
    #[inline(always)]
    fn jump(&mut self, h: [i64; 3], _: [i64; 3]) -> Option<[i64; 3]> {
        let d = self.mid.jump_box(h, &mut self.mid_left)?;
        for (ck, dk) in self.c.iter_mut().zip(d) {
            *ck += dk;
        }
        Some(d)
    }
    #[inline(always)]
    fn mode(&self) -> bool {
        self.twenty_six
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
        self.mid.jump_box(h, &mut self.mid_left)
    }
    #[inline(always)]
    fn mode(&self) -> bool {
        false
    }
}

fn first_hit_exact<G: RenderBricks>(
    occ: &G,
    seg: &Segment,
    kind: RayKind,
    skip: bool,
    n: &mut CastCounters,
) -> Option<IVec3> {
    let f = Frame::new(seg);
    // The segment lies in the grid: its whole path is in-grid.
    debug_assert!(occ.contains_voxel(seg.start_voxel()) && occ.contains_voxel(seg.end_voxel()));
    // Grids are at most MAX_RENDER_DIM voxels per axis: the jump arithmetic
    // is exact in i64 for every in-grid segment.
    debug_assert!(f.d[0] <= JUMP_MAX_DELTA);
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
        _ => walk(occ, &f, Adaptive::new(&f), kind, skip, n),
    }
}

/// The walk of one exact ray from the segment's start voxel: per brick,
/// jump its empty box when the cloud allows, else visit voxel by voxel.
#[inline(always)]
fn walk<G: RenderBricks, S: Stepper>(
    occ: &G,
    f: &Frame,
    mut s: S,
    kind: RayKind,
    skip: bool,
    n: &mut CastCounters,
) -> Option<IVec3> {
    let steps = f.mask_steps();
    let geo = BrickGeometry::new(f);
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
        let at = occ.locate(b);
        let k = occ.cloud(at);
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
        let flags = occ.flags(at);
        // A switch to 26 mode in a jumpable brick hands back to the jump test.
        let jumpable = skip && k >= 1 && S::READS_FLAGS;
        // Pointer-offset stepping inside the brick: the bit index
        // `lx + 8 ly + 64 lz` moves by per-mask offsets, and each local axis
        // counts the steps it may still take in this brick in a biased
        // 16-bit lane (`0x100 + steps`): a lane below 0x100 has left it.
        let mut li = ((v.x & 7) + 8 * (v.y & 7) + 64 * (v.z & 7)) as usize;
        let mut lanes = 0u64;
        for j in 0..3 {
            let w = f.perm[j];
            let left = if f.sign[j] > 0 {
                7 - (v[w] & 7)
            } else {
                v[w] & 7
            };
            lanes |= (0x100 + left as u64) << (16 * j);
        }
        loop {
            n.visited += 1;
            if flags.occ[li >> 6] >> (li & 63) & 1 == 1 {
                return Some(v);
            }
            if t >= te {
                return None;
            }
            let flag = S::READS_FLAGS && flags.prox[li >> 6] >> (li & 63) & 1 == 1;
            let was = s.mode();
            let mask = s.step(flag);
            v += steps[mask];
            t += i64::from(mask.count_ones());
            li = li.wrapping_add_signed(geo.local_offset[mask]);
            lanes -= geo.lane_dec[mask];
            if !lanes & LANE_FLOOR != 0 || (jumpable && was != s.mode()) {
                break;
            }
        }
    }
}

/// The 0x100 bit of each of the three step-count lanes.
const LANE_FLOOR: u64 = 0x100 | 0x100 << 16 | 0x100 << 32;

/// Per-ray tables of the in-brick stepping, by local move mask.
struct BrickGeometry {
    /// Change of the in-brick bit index `lx + 8 ly + 64 lz`.
    local_offset: [isize; 8],
    /// One step off the lane of every local axis in the mask.
    lane_dec: [u64; 8],
}

impl BrickGeometry {
    fn new(f: &Frame) -> Self {
        let axis: [isize; 3] =
            std::array::from_fn(|j| f.sign[j] as isize * [1isize, 8, 64][f.perm[j]]);
        BrickGeometry {
            local_offset: std::array::from_fn(|m| {
                (0..3).filter(|j| m >> j & 1 == 1).map(|j| axis[j]).sum()
            }),
            lane_dec: std::array::from_fn(|m| {
                (0..3)
                    .filter(|j| m >> j & 1 == 1)
                    .map(|j| 1u64 << (16 * j))
                    .sum()
            }),
        }
    }
}

fn first_hit_aw<G: RenderBricks>(
    occ: &G,
    seg: &Segment,
    skip: bool,
    n: &mut CastCounters,
) -> Option<IVec3> {
    let [a, b] = [seg.a(), seg.b()].map(|p| DVec3::from_array(p.map(crate::fixed::to_f64)));
    let mut s = AwStepper::new(a, b).ok()?;
    loop {
        let v = s.voxel();
        let bk = v >> 3;
        let at = occ.locate(bk);
        let k = occ.cloud(at);
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
        let flags = occ.flags(at);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::line::adaptive::Core;
    use rand::{Rng, SeedableRng};

    /// The lean adaptive stepper makes the adaptive core's moves, step for
    /// step, under random flag sequences (runs of flagged and unflagged
    /// voxels), to the segment's end.
    #[test]
    fn lean_adaptive_equals_core() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(314);
        for round in 0..3000 {
            let span = if round % 4 == 0 { 5.0 } else { 150.0 };
            let p = |rng: &mut rand_chacha::ChaCha8Rng| -> [f64; 3] {
                std::array::from_fn(|_| {
                    let x: f64 = rng.random_range(-span..span);
                    if rng.random_bool(0.2) { x.round() } else { x }
                })
            };
            let seg = Segment::from_f64(p(&mut rng), p(&mut rng)).unwrap();
            let f = Frame::new(&seg);
            let mut core = Core::at_tripod_in(&f, [0; 3]);
            let mut lean = Adaptive::new(&f);
            let steps = f.tripod_steps();
            let mut flagged = rng.random_bool(0.5);
            let mut i = 0u64;
            while core.c != f.end {
                if rng.random_bool(0.1) {
                    flagged = !flagged;
                }
                let m = core.step_on(flagged);
                assert_eq!(lean.step(flagged), m, "{seg:?} step {i}");
                assert_eq!(lean.c, core.c);
                i += 1;
                assert!(i <= steps);
            }
        }
    }
}
