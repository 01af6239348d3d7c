//! One traversal driver for every render: a ray kind's stepping state
//! ([`Stepper`]) walks a segment brick by brick and hands each run of
//! voxels to a [`Visitor`] (the first occupied voxel of a grid, or a
//! volume's MIP, composite or iso), which also says, per brick, which box
//! the ray may jump.
//!
//! The exact kinds share [`walk`]: the segment's local frame (major axis
//! first, every direction non-negative), the tripod index `t` (sum of local
//! coordinates) counted to the end voxel's, the world voxel moved by
//! per-move offsets, and inside a brick the in-brick index `lx + 8 ly + 64
//! lz` moved by pointer offsets (1, 8, 64 signed per local axis) until the
//! world voxel leaves the brick: no 3D→1D recomputation and no bounds
//! check while stepping (the segment was clipped into the grid once, so its
//! whole path is in it). (Biased step-count lanes per local axis, as an
//! exit test, cost more to set up per brick than they saved per step on the
//! short brick paths of jumping rays.) The steppers
//! are the lean states of the line engine: the tripod 6-ray ([`Six`]), the
//! 26-line's plan ([`TwentySix`]), the adaptive ray ([`Adaptive`], pinned
//! to the line engine's core by `lean_adaptive_equals_core`), and for wide
//! frames (`i128` decision variables) the core itself ([`CoreStep`]).
//! Amanatides–Woo steps in `f64` on its own state and has its own driver
//! ([`walk_aw`]) over the same visitors.
//!
//! Jumps: where the visitor gives a box the ray may skip (nothing in it can
//! change the result: an empty box of bricks, a transparent or
//! sub-threshold one), the stepper leaves it in O(1), in exactly the state
//! stepping would reach; a box that holds the rest of the ray ends it.

use glam::{DVec3, IVec3};

use crate::line::adaptive::{Core, RayMode};
use crate::line::amanatides_woo::AwStepper;
use crate::line::line26::{Mid26State, Moves, Plan26};
use crate::line::segment::{Frame, Segment};
use crate::line::tripod6::{JUMP_MAX_DELTA, TripodState};

use super::RayKind;
use super::occupancy::local_index;

/// Counters of one ray (summed over an image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct CastCounters {
    /// Voxels the walk stepped onto, up to where the ray ended (not those
    /// jumped over; a grid brick's voxels count whether or not they are
    /// read).
    pub visited: u64,
    /// Jumps over boxes.
    pub jumps: u64,
    /// Rays not cast (their tile was culled).
    pub culled: u64,
}

/// Voxels stepped before they are handed over (a brick's path has at most
/// 22 for the 6-ray, fewer for the others).
pub(crate) const BUF: usize = 32;

/// One run of stepped voxels: world voxel and storage index (the brick's
/// [`Visitor::base`] plus the in-brick index).
pub(crate) type Run = [(IVec3, usize)];

/// The voxels stepped through one brick, handed over as a [`Run`]. Not
/// zeroed per ray (a pixel's walk is short: clearing 768 bytes per ray
/// was measurable): entries are written before they are read.
struct RunBuf {
    items: [std::mem::MaybeUninit<(IVec3, usize)>; BUF],
    /// Invariant: `items[..len]` are initialised.
    len: usize,
}

impl RunBuf {
    #[inline(always)]
    fn new() -> Self {
        RunBuf {
            items: [std::mem::MaybeUninit::uninit(); BUF],
            len: 0,
        }
    }

    /// Appends one voxel (the drivers stop a run at [`BUF`]).
    #[inline(always)]
    fn push(&mut self, x: (IVec3, usize)) {
        self.items[self.len].write(x);
        self.len += 1;
    }

    #[inline(always)]
    fn as_run(&self) -> &Run {
        // SAFETY: `items[..len]` are initialised (the invariant: `push`
        // writes an entry before it counts it, `clear` only shrinks).
        unsafe { std::slice::from_raw_parts(self.items.as_ptr().cast(), self.len) }
    }

    #[inline(always)]
    fn clear(&mut self) {
        self.len = 0;
    }
}

