//! The adaptive ray (Cohen-Or & Kaufman, "Alternating between
//! connectivities", eqs. 9–13): 26-connected steps while the voxels it visits
//! carry no proximity flag, tripod 6-connected steps while they do.
//!
//! Switching corrects the decision variables (eqs. 9–13 with scale `S`:
//! `e_mu = E_mu − D_u·S/2`, `e_mv = E_mv − D_v·S/2`, and `e_vu` from the
//! current voxel; printed eq. 11 has a sign error, errata). Here both forms
//! are re-derived exactly from the voxel's local coordinates (O(1), `i128`),
//! which is the same correction without carrying `e_vu` through 26-steps.
//!
//! * 26→6 at any flagged voxel: every voxel of the 26-line lies on the tripod
//!   path of the (shifted) line, so the tripod continues exactly as the pure
//!   tripod line from there.
//! * 6→26 only at an unflagged voxel whose next tripod step is along the major
//!   axis, and only if the next column is not the last (local `m ≤ M − 2`):
//!   then the line leaves the voxel through its m face, the midpoint recurrence
//!   is valid from it, and the 26-line's suffix to `V1` stays intact (errata:
//!   switching back anywhere else gives voxels not touched by the line or not
//!   26-adjacent in ~5% of switch-backs).
//!
//! # Guarantees
//! The ray is a subsequence of the tripod path (so every voxel is touched);
//! it steps 6-connected from every flagged voxel; with flags of Chebyshev
//! radius ≥ 1 around occupied voxels, its first occupied voxel is the tripod
//! line's first occupied voxel (a 26-step from an unflagged voxel only skips
//! voxels within Chebyshev distance 1 of it, which are unoccupied).

use std::ops::ControlFlow;

use glam::IVec3;

use crate::grid::{DenseGrid, Voxel};

use super::clip::{GridBox, tripod_range};
use super::line26::{AnyMid, Cursor26, Plan26};
use super::segment::{Frame, Segment};
use super::tripod6::AnyTripod;
use super::walk::{GridShape, Offsets, WalkOutcome};

/// Cell bit: the voxel is occupied (part of an object).
pub const OCCUPIED: u8 = 1 << 0;
/// Cell bit: the voxel is within the proximity radius of an occupied voxel
/// (set by [`set_proximity_flags`]; occupied voxels carry it too).
pub const PROXIMITY: u8 = 1 << 1;

/// Sets [`PROXIMITY`] on every voxel within Chebyshev distance `radius` of a
/// voxel with [`OCCUPIED`] (including the occupied voxels themselves), and
/// clears it everywhere else. Separable running-window dilation: O(cells),
/// independent of `radius`.
///
/// ```
/// use voxkit::grid::{DenseGrid, MemoryLimit};
/// use voxkit::line::{set_proximity_flags, OCCUPIED, PROXIMITY};
/// let mut g = DenseGrid::new([5, 5, 5], 0u8, MemoryLimit::DEFAULT).unwrap();
/// *g.get_mut([2, 2, 2].into()).unwrap() = OCCUPIED;
/// set_proximity_flags(&mut g, 1);
/// assert_eq!(g.as_slice().iter().filter(|&&c| c & PROXIMITY != 0).count(), 27);
/// ```
pub fn set_proximity_flags(grid: &mut DenseGrid<u8>, radius: u32) {
    let [nx, ny, nz] = grid.dims();
    let mut mark: Vec<bool> = grid.as_slice().iter().map(|c| c & OCCUPIED != 0).collect();
    let r = radius as usize;
    let mut line = Vec::new();
    // Dilate along one axis: `n` cells per line, `stride` apart, lines at `starts`.
    let mut dilate = |mark: &mut Vec<bool>, n: usize, stride: usize, starts: Vec<usize>| {
        for s in starts {
            line.clear();
            line.extend((0..n).map(|i| mark[s + i * stride]));
            let mut count = 0usize;
            // count = number of marks in [i − r, i + r].
            for &b in line.iter().take(r.min(n)) {
                count += usize::from(b);
            }
            for i in 0..n {
                if i + r < n {
                    count += usize::from(line[i + r]);
                }
                if i > r {
                    count -= usize::from(line[i - r - 1]);
                }
                mark[s + i * stride] = count > 0;
            }
        }
    };
    let xs: Vec<usize> = (0..ny * nz).map(|yz| yz * nx).collect();
    dilate(&mut mark, nx, 1, xs);
    let ys: Vec<usize> = (0..nz)
        .flat_map(|z| (0..nx).map(move |x| x + z * nx * ny))
        .collect();
    dilate(&mut mark, ny, nx, ys);
    let zs: Vec<usize> = (0..nx * ny).collect();
    dilate(&mut mark, nz, nx * ny, zs);
    for (c, m) in grid.as_mut_slice().iter_mut().zip(mark) {
        *c = if m { *c | PROXIMITY } else { *c & !PROXIMITY };
    }
}

