//! The 18-connected line: the 26-line with every corner (m+u+v) move split
//! in two.
//!
//! 18- and 26-lines differ only at moves that change all three coordinates
//! (Cohen-Or & Kaufman). At such a move from `p` to `p + (1,1,1)` the line
//! crosses the three faces of `p`'s tripod in some order; the voxel after the
//! first two crossings, `p + (1,1,1) − e_last`, is touched by the segment,
//! an 18-neighbour of `p` and a 6-neighbour of the next voxel. The last axis
//! is read from the exact tripod decision variables at `p` (three sign tests).
//! There is no count-down (the 18-distance is not the number of steps of the
//! best approximation, see the paper's Fig. 2), so the iterator's size hint is
//! a range.
//!
//! # Guarantees
//! 18-connected; first voxel `V0`, last `V1`; every voxel touched by the
//! closed segment; a subsequence of the tripod path.

use std::ops::ControlFlow;

use glam::IVec3;

use crate::fixed::HALF;

use super::line26::{Compact26, Mid26State, Plan26};
use super::segment::{DecisionInt, Frame, LeanFrame, Segment};

/// Local axis crossed last when leaving a voxel with biased tripod variables
/// `e = [e_mu, e_mv, e_vu]`.
#[inline(always)]
fn last_of<T: DecisionInt>(e: [T; 3]) -> usize {
    if e[0] < T::ZERO {
        // m before u: the last is u or v.
        if e[2] < T::ZERO { 1 } else { 2 }
    } else if e[1] < T::ZERO {
        // u before m, m before v.
        2
    } else {
        0
    }
}

/// Local axis crossed last when leaving local voxel `c` of the tripod path
/// (exact).
pub(crate) fn last_crossed(f: &Frame, c: [i64; 3]) -> usize {
    if f.wide {
        last_of(f.tripod_e(c))
    } else {
        last_of(f.tripod_e64(c))
    }
}

/// Mask of the intermediate voxel of a corner move (7) out of local voxel
/// `c`, else 0.
#[inline]
fn split_at(f: &Frame, c: [i64; 3], mask: usize) -> usize {
    if mask == 7 {
        7 ^ (1 << last_crossed(f, c))
    } else {
        0
    }
}

/// The 26-line's midpoint state plus the third tripod variable `e_vu`, so
/// that a corner move knows its last crossing without re-deriving the tripod
/// variables: at a column-centre voxel `e_mu = E_mu − D_u·S/2`,
/// `e_mv = E_mv − D_v·S/2`, and `e_vu` changes by `−D_v·S` on a u move and
/// `+D_u·S` on a v move (none on m).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Mid18<T> {
    s: Mid26State<T>,
    evu: T,
    hu: T,
    hv: T,
}

impl<T: DecisionInt> Mid18<T> {
    #[inline]
    pub(crate) fn at(f: &Frame, c: [i64; 3]) -> Self {
        let half = |x: i64| {
            if T::WIDE {
                T::from_i128(x as i128 * HALF as i128)
            } else {
                T::from_i64(x * HALF)
            }
        };
        Mid18 {
            s: Mid26State::at(f, c),
            evu: f.tripod_e_t::<T>(c)[2],
            hu: half(f.d[1]),
            hv: half(f.d[2]),
        }
    }

    /// One column: the 26-line's move mask and, for a corner move, the mask
    /// of the intermediate voxel (else 0).
    #[inline(always)]
    pub(crate) fn step(&mut self) -> (usize, usize) {
        let e = [self.s.eu - self.hu, self.s.ev - self.hv, self.evu];
        let su = !self.s.eu.neg_mask();
        let sv = !self.s.ev.neg_mask();
        let mask = self.s.step();
        self.evu += (sv & self.s.du) - (su & self.s.dv);
        let split = if mask == 7 { 7 ^ (1 << last_of(e)) } else { 0 };
        (mask, split)
    }
}

impl Mid18<i64> {
    /// The state at a column-centre voxel from the midpoint state and the
    /// tripod variable `e_vu` there.
    #[inline]
    fn from_parts(s: Mid26State<i64>, evu: i64) -> Self {
        // D·S/2 exactly: S is even.
        Mid18 {
            s,
            evu,
            hu: s.du / 2,
            hv: s.dv / 2,
        }
    }
}

/// Walks a narrow 18-line lying wholly in a grid without the general frame:
/// the compact 26-line's moves with each corner move split (see the module
/// docs), its visits as linear indices. `index` gives a voxel's linear
/// index, `stride` the index steps of world x, y, z. Returns the number visited, or
/// `Err(index)` where the visitor stopped; `None` if the line is wide, has
/// longer end paths or leaves the grid.
pub(crate) fn walk_inside<F: FnMut(usize) -> ControlFlow<()>>(
    seg: &Segment,
    dims: crate::grid::Dims,
    stride: [isize; 3],
    index: impl Fn(IVec3) -> usize,
    visit: &mut F,
) -> Option<Result<u64, usize>> {
    let f = LeanFrame::new(seg)?;
    let c = Compact26::from_lean(&f)?;
    if !c.inside(dims) {
        return None;
    }
    let off = super::walk::mask_offsets(super::walk::axis_offsets(c.steps(), stride));
    Some(run_inside(&c, f.tripod_e(), index(c.start()), &off, visit))
}