/// What a render does with a ray's voxels.
pub(crate) trait Visitor {
    /// What the visitor looks up once per brick.
    type Brick: Copy;
    /// Locates brick `b` (inside the grid) as the ray enters it.
    fn enter(&mut self, b: IVec3) -> Self::Brick;
    /// Added to the in-brick index `lx + 8 ly + 64 lz` of a run's voxels.
    fn base(&self, brick: Self::Brick) -> usize;
    /// A world box (inclusive) around the ray's voxel `v` in brick `b` that
    /// it may jump now, if any; `in26`: the adaptive ray is in 26 mode.
    fn jump_box(
        &mut self,
        brick: Self::Brick,
        b: IVec3,
        v: IVec3,
        in26: bool,
    ) -> Option<(IVec3, IVec3)>;
    /// Whether the voxels of this brick are read at all (`false`: the ray
    /// steps through it without a run; a grid brick without occupied
    /// voxels).
    #[inline(always)]
    fn reads(&self, _brick: Self::Brick) -> bool {
        true
    }
    /// Whether the brick is inert: no voxel of it is read and none is
    /// flagged, so the ray only steps through it (no run, no flag tests,
    /// no storage index). Implies `!reads(brick)`.
    #[inline(always)]
    fn inert(&self, _brick: Self::Brick) -> bool {
        false
    }
    /// Whether the voxel at storage index `i` ([`Visitor::base`] plus the
    /// in-brick index) is flagged (read by the adaptive ray).
    fn flagged(&self, brick: Self::Brick, i: usize) -> bool;
    /// Whether a change of stepping mode inside this brick must hand back
    /// to the jump test (a 26 stretch may jump where 6 steps may not).
    fn recheck_on_mode_change(&self, brick: Self::Brick) -> bool;
    /// Whether the visitor takes each voxel as it is stepped ([`Visitor::voxel`],
    /// a first hit: no run is buffered) rather than runs ([`Visitor::run`],
    /// whose reads overlap).
    const PER_VOXEL: bool = false;
    /// Takes one voxel (storage index, and its world voxel found by `v` only
    /// where the visitor keeps it) as it is stepped, where
    /// [`Visitor::PER_VOXEL`]; `true` ends the ray at it.
    #[inline(always)]
    fn voxel(&mut self, _brick: Self::Brick, _i: usize, _v: impl FnOnce() -> IVec3) -> bool {
        false
    }
    /// Whether every voxel of the brick is flagged (an adaptive ray in 6
    /// mode stays in it through the whole brick).
    #[inline(always)]
    fn all_flagged(&self, _brick: Self::Brick) -> bool {
        false
    }
    /// Takes a run of voxels in order; `Some(i)` when voxel `i` ends the ray.
    #[inline(always)]
    fn run(&mut self, _brick: Self::Brick, _run: &Run) -> Option<usize> {
        None
    }
    /// Told after each jump (the 26-ray's column bookkeeping).
    #[inline(always)]
    fn jumped(&mut self) {}
}

/// What the driver needs from a ray kind's stepping state.
pub(crate) trait Stepper {
    /// Whether a voxel's flag matters (the adaptive ray).
    const READS_FLAGS: bool;
    /// One step out of the current voxel (not the last); the local move
    /// mask. `local` gives the current voxel's local coordinates (asked
    /// only where the adaptive ray switches mode: stepping does not track
    /// them).
    fn step(&mut self, flagged: bool, local: impl Fn() -> [i64; 3]) -> usize;
    /// Whether a jump may be tried now.
    fn may_jump(&self) -> bool;
    /// O(1) jump past the local box `[c, c + h]` of the current voxel `c`
    /// (`h` clipped to the end voxel, which lies outside the box); the
    /// local moves, or `None` where no jump applies.
    fn jump(&mut self, h: [i64; 3], c: [i64; 3]) -> Option<[i64; 3]>;
    /// Whether the ray is in a 26 stretch of the adaptive ray.
    fn in_26(&self) -> bool;
    /// The tripod state where the ray steps as the 6-ray does through a
    /// brick whose voxels are all flagged (or whose flags it does not read).
    #[inline(always)]
    fn tripod(&mut self) -> Option<&mut TripodState<i64>> {
        None
    }
}

/// The tripod 6-ray on its bare decision variables.
pub(crate) struct Six {
    s: TripodState<i64>,
}

impl Stepper for Six {
    const READS_FLAGS: bool = false;
    #[inline(always)]
    fn step(&mut self, _: bool, _: impl Fn() -> [i64; 3]) -> usize {
        1 << self.s.step()
    }
    #[inline(always)]
    fn may_jump(&self) -> bool {
        true
    }
    #[inline(always)]
    fn jump(&mut self, h: [i64; 3], _: [i64; 3]) -> Option<[i64; 3]> {
        Some(self.s.exit_box(h))
    }
    #[inline(always)]
    fn in_26(&self) -> bool {
        false
    }
    #[inline(always)]
    fn tripod(&mut self) -> Option<&mut TripodState<i64>> {
        Some(&mut self.s)
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
            post: None,
        }
    }
}

