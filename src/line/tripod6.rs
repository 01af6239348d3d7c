//! The tripod 6-connected line (Cohen-Or & Kaufman, Fig. 6), exact for
//! sub-voxel endpoints.
//!
//! At each voxel the line leaves through one of the three faces of the
//! "tripod" (the faces ahead along m, u, v). Two sign tests of the decision
//! variables `e_mu`, `e_mv`, `e_vu` (see [`super::segment`]) pick the face:
//! `e_mu < 0` means the m face comes before the u face, and so on. The paper's
//! printed figure has `e_xz = A_2` where `e_xz −= 2A` is meant; the updates here
//! are derived from `e_ij = D_j·r_i − D_i·r_j`:
//!
//! | step | `e_mu` | `e_mv` | `e_vu` |
//! |---|---|---|---|
//! | m | `+D_u·S` | `+D_v·S` | |
//! | u | `−D_m·S` | | `−D_v·S` |
//! | v | | `−D_m·S` | `+D_u·S` |
//!
//! # Guarantees
//! * 6-connected, first voxel = the start point's voxel, last = the end
//!   point's voxel, exactly `1 + Σ|V1ᵢ − V0ᵢ|` voxels (faces crossed + 1).
//! * Containment: the union of the closed voxels covers the closed segment.
//! * The voxel *set* of `a→b` equals that of `b→a` (world-shift tie rule).

use std::ops::ControlFlow;

use glam::IVec3;

use super::clip::{GridBox, tripod_range};
use super::segment::{DecisionInt, Frame, LeanFrame, Segment};

/// The stepping state of the tripod: three decision variables and the three
/// scaled direction components. `Copy`, no coordinates: a walk moves a
/// linear index, an iterator a voxel.
#[derive(Clone, Copy, Debug)]
pub struct TripodState<T> {
    e: [T; 3],
    dm: T,
    du: T,
    dv: T,
}

impl<T: DecisionInt> TripodState<T> {
    #[inline]
    pub(crate) fn at(frame: &Frame, c: [i64; 3]) -> Self {
        let [dm, du, dv] = frame.scaled_d::<T>();
        TripodState {
            e: frame.tripod_e_t::<T>(c),
            dm,
            du,
            dv,
        }
    }

    /// One step: returns the local axis (0 = m, 1 = u, 2 = v) of the face
    /// the line leaves through, and updates the decision variables.
    ///
    /// Branch-free: the three sign tests become masks `m` (m step: `e_mu < 0`
    /// and `e_mv < 0`), `u` (`e_mu ≥ 0` and `e_vu ≥ 0`) and `v` (the rest),
    /// and each variable adds its table entry under its mask. Random slopes
    /// make the branches of the decision tree unpredictable.
    #[inline(always)]
    pub fn step(&mut self) -> usize {
        let [a, b, c] = self.e.map(T::neg_mask);
        let m = a & b;
        let u = !(a | c);
        let v = !(m | u);
        self.e[0] += (m & self.du) - (u & self.dm);
        self.e[1] += (m & self.dv) - (v & self.dm);
        self.e[2] += (v & self.du) - (u & self.dv);
        (u.low_bits() & 1) | (v.low_bits() & 2)
    }

    /// [`TripodState::step`] as the decision tree (same decisions). Used
    /// where the select form runs out of registers: the iterator's `fold`
    /// also carries the world voxel and the caller's accumulator, and there
    /// the branch-free form compiled to a loop with spills several times the
    /// size of this one.
    #[inline(always)]
    pub(crate) fn step_tree(&mut self) -> usize {
        if self.e[0] < T::ZERO {
            if self.e[1] < T::ZERO {
                self.e[0] += self.du;
                self.e[1] += self.dv;
                0
            } else {
                self.e[1] -= self.dm;
                self.e[2] += self.du;
                2
            }
        } else if self.e[2] < T::ZERO {
            self.e[1] -= self.dm;
            self.e[2] += self.du;
            2
        } else {
            self.e[0] -= self.dm;
            self.e[2] -= self.dv;
            1
        }
    }

    /// Whether the next step is along the major axis.
    #[inline]
    pub(crate) fn next_is_major(&self) -> bool {
        self.e[0] < T::ZERO && self.e[1] < T::ZERO
    }
}

