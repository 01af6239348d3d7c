//! The 26-connected midpoint line (Cohen-Or & Kaufman, Fig. 4), exact for
//! sub-voxel endpoints.
//!
//! Along the major axis m, one voxel per column: the line's minor coordinates
//! at the column centre, rounded (ties by the world-shift rule, see
//! [`super::segment`]). Two midpoint variables `E_mu`, `E_mv` decide the minor
//! steps with the tree of Fig. 4 (`E ≥ 0`: step; forward differences `D·S` and
//! `(D − D_m)·S`); the loop counts down the columns (termination by `d26`).
//!
//! With sub-voxel endpoints the column centre of the first or last column may
//! lie outside the segment (errata: ~17% of random lines get the first or last
//! voxel wrong if evaluated there). So the line is: the start voxel `V0`, a
//! short *prefix* that reaches the centre voxel of column 1, the column centres
//! 2..M−1, and a short *suffix* that reaches the end voxel `V1`. Prefix and
//! suffix are the tripod path between those voxels, compressed greedily to a
//! 26-path (at most a few voxels). With integer endpoints both are a single
//! step and the line has exactly `d26 + 1` voxels.
//!
//! # Guarantees
//! * 26-connected; first voxel `V0`, last `V1`; every voxel is touched by the
//!   closed segment (all voxels lie on the tripod path of the shifted line).
//! * Integer endpoints: exactly `d26(V0, V1) + 1` voxels.

use glam::IVec3;

use super::clip::GridBox;
use super::segment::{DecisionInt, Frame, Segment};
use super::tripod6::TripodState;

/// The Fig. 4 stepping state: two midpoint variables and their forward
/// differences. `step` returns the local move mask (bit 0 = m, always set;
/// bit 1 = u; bit 2 = v).
#[derive(Clone, Copy, Debug)]
pub struct Mid26State<T> {
    pub(crate) eu: T,
    pub(crate) ev: T,
    /// `D_u·S`, `D_v·S`.
    pub(crate) du: T,
    pub(crate) dv: T,
    /// `D_m·S`.
    dm: T,
}

impl<T: DecisionInt> Mid26State<T> {
    #[inline]
    pub(crate) fn at(frame: &Frame, c: [i64; 3]) -> Self {
        let [eu, ev] = frame.mid_e_t::<T>(c);
        let [dm, du, dv] = frame.scaled_d::<T>();
        Mid26State { eu, ev, du, dv, dm }
    }

    /// One column step; returns the local move mask.
    #[inline(always)]
    pub fn step(&mut self) -> usize {
        // The tree of Fig. 4 as sign masks (`E ≥ 0`: all ones): random
        // slopes make branches unpredictable, and a select between the two
        // differences compiled to a load on the dependency chain. With
        // `D − D_m` = `D + (−D_m)`: `E += D − (mask & D_m)`.
        let su = !self.eu.neg_mask();
        let sv = !self.ev.neg_mask();
        self.eu += self.du - (su & self.dm);
        self.ev += self.dv - (sv & self.dm);
        1 | (su.low_bits() & 2) | (sv.low_bits() & 4)
    }
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum AnyMid {
    Narrow(Mid26State<i64>),
    Wide(Mid26State<i128>),
}

impl AnyMid {
    #[inline]
    pub(crate) fn at(f: &Frame, c: [i64; 3]) -> Self {
        if f.wide {
            AnyMid::Wide(Mid26State::at(f, c))
        } else {
            AnyMid::Narrow(Mid26State::at(f, c))
        }
    }
    #[inline(always)]
    pub(crate) fn step(&mut self) -> usize {
        match self {
            AnyMid::Narrow(s) => s.step(),
            AnyMid::Wide(s) => s.step(),
        }
    }
}

/// Up to this many voxels in a prefix or suffix (the tripod path between the
/// two voxels has at most 7 steps).
const MAX_SPECIAL: usize = 8;

/// A short list of local move masks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Moves {
    pub m: [u8; MAX_SPECIAL],
    pub len: usize,
}