impl Stepper for Adaptive<'_> {
    const READS_FLAGS: bool = true;
    #[inline(always)]
    fn step(&mut self, flagged: bool, local: impl Fn() -> [i64; 3]) -> usize {
        if self.twenty_six {
            if flagged {
                self.twenty_six = false;
                self.tri = TripodState::at(self.f, local());
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
        } else if !flagged && self.tri.next_is_major() {
            let c = local();
            if c[0] <= self.f.end[0] - 2 {
                self.twenty_six = true;
                self.mid = Mid26State::at(self.f, c);
                self.mid_left = (self.f.end[0] - 2 - c[0]) as u64;
                self.post = None;
                self.mid.step()
            } else {
                1 << self.tri.step()
            }
        } else {
            1 << self.tri.step()
        }
    }
    /// In 26 mode while the middle columns last; in 6 mode always (the
    /// tripod's box exit: the visitor decides whether a 6 stretch may jump).
    #[inline(always)]
    fn may_jump(&self) -> bool {
        !self.twenty_six || self.mid_left > 0
    }
    #[inline(always)]
    fn jump(&mut self, h: [i64; 3], _: [i64; 3]) -> Option<[i64; 3]> {
        if self.twenty_six {
            self.mid.jump_box(h, &mut self.mid_left)
        } else {
            Some(self.tri.exit_box(h))
        }
    }
    #[inline(always)]
    fn in_26(&self) -> bool {
        self.twenty_six
    }
    /// In 6 mode: a flagged voxel keeps the ray there.
    #[inline(always)]
    fn tripod(&mut self) -> Option<&mut TripodState<i64>> {
        (!self.twenty_six).then_some(&mut self.tri)
    }
}

/// The 26-ray: the plan's prefix and suffix moves around the middle
/// columns, which step on the bare midpoint variables.
pub(crate) struct TwentySix {
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
    fn step(&mut self, _: bool, _: impl Fn() -> [i64; 3]) -> usize {
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
    fn in_26(&self) -> bool {
        false
    }
}

/// The line engine's core as a stepper: wide frames (decision variables
/// beyond `i64`), any exact kind. `fixed`: the flag every voxel gets (the
/// 6-ray: all flagged; the 26-ray: none); `None` for the adaptive ray.
pub(crate) struct CoreStep {
    core: Core,
    fixed: Option<bool>,
}

impl Stepper for CoreStep {
    const READS_FLAGS: bool = true;
    #[inline(always)]
    fn step(&mut self, flagged: bool, _: impl Fn() -> [i64; 3]) -> usize {
        self.core.step_on(self.fixed.unwrap_or(flagged))
    }
    #[inline(always)]
    fn may_jump(&self) -> bool {
        true
    }
    #[inline(always)]
    fn jump(&mut self, h: [i64; 3], _: [i64; 3]) -> Option<[i64; 3]> {
        self.core.jump(h)
    }
    #[inline(always)]
    fn in_26(&self) -> bool {
        self.fixed.is_none() && self.core.mode == RayMode::TwentySix
    }
}

/// Walks one ray of an exact kind over `seg` (clipped into the grid) into
/// `vis`: the lean stepper of the kind, or the core on wide frames.
#[inline(always)]
pub(crate) fn walk_exact<V: Visitor>(
    seg: &Segment,
    kind: RayKind,
    vis: &mut V,
    n: &mut CastCounters,
) {
    let f = Frame::new(seg);
    if f.wide {
        return walk_core(seg, kind, vis, n);
    }
    match kind {
        RayKind::Six => walk(
            &f,
            Six {
                s: TripodState::at(&f, [0; 3]),
            },
            vis,
            n,
        ),
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
            walk(&f, s, vis, n)
        }
        _ => walk(&f, Adaptive::new(&f), vis, n),
    }
}