/// Largest box extent (voxels per local axis) an O(1) jump may take: keeps
/// every product `h·D·S` of [`TripodState::exit_box`] and
/// [`super::line26::Mid26State::jump_box`] below `2^62` for direction
/// components up to [`JUMP_MAX_DELTA`].
pub(crate) const JUMP_MAX_EXTENT: i64 = 127;

/// Direction components (fixed point, `D·S` below `2^55`: 2^15 voxels) up to
/// which jumps are exact in `i64`.
pub(crate) const JUMP_MAX_DELTA: i64 = 1 << 35;

/// `floor(a / b)` for `b > 0`.
#[inline(always)]
fn floor_div(a: i64, b: i64) -> i64 {
    a.div_euclid(b)
}

impl TripodState<i64> {
    /// Moves the state past the local box `[c, c + h]` of the current voxel
    /// `c` (`h ≥ 0`, clipped here to [`JUMP_MAX_EXTENT`]; the box already
    /// clipped to the end voxel, at least one axis ending before it; see
    /// [`TripodState::exit_box_before`]): to the first voxel of
    /// the tripod path outside the box, in O(1). Returns the local moves
    /// `[δm, δu, δv]`; the state is exactly the one stepping would reach.
    ///
    /// The exit face is the first of the box's three far planes the line
    /// crosses: the tripod's decision tree on the decision variables of the
    /// virtual voxel `c + h` (they compare exactly those plane crossings).
    /// Along each other axis `j`, the path has crossed the planes `j` crosses
    /// before that one: a count from the pair's variable, one division.
    pub(crate) fn exit_box(&mut self, h: [i64; 3]) -> [i64; 3] {
        let h = h.map(|x| x.clamp(0, JUMP_MAX_EXTENT));
        let d = [self.dm, self.du, self.dv];
        debug_assert!(
            d.iter()
                .all(|&x| x < JUMP_MAX_DELTA << crate::fixed::FRAC_BITS)
        );
        // Biased variable of ordered pair (i, j) at offset `o` from c.
        let at = |n: usize, o: [i64; 3]| {
            let (i, j) = super::segment::PAIRS[n];
            self.e[n] + o[i] * d[j] - o[j] * d[i]
        };
        let (a, b, c) = (at(0, h) < 0, at(1, h) < 0, at(2, h) < 0);
        let k = if a && b {
            0
        } else if !a && !c {
            1
        } else {
            2
        };
        let mut delta = [0i64; 3];
        delta[k] = h[k] + 1;
        for j in 0..3 {
            if j == k {
                continue;
            }
            // Planes of j crossed before the plane of k at c_k + h_k + 1/2.
            let n = match pair_index(j, k) {
                // Stored as (j, k): "j first" ⇔ E_jk + n·d_k − h_k·d_j < 0.
                (n, false) => {
                    let x = h[k] * d[j] - self.e[n];
                    if x <= 0 { 0 } else { -floor_div(-x, d[k]) }
                }
                // Stored as (k, j): "j first" ⇔ E_kj + h_k·d_j − n·d_k ≥ 0.
                (n, true) => (floor_div(self.e[n] + h[k] * d[j], d[k]) + 1).max(0),
            };
            delta[j] = n;
        }
        for n in 0..3 {
            let (i, j) = super::segment::PAIRS[n];
            self.e[n] += delta[i] * d[j] - delta[j] * d[i];
        }
        delta
    }
}

impl TripodState<i64> {
    /// [`TripodState::exit_box`] for a line at local voxel `c` ending at
    /// local voxel `end`: the box clipped to the end voxel, `None` (no move)
    /// if the line ends inside it.
    pub(crate) fn exit_box_before(
        &mut self,
        h: [i64; 3],
        c: [i64; 3],
        end: [i64; 3],
    ) -> Option<[i64; 3]> {
        let h: [i64; 3] =
            std::array::from_fn(|k| h[k].clamp(0, JUMP_MAX_EXTENT).min(end[k] - c[k]));
        if (0..3).all(|k| c[k] + h[k] == end[k]) {
            return None;
        }
        Some(self.exit_box(h))
    }
}