#[inline]
fn run_inside<F: FnMut(usize) -> ControlFlow<()>>(
    c: &Compact26,
    e0: [i64; 3],
    mut idx: usize,
    off: &[isize; 8],
    visit: &mut F,
) -> Result<u64, usize> {
    let mut visited = 0u64;
    let mut one = |i: usize, visited: &mut u64| -> Result<(), usize> {
        *visited += 1;
        if visit(i).is_break() { Err(i) } else { Ok(()) }
    };
    one(idx, &mut visited)?;
    let last = c.last();
    if last == 0 {
        return Ok(visited);
    }
    let (pre, post) = c.end_moves();
    let mid = c.mid();
    if pre == 7 {
        one(
            idx.wrapping_add_signed(off[7 ^ (1 << last_of(e0))]),
            &mut visited,
        )?;
    }
    idx = idx.wrapping_add_signed(off[usize::from(pre)]);
    one(idx, &mut visited)?;
    if last == 1 {
        return Ok(visited);
    }
    // e_vu at column 1: −D_v·S per u step and +D_u·S per v step of the
    // first move (m steps leave it).
    let evu1 = e0[2] - i64::from(pre >> 1 & 1) * mid.dv + i64::from(pre >> 2 & 1) * mid.du;
    let mut s = Mid18::from_parts(mid, evu1);
    for _ in 0..last - 2 {
        let (mask, split) = s.step();
        if split != 0 {
            one(idx.wrapping_add_signed(off[split]), &mut visited)?;
        }
        idx = idx.wrapping_add_signed(off[mask]);
        one(idx, &mut visited)?;
    }
    if post == 7 {
        let e = [s.s.eu - s.hu, s.s.ev - s.hv, s.evu];
        one(
            idx.wrapping_add_signed(off[7 ^ (1 << last_of(e))]),
            &mut visited,
        )?;
    }
    idx = idx.wrapping_add_signed(off[usize::from(post)]);
    one(idx, &mut visited)?;
    Ok(visited)
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum AnyMid18 {
    Narrow(Mid18<i64>),
    Wide(Mid18<i128>),
}

/// Runs `n` middle columns, emitting (move mask, split mask) pairs.
#[inline(always)]
fn run_mid18<T: DecisionInt, B>(
    s: &mut Mid18<T>,
    n: u64,
    mut acc: B,
    emit: &mut impl FnMut(B, usize, usize) -> ControlFlow<B, B>,
) -> ControlFlow<B, B> {
    for _ in 0..n {
        let (mask, split) = s.step();
        acc = emit(acc, mask, split)?;
    }
    ControlFlow::Continue(acc)
}

/// Cursor over the 26-line's moves with each corner move's split: prefix,
/// middle (the [`Mid18`] recurrence), suffix. `local` is the local voxel
/// before the next prefix or suffix move (stale inside the middle).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cursor18 {
    plan: Plan26,
    pre_i: usize,
    mid_left: u64,
    mid: AnyMid18,
    post_i: usize,
    local: [i64; 3],
}

impl Cursor18 {
    /// Cursor standing at 26-line position `p`.
    pub(crate) fn at(f: &Frame, plan: Plan26, p: u64) -> Self {
        let pre = plan.pre.len as u64;
        let (pre_i, mid_left, mid_at, post_i) = if p <= pre {
            (p as usize, plan.mid, plan.mid_start, 0)
        } else if p <= pre + plan.mid {
            let c = f.centre((p - pre + 1) as i64);
            (plan.pre.len, plan.mid - (p - pre), c, 0)
        } else {
            (
                plan.pre.len,
                0,
                plan.mid_start,
                (p - pre - plan.mid) as usize,
            )
        };
        let mid = if f.wide {
            AnyMid18::Wide(Mid18::at(f, mid_at))
        } else {
            AnyMid18::Narrow(Mid18::at(f, mid_at))
        };
        Cursor18 {
            plan,
            pre_i,
            mid_left,
            mid,
            post_i,
            local: plan.voxel_at(f, p),
        }
    }