/// [`walk_exact`] on the line engine's core, whatever the frame: what wide
/// frames take, and the reference the lean steppers are tested against.
pub(crate) fn walk_core<V: Visitor>(
    seg: &Segment,
    kind: RayKind,
    vis: &mut V,
    n: &mut CastCounters,
) {
    let f = Frame::new(seg);
    let core = match kind {
        RayKind::TwentySix => Core::at_26_start(&f),
        _ => Core::at_tripod_in(&f, [0; 3]),
    };
    let fixed = match kind {
        RayKind::Six => Some(true),
        RayKind::TwentySix => Some(false),
        _ => None,
    };
    walk(&f, CoreStep { core, fixed }, vis, n)
}

/// The driver: per brick, the visitor's jump box if the stepper can leave
/// it in O(1), else the brick's voxels stepped into a run for the visitor.
#[inline(always)]
fn walk<S: Stepper, V: Visitor>(f: &Frame, mut s: S, vis: &mut V, n: &mut CastCounters) {
    let steps = f.mask_steps();
    let geo = BrickGeometry::new(f, &steps);
    let te = f.tripod_steps() as i64;
    let v0 = f.voxel_world([0; 3]);
    let local = |v: IVec3| -> [i64; 3] {
        std::array::from_fn(|j| f.sign[j] * i64::from(v[f.perm[j]] - v0[f.perm[j]]))
    };
    // Jumps are exact in i64 up to this extent.
    let jumps = f.d[0] <= JUMP_MAX_DELTA;
    let mut v = v0;
    let mut t = 0i64;
    let mut buf = RunBuf::new();
    loop {
        let b = v >> 3;
        let brick = vis.enter(b);
        if jumps
            && s.may_jump()
            && let Some((lo, hi)) = vis.jump_box(brick, b, v, s.in_26())
        {
            let c = local(v);
            // Extent of the box ahead of v along each local axis, clipped to
            // the end voxel.
            let h: [i64; 3] = std::array::from_fn(|j| {
                let w = f.perm[j];
                i64::from(if f.sign[j] > 0 {
                    hi[w] - v[w]
                } else {
                    v[w] - lo[w]
                })
                .min(f.end[j] - c[j])
            });
            if (0..3).all(|j| c[j] + h[j] >= f.end[j]) {
                // The rest of the ray lies in the box: nothing to see.
                return;
            }
            if let Some(d) = s.jump(h, c) {
                n.jumps += 1;
                for (j, &dj) in d.iter().enumerate() {
                    v += steps[1 << j] * dj as i32;
                    t += dj;
                }
                vis.jumped();
                continue;
            }
        }
        let recheck = S::READS_FLAGS && vis.recheck_on_mode_change(brick);
        if vis.inert(brick) {
            // The same steps as below with every flag false and nothing
            // taken: only the exits (end, brick, mode change) are tested.
            let mut cnt = 0;
            loop {
                cnt += 1;
                if t >= te {
                    n.visited += cnt;
                    return;
                }
                let was = s.in_26();
                let mask = s.step(false, || local(v));
                v += steps[mask];
                t += MASK_STEPS[mask];
                if v >> 3 != b || (recheck && was != s.in_26()) {
                    break;
                }
            }
            n.visited += cnt;
            continue;
        }
        let base = vis.base(brick);
        let reads = vis.reads(brick);
        // The storage index moves by per-mask offsets inside the brick.
        let mut i = base + local_index(v);
        if V::PER_VOXEL
            && reads
            && (!S::READS_FLAGS || vis.all_flagged(brick))
            && let Some(tri) = s.tripod()
        {
            match six_through_brick(tri, vis, brick, (b, v, i), &geo, (&mut t, te), n) {
                Some(next) => {
                    v = next;
                    continue;
                }
                None => return,
            }
        }
        let mut cnt = 0;
        let mut ended = false;
        buf.clear();
        loop {
            if take(vis, brick, reads, (v, i), &mut buf, cnt, n) {
                return;
            }
            cnt += 1;
            if t >= te {
                ended = true;
                break;
            }
            let flag = S::READS_FLAGS && vis.flagged(brick, i);
            let was = s.in_26();
            let mask = s.step(flag, || local(v));
            v += steps[mask];
            // A table, not `count_ones` (a software popcount on the
            // baseline x86-64 target).
            t += MASK_STEPS[mask];
            i = i.wrapping_add_signed(geo.local_offset[mask]);
            if v >> 3 != b || (recheck && was != s.in_26()) || cnt == BUF {
                break;
            }
        }
        if hand_over(vis, brick, reads, &buf, cnt, n) || ended {
            return;
        }
    }
}