/// The stored decision variable of the unordered pair `{i, j}`: its index in
/// [`super::segment::PAIRS`] and whether it is stored as `(j, i)`.
#[inline(always)]
fn pair_index(i: usize, j: usize) -> (usize, bool) {
    match (i, j) {
        (0, 1) => (0, false),
        (1, 0) => (0, true),
        (0, 2) => (1, false),
        (2, 0) => (1, true),
        (2, 1) => (2, false),
        _ => (2, true),
    }
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum AnyTripod {
    Narrow(TripodState<i64>),
    Wide(TripodState<i128>),
}

impl AnyTripod {
    #[inline]
    pub(crate) fn at(frame: &Frame, c: [i64; 3]) -> Self {
        if frame.wide {
            AnyTripod::Wide(TripodState::at(frame, c))
        } else {
            AnyTripod::Narrow(TripodState::at(frame, c))
        }
    }
    #[inline(always)]
    pub(crate) fn step(&mut self) -> usize {
        match self {
            AnyTripod::Narrow(s) => s.step(),
            AnyTripod::Wide(s) => s.step(),
        }
    }
    #[inline]
    pub(crate) fn next_is_major(&self) -> bool {
        match self {
            AnyTripod::Narrow(s) => s.next_is_major(),
            AnyTripod::Wide(s) => s.next_is_major(),
        }
    }
}

/// Iterator over the voxels of the tripod 6-line, start voxel first.
///
/// ```
/// use voxkit::line::{Segment, Tripod6};
/// let s = Segment::from_voxels([0, 0, 0].into(), [2, 1, 0].into()).unwrap();
/// let v: Vec<[i32; 3]> = Tripod6::new(&s).map(|v| v.to_array()).collect();
/// assert_eq!(v.len(), 4); // 1 + 2 + 1 faces crossed
/// assert_eq!(v[0], [0, 0, 0]);
/// assert_eq!(v[3], [2, 1, 0]);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Tripod6 {
    state: AnyTripod,
    cur: IVec3,
    /// World steps of local axes m, u, v (and a zero pad: a 4-entry table
    /// needs no bounds check for a 2-bit index).
    steps: [IVec3; 4],
    remaining: u64,
    /// Steps left along local m, u, v to the end voxel (their sum is
    /// `remaining − 1` unless the line is clipped short).
    left: [u64; 3],
}

impl Tripod6 {
    /// The whole line of `seg`.
    #[inline]
    pub fn new(seg: &Segment) -> Self {
        match LeanFrame::new(seg) {
            Some(f) => Self::from_lean(&f),
            None => Self::from_frame(&Frame::new(seg)),
        }
    }

    /// The narrow set-up: the decision variables at the start voxel from
    /// the lean frame (the same values as [`TripodState::at`]).
    #[inline]
    fn from_lean(f: &LeanFrame) -> Self {
        use crate::fixed::ONE;
        let [dm, du, dv] = f.d;
        let e = f.tripod_e();
        let [sm, su, sv] = f.steps;
        Tripod6 {
            state: AnyTripod::Narrow(TripodState {
                e,
                dm: dm * ONE,
                du: du * ONE,
                dv: dv * ONE,
            }),
            cur: f.start,
            steps: [sm, su, sv, IVec3::ZERO],
            remaining: f.end.iter().sum::<i64>() as u64 + 1,
            left: f.end.map(|x| x as u64),
        }
    }

    #[inline]
    pub(crate) fn from_frame(f: &Frame) -> Self {
        let f = *f;
        Tripod6 {
            state: AnyTripod::at(&f, [0; 3]),
            cur: f.voxel_world([0; 3]),
            steps: steps4(&f),
            remaining: f.tripod_steps() + 1,
            left: f.end.map(|x| x as u64),
        }
    }

    /// The part of the line inside `box_` (a contiguous run of the line),
    /// started in O(1) at its first voxel. Empty if the line misses the box.
    pub fn clipped(seg: &Segment, box_: &GridBox) -> Self {
        let f = Frame::new(seg);
        match tripod_range(&f, box_) {
            Some((c, n)) => Tripod6 {
                state: AnyTripod::at(&f, c),
                cur: f.voxel_world(c),
                steps: steps4(&f),
                remaining: n,
                left: std::array::from_fn(|k| (f.end[k] - c[k]) as u64),
            },
            None => Tripod6 {
                state: AnyTripod::at(&f, [0; 3]),
                cur: f.voxel_world([0; 3]),
                steps: steps4(&f),
                remaining: 0,
                left: [0; 3],
            },
        }
    }
}

fn steps4(f: &Frame) -> [IVec3; 4] {
    let [a, b, c] = f.world_steps();
    [a, b, c, IVec3::ZERO]
}

