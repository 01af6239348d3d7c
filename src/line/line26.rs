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
use super::segment::{DecisionInt, Frame, Segment, within26};

/// The Fig. 4 stepping state: two midpoint variables and their forward
/// differences. `step` returns the local move mask (bit 0 = m, always set;
/// bit 1 = u; bit 2 = v).
#[derive(Clone, Copy, Debug)]
pub struct Mid26State<T> {
    eu: T,
    ev: T,
    du: T,
    dv: T,
    dum: T,
    dvm: T,
}

impl<T: DecisionInt> Mid26State<T> {
    pub(crate) fn at(frame: &Frame, c: [i64; 3]) -> Self {
        let [eu, ev] = frame.mid_e(c);
        let s = crate::fixed::ONE as i128;
        let [dm, du, dv] = frame.d.map(|x| x as i128 * s);
        Mid26State {
            eu: T::from_i128(eu),
            ev: T::from_i128(ev),
            du: T::from_i128(du),
            dv: T::from_i128(dv),
            dum: T::from_i128(du - dm),
            dvm: T::from_i128(dv - dm),
        }
    }

    /// One column step; returns the local move mask.
    #[inline(always)]
    pub fn step(&mut self) -> usize {
        // The tree of Fig. 4, written as selects so that it compiles to
        // conditional moves (random slopes make the branches unpredictable).
        let su = self.eu >= T::ZERO;
        let sv = self.ev >= T::ZERO;
        self.eu += if su { self.dum } else { self.du };
        self.ev += if sv { self.dvm } else { self.dv };
        1 | (usize::from(su) << 1) | (usize::from(sv) << 2)
    }
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum AnyMid {
    Narrow(Mid26State<i64>),
    Wide(Mid26State<i128>),
}

impl AnyMid {
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
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Moves {
    pub m: [u8; MAX_SPECIAL],
    pub len: usize,
}

/// Longest tripod path between a line's end voxel and its first or last
/// column centre (at most 7 steps: see [`MAX_SPECIAL`]), with room to spare.
const MAX_PATH: usize = 16;

/// A short tripod path kept on the stack: the 26-line plans two per line,
/// and a heap allocation there cost more than the whole middle of a
/// 64-voxel line.
struct ShortPath {
    v: [[i64; 3]; MAX_PATH],
    len: usize,
}

impl std::ops::Deref for ShortPath {
    type Target = [[i64; 3]];
    fn deref(&self) -> &[[i64; 3]] {
        &self.v[..self.len]
    }
}

/// The exact tripod path (local voxels) from `from` to `to`, both on it.
fn tripod_path(f: &Frame, from: [i64; 3], to: [i64; 3]) -> ShortPath {
    let mut e = f.tripod_e(from);
    let mut c = from;
    let mut out = ShortPath {
        v: [[0; 3]; MAX_PATH],
        len: 1,
    };
    out.v[0] = c;
    let n: i64 = (0..3).map(|k| to[k] - c[k]).sum();
    assert!(
        (n.max(0) as usize) < MAX_PATH,
        "tripod path between a line end and its column centre has {n} steps"
    );
    for _ in 0..n.max(0) {
        let k = Frame::tripod_choice(e);
        f.tripod_advance(&mut e, k);
        c[k] += 1;
        out.v[out.len] = c;
        out.len += 1;
    }
    debug_assert_eq!(c, to, "tripod path does not reach its target");
    out
}

/// Greedy 26-compression of a tripod path: from the last kept voxel, jump to
/// the furthest later voxel that is still a 26-neighbour.
fn compress(path: &[[i64; 3]]) -> Moves {
    let mut mv = Moves::default();
    let mut i = 0;
    while i + 1 < path.len() {
        let mut j = i + 1;
        while j + 1 < path.len() && within26(path[i], path[j + 1]) {
            j += 1;
        }
        let mut mask = 0u8;
        for (k, (p, q)) in path[j].iter().zip(path[i].iter()).enumerate() {
            if p != q {
                mask |= 1 << k;
            }
        }
        mv.m[mv.len] = mask;
        mv.len += 1;
        i = j;
    }
    mv
}

/// The shape of a 26-line: prefix moves, middle column count, suffix moves.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Plan26 {
    pub pre: Moves,
    pub mid: u64,
    pub post: Moves,
    /// Local voxel where the middle starts (centre of column 1), if any.
    pub mid_start: [i64; 3],
}

impl Plan26 {
    pub(crate) fn new(f: &Frame) -> Self {
        let m = f.end[0];
        let integer =
            (0..3).all(|k| f.a[k] % crate::fixed::ONE == 0 && f.d[k] % crate::fixed::ONE == 0);
        if integer && m >= 2 {
            // Integer endpoints (Fig. 4 proper): every voxel is a column
            // centre, the end voxels included, so the end paths are single
            // moves: the first from the midpoint state at voxel 0, the last
            // from column m − 1 to the end voxel. Same layout as below.
            let first = AnyMid::at(f, [0; 3]).step() as u8;
            let cl = f.centre(m - 1);
            let last = (0..3).fold(0u8, |mask, k| mask | (u8::from(f.end[k] != cl[k]) << k));
            let single = |mv: u8| {
                let mut moves = Moves::default();
                moves.m[0] = mv;
                moves.len = 1;
                moves
            };
            return Plan26 {
                pre: single(first),
                mid: (m - 2) as u64,
                post: single(last),
                mid_start: [1, i64::from(first >> 1 & 1), i64::from(first >> 2 & 1)],
            };
        }
        if m >= 2 {
            let c1 = f.centre(1);
            let cl = f.centre(m - 1);
            Plan26 {
                pre: compress(&tripod_path(f, [0; 3], c1)),
                mid: (m - 2) as u64,
                post: compress(&tripod_path(f, cl, f.end)),
                mid_start: c1,
            }
        } else {
            Plan26 {
                pre: compress(&tripod_path(f, [0; 3], f.end)),
                mid: 0,
                post: Moves::default(),
                mid_start: [0; 3],
            }
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
            let mut c = f.centre(f.end[0] - 1);
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
    pub fn new(seg: &Segment) -> Self {
        let f = Frame::new(seg);
        let plan = Plan26::new(&f);
        Line26 {
            cur: f.voxel_world([0; 3]),
            cursor: Cursor26::at(&f, plan, 0),
            steps: std::array::from_fn(|m| f.mask_step(m as u8)),
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
            steps: std::array::from_fn(|m| f.mask_step(m as u8)),
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
}

impl ExactSizeIterator for Line26 {}
impl std::iter::FusedIterator for Line26 {}