/// A stepped voxel (world, storage index), the `cnt`-th of its brick: to
/// a per-voxel visitor at once (`true`: the ray ends there, counted), else
/// into the run. Nothing for a brick the visitor does not read.
#[inline(always)]
fn take<V: Visitor>(
    vis: &mut V,
    brick: V::Brick,
    reads: bool,
    voxel: (IVec3, usize),
    buf: &mut RunBuf,
    cnt: usize,
    n: &mut CastCounters,
) -> bool {
    if V::PER_VOXEL {
        if reads && vis.voxel(brick, voxel.1, || voxel.0) {
            n.visited += cnt as u64 + 1;
            return true;
        }
    } else if reads {
        buf.push(voxel);
    }
    false
}

/// The end of a brick's stepping (`cnt` voxels): the run to a run
/// visitor; `true` when the ray ends in it. Counts the voxels read.
#[inline(always)]
fn hand_over<V: Visitor>(
    vis: &mut V,
    brick: V::Brick,
    reads: bool,
    buf: &RunBuf,
    cnt: usize,
    n: &mut CastCounters,
) -> bool {
    if !V::PER_VOXEL
        && reads
        && let Some(i) = vis.run(brick, buf.as_run())
    {
        n.visited += i as u64 + 1;
        return true;
    }
    n.visited += cnt as u64;
    false
}

/// Steps a local move mask makes (its bit count).
const MASK_STEPS: [i64; 8] = [0, 1, 1, 2, 1, 2, 2, 3];

/// Per-ray tables of the in-brick stepping, by local move mask.
struct BrickGeometry {
    /// Change of the in-brick index `lx + 8 ly + 64 lz`.
    local_offset: [isize; 8],
    /// The same per local axis (a one-axis move).
    axis_offset: [isize; 3],
    /// The world step of each local axis.
    dir: [IVec3; 3],
    /// The in-brick voxel a probe of 0 stands for: per world axis, 0 where
    /// the ray moves up it, 7 where it moves down.
    corner: IVec3,
}

impl BrickGeometry {
    #[inline(always)]
    fn new(f: &Frame, steps: &[IVec3; 8]) -> Self {
        let axis: [isize; 3] =
            std::array::from_fn(|j| f.sign[j] as isize * [1isize, 8, 64][f.perm[j]]);
        // The one-axis moves' steps (the frame's world steps, not
        // recomputed: a cost per ray).
        let dir = [steps[1], steps[2], steps[4]];
        BrickGeometry {
            local_offset: std::array::from_fn(|m| {
                (0..3).filter(|j| m >> j & 1 == 1).map(|j| axis[j]).sum()
            }),
            axis_offset: axis,
            dir,
            // The unit steps are along distinct axes: their sum's negative
            // components are the axes the ray moves down.
            corner: (dir[0] + dir[1] + dir[2]).min(IVec3::ZERO) * -7,
        }
    }

    /// The probe of voxel `v` (see [`six_through_brick`]): per local axis
    /// `j`, in bits `4j..4j + 4`, how far `v` lies into its brick along
    /// the ray's direction on that axis (0..=7).
    #[inline(always)]
    fn probe(&self, v: IVec3) -> u32 {
        let d = (v & 7) - self.corner;
        let [a, b, c] = self.dir.map(|e| d.dot(e) as u32);
        a | b << 4 | c << 8
    }

    /// The world voxel of probe `p` in brick `b` (a field of 8: the voxel
    /// just past the brick along that axis).
    #[inline(always)]
    fn voxel(&self, b: IVec3, p: u32) -> IVec3 {
        let c = |j: u32| (p >> (4 * j) & 15) as i32;
        b * 8 + self.corner + self.dir[0] * c(0) + self.dir[1] * c(1) + self.dir[2] * c(2)
    }
}

/// Set in a probe's field once a move takes it past the brick's last
/// voxel along that local axis.
const PROBE_OUT: u32 = 0x888;