/// Which connectivity the adaptive ray is stepping with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayMode {
    /// 26-connected (midpoint) steps.
    TwentySix,
    /// 6-connected (tripod) steps.
    Six,
}

/// The stepping state of a discrete ray: the adaptive ray's core, which is
/// also the pure tripod ray (every voxel flagged: it never leaves 6 mode) and
/// the pure 26-line (no voxel flagged: it never leaves 26 mode). The ray
/// caster ([`crate::render`]) drives it voxel by voxel and jumps it across
/// empty boxes ([`Core::jump`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Core {
    pub(crate) f: Frame,
    plan: Plan26,
    /// Current voxel, local frame.
    pub(crate) c: [i64; 3],
    pub(crate) mode: RayMode,
    cursor: Cursor26,
    tri: AnyTripod,
}

impl Core {
    pub(crate) fn new(seg: &Segment) -> Self {
        let f = Frame::new(seg);
        let plan = Plan26::new(&f);
        Core {
            f,
            plan,
            c: [0; 3],
            mode: RayMode::TwentySix,
            cursor: Cursor26::at(&f, plan, 0),
            tri: AnyTripod::at(&f, [0; 3]),
        }
    }

    /// Starts in tripod mode at local voxel `c` of the tripod path.
    pub(crate) fn at_tripod(seg: &Segment, c: [i64; 3]) -> Self {
        let mut core = Core::new(seg);
        core.c = c;
        core.mode = RayMode::Six;
        core.tri = AnyTripod::at(&core.f, c);
        core
    }

    /// [`Core::at_tripod`] on a frame already built.
    pub(crate) fn at_tripod_in(f: &Frame, c: [i64; 3]) -> Self {
        let plan = Plan26::new(f);
        Core {
            f: *f,
            plan,
            c,
            mode: RayMode::Six,
            cursor: Cursor26::at(f, plan, 0),
            tri: AnyTripod::at(f, c),
        }
    }

    /// Starts in 26 mode at the segment's start voxel.
    pub(crate) fn at_26_start(f: &Frame) -> Self {
        let plan = Plan26::new(f);
        Core {
            f: *f,
            plan,
            c: [0; 3],
            mode: RayMode::TwentySix,
            cursor: Cursor26::at(f, plan, 0),
            tri: AnyTripod::at(f, [0; 3]),
        }
    }

    /// Whether the current voxel is the segment's end voxel.
    #[cfg(test)]
    pub(crate) fn at_end(&self) -> bool {
        self.c == self.f.end
    }

    /// Jumps past the local box `[c, c + h]` of the current voxel (`h ≥ 0`,
    /// any size: clipped here) in O(1), in the current mode, to exactly the
    /// voxel and state that stepping reaches first outside the box (or, in
    /// 26 mode, the last column of the line's middle). The caller vouches
    /// that nothing in the box would change the walk: no occupied voxel, and
    /// for the adaptive ray no flagged one (26 mode stays 26 mode across
    /// unflagged voxels, and its columns are those of the 26-line). Returns
    /// the local moves, or `None` where no jump applies (a wide frame, the
    /// 26-line's prefix or suffix, the end voxel inside the box).
    pub(crate) fn jump(&mut self, h: [i64; 3]) -> Option<[i64; 3]> {
        if self.f.d[0] > super::tripod6::JUMP_MAX_DELTA {
            return None;
        }
        let delta = match self.mode {
            RayMode::Six => {
                let AnyTripod::Narrow(s) = &mut self.tri else {
                    return None;
                };
                s.exit_box_before(h, self.c, self.f.end)?
            }
            RayMode::TwentySix => {
                let cur = &mut self.cursor;
                if cur.pre_i < cur.plan.pre.len {
                    return None;
                }
                let AnyMid::Narrow(s) = &mut cur.mid else {
                    return None;
                };
                s.jump_box(h, &mut cur.mid_left)?
            }
        };
        for (ck, dk) in self.c.iter_mut().zip(delta) {
            *ck += dk;
        }
        Some(delta)
    }

    /// The move (local mask) out of the current voxel given its flag, or
    /// `None` at the end voxel.
    #[inline]
    fn step(&mut self, flagged: bool) -> Option<usize> {
        if self.c == self.f.end {
            return None;
        }
        Some(self.step_on(flagged))
    }