impl Iterator for Tripod6 {
    type Item = IVec3;
    #[inline]
    fn next(&mut self) -> Option<IVec3> {
        if self.remaining == 0 {
            return None;
        }
        let v = self.cur;
        self.remaining -= 1;
        if self.remaining > 0 {
            let k = self.state.step();
            self.cur += self.steps[k];
            self.left[k] -= 1;
        }
        Some(v)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = usize::try_from(self.remaining).unwrap_or(usize::MAX);
        (n, usize::try_from(self.remaining).ok())
    }

    /// Internal iteration: one tight loop, the `i64`/`i128` choice made
    /// once; with AVX2, the columns of a narrow line run eight at a time
    /// (`lanes::tripod_voxels`; the voxels are the same).
    #[inline]
    fn fold<B, G: FnMut(B, IVec3) -> B>(self, init: B, mut g: G) -> B {
        let mut acc = init;
        if self.remaining == 0 {
            return acc;
        }
        let mut cur = self.cur;
        acc = g(acc, cur);
        let steps = self.steps;
        let mut n = self.remaining - 1;
        match self.state {
            AnyTripod::Narrow(mut s) => {
                #[cfg(target_arch = "x86_64")]
                {
                    let mut left = self.left;
                    // To the exit voxel of the current column (the next
                    // step along m), at most two steps.
                    while n > 0 && !s.next_is_major() {
                        let k = s.step_tree();
                        cur += steps[k];
                        left[k] -= 1;
                        n -= 1;
                        acc = g(acc, cur);
                    }
                    if let Some(l) = TripodRun::new(&s, left, n) {
                        // SAFETY: `TripodRun::new` checked AVX2.
                        let (a, last) = unsafe {
                            super::lanes::tripod_voxels(
                                l.r,
                                l.e,
                                l.d,
                                cur,
                                [steps[0], steps[1], steps[2]],
                                l.columns,
                                acc,
                                &mut g,
                            )
                        };
                        acc = a;
                        let moved = [steps[1], steps[2]].map(|w| (last - cur).dot(w) as i64);
                        n -= l.advance(&mut s, moved);
                        cur = last;
                    }
                }
                for _ in 0..n {
                    cur += steps[s.step_tree()];
                    acc = g(acc, cur);
                }
            }
            AnyTripod::Wide(mut s) => {
                for _ in 0..n {
                    cur += steps[s.step_tree()];
                    acc = g(acc, cur);
                }
            }
        }
        acc
    }
}

impl Tripod6 {
    /// The line of a narrow segment and its end voxels, or `None` if it is
    /// wide.
    #[inline]
    pub(crate) fn narrow(seg: &Segment) -> Option<(Self, [IVec3; 2])> {
        let f = LeanFrame::new(seg)?;
        Some((Self::from_lean(&f), [f.start, f.end_voxel]))
    }

    /// Visits the linear indices of a fresh narrow line lying wholly in a
    /// grid: `idx` is the start voxel's index, `stride` the index steps of
    /// world x, y, z, `small`: the grid has fewer than 2^31 cells. Returns
    /// the number visited, or `Err(index)` where the visitor stopped.
    #[inline]
    pub(crate) fn walk<F: FnMut(usize) -> ControlFlow<()>>(
        &self,
        idx: usize,
        stride: [isize; 3],
        small: bool,
        visit: &mut F,
    ) -> Result<u64, usize> {
        let AnyTripod::Narrow(mut s) = self.state else {
            unreachable!("Tripod6::walk runs narrow lines only")
        };
        let [om, ou, ov] =
            super::walk::axis_offsets([self.steps[0], self.steps[1], self.steps[2]], stride);
        let off = [om, ou, ov, 0];
        let mut idx = idx;
        if visit(idx).is_break() {
            return Err(idx);
        }
        let mut n = self.remaining - 1;
        #[cfg(target_arch = "x86_64")]
        if small {
            let mut left = self.left;
            while n > 0 && !s.next_is_major() {
                let k = s.step();
                idx = idx.wrapping_add_signed(off[k]);
                left[k] -= 1;
                n -= 1;
                if visit(idx).is_break() {
                    return Err(idx);
                }
            }
            if let Some(l) = TripodRun::new(&s, left, n) {
                // SAFETY: `TripodRun::new` checked AVX2; every index is an
                // in-grid cell of a grid of fewer than 2^31 cells.
                let (last, moved) = unsafe {
                    super::lanes::tripod_indices(
                        l.r,
                        l.e,
                        l.d,
                        idx,
                        [off[0], off[1], off[2]],
                        l.columns,
                        visit,
                    )?
                };
                n -= l.advance(&mut s, moved);
                idx = last;
            }
        }
        let _ = small;
        for _ in 0..n {
            idx = idx.wrapping_add_signed(off[s.step()]);
            if visit(idx).is_break() {
                return Err(idx);
            }
        }
        Ok(self.remaining)
    }
}