/// The driver's brick loop for a ray stepping as the 6-ray (`tri`) through
/// brick `b` of a per-voxel visitor that reads it, from voxel `v` (storage
/// index `i`), `t` of the end's `te` tripod steps taken: the same voxels,
/// visits and state as the general loop, on fewer live values. The world
/// voxel is not tracked: a probe (per local axis, 4 bits counting the
/// voxels crossed into the brick along the ray's direction, each move
/// adding 1 to its axis's field) tells the brick's exit by one mask test,
/// and gives the voxel where the visitor keeps one or the ray leaves.
/// Returns the voxel the ray moves on to, `None` when it ends.
#[inline(always)]
fn six_through_brick<V: Visitor>(
    tri: &mut TripodState<i64>,
    vis: &mut V,
    brick: V::Brick,
    (b, v, mut i): (IVec3, IVec3, usize),
    geo: &BrickGeometry,
    (t, te): (&mut i64, i64),
    n: &mut CastCounters,
) -> Option<IVec3> {
    let mut s = *tri;
    let mut p = geo.probe(v);
    let mut tt = *t;
    let mut cnt = 0u64;
    let next = loop {
        cnt += 1;
        if vis.voxel(brick, i, || geo.voxel(b, p)) || tt >= te {
            break None;
        }
        let k = s.step();
        tt += 1;
        i = i.wrapping_add_signed(geo.axis_offset[k]);
        p += 1 << (4 * k);
        if p & PROBE_OUT != 0 {
            break Some(geo.voxel(b, p));
        }
    };
    *tri = s;
    *t = tt;
    n.visited += cnt;
    next
}

/// Walks one Amanatides–Woo ray over `seg` into `vis` (6-connected steps in
/// `f64`; jumps by the stepper's own box exit, in 6 mode).
#[inline(always)]
pub(crate) fn walk_aw<V: Visitor>(seg: &Segment, vis: &mut V, n: &mut CastCounters) {
    let [a, b] = [seg.a(), seg.b()].map(|p| DVec3::from_array(p.map(crate::fixed::to_f64)));
    let Ok(mut s) = AwStepper::new(a, b) else {
        return;
    };
    let dir = s.direction();
    let off: [isize; 3] = std::array::from_fn(|k| dir[k] as isize * [1isize, 8, 64][k]);
    let mut buf = RunBuf::new();
    loop {
        let mut v = s.voxel();
        let bk = v >> 3;
        let brick = vis.enter(bk);
        if let Some((lo, hi)) = vis.jump_box(brick, bk, v, false) {
            if !s.jump_past_box(lo, hi) {
                return;
            }
            n.jumps += 1;
            vis.jumped();
            continue;
        }
        let base = vis.base(brick);
        let reads = vis.reads(brick);
        let mut i = base + local_index(v);
        let mut cnt = 0;
        let mut ended = false;
        buf.clear();
        loop {
            if take(vis, brick, reads, (v, i), &mut buf, cnt, n) {
                return;
            }
            cnt += 1;
            let Some(axis) = s.next_axis() else {
                ended = true;
                break;
            };
            s.step();
            v[axis] += dir[axis];
            i = i.wrapping_add_signed(off[axis]);
            if v >> 3 != bk || cnt == BUF {
                break;
            }
        }
        if hand_over(vis, brick, reads, &buf, cnt, n) || ended {
            return;
        }
    }
}