    /// Emits the next `n` moves (the caller knows they exist) as
    /// `(mask, split)`; stops at the first `Break`, after which the cursor is
    /// unspecified.
    #[inline(always)]
    pub(crate) fn drive<B>(
        &mut self,
        f: &Frame,
        mut n: u64,
        mut acc: B,
        mut emit: impl FnMut(B, usize, usize) -> ControlFlow<B, B>,
    ) -> ControlFlow<B, B> {
        let add = |c: [i64; 3], mask: usize| -> [i64; 3] {
            std::array::from_fn(|k| c[k] + (mask >> k & 1) as i64)
        };
        while n > 0 && self.pre_i < self.plan.pre.len {
            let mask = self.plan.pre.m[self.pre_i] as usize;
            self.pre_i += 1;
            n -= 1;
            let split = split_at(f, self.local, mask);
            self.local = add(self.local, mask);
            acc = emit(acc, mask, split)?;
        }
        let k = n.min(self.mid_left);
        if k > 0 {
            n -= k;
            self.mid_left -= k;
            acc = match &mut self.mid {
                AnyMid18::Narrow(s) => run_mid18(s, k, acc, &mut emit)?,
                AnyMid18::Wide(s) => run_mid18(s, k, acc, &mut emit)?,
            };
            if self.mid_left == 0 {
                self.local = self.plan.post_start;
            }
        }
        while n > 0 && self.post_i < self.plan.post.len {
            let mask = self.plan.post.m[self.post_i] as usize;
            self.post_i += 1;
            n -= 1;
            let split = split_at(f, self.local, mask);
            self.local = add(self.local, mask);
            acc = emit(acc, mask, split)?;
        }
        debug_assert_eq!(n, 0, "18-line cursor ran past the line");
        ControlFlow::Continue(acc)
    }
}

/// Iterator over the voxels of the 18-connected line, start voxel first.
///
/// ```
/// use voxkit::line::{Line18, Segment};
/// let s = Segment::from_voxels([0, 0, 0].into(), [2, 2, 2].into()).unwrap();
/// let v: Vec<_> = Line18::new(&s).map(|v| v.to_array()).collect();
/// assert_eq!(v.len(), 5); // two corner moves, each split in two
/// assert_eq!(v[4], [2, 2, 2]);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Line18 {
    frame: Frame,
    cursor: Cursor18,
    steps: [IVec3; 8],
    /// The last voxel returned (the start voxel before the first).
    cur: IVec3,
    /// The 26-line voxel after a returned intermediate voxel.
    pending: Option<IVec3>,
    /// 26-line voxels not yet returned.
    remaining26: u64,
    started: bool,
}

impl Line18 {
    /// The whole line of `seg`.
    #[inline]
    pub fn new(seg: &Segment) -> Self {
        Self::from_frame(&Frame::new(seg))
    }

    #[inline]
    pub(crate) fn from_frame(f: &Frame) -> Self {
        let f = *f;
        let plan = Plan26::new(&f);
        Line18 {
            frame: f,
            cursor: Cursor18::at(&f, plan, 0),
            steps: f.mask_steps(),
            cur: f.voxel_world([0; 3]),
            pending: None,
            remaining26: plan.count(),
            started: false,
        }
    }
}

impl Iterator for Line18 {
    type Item = IVec3;
    #[inline]
    fn next(&mut self) -> Option<IVec3> {
        if !self.started {
            self.started = true;
            self.remaining26 -= 1;
            return Some(self.cur);
        }
        if let Some(p) = self.pending.take() {
            self.cur = p;
            return Some(p);
        }
        if self.remaining26 == 0 {
            return None;
        }
        self.remaining26 -= 1;
        let mut out = (0, 0);
        let _ = self.cursor.drive(&self.frame, 1, (), |(), m, s| {
            out = (m, s);
            ControlFlow::Continue(())
        });
        let (mask, split) = out;
        let next = self.cur + self.steps[mask];
        if split != 0 {
            self.pending = Some(next);
            self.cur += self.steps[split];
        } else {
            self.cur = next;
        }
        Some(self.cur)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let base = self.remaining26 + u64::from(self.pending.is_some());
        let lo = usize::try_from(base).unwrap_or(usize::MAX);
        (lo, lo.checked_mul(2))
    }

    /// Internal iteration: the middle of the line as one tight loop.
    #[inline]
    fn fold<B, G: FnMut(B, IVec3) -> B>(mut self, init: B, mut g: G) -> B {
        let mut acc = init;
        if !self.started {
            self.remaining26 -= 1;
            acc = g(acc, self.cur);
        }
        let mut cur = self.cur;
        if let Some(p) = self.pending {
            cur = p;
            acc = g(acc, cur);
        }
        let steps = self.steps;
        let r = self.cursor.drive(
            &self.frame,
            self.remaining26,
            acc,
            |mut acc, mask, split| {
                if split != 0 {
                    acc = g(acc, cur + steps[split]);
                }
                cur += steps[mask];
                ControlFlow::Continue(g(acc, cur))
            },
        );
        match r {
            ControlFlow::Continue(acc) | ControlFlow::Break(acc) => acc,
        }
    }
}

impl std::iter::FusedIterator for Line18 {}