/// The columns a narrow tripod line runs in AVX2 lanes from an exit voxel
/// (the next step along m): all but the last column (whose exit is the end
/// point, not a face), if the lanes apply.
#[cfg(target_arch = "x86_64")]
pub(crate) struct TripodRun {
    /// Exit remainders, floored `e_vu / S`, direction components (compact).
    pub r: [i32; 2],
    pub e: i32,
    pub d: [i32; 3],
    pub columns: u64,
}

#[cfg(target_arch = "x86_64")]
impl TripodRun {
    /// Columns of fewer than this run scalar.
    const MIN_COLUMNS: u64 = 8;

    /// At an exit voxel with state `s`, `left` steps per axis and `n`
    /// steps to go (equal unless clipped short): the lanes' start, if AVX2
    /// is available and the span is under 256 voxels.
    #[inline]
    pub(crate) fn new(s: &TripodState<i64>, left: [u64; 3], n: u64) -> Option<Self> {
        use crate::fixed::FRAC_BITS;
        let columns = left[0].checked_sub(1)?;
        let dm = s.dm >> FRAC_BITS;
        if columns < Self::MIN_COLUMNS
            || n != left.iter().sum::<u64>()
            || dm >= super::lanes::LANES_MAX_DM
            || !super::lanes::avx2::available()
        {
            return None;
        }
        debug_assert!(s.next_is_major(), "tripod lanes start off an exit voxel");
        // At an exit voxel e_mu, e_mv ∈ [−D_m·S, 0): R = floor(e / S) + D_m.
        let r = [s.e[0], s.e[1]].map(|e| ((e >> FRAC_BITS) + dm) as i32);
        debug_assert!(r.iter().all(|&x| (0..dm as i32).contains(&x)));
        Some(TripodRun {
            r,
            e: (s.e[2] >> FRAC_BITS) as i32,
            d: [dm, s.du >> FRAC_BITS, s.dv >> FRAC_BITS].map(|x| x as i32),
            columns,
        })
    }

    /// Moves `s` over the run's columns, which took `moved = [Δu, Δv]`
    /// minor steps; returns the number of steps taken.
    #[inline]
    pub(crate) fn advance(&self, s: &mut TripodState<i64>, moved: [i64; 2]) -> u64 {
        let k = self.columns as i64;
        let [du_steps, dv_steps] = moved;
        s.e[0] += k * s.du - du_steps * s.dm;
        s.e[1] += k * s.dv - dv_steps * s.dm;
        s.e[2] += dv_steps * s.du - du_steps * s.dv;
        (k + du_steps + dv_steps) as u64
    }
}

impl ExactSizeIterator for Tripod6 {}
impl std::iter::FusedIterator for Tripod6 {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::line::line26::Mid26State;
    use rand::{Rng, SeedableRng};

    /// The `i64` and `i128` stepping states make the same decisions on
    /// segments where both are valid (the `i128` path is the one long
    /// segments take).
    #[test]
    fn narrow_and_wide_states_agree() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(64128);
        let one = crate::fixed::ONE;
        for _ in 0..300 {
            let p = |rng: &mut rand_chacha::ChaCha8Rng| -> [i64; 3] {
                std::array::from_fn(|_| rng.random_range(-300 * one..300 * one))
            };
            let seg = Segment::from_fixed(p(&mut rng), p(&mut rng)).unwrap();
            let f = Frame::new(&seg);
            assert!(!f.wide);
            let mut a = TripodState::<i64>::at(&f, [0; 3]);
            let mut b = TripodState::<i128>::at(&f, [0; 3]);
            let mut t = a;
            for _ in 0..f.tripod_steps() {
                let k = a.step();
                assert_eq!(k, b.step());
                assert_eq!(k, t.step_tree(), "select and tree forms differ");
                assert_eq!(a.e, t.e);
            }
            if f.end[0] >= 1 {
                let mut a = Mid26State::<i64>::at(&f, [0; 3]);
                let mut b = Mid26State::<i128>::at(&f, [0; 3]);
                for _ in 0..f.end[0] {
                    assert_eq!(a.step(), b.step());
                }
            }
        }
    }
}