/// The tripod path from `from` to `to` (both on it), compressed greedily to
/// a 26-path: from the last kept voxel, jump to the furthest later voxel that
/// is still a 26-neighbour. The path is monotone with unit steps, so that
/// voxel is the one before the first axis repeats: one pass, no buffer.
#[inline]
fn moves_between(f: &Frame, from: [i64; 3], to: [i64; 3]) -> Moves {
    let n: i64 = (0..3).map(|k| to[k] - from[k]).sum();
    // Between a line end and its first or last column centre: ≤ 1 + 2 + 2.
    assert!(
        (0..=MAX_SPECIAL as i64).contains(&n),
        "tripod path between a line end and its column centre has {n} steps"
    );
    if f.wide {
        compress_steps(TripodState::<i128>::at(f, from), n as usize)
    } else {
        compress_steps(TripodState::<i64>::at(f, from), n as usize)
    }
}

#[inline]
fn compress_steps<T: DecisionInt>(mut s: TripodState<T>, n: usize) -> Moves {
    let mut mv = Moves::default();
    let mut mask = 0u8;
    for _ in 0..n {
        let bit = 1u8 << s.step();
        if mask & bit != 0 {
            mv.m[mv.len] = mask;
            mv.len += 1;
            mask = 0;
        }
        mask |= bit;
    }
    if mask != 0 {
        mv.m[mv.len] = mask;
        mv.len += 1;
    }
    mv
}

/// The shape of a 26-line: prefix moves, middle column count, suffix moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Plan26 {
    pub pre: Moves,
    pub mid: u64,
    pub post: Moves,
    /// Local voxel where the middle starts (centre of column 1), if any.
    pub mid_start: [i64; 3],
    /// Local voxel where the suffix starts (centre of column `M − 1`), if
    /// any.
    pub post_start: [i64; 3],
}

impl Plan26 {
    #[inline]
    pub(crate) fn new(f: &Frame) -> Self {
        let m = f.end[0];
        if m < 2 {
            return Plan26 {
                pre: moves_between(f, [0; 3], f.end),
                mid: 0,
                post: Moves::default(),
                mid_start: [0; 3],
                post_start: [0; 3],
            };
        }
        let one = crate::fixed::ONE;
        let integer = (0..3).all(|k| (f.a[k] | f.d[k]) & (one - 1) == 0);
        let cl = f.centre_last();
        let (pre, c1, post);
        if integer {
            // Integer endpoints (Fig. 4 proper): every voxel is a column
            // centre, the end voxels included, so the end paths are single
            // moves: the first from the midpoint state at voxel 0, the last
            // from column m − 1 to the end voxel. Same layout as below.
            let first = AnyMid::at(f, [0; 3]).step() as u8;
            let last = (0..3).fold(0u8, |mask, k| mask | (u8::from(f.end[k] != cl[k]) << k));
            pre = single(first);
            post = single(last);
            c1 = [1, i64::from(first >> 1 & 1), i64::from(first >> 2 & 1)];
        } else {
            c1 = f.centre_first();
            pre = moves_between(f, [0; 3], c1);
            post = moves_between(f, cl, f.end);
        }
        Plan26 {
            pre,
            mid: (m - 2) as u64,
            post,
            mid_start: c1,
            post_start: cl,
        }
    }

    pub(crate) fn count(&self) -> u64 {
        1 + self.pre.len as u64 + self.mid + self.post.len as u64
    }

    /// Local voxel at position `p` (O(1)).
    pub(crate) fn voxel_at(&self, f: &Frame, p: u64) -> [i64; 3] {
        let apply = |mut c: [i64; 3], mask: u8| {
            for (k, ck) in c.iter_mut().enumerate() {
                *ck += i64::from(mask >> k & 1);
            }
            c
        };
        let pre = self.pre.len as u64;
        if p <= pre {
            let mut c = [0; 3];
            for &mk in &self.pre.m[..p as usize] {
                c = apply(c, mk);
            }
            c
        } else if p <= pre + self.mid {
            f.centre((p - pre + 1) as i64)
        } else {
            let mut c = self.post_start;
            for &mk in &self.post.m[..(p - pre - self.mid) as usize] {
                c = apply(c, mk);
            }
            c
        }
    }