    /// [`Core::step`] before the end voxel (the caller knows it is not there).
    #[inline(always)]
    pub(crate) fn step_on(&mut self, flagged: bool) -> usize {
        if self.mode == RayMode::TwentySix && flagged {
            self.mode = RayMode::Six;
            self.tri = AnyTripod::at(&self.f, self.c);
        } else if self.mode == RayMode::Six
            && !flagged
            && self.c[0] <= self.f.end[0] - 2
            && self.tri.next_is_major()
        {
            self.mode = RayMode::TwentySix;
            self.cursor = Cursor26 {
                plan: self.plan,
                pre_i: self.plan.pre.len,
                mid_left: (self.f.end[0] - 1 - self.c[0]) as u64,
                mid: AnyMid::at(&self.f, self.c),
                post_i: 0,
            };
        }
        let mask = match self.mode {
            RayMode::TwentySix => self.cursor.advance(),
            RayMode::Six => 1 << self.tri.step(),
        };
        for (k, ck) in self.c.iter_mut().enumerate() {
            *ck += (mask >> k & 1) as i64;
        }
        mask
    }
}

/// Iterator over the adaptive ray of a segment, with proximity flags given by
/// a predicate on voxels; starts at the start voxel in 26 mode. With no flags
/// it is exactly [`super::Line26`]; with every voxel flagged it is
/// [`super::Tripod6`].
///
/// ```
/// use voxkit::line::{AdaptiveRay, Line26, Segment};
/// let s = Segment::from_f64([0.0, 0.0, 0.0], [9.0, 4.0, 2.5]).unwrap();
/// let fast: Vec<_> = AdaptiveRay::new(&s, |_| false).collect();
/// assert_eq!(fast, Line26::new(&s).collect::<Vec<_>>());
/// ```
#[derive(Clone, Debug)]
pub struct AdaptiveRay<F> {
    core: Core,
    flagged: F,
    done: bool,
}

impl<F: FnMut(Voxel) -> bool> AdaptiveRay<F> {
    /// The adaptive ray of `seg`, `flagged(v)` telling whether voxel `v`
    /// carries a proximity flag.
    pub fn new(seg: &Segment, flagged: F) -> Self {
        AdaptiveRay {
            core: Core::new(seg),
            flagged,
            done: false,
        }
    }

    /// The mode the ray will use for its next step.
    pub fn mode(&self) -> RayMode {
        self.core.mode
    }
}

impl<F: FnMut(Voxel) -> bool> Iterator for AdaptiveRay<F> {
    type Item = IVec3;
    fn next(&mut self) -> Option<IVec3> {
        if self.done {
            return None;
        }
        let v = self.core.f.voxel_world(self.core.c);
        let fl = (self.flagged)(v);
        if self.core.step(fl).is_none() {
            self.done = true;
        }
        Some(v)
    }
}

impl<F: FnMut(Voxel) -> bool> std::iter::FusedIterator for AdaptiveRay<F> {}

