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

use std::ops::ControlFlow;

use glam::IVec3;

use super::clip::GridBox;
use super::segment::{DecisionInt, Frame, LeanFrame, Segment};
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
    pub(crate) dm: T,
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

impl Mid26State<i64> {
    /// Jumps ahead `1 ≤ k ≤ mid_left` columns in O(1), to the first column
    /// whose voxel leaves the local box `[w, w + h]` of the current voxel `w`
    /// (`h ≥ 0`, clipped here to [`super::tripod6::JUMP_MAX_EXTENT`]), or
    /// `mid_left` columns if that comes first, and counts them off
    /// `mid_left`. Returns the local moves `[k, n_u, n_v]` (the state is
    /// exactly the one `k` steps reach), or `None` where no jump applies:
    /// no column left, or the state is off a column voxel.
    ///
    /// In the middle of a line `E ∈ [D_u·S − D_m·S, D_u·S)` at every voxel
    /// (both branches of the step keep it there), and then the minor steps
    /// taken in `k` columns are `n(k) = ⌊(E + (k − 1)·D_u·S) / (D_m·S)⌋ + 1`:
    /// the first `k` with `n_u(k) > h_u` is `1 + ⌈(h_u·D_m·S − E) / (D_u·S)⌉`.
    pub(crate) fn jump_box(&mut self, h: [i64; 3], mid_left: &mut u64) -> Option<[i64; 3]> {
        let h = h.map(|x| x.clamp(0, super::tripod6::JUMP_MAX_EXTENT));
        let (dm, du, dv) = (self.dm, self.du, self.dv);
        // Off a column voxel (the adaptive ray's first column after a switch
        // back from 6 mode) the closed form does not hold yet: step first.
        if !(self.eu >= du - dm && self.eu < du.max(1) && self.ev >= dv - dm && self.ev < dv.max(1))
        {
            return None;
        }
        let first_past = |e: i64, d: i64, hk: i64| -> i64 {
            if d == 0 {
                return i64::MAX;
            }
            let x = hk * dm - e;
            1 + if x <= 0 { 0 } else { -(-x).div_euclid(d) }
        };
        let k = (h[0] + 1)
            .min(first_past(self.eu, du, h[1]))
            .min(first_past(self.ev, dv, h[2]))
            .min(*mid_left as i64);
        if k <= 0 {
            return None;
        }
        let nu = (self.eu + (k - 1) * du).div_euclid(dm) + 1;
        let nv = (self.ev + (k - 1) * dv).div_euclid(dm) + 1;
        self.eu += k * du - nu * dm;
        self.ev += k * dv - nv * dm;
        *mid_left -= k as u64;
        Some([k, nu, nv])
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
    let delta: [i64; 3] = std::array::from_fn(|k| to[k] - from[k]);
    if delta.iter().all(|&d| d == 0 || d == 1) {
        // `to` is a 26-neighbour of `from` (or `from` itself): the greedy
        // compression jumps there at once, whatever the tripod order.
        let mask = (0..3).fold(0u8, |m, k| m | ((delta[k] as u8) << k));
        return if mask == 0 {
            Moves::default()
        } else {
            single(mask)
        };
    }
    let n: i64 = delta.iter().sum();
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

/// The general 26-line iterator: any frame (`i64` or `i128`), any start
/// position (clipping), end paths of any length.
#[derive(Clone, Copy, Debug)]
struct General26 {
    cur: IVec3,
    cursor: Cursor26,
    steps: [IVec3; 8],
    remaining: u64,
}

impl General26 {
    #[inline]
    fn new(seg: &Segment) -> Self {
        Self::from_frame(&Frame::new(seg))
    }

    #[inline]
    pub(crate) fn from_frame(f: &Frame) -> Self {
        let f = *f;
        let plan = Plan26::new(&f);
        General26 {
            cur: f.voxel_world([0; 3]),
            cursor: Cursor26::at(&f, plan, 0),
            steps: f.mask_steps(),
            remaining: plan.count(),
        }
    }

    /// The part of the line inside `box_`, started in O(1) at its first
    /// in-box voxel.
    fn clipped(seg: &Segment, box_: &GridBox) -> Self {
        let f = Frame::new(seg);
        let plan = Plan26::new(&f);
        let (p, n) = match plan.range(&f, box_) {
            Some((a, b)) => (a, b - a + 1),
            None => (0, 0),
        };
        General26 {
            cur: f.voxel_world(plan.voxel_at(&f, p)),
            cursor: Cursor26::at(&f, plan, p),
            steps: f.mask_steps(),
            remaining: n,
        }
    }
}

impl Iterator for General26 {
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

    /// Internal iteration. With AVX2 the middle columns run eight at a
    /// time ([`super::lanes`]); the voxels are the same.
    #[inline]
    fn fold<B, G: FnMut(B, IVec3) -> B>(self, init: B, g: G) -> B {
        #[cfg(target_arch = "x86_64")]
        if self.cursor.mid_left >= LANES_MIN_COLUMNS && super::lanes::avx2::available() {
            // SAFETY: AVX2 was detected at run time.
            return unsafe { self.fold_avx2(init, g) };
        }
        self.run(init, g, scalar_mid)
    }
}

/// Middle columns below this count run scalar: the lanes' set-up costs
/// about as much as stepping a handful of columns.
pub(crate) const LANES_MIN_COLUMNS: u64 = 8;

/// The middle of a 26-line, scalar: `n` column steps from `cur` (the voxel of
/// the state's column), each voxel handed to `g`; returns the accumulator
/// and the last voxel.
#[inline(always)]
fn scalar_mid<B, G: FnMut(B, IVec3) -> B>(
    mid: &mut AnyMid,
    mut cur: IVec3,
    steps: &[IVec3; 8],
    n: u64,
    mut acc: B,
    g: &mut G,
) -> (B, IVec3) {
    match mid {
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
    (acc, cur)
}

impl General26 {
    /// Internal iteration: the prefix and suffix moves from their lists, the
    /// middle by `mid` (no per-voxel phase test).
    #[inline(always)]
    fn run<B, G: FnMut(B, IVec3) -> B>(
        mut self,
        init: B,
        mut g: G,
        mid: impl FnOnce(&mut AnyMid, IVec3, &[IVec3; 8], u64, B, &mut G) -> (B, IVec3),
    ) -> B {
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
        if n > 0 {
            (acc, cur) = mid(&mut c.mid, cur, &steps, n, acc, &mut g);
        }
        let post = &c.plan.post.m[c.post_i..];
        for &mv in post.iter().take(left as usize) {
            cur += steps[mv as usize & 7];
            acc = g(acc, cur);
        }
        acc
    }

    /// [`General26::run`] with the middle in AVX2 lanes where they apply.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn fold_avx2<B, G: FnMut(B, IVec3) -> B>(self, init: B, g: G) -> B {
        use super::lanes::{avx2::MidColumns, mid_voxels};
        self.run(init, g, |mid, cur, steps, n, acc, g| {
            if let AnyMid::Narrow(s) = mid
                && n >= LANES_MIN_COLUMNS
                && let Some(cols) = MidColumns::new([s.eu, s.ev], [s.dm, s.du, s.dv])
            {
                // SAFETY: the caller checked AVX2.
                unsafe { mid_voxels(&cols, cur, [steps[1], steps[2], steps[4]], n, acc, g) }
            } else {
                scalar_mid(mid, cur, steps, n, acc, g)
            }
        })
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
pub struct Line26(Inner26);

// The common variant is written in place; boxing the general one would
// allocate for every clipped line.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
enum Inner26 {
    Compact(Compact26),
    General(General26),
}

impl Line26 {
    /// The whole line of `seg`.
    #[inline]
    pub fn new(seg: &Segment) -> Self {
        match Compact26::new(seg) {
            Some(c) => Line26(Inner26::Compact(c)),
            None => Line26(Inner26::General(General26::new(seg))),
        }
    }

    #[cfg(test)]
    pub(crate) fn from_frame(f: &Frame) -> Self {
        Line26(Inner26::General(General26::from_frame(f)))
    }

    /// The part of the line inside `box_`, started in O(1) at its first
    /// in-box voxel.
    pub fn clipped(seg: &Segment, box_: &GridBox) -> Self {
        Line26(Inner26::General(General26::clipped(seg, box_)))
    }
}

impl Iterator for Line26 {
    type Item = IVec3;
    #[inline]
    fn next(&mut self) -> Option<IVec3> {
        match &mut self.0 {
            Inner26::Compact(c) => c.next(),
            Inner26::General(g) => g.next(),
        }
    }

    #[inline]
    fn size_hint(&self) -> (usize, Option<usize>) {
        match &self.0 {
            Inner26::Compact(c) => c.size_hint(),
            Inner26::General(g) => g.size_hint(),
        }
    }

    #[inline]
    fn fold<B, G: FnMut(B, IVec3) -> B>(self, init: B, g: G) -> B {
        match self.0 {
            Inner26::Compact(c) => c.fold(init, g),
            Inner26::General(l) => l.fold(init, g),
        }
    }
}

impl ExactSizeIterator for Line26 {}
impl std::iter::FusedIterator for Line26 {}

/// The common 26-line, set up without the general frame: a narrow segment
/// (no axis longer than 2^20 voxels) whose end paths are single moves (the
/// start voxel is a 26-neighbour of column 1's centre voxel, the end voxel
/// of column `M − 1`'s). Positions: 0 = `V0`, `c` = column `c`'s centre
/// (`1 ≤ c < M`), `last` = `V1`. The same voxels as [`General26`] (unit
/// test `compact_equals_general`), at a fraction of the set-up.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Compact26 {
    cur: IVec3,
    /// The end voxel `V1`.
    end: IVec3,
    /// Position of `cur`; past `last` when exhausted.
    pos: u64,
    last: u64,
    /// Midpoint state at column `pos` while `1 ≤ pos < last`.
    mid: Mid26State<i64>,
    /// Local move masks `V0 → C1` and `C(M−1) → V1` (or `V0 → V1` when
    /// `M < 2`).
    pre: u8,
    post: u8,
    /// World unit steps of local m, u, v.
    steps: [IVec3; 3],
}

impl Compact26 {
    /// The same quantities as [`Frame::new`], [`Plan26::new`] and
    /// [`Cursor26::at`] for the narrow case, or `None` where the general
    /// iterator is needed.
    #[inline]
    pub(crate) fn new(seg: &Segment) -> Option<Self> {
        Self::from_lean(&LeanFrame::new(seg)?)
    }

    /// [`Compact26::new`] from a lean frame.
    #[inline(always)]
    pub(crate) fn from_lean(f: &LeanFrame) -> Option<Self> {
        use crate::fixed::{HALF, ONE};
        let [dm, du, dv] = f.d;
        let [am, au, av] = f.a;
        let [mm, eu, ev] = f.end;
        let (cur, end, steps) = (f.start, f.end_voxel, f.steps);
        let (sdm, sdu, sdv) = (dm * ONE, du * ONE, dv * ONE);
        // Local move mask of steps of 0 or 1 along u and v (and `m` along m).
        let mask = |m: i64, u: i64, v: i64| -> Option<u8> {
            ((m | u | v) as u64 <= 1).then_some((m | u << 1 | v << 2) as u8)
        };
        if mm < 2 {
            let pre = mask(mm, eu, ev)?;
            return Some(Compact26 {
                cur,
                end,
                pos: 0,
                last: u64::from(pre != 0),
                mid: Mid26State {
                    eu: 0,
                    ev: 0,
                    du: sdu,
                    dv: sdv,
                    dm: sdm,
                },
                pre,
                post: 0,
                steps,
            });
        }
        let (bias_u, bias_v) = (f.bias(0, 1), f.bias(0, 2));
        // Columns 1 and M − 1 as Frame::centre_first / centre_last (same
        // bounds: each quotient takes three comparisons).
        let den = sdm;
        let n1 = |dk: i64, ak: i64, bias: i64| dk * (ONE - am) + dm * (ak + HALF) - bias;
        let q1 = |n: i64| i64::from(n >= den) + i64::from(n >= 2 * den) - i64::from(n < 0);
        let (nu, nv) = (n1(du, au, bias_u), n1(dv, av, bias_v));
        let (qu, qv) = (q1(nu), q1(nv));
        let bm = am + dm - (mm - 1) * ONE;
        // V1_k minus column M − 1's voxel along k: 2 − (three comparisons).
        let back = |dk: i64, ak: i64, ek: i64, bias: i64| -> i64 {
            let n = dm * (ak + dk - ek * ONE + HALF) - dk * bm - bias;
            2 - i64::from(n >= -den) - i64::from(n >= 0) - i64::from(n >= den)
        };
        let pre = mask(1, qu, qv)?;
        let post = mask(1, back(du, au, eu, bias_u), back(dv, av, ev, bias_v))?;
        // E at column 1: N(2) − (U(1) + 1)·D_m·S with N(2) = N(1) + D_k·S.
        let mid = Mid26State {
            eu: nu + sdu - (qu + 1) * sdm,
            ev: nv + sdv - (qv + 1) * sdm,
            du: sdu,
            dv: sdv,
            dm: sdm,
        };
        Some(Compact26 {
            cur,
            end,
            pos: 0,
            last: mm as u64,
            mid,
            pre,
            post,
            steps,
        })
    }

    /// The voxel at the current position.
    #[inline]
    pub(crate) fn start(&self) -> IVec3 {
        self.cur
    }

    /// The position of the end voxel `V1` (the number of moves).
    #[inline]
    pub(crate) fn last(&self) -> u64 {
        self.last
    }

    /// The move masks `V0 → C1` and `C(M−1) → V1`.
    #[inline]
    pub(crate) fn end_moves(&self) -> (u8, u8) {
        (self.pre, self.post)
    }

    /// The midpoint state at column 1.
    #[inline]
    pub(crate) fn mid(&self) -> Mid26State<i64> {
        self.mid
    }

    /// World unit steps of local m, u, v.
    #[inline]
    pub(crate) fn steps(&self) -> [IVec3; 3] {
        self.steps
    }

    /// Whether the whole line lies in the box `0..dims` (it is monotone
    /// between its end voxels, so they decide).
    #[inline]
    pub(crate) fn inside(&self, dims: crate::grid::Dims) -> bool {
        super::walk::in_box(self.cur, dims) && super::walk::in_box(self.end, dims)
    }

    /// Visits the linear indices of a fresh line lying wholly in a grid
    /// (`inside`): `idx` is the start voxel's index, `stride` the index
    /// steps of world x, y, z. `small`: the grid has fewer than 2^31 cells
    /// (the AVX2 lanes may run the middle). Returns the number visited, or
    /// `Err(index)` where the visitor stopped.
    #[inline]
    pub(crate) fn walk<F: FnMut(usize) -> ControlFlow<()>>(
        &self,
        idx: usize,
        stride: [isize; 3],
        small: bool,
        visit: &mut F,
    ) -> Result<u64, usize> {
        debug_assert_eq!(self.pos, 0, "walk of a started line");
        let axis = super::walk::axis_offsets(self.steps, stride);
        let mask_off = super::walk::mask_offsets(axis);
        let off = |mask: u8| mask_off[usize::from(mask & 7)];
        let mut idx = idx;
        if visit(idx).is_break() {
            return Err(idx);
        }
        if self.last == 0 {
            return Ok(1);
        }
        idx = idx.wrapping_add_signed(off(self.pre));
        if visit(idx).is_break() {
            return Err(idx);
        }
        if self.last == 1 {
            return Ok(2);
        }
        let n = self.last - 2;
        if n > 0 {
            idx = self.walk_mid(idx, axis, n, small, visit)?;
        }
        idx = idx.wrapping_add_signed(off(self.post));
        if visit(idx).is_break() {
            return Err(idx);
        }
        Ok(self.last + 1)
    }

    /// The middle columns `2..M` of [`Compact26::walk`] after column 1's
    /// index `idx`; returns the last index.
    #[inline(always)]
    fn walk_mid<F: FnMut(usize) -> ControlFlow<()>>(
        &self,
        mut idx: usize,
        axis: [isize; 3],
        n: u64,
        small: bool,
        visit: &mut F,
    ) -> Result<usize, usize> {
        let s = self.mid;
        #[cfg(target_arch = "x86_64")]
        if small && n >= LANES_MIN_COLUMNS && super::lanes::avx2::available() {
            use super::lanes::{avx2::MidColumns, mid_indices};
            if let Some(cols) = MidColumns::new([s.eu, s.ev], [s.dm, s.du, s.dv]) {
                // SAFETY: AVX2 is available; every index visited is an
                // in-grid cell of a grid with fewer than 2^31 cells.
                return unsafe { mid_indices(&cols, idx, axis, n, visit) };
            }
        }
        let _ = small;
        let mut s = s;
        let mask_off = super::walk::mask_offsets(axis);
        for _ in 0..n {
            idx = idx.wrapping_add_signed(mask_off[s.step()]);
            if visit(idx).is_break() {
                return Err(idx);
            }
        }
        Ok(idx)
    }

    /// World step of local move mask `mask`.
    #[inline(always)]
    fn step_of(&self, mask: usize) -> IVec3 {
        let [m, u, v] = self.steps;
        let bit = |k: usize| (mask >> k & 1) as i32;
        m * bit(0) + u * bit(1) + v * bit(2)
    }

    /// The table of [`Compact26::step_of`] for all eight masks.
    #[inline(always)]
    fn mask_steps(&self) -> [IVec3; 8] {
        let [m, u, v] = self.steps;
        [IVec3::ZERO, m, u, m + u, v, m + v, u + v, m + u + v]
    }

    #[inline]
    fn next(&mut self) -> Option<IVec3> {
        if self.pos > self.last {
            return None;
        }
        let v = self.cur;
        if self.pos < self.last {
            let mask = if self.pos == 0 {
                usize::from(self.pre)
            } else if self.pos + 1 == self.last {
                usize::from(self.post)
            } else {
                self.mid.step()
            };
            self.cur += self.step_of(mask);
        }
        self.pos += 1;
        Some(v)
    }

    #[inline]
    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = (self.last + 1).saturating_sub(self.pos);
        let n = usize::try_from(n).unwrap_or(usize::MAX);
        (n, Some(n))
    }

    /// Internal iteration: the end moves, and the middle columns in one
    /// loop (AVX2 lanes where available).
    #[inline]
    fn fold<B, G: FnMut(B, IVec3) -> B>(self, init: B, g: G) -> B {
        #[cfg(target_arch = "x86_64")]
        if self.last >= self.pos + 1 + LANES_MIN_COLUMNS && super::lanes::avx2::available() {
            // SAFETY: AVX2 was detected at run time.
            return unsafe { self.fold_avx2(init, g) };
        }
        self.run(init, g, |mid, cur, steps, n, acc, g| {
            scalar_mid(&mut AnyMid::Narrow(*mid), cur, steps, n, acc, g)
        })
    }

    #[inline(always)]
    fn run<B, G: FnMut(B, IVec3) -> B>(
        mut self,
        init: B,
        mut g: G,
        mid: impl FnOnce(&Mid26State<i64>, IVec3, &[IVec3; 8], u64, B, &mut G) -> (B, IVec3),
    ) -> B {
        let mut acc = init;
        if self.pos > self.last {
            return acc;
        }
        let mut cur = self.cur;
        acc = g(acc, cur);
        if self.pos == self.last {
            return acc;
        }
        let steps = self.mask_steps();
        if self.pos == 0 {
            cur += steps[usize::from(self.pre)];
            acc = g(acc, cur);
            self.pos = 1;
            if self.last == 1 {
                return acc;
            }
        }
        let n = self.last - 1 - self.pos;
        if n > 0 {
            (acc, cur) = mid(&self.mid, cur, &steps, n, acc, &mut g);
        }
        cur += steps[usize::from(self.post)];
        g(acc, cur)
    }

    /// [`Compact26::run`] with the middle in AVX2 lanes where they apply.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn fold_avx2<B, G: FnMut(B, IVec3) -> B>(self, init: B, g: G) -> B {
        use super::lanes::{avx2::MidColumns, mid_voxels};
        self.run(init, g, |s, cur, steps, n, acc, g| {
            match MidColumns::new([s.eu, s.ev], [s.dm, s.du, s.dv]) {
                // SAFETY: the caller checked AVX2.
                Some(cols) => unsafe {
                    mid_voxels(&cols, cur, [steps[1], steps[2], steps[4]], n, acc, g)
                },
                None => scalar_mid(&mut AnyMid::Narrow(*s), cur, steps, n, acc, g),
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::ONE;
    use rand::{Rng, SeedableRng};

    fn collect_next(mut it: impl Iterator<Item = IVec3>) -> Vec<IVec3> {
        std::iter::from_fn(move || it.next()).collect()
    }

    fn collect_fold(it: impl Iterator<Item = IVec3>) -> Vec<IVec3> {
        it.fold(Vec::new(), |mut v, x| {
            v.push(x);
            v
        })
    }

    /// The compact set-up gives the general iterator's voxels (by `next`
    /// and by `fold`, from every start position) on integer, sub-voxel and
    /// quarter-voxel endpoints (exact ties), axis-parallel, diagonal and
    /// far-out segments; and it applies to most segments.
    #[test]
    fn compact_equals_general() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2626);
        let mut compact = 0;
        let total = 20000;
        for i in 0..total {
            let span = [2i64, 5, 40, 200][i % 4];
            let kind = rng.random_range(0..5);
            let far = if i % 7 == 0 { (1i64 << 30) - 500 } else { 0 };
            let p = |rng: &mut rand_chacha::ChaCha8Rng| -> [i64; 3] {
                std::array::from_fn(|_| {
                    far * ONE
                        + match kind {
                            0 => rng.random_range(-span..=span) * ONE,
                            1 => rng.random_range(-4 * span..=4 * span) * (ONE / 4),
                            _ => rng.random_range(-span * ONE..=span * ONE),
                        }
                })
            };
            let a = p(&mut rng);
            let mut b = p(&mut rng);
            if kind == 3 {
                b[i % 3] = a[i % 3];
            }
            if kind == 4 {
                let t = rng.random_range(-span..=span) * (ONE / 2);
                b = [a[0] + t, a[1] - t, a[2] + t];
            }
            let seg = Segment::from_fixed(a, b).unwrap();
            let general = General26::new(&seg);
            let Some(c) = Compact26::new(&seg) else {
                continue;
            };
            compact += 1;
            let want = collect_next(general);
            assert_eq!(
                collect_next(Line26(Inner26::Compact(c))),
                want,
                "next {seg:?}"
            );
            assert_eq!(c.size_hint(), (want.len(), Some(want.len())), "{seg:?}");
            for skip in [0, 1, 2, want.len().saturating_sub(2), want.len()] {
                let mut c = c;
                for _ in 0..skip.min(want.len()) {
                    c.next();
                }
                let rest = &want[skip.min(want.len())..];
                let c = Line26(Inner26::Compact(c));
                assert_eq!(collect_fold(c), rest, "fold after {skip} {seg:?}");
            }
        }
        assert!(
            compact * 10 > total * 8,
            "compact path taken {compact} / {total}"
        );
    }
}