    /// First and last in-box positions, or `None`.
    pub(crate) fn range(&self, f: &Frame, b: &GridBox) -> Option<(u64, u64)> {
        let (l, h) = b.local(f);
        let inside = |c: [i64; 3]| (0..3).all(|k| c[k] >= l[k] && c[k] <= h[k]);
        let pre = self.pre.len as u64;
        let total = self.count();
        // The path is monotone in local coordinates: with both end voxels in
        // the box, all of it is.
        if inside([0; 3]) && inside(f.end) {
            return Some((0, total - 1));
        }
        // Middle columns 2..=M−1 inside the box, from per-axis thresholds.
        let (mut lo, mut hi) = (2i64, f.end[0] - 1);
        if self.mid > 0 {
            lo = lo.max(l[0]);
            hi = hi.min(h[0]);
            for k in 1..3 {
                lo = lo.max(first_column_at_least(f, k, l[k]));
                hi = hi.min(first_column_at_least(f, k, h[k] + 1) - 1);
            }
        }
        let mid_pos = |c: i64| pre + (c - 1) as u64;
        let first = (0..=pre)
            .find(|&p| inside(self.voxel_at(f, p)))
            .or_else(|| (self.mid > 0 && lo <= hi).then(|| mid_pos(lo)))
            .or_else(|| (pre + self.mid + 1..total).find(|&p| inside(self.voxel_at(f, p))))?;
        let last = (pre + self.mid + 1..total)
            .rev()
            .find(|&p| inside(self.voxel_at(f, p)))
            .or_else(|| (self.mid > 0 && lo <= hi).then(|| mid_pos(hi)))
            .or_else(|| (0..=pre).rev().find(|&p| inside(self.voxel_at(f, p))))?;
        (first <= last).then_some((first, last))
    }
}

fn single(mv: u8) -> Moves {
    let mut moves = Moves::default();
    moves.m[0] = mv;
    moves.len = 1;
    moves
}

/// Smallest column `c` whose centre voxel has local coordinate `≥ target`
/// along minor axis `k` (saturated to a huge value if none).
fn first_column_at_least(f: &Frame, k: usize, target: i64) -> i64 {
    let s = crate::fixed::ONE as i128;
    let bias = f.bias[k - 1] as i128;
    let dk = f.d[k] as i128;
    let dm = f.d[0] as i128;
    if dk == 0 {
        return if f.centre(0)[k] >= target {
            i64::MIN / 4
        } else {
            i64::MAX / 4
        };
    }
    // D_k (c S − a_m) − D_m ((target − 1/2) S − a_k) − bias ≥ 0
    let r = dk * f.a[0] as i128 + dm * (target as i128 * s - s / 2 - f.a[k] as i128) + bias;
    let c = -((-r).div_euclid(dk * s));
    c.clamp(i64::MIN as i128 / 4, i64::MAX as i128 / 4) as i64
}

/// Cursor over a 26-line plan: prefix, middle, suffix.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cursor26 {
    pub plan: Plan26,
    pub pre_i: usize,
    pub mid_left: u64,
    pub mid: AnyMid,
    pub post_i: usize,
}

impl Cursor26 {
    /// Cursor standing at position `p`.
    pub(crate) fn at(f: &Frame, plan: Plan26, p: u64) -> Self {
        let pre = plan.pre.len as u64;
        if p <= pre {
            Cursor26 {
                plan,
                pre_i: p as usize,
                mid_left: plan.mid,
                mid: AnyMid::at(f, plan.mid_start),
                post_i: 0,
            }
        } else if p <= pre + plan.mid {
            let c = (p - pre + 1) as i64;
            Cursor26 {
                plan,
                pre_i: plan.pre.len,
                mid_left: plan.mid - (p - pre),
                mid: AnyMid::at(f, f.centre(c)),
                post_i: 0,
            }
        } else {
            Cursor26 {
                plan,
                pre_i: plan.pre.len,
                mid_left: 0,
                mid: AnyMid::at(f, plan.mid_start),
                post_i: (p - pre - plan.mid) as usize,
            }
        }
    }

