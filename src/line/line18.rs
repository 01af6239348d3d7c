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

use glam::IVec3;

use super::line26::{Cursor26, Plan26};
use super::segment::{Frame, Segment};

/// Local axis crossed last when leaving local voxel `c` (exact).
pub(crate) fn last_crossed(f: &Frame, c: [i64; 3]) -> usize {
    let e = f.tripod_e(c);
    if e[0] < 0 {
        // m before u: the last is u or v.
        if e[2] < 0 { 1 } else { 2 }
    } else if e[1] < 0 {
        // u before m, m before v.
        2
    } else {
        0
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
#[derive(Clone, Debug)]
pub struct Line18 {
    frame: Frame,
    cursor: Cursor26,
    cur: [i64; 3],
    pending: Option<[i64; 3]>,
    remaining26: u64,
    started: bool,
}

impl Line18 {
    /// The whole line of `seg`.
    pub fn new(seg: &Segment) -> Self {
        let f = Frame::new(seg);
        let plan = Plan26::new(&f);
        Line18 {
            frame: f,
            cursor: Cursor26::at(&f, plan, 0),
            cur: [0; 3],
            pending: None,
            remaining26: plan.count(),
            started: false,
        }
    }

    /// Starts at 26-line position `p` (used by the grid walk).
    pub(crate) fn at_position(f: &Frame, plan: Plan26, p: u64) -> Self {
        Line18 {
            frame: *f,
            cursor: Cursor26::at(f, plan, p),
            cur: plan.voxel_at(f, p),
            pending: None,
            remaining26: plan.count() - p,
            started: false,
        }
    }

    /// Next voxel in local coordinates.
    #[inline]
    pub(crate) fn next_local(&mut self) -> Option<[i64; 3]> {
        if !self.started {
            self.started = true;
            return (self.remaining26 > 0).then_some(self.cur);
        }
        if let Some(p) = self.pending.take() {
            self.cur = p;
            return Some(p);
        }
        if self.remaining26 <= 1 {
            self.remaining26 = 0;
            return None;
        }
        self.remaining26 -= 1;
        let mask = self.cursor.advance();
        let mut next = self.cur;
        for (k, nk) in next.iter_mut().enumerate() {
            *nk += (mask >> k & 1) as i64;
        }
        if mask == 7 {
            let mut mid = next;
            mid[last_crossed(&self.frame, self.cur)] -= 1;
            self.pending = Some(next);
            self.cur = mid;
            return Some(mid);
        }
        self.cur = next;
        Some(next)
    }
}

impl Iterator for Line18 {
    type Item = IVec3;
    #[inline]
    fn next(&mut self) -> Option<IVec3> {
        self.next_local().map(|c| self.frame.voxel_world(c))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let base = self.remaining26.saturating_sub(u64::from(self.started))
            + u64::from(self.pending.is_some());
        let lo = usize::try_from(base).unwrap_or(usize::MAX);
        (lo, lo.checked_mul(2))
    }
}

impl std::iter::FusedIterator for Line18 {}
