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

use glam::IVec3;

use super::clip::{GridBox, tripod_range};
use super::segment::{DecisionInt, Frame, Segment};

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
}

impl Tripod6 {
    /// The whole line of `seg`.
    #[inline]
    pub fn new(seg: &Segment) -> Self {
        Self::from_frame(&Frame::new(seg))
    }

    #[inline]
    pub(crate) fn from_frame(f: &Frame) -> Self {
        let f = *f;
        Tripod6 {
            state: AnyTripod::at(&f, [0; 3]),
            cur: f.voxel_world([0; 3]),
            steps: steps4(&f),
            remaining: f.tripod_steps() + 1,
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
            },
            None => Tripod6 {
                state: AnyTripod::at(&f, [0; 3]),
                cur: f.voxel_world([0; 3]),
                steps: steps4(&f),
                remaining: 0,
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
        }
        Some(v)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = usize::try_from(self.remaining).unwrap_or(usize::MAX);
        (n, usize::try_from(self.remaining).ok())
    }

    /// Internal iteration: one tight loop, the `i64`/`i128` choice made once.
    #[inline]
    fn fold<B, G: FnMut(B, IVec3) -> B>(self, init: B, mut g: G) -> B {
        let mut acc = init;
        if self.remaining == 0 {
            return acc;
        }
        let mut cur = self.cur;
        acc = g(acc, cur);
        let steps = self.steps;
        let n = self.remaining - 1;
        match self.state {
            AnyTripod::Narrow(mut s) => {
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