    /// The next move mask (the caller knows one exists).
    #[inline(always)]
    pub(crate) fn advance(&mut self) -> usize {
        if self.pre_i < self.plan.pre.len {
            self.pre_i += 1;
            self.plan.pre.m[self.pre_i - 1] as usize
        } else if self.mid_left > 0 {
            self.mid_left -= 1;
            self.mid.step()
        } else {
            self.post_i += 1;
            self.plan.post.m[self.post_i - 1] as usize
        }
    }
}

/// Iterator over the voxels of the 26-connected line, start voxel first.
///
/// ```
/// use voxkit::line::{Line26, Segment};
/// let s = Segment::from_voxels([0, 0, 0].into(), [4, -2, 1].into()).unwrap();
/// let v: Vec<_> = Line26::new(&s).collect();
/// assert_eq!(v.len(), 5); // d26 + 1
/// assert_eq!(v[4].to_array(), [4, -2, 1]);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Line26 {
    cur: IVec3,
    cursor: Cursor26,
    steps: [IVec3; 8],
    remaining: u64,
}

impl Line26 {
    /// The whole line of `seg`.
    #[inline]
    pub fn new(seg: &Segment) -> Self {
        Self::from_frame(&Frame::new(seg))
    }

    #[inline]
    pub(crate) fn from_frame(f: &Frame) -> Self {
        let f = *f;
        let plan = Plan26::new(&f);
        Line26 {
            cur: f.voxel_world([0; 3]),
            cursor: Cursor26::at(&f, plan, 0),
            steps: f.mask_steps(),
            remaining: plan.count(),
        }
    }

    /// The part of the line inside `box_`, started in O(1) at its first
    /// in-box voxel.
    pub fn clipped(seg: &Segment, box_: &GridBox) -> Self {
        let f = Frame::new(seg);
        let plan = Plan26::new(&f);
        let (p, n) = match plan.range(&f, box_) {
            Some((a, b)) => (a, b - a + 1),
            None => (0, 0),
        };
        Line26 {
            cur: f.voxel_world(plan.voxel_at(&f, p)),
            cursor: Cursor26::at(&f, plan, p),
            steps: f.mask_steps(),
            remaining: n,
        }
    }
}

impl Iterator for Line26 {
    type Item = IVec3;
    #[inline]
    fn next(&mut self) -> Option<IVec3> {
        if self.remaining == 0 {
            return None;
        }
        let v = self.cur;
        self.remaining -= 1;
        if self.remaining > 0 {
            let m = self.cursor.advance();
            self.cur += self.steps[m];
        }
        Some(v)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = usize::try_from(self.remaining).unwrap_or(usize::MAX);
        (n, usize::try_from(self.remaining).ok())
    }

    #[inline]
    fn fold<B, G: FnMut(B, IVec3) -> B>(self, init: B, g: G) -> B {
        self.run(init, g)
    }
}

impl Line26 {
    /// Internal iteration: the prefix and suffix moves from their lists, the
    /// middle as one tight loop of the midpoint state (no per-voxel phase
    /// test, the `i64`/`i128` choice made once).
    #[inline(always)]
    fn run<B>(mut self, init: B, mut g: impl FnMut(B, IVec3) -> B) -> B {
        let mut acc = init;
        if self.remaining == 0 {
            return acc;
        }
        let mut cur = self.cur;
        acc = g(acc, cur);
        let mut left = self.remaining - 1;
        let c = &mut self.cursor;
        let steps = self.steps;
        while left > 0 && c.pre_i < c.plan.pre.len {
            cur += steps[c.plan.pre.m[c.pre_i] as usize & 7];
            c.pre_i += 1;
            left -= 1;
            acc = g(acc, cur);
        }
        let n = left.min(c.mid_left);
        left -= n;
        match &mut c.mid {
            AnyMid::Narrow(s) => {
                for _ in 0..n {
                    cur += steps[s.step()];
                    acc = g(acc, cur);
                }
            }
            AnyMid::Wide(s) => {
                for _ in 0..n {
                    cur += steps[s.step()];
                    acc = g(acc, cur);
                }
            }
        }
        let post = &c.plan.post.m[c.post_i..];
        for &mv in post.iter().take(left as usize) {
            cur += steps[mv as usize & 7];
            acc = g(acc, cur);
        }
        acc
    }
}

impl ExactSizeIterator for Line26 {}
impl std::iter::FusedIterator for Line26 {}