/// Casts the adaptive ray of `seg` through a flag grid (cells with
/// [`OCCUPIED`] / [`PROXIMITY`] bits), calling `visit` on each visited in-grid
/// cell until it returns `Break` (typically at the first occupied cell).
///
/// The ray enters the grid at the tripod line's first in-grid voxel (clipped
/// once, O(1)) in 6 mode and leaves when its tripod index (sum of local
/// coordinates) passes the last in-grid tripod voxel: the ray is a
/// subsequence of the tripod path, whose in-grid voxels are one run, so one
/// comparison per step replaces bounds checks, and cells are read by a linear
/// index moved by neighbour offsets. Outside the grid nothing is flagged;
/// starting at the tripod entry keeps the first-hit guarantee at the grid
/// boundary.
///
/// ```
/// use std::ops::ControlFlow;
/// use voxkit::grid::{DenseGrid, MemoryLimit};
/// use voxkit::line::{adaptive_walk, set_proximity_flags, Segment, OCCUPIED};
/// let mut g = DenseGrid::new([16, 16, 16], 0u8, MemoryLimit::DEFAULT).unwrap();
/// *g.get_mut([10, 5, 5].into()).unwrap() = OCCUPIED;
/// set_proximity_flags(&mut g, 1);
/// let s = Segment::from_f64([-2.0, 5.2, 4.9], [20.0, 5.2, 5.1]).unwrap();
/// let hit = adaptive_walk(&g, &s, |&c| {
///     if c & OCCUPIED != 0 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
/// });
/// assert_eq!(hit.stopped_at().map(|v| v.to_array()), Some([10, 5, 5]));
/// ```
pub fn adaptive_walk(
    grid: &DenseGrid<u8>,
    seg: &Segment,
    mut visit: impl FnMut(&u8) -> ControlFlow<()>,
) -> WalkOutcome {
    let shape = GridShape::of(grid);
    let f = Frame::new(seg);
    let gbox = GridBox::from_dims(shape.dims);
    let Some((c, n)) = tripod_range(&f, &gbox) else {
        return WalkOutcome::Completed { visited: 0 };
    };
    // In-grid tripod indices: ts..=te (te ≤ the end voxel's index).
    let ts: i64 = c.iter().sum();
    let te = ts + n as i64 - 1;
    let off = Offsets::new(&shape.table, &f);
    let cells = grid.as_slice();
    let mut core = Core::at_tripod(seg, c);
    let mut idx = shape.index(f.voxel_world(c));
    let mut t = ts;
    let mut visited = 0u64;
    loop {
        debug_assert!(idx < cells.len() && t >= ts && t <= te);
        // SAFETY: `idx` is the linear index of a voxel of the tripod path
        // with tripod index `t` in `ts..=te`, the path's in-grid run
        // (`tripod_range`), so `idx < cells.len()`: the loop leaves as soon as
        // `t` passes `te`. Tested against the checked ray iterator in
        // `adaptive_ray_properties` (debug builds assert the bound).
        let cell = unsafe { cells.get_unchecked(idx) };
        visited += 1;
        if visit(cell).is_break() {
            return WalkOutcome::Stopped {
                index: idx,
                voxel: grid.voxel_of_index(idx),
            };
        }
        if t >= te {
            break;
        }
        let mask = core.step_on(cell & PROXIMITY != 0);
        t += i64::from(mask.count_ones());
        if t > te {
            break;
        }
        idx = idx.wrapping_add_signed(off.mask[mask]);
    }
    WalkOutcome::Completed { visited }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::MemoryLimit;
    use rand::{Rng, SeedableRng};

    fn random_segment(rng: &mut rand_chacha::ChaCha8Rng, span: f64) -> Segment {
        let p = |rng: &mut rand_chacha::ChaCha8Rng| -> [f64; 3] {
            std::array::from_fn(|_| {
                let x = rng.random_range(-span..span);
                // Ties: lattice and half-lattice endpoints now and then.
                match rng.random_range(0..6) {
                    0 => x.round(),
                    1 => x.round() + 0.5,
                    _ => x,
                }
            })
        };
        Segment::from_f64(p(rng), p(rng)).unwrap()
    }

    /// Steps `core` (with a constant flag) until its voxel leaves the local
    /// box `[c0, c0 + h]` or the line ends; in 26 mode also stops after
    /// `max_cols` columns.
    fn step_out(core: &mut Core, c0: [i64; 3], h: [i64; 3], flag: bool, max_cols: i64) {
        let h = h.map(|x| x.min(super::super::tripod6::JUMP_MAX_EXTENT));
        let inside = |c: [i64; 3]| (0..3).all(|k| c[k] <= c0[k] + h[k]);
        while inside(core.c) && !core.at_end() && core.c[0] - c0[0] < max_cols {
            core.step_on(flag);
        }
    }

    /// A jump lands exactly where stepping first leaves the box, with the
    /// same state (the next moves agree), for the tripod and the 26-line, on
    /// random segments with ties, boxes of every shape.
    #[test]
    fn jumps_equal_stepping() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(77);
        let (mut jumped6, mut jumped26) = (0, 0);
        for round in 0..4000 {
            let span = if round % 3 == 0 { 8.0 } else { 300.0 };
            let seg = random_segment(&mut rng, span);
            let f = Frame::new(&seg);
            let h: [i64; 3] = std::array::from_fn(|_| match rng.random_range(0..4) {
                0 => 0,
                1 => rng.random_range(0..4),
                _ => rng.random_range(0..200),
            });
            let flag = round % 2 == 0;
            let mut core = if flag {
                Core::at_tripod_in(&f, [0; 3])
            } else {
                Core::at_26_start(&f)
            };
            // Walk a random prefix first.
            for _ in 0..rng.random_range(0..40) {
                if core.at_end() {
                    break;
                }
                core.step_on(flag);
            }
            let c0 = core.c;
            let mut want = core;
            let mut got = core;
            let Some(delta) = got.jump(h) else { continue };
            let max_cols = if flag { i64::MAX } else { delta[0] };
            step_out(&mut want, c0, h, flag, max_cols);
            assert_eq!(got.c, want.c, "{seg:?} h {h:?} from {c0:?} (six: {flag})");
            if flag {
                jumped6 += 1
            } else {
                jumped26 += 1
            }
            for _ in 0..30 {
                if want.at_end() {
                    assert!(got.at_end());
                    break;
                }
                assert_eq!(
                    got.step_on(flag),
                    want.step_on(flag),
                    "{seg:?} after the jump"
                );
            }
        }
        assert!(jumped6 > 1000 && jumped26 > 600, "{jumped6} {jumped26}");
    }

    /// The adaptive ray in 26 mode jumps exactly like stepping too, also
    /// right after switching back from 6 mode.
    #[test]
    fn adaptive_jumps_after_switching_back() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(78);
        let mut jumped = 0;
        for _ in 0..3000 {
            let seg = random_segment(&mut rng, 200.0);
            let f = Frame::new(&seg);
            let mut core = Core::at_tripod_in(&f, [0; 3]);
            // Flagged for a while (6 mode), then unflagged (switch back).
            for i in 0..rng.random_range(1..30) {
                if core.at_end() {
                    break;
                }
                core.step_on(i < 10);
            }
            if core.mode != RayMode::TwentySix || core.at_end() {
                continue;
            }
            let h: [i64; 3] = std::array::from_fn(|_| rng.random_range(0..100));
            let c0 = core.c;
            let mut got = core;
            let Some(delta) = got.jump(h) else { continue };
            let mut want = core;
            step_out(&mut want, c0, h, false, delta[0]);
            assert_eq!(got.c, want.c, "{seg:?}");
            for _ in 0..30 {
                if want.at_end() {
                    break;
                }
                assert_eq!(got.step_on(false), want.step_on(false));
            }
            jumped += 1;
        }
        assert!(jumped > 500, "{jumped}");
    }

    /// The walk as first written: bounds-checked reads, per-axis box test
    /// and end test at every step.
    fn checked_reference(grid: &DenseGrid<u8>, seg: &Segment) -> Vec<usize> {
        let shape = GridShape::of(grid);
        let f = Frame::new(seg);
        let gbox = GridBox::from_dims(shape.dims);
        let Some((c, _)) = tripod_range(&f, &gbox) else {
            return Vec::new();
        };
        let (_, h) = gbox.local(&f);
        let off = Offsets::new(&shape.table, &f);
        let cells = grid.as_slice();
        let mut core = Core::at_tripod(seg, c);
        let mut idx = shape.index(f.voxel_world(c));
        let mut out = Vec::new();
        loop {
            out.push(idx);
            let Some(mask) = core.step(cells[idx] & PROXIMITY != 0) else {
                break;
            };
            if (0..3).any(|k| core.c[k] > h[k]) {
                break;
            }
            idx = idx.wrapping_add_signed(off.mask[mask]);
        }
        out
    }

    /// The pointer-offset walk (one tripod-index test per step, unchecked
    /// reads) visits exactly the cells of the checked walk, in order, on
    /// segments entering, leaving, crossing and missing the grid.
    #[test]
    fn walk_matches_checked_reference() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4242);
        let dims = [13, 9, 11];
        for _ in 0..20 {
            let mut g = DenseGrid::new(dims, 0u8, MemoryLimit::DEFAULT).unwrap();
            for c in g.as_mut_slice().iter_mut() {
                if rng.random_bool(0.01) {
                    *c = OCCUPIED;
                }
            }
            set_proximity_flags(&mut g, 1);
            for _ in 0..150 {
                let p = |rng: &mut rand_chacha::ChaCha8Rng| -> [f64; 3] {
                    std::array::from_fn(|k| {
                        let x = rng.random_range(-4.0..dims[k] as f64 + 4.0);
                        if rng.random_bool(0.2) { x.round() } else { x }
                    })
                };
                let seg = Segment::from_f64(p(&mut rng), p(&mut rng)).unwrap();
                let want = checked_reference(&g, &seg);
                let mut got = Vec::new();
                let cells = g.as_slice().as_ptr();
                let out = adaptive_walk(&g, &seg, |c| {
                    // SAFETY: `c` is a reference into `g`'s cells.
                    got.push(unsafe { (c as *const u8).offset_from(cells) } as usize);
                    ControlFlow::Continue(())
                });
                assert_eq!(got, want, "{seg:?}");
                assert_eq!(
                    out,
                    WalkOutcome::Completed {
                        visited: want.len() as u64
                    }
                );
            }
        }
    }
}