/// The voxels a walk of `kind` steps onto along `seg`, in order, with no
/// jumps and flags drawn at random per voxel (for the adaptive ray): for
/// tests of what any walk may visit.
#[cfg(test)]
pub(crate) fn visited_voxels(seg: &Segment, kind: RayKind, seed: u64) -> Vec<IVec3> {
    struct Record {
        seed: u64,
        seen: Vec<IVec3>,
    }
    impl Visitor for Record {
        type Brick = IVec3;
        fn enter(&mut self, b: IVec3) -> IVec3 {
            b
        }
        fn base(&self, _: IVec3) -> usize {
            0
        }
        fn jump_box(&mut self, _: IVec3, _: IVec3, _: IVec3, _: bool) -> Option<(IVec3, IVec3)> {
            None
        }
        fn flagged(&self, b: IVec3, i: usize) -> bool {
            let h =
                (b.x as u64 * 73_856_093) ^ (b.y as u64 * 19_349_663) ^ (b.z as u64 * 83_492_791);
            (h ^ self.seed ^ i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 62 == 0
        }
        fn recheck_on_mode_change(&self, _: IVec3) -> bool {
            false
        }
        const PER_VOXEL: bool = true;
        fn voxel(&mut self, _: IVec3, _: usize, v: impl FnOnce() -> IVec3) -> bool {
            self.seen.push(v());
            false
        }
    }
    let mut vis = Record {
        seed,
        seen: Vec::new(),
    };
    let mut n = CastCounters::default();
    match kind {
        RayKind::AmanatidesWoo => walk_aw(seg, &mut vis, &mut n),
        _ => walk_exact(seg, kind, &mut vis, &mut n),
    }
    vis.seen
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::line::adaptive::Core;
    use crate::line::segment::{Frame, Segment};
    use rand::{Rng, SeedableRng};

    /// A probe names its voxel: for frames of every major axis and sign,
    /// every voxel of a brick round-trips through its probe, and a move
    /// along a local axis adds 1 to that axis's field, names the voxel one
    /// world step on (past the brick's last voxel, the next brick's first,
    /// its field at 8 and the exit bit set) and moves the storage index
    /// by the axis's offset inside the brick.
    #[test]
    fn probes_name_their_voxels() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(77);
        let mut orders = std::collections::HashSet::new();
        for _ in 0..300 {
            let p = |rng: &mut rand_chacha::ChaCha8Rng| -> [f64; 3] {
                std::array::from_fn(|_| rng.random_range(-40.0..40.0))
            };
            let seg = Segment::from_f64(p(&mut rng), p(&mut rng)).unwrap();
            let f = Frame::new(&seg);
            orders.insert((f.perm, f.sign));
            let geo = BrickGeometry::new(&f, &f.mask_steps());
            let steps = f.world_steps();
            let b = IVec3::new(
                rng.random_range(-3..3),
                rng.random_range(-3..3),
                rng.random_range(-3..3),
            );
            for l in 0..512 {
                let v = b * 8 + IVec3::new(l & 7, l >> 3 & 7, l >> 6);
                let pr = geo.probe(v);
                assert_eq!(geo.voxel(b, pr), v);
                assert_eq!(pr & PROBE_OUT, 0);
                for (j, &step) in steps.iter().enumerate() {
                    let q = pr + (1 << (4 * j));
                    let w = v + step;
                    assert_eq!(geo.voxel(b, q), w, "{f:?} {v} axis {j}");
                    assert_eq!(q & PROBE_OUT != 0, w >> 3 != b);
                    assert_eq!(geo.local_offset[1 << j], geo.axis_offset[j]);
                    if w >> 3 == b {
                        let moved = local_index(w) as isize - local_index(v) as isize;
                        assert_eq!(moved, geo.axis_offset[j]);
                    }
                }
            }
        }
        assert_eq!(orders.len(), 24, "every major axis with every sign");
    }

    /// The frame's world steps and mask steps are its local unit moves as
    /// [`Frame::voxel_world`] maps them (an independent path: it adds
    /// `sign·c` along `perm`), for frames of every major axis and sign,
    /// axis-parallel and diagonal ones (ties between axes) included.
    #[test]
    fn world_steps_are_the_frames_unit_moves() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(78);
        let mut orders = std::collections::HashSet::new();
        for _ in 0..600 {
            // Integer endpoints in a small box: many ties and zero spans.
            let p = |rng: &mut rand_chacha::ChaCha8Rng| -> [f64; 3] {
                std::array::from_fn(|_| f64::from(rng.random_range(-3i32..=3)))
            };
            let (a, b) = (p(&mut rng), p(&mut rng));
            let Ok(seg) = Segment::from_f64(a, b) else {
                continue;
            };
            let f = Frame::new(&seg);
            orders.insert((f.perm, f.sign));
            let c = [2, -1, 3];
            let at = f.voxel_world(c);
            let w = f.world_steps();
            let m = f.mask_steps();
            for k in 0..3 {
                let mut e = c;
                e[k] += 1;
                assert_eq!(f.voxel_world(e) - at, w[k], "{f:?} axis {k}");
            }
            for (mask, &step) in m.iter().enumerate() {
                let e: [i64; 3] = std::array::from_fn(|k| c[k] + (mask >> k & 1) as i64);
                assert_eq!(f.voxel_world(e) - at, step, "{f:?} mask {mask}");
            }
        }
        assert_eq!(orders.len(), 24, "every major axis with every sign");
    }

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
            let mut c = [0i64; 3];
            let mut i = 0u64;
            while core.c != f.end {
                if rng.random_bool(0.1) {
                    flagged = !flagged;
                }
                let m = core.step_on(flagged);
                assert_eq!(lean.step(flagged, || c), m, "{seg:?} step {i}");
                for (k, ck) in c.iter_mut().enumerate() {
                    *ck += (m >> k & 1) as i64;
                }
                assert_eq!(c, core.c);
                i += 1;
                assert!(i <= steps);
            }
        }
    }
}
