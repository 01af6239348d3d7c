//! The segment type shared by every exact line algorithm, and the
//! mirrored/permuted *local frame* in which they all step.
//!
//! # Local frame
//! Every axis is mirrored so that the direction is non-negative, and the axes
//! are permuted so that local axis `m` (index 0) has the largest direction
//! component; `u`, `v` (indices 1, 2) are the other two in world order.
//! Local coordinates are measured from the centre of the start voxel `V0`, in
//! fixed point (`S = 2^FRAC_BITS` per voxel): the start point lies in
//! `[-S/2, S/2]` on every axis.
//!
//! # Decision variables
//! For an ordered pair of local axes `(i, j)` and a voxel `c`, with
//! `r_k = (c_k + 1/2)·S − a_k` the distance from the start point to the exit
//! face of `c` along `k`, the tripod decision variable is
//! `e_ij = D_j·r_i − D_i·r_j`; `e_ij < 0` iff the line leaves `c` through its
//! `i` face before its `j` face. The 26-line's midpoint variable is
//! `E_ij = e_ij + D_j·S/2` (eq. 9 of Cohen-Or & Kaufman with scale `S`).
//!
//! # Tie rule (world shift)
//! Exact ties (the line passing through a voxel edge or corner, or a column
//! centre exactly between two voxels) are resolved as if the segment were
//! shifted by the infinitesimal world vector `(ε³, ε, ε²)`. For a pair the
//! shift adds `p_ij = −D_j·s_i·δ_i + D_i·s_j·δ_j` to `e_ij`; its sign is that
//! of the coefficient of the larger infinitesimal (`y` > `z` > `x`). Since all
//! decision variables are integers, `e + p < 0` is `e − [p < 0] < 0`: each
//! pair carries a *bias* of 0 or 1 subtracted once at initialisation. The
//! shifted segment has the same endpoint voxels as the original (the voxel rule
//! `floor(p + 1/2)` rounds boundary points up), passes through no edge or
//! corner, and its voxel set does not depend on the direction of travel.

use glam::IVec3;

use crate::error::{Result, VoxkitError};
use crate::fixed::{self, FixedPoint, HALF, ONE};
use crate::grid::Voxel;

/// Largest supported fixed-point coordinate magnitude (`2^30` voxels).
pub const MAX_FIXED: i64 = 1 << (30 + fixed::FRAC_BITS);

/// Direction components (fixed point) up to this bound (2^20 voxels) run on
/// `i64` decision variables and an `i64`, division-free set-up; longer
/// segments use `i128` throughout. On the line's voxels the decision
/// variables stay within `S·max(D) + S·max(D)/2 + 1 ≤ 1.5·2^60 + 1`, and every
/// set-up product within `2.5·2^60` (see `Frame::tripod_e64`,
/// `Frame::centre_first`, `Frame::centre_last`): below `2^63`.
pub const NARROW_MAX_DELTA: i64 = 1 << 40;

/// A validated 3D segment in grid space, endpoints in fixed point
/// (see [`crate::fixed`]).
///
/// ```
/// use voxkit::line::Segment;
/// let s = Segment::from_f64([0.2, 0.0, 0.0], [3.0, -1.6, 0.5]).unwrap();
/// assert_eq!(s.start_voxel().to_array(), [0, 0, 0]);
/// assert_eq!(s.end_voxel().to_array(), [3, -2, 1]);
/// assert!(Segment::from_f64([f64::NAN, 0.0, 0.0], [0.0; 3]).is_err());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Segment {
    a: FixedPoint,
    b: FixedPoint,
}

impl Segment {
    /// A segment from fixed-point endpoints; every coordinate must satisfy
    /// `|x| ≤ 2^30` voxels ([`MAX_FIXED`]).
    pub fn from_fixed(a: FixedPoint, b: FixedPoint) -> Result<Self> {
        for p in [a, b] {
            if p.iter().any(|c| c.unsigned_abs() > MAX_FIXED as u64) {
                return Err(VoxkitError::invalid(format!(
                    "fixed-point endpoint {p:?} is outside the supported range ±2^30 voxels"
                )));
            }
        }
        Ok(Segment { a, b })
    }

    /// A segment from grid-space `f64` endpoints, rounded to the fixed-point
    /// lattice; rejects NaN, infinities and coordinates beyond `±2^30`.
    pub fn from_f64(a: [f64; 3], b: [f64; 3]) -> Result<Self> {
        Self::from_fixed(fixed::point_to_fixed(a)?, fixed::point_to_fixed(b)?)
    }

    /// A segment between two voxel centres.
    pub fn from_voxels(a: Voxel, b: Voxel) -> Result<Self> {
        let f = |v: Voxel| [v.x as i64 * ONE, v.y as i64 * ONE, v.z as i64 * ONE];
        Self::from_fixed(f(a), f(b))
    }

    /// Start point (fixed point).
    #[inline]
    pub fn a(&self) -> FixedPoint {
        self.a
    }

    /// End point (fixed point).
    #[inline]
    pub fn b(&self) -> FixedPoint {
        self.b
    }

    /// The segment traversed the other way.
    #[inline]
    pub fn reversed(&self) -> Self {
        Segment {
            a: self.b,
            b: self.a,
        }
    }

    /// The voxel containing the start point (`floor(a + 1/2)`).
    pub fn start_voxel(&self) -> Voxel {
        voxel_of_point(self.a)
    }

    /// The voxel containing the end point.
    pub fn end_voxel(&self) -> Voxel {
        voxel_of_point(self.b)
    }

    /// Whether both endpoints are voxel centres.
    pub fn has_integer_endpoints(&self) -> bool {
        self.a.iter().chain(self.b.iter()).all(|c| c % ONE == 0)
    }
}

fn voxel_of_point(p: FixedPoint) -> Voxel {
    IVec3::new(
        fixed::voxel_of(p[0]) as i32,
        fixed::voxel_of(p[1]) as i32,
        fixed::voxel_of(p[2]) as i32,
    )
}

/// An integer type for decision variables: `i64` when the segment's bound
/// allows it, `i128` otherwise. Chosen once per segment.
pub trait DecisionInt:
    Copy
    + Ord
    + core::fmt::Debug
    + core::ops::Add<Output = Self>
    + core::ops::Sub<Output = Self>
    + core::ops::AddAssign
    + core::ops::SubAssign
    + core::ops::BitAnd<Output = Self>
    + core::ops::BitOr<Output = Self>
    + core::ops::Not<Output = Self>
{
    /// Zero.
    const ZERO: Self;
    /// Whether this is the wide (`i128`) type: set-up then uses the general
    /// `i128` formulas instead of the `i64` ones.
    const WIDE: bool;
    /// Narrows an exact `i128` value; the caller has proved it fits.
    fn from_i128(v: i128) -> Self;
    /// Widens an `i64` value.
    fn from_i64(v: i64) -> Self;
    /// All bits set if negative, else zero (a branch-free sign test).
    fn neg_mask(self) -> Self;
    /// The low bits, for building a move index from masks.
    fn low_bits(self) -> usize;
}

impl DecisionInt for i64 {
    const ZERO: Self = 0;
    const WIDE: bool = false;
    #[inline(always)]
    fn from_i64(v: i64) -> Self {
        v
    }
    #[inline(always)]
    fn neg_mask(self) -> Self {
        self >> 63
    }
    #[inline(always)]
    fn low_bits(self) -> usize {
        self as usize
    }
    #[inline(always)]
    fn from_i128(v: i128) -> Self {
        debug_assert!(
            i64::try_from(v).is_ok(),
            "decision variable {v} exceeds i64"
        );
        v as i64
    }
}

impl DecisionInt for i128 {
    const ZERO: Self = 0;
    const WIDE: bool = true;
    #[inline(always)]
    fn from_i64(v: i64) -> Self {
        v as i128
    }
    #[inline(always)]
    fn neg_mask(self) -> Self {
        self >> 127
    }
    #[inline(always)]
    fn low_bits(self) -> usize {
        self as usize
    }
    #[inline(always)]
    fn from_i128(v: i128) -> Self {
        v
    }
}

/// Shift order of the tie rule: `y` has the largest infinitesimal, then `z`,
/// then `x`.
const SHIFT_RANK: [u8; 3] = [2, 0, 1];

/// Whether the tie-rule perturbation of the decision variable of world axes
/// `(wi, wj)` is negative, for world direction magnitudes `wd` and signs
/// `wsign` (see the module docs: `p = −D_j s_i δ_i + D_i s_j δ_j`, the
/// dominant infinitesimal decides).
#[inline(always)]
pub(crate) fn tie_perturbation_negative(
    wd: &[i64; 3],
    wsign: &[i64; 3],
    wi: usize,
    wj: usize,
) -> bool {
    // Only signs matter: sign(c_i) = −sign(D_j)·s_i, sign(c_j) = sign(D_i)·s_j
    // (D ≥ 0). Written as selects: the axes vary from line to line, and
    // branches on them mispredict in a line's set-up.
    let ci = -i64::from(wd[wj] != 0) * wsign[wi];
    let cj = i64::from(wd[wi] != 0) * wsign[wj];
    let i_first = SHIFT_RANK[wi] < SHIFT_RANK[wj];
    let first = if i_first { ci } else { cj };
    let second = if i_first { cj } else { ci };
    first + i64::from(first == 0) * second < 0
}

/// The local frame of a narrow segment (no axis longer than 2^20 voxels),
/// computed straight-line: the same quantities as [`Frame::new`] for the
/// compact 26-line and tripod iterators, without the general frame's
/// `i128` and clipping fields. Branch-free where the outcome varies from
/// line to line (major axis, signs): a mispredicted branch costs as much as
/// the rest of a line's set-up.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LeanFrame {
    /// World start and end voxels.
    pub start: IVec3,
    pub end_voxel: IVec3,
    /// World axis of each local axis (m, u, v).
    pub perm: [usize; 3],
    /// Local direction components `D ≥ 0` (fixed point), `d[0]` the largest.
    pub d: [i64; 3],
    /// Local start point relative to the centre of `V0` (fixed point).
    pub a: [i64; 3],
    /// Local end voxel.
    pub end: [i64; 3],
    /// World unit steps of local m, u, v.
    pub steps: [IVec3; 3],
    wd: [i64; 3],
    wsign: [i64; 3],
}

impl LeanFrame {
    /// The frame of `seg`, or `None` if it is wide.
    #[inline(always)]
    pub(crate) fn new(seg: &Segment) -> Option<Self> {
        const PERMS: [[usize; 3]; 3] = [[0, 1, 2], [1, 0, 2], [2, 0, 1]];
        let (a, b) = (seg.a, seg.b);
        let v0w = a.map(|c| (c + HALF) >> fixed::FRAC_BITS);
        let v1w = b.map(|c| (c + HALF) >> fixed::FRAC_BITS);
        let wsign: [i64; 3] = std::array::from_fn(|k| ((b[k] - a[k]) >> 63) | 1);
        let wd: [i64; 3] = std::array::from_fn(|k| (b[k] - a[k]).abs());
        let m01 = usize::from(wd[1] > wd[0]);
        let m = if wd[2] > wd[m01] { 2 } else { m01 };
        let perm = PERMS[m];
        if wd[perm[0]] > NARROW_MAX_DELTA {
            return None;
        }
        let local = |w: usize| {
            (
                wsign[w] * (a[w] - v0w[w] * ONE),
                wsign[w] * (v1w[w] - v0w[w]),
            )
        };
        let unit = |w: usize| {
            let s = wsign[w] as i32;
            IVec3::new(
                s * i32::from(w == 0),
                s * i32::from(w == 1),
                s * i32::from(w == 2),
            )
        };
        let [(am, em), (au, eu), (av, ev)] = perm.map(local);
        Some(LeanFrame {
            start: IVec3::new(v0w[0] as i32, v0w[1] as i32, v0w[2] as i32),
            end_voxel: IVec3::new(v1w[0] as i32, v1w[1] as i32, v1w[2] as i32),
            perm,
            d: perm.map(|w| wd[w]),
            a: [am, au, av],
            end: [em, eu, ev],
            steps: perm.map(unit),
            wd,
            wsign,
        })
    }

    /// The biased tripod variables `[e_mu, e_mv, e_vu]` at the start voxel
    /// (the values of [`Frame::tripod_e64`] there; `|e| ≤ S·D_m + 1`).
    #[inline(always)]
    pub(crate) fn tripod_e(&self) -> [i64; 3] {
        let [dm, du, dv] = self.d;
        let [rm, ru, rv] = self.a.map(|a| HALF - a);
        [
            du * rm - dm * ru - self.bias(0, 1),
            dv * rm - dm * rv - self.bias(0, 2),
            du * rv - dv * ru - self.bias(2, 1),
        ]
    }

    /// The tie bias (0 or 1) of the decision variable of local axes `(i, j)`.
    #[inline(always)]
    pub(crate) fn bias(&self, i: usize, j: usize) -> i64 {
        i64::from(tie_perturbation_negative(
            &self.wd,
            &self.wsign,
            self.perm[i],
            self.perm[j],
        ))
    }
}

/// The mirrored, permuted frame of a segment (see the module docs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    /// World start voxel.
    pub v0: [i64; 3],
    /// World axis of each local axis (m, u, v).
    pub perm: [usize; 3],
    /// World sign (+1 / −1) of each local axis.
    pub sign: [i64; 3],
    /// Local direction components `D ≥ 0` (fixed point), `d[0]` the largest.
    pub d: [i64; 3],
    /// Local start point relative to the centre of `V0` (fixed point).
    pub a: [i64; 3],
    /// Local end voxel (`≥ 0` on every axis).
    pub end: [i64; 3],
    /// Tie biases of the pairs (m,u), (m,v), (v,u).
    pub bias: [i64; 3],
    /// `pneg[i][j]`: the tie-rule perturbation of `e_ij` is negative.
    pub pneg: [[bool; 3]; 3],
    /// Whether the decision variables need `i128`.
    pub wide: bool,
}

/// Local pair indices of the three decision variables: `e_mu`, `e_mv`, `e_vu`.
pub(crate) const PAIRS: [(usize, usize); 3] = [(0, 1), (0, 2), (2, 1)];

impl Frame {
    #[inline]
    pub fn new(seg: &Segment) -> Self {
        let (a, b) = (seg.a, seg.b);
        let v0w = [
            fixed::voxel_of(a[0]),
            fixed::voxel_of(a[1]),
            fixed::voxel_of(a[2]),
        ];
        let v1w = [
            fixed::voxel_of(b[0]),
            fixed::voxel_of(b[1]),
            fixed::voxel_of(b[2]),
        ];
        let wsign: [i64; 3] = std::array::from_fn(|i| if b[i] < a[i] { -1 } else { 1 });
        let wd: [i64; 3] = std::array::from_fn(|i| (b[i] - a[i]).abs());
        // Major axis: the largest component, first in x, y, z order on ties.
        let mut m = 0;
        for i in 1..3 {
            if wd[i] > wd[m] {
                m = i;
            }
        }
        // The other two axes in x, y, z order (no allocation: this runs once
        // per line, and lines are short).
        let perm = match m {
            0 => [0, 1, 2],
            1 => [1, 0, 2],
            _ => [2, 0, 1],
        };
        let sign = perm.map(|w| wsign[w]);
        let d = perm.map(|w| wd[w]);
        let la = perm.map(|w| wsign[w] * (a[w] - v0w[w] * ONE));
        let end = perm.map(|w| wsign[w] * (v1w[w] - v0w[w]));
        let pneg_of = |i: usize, j: usize| tie_perturbation_negative(&wd, &wsign, perm[i], perm[j]);
        let pneg: [[bool; 3]; 3] =
            std::array::from_fn(|i| std::array::from_fn(|j| i != j && pneg_of(i, j)));
        let bias = PAIRS.map(|(i, j)| i64::from(pneg[i][j]));
        Frame {
            v0: v0w,
            perm,
            sign,
            d,
            a: la,
            end,
            bias,
            pneg,
            wide: d[0] > NARROW_MAX_DELTA,
        }
    }

    /// World voxel of local voxel `c`.
    #[inline]
    pub fn voxel_world(&self, c: [i64; 3]) -> Voxel {
        let mut w = self.v0;
        for k in 0..3 {
            w[self.perm[k]] += self.sign[k] * c[k];
        }
        IVec3::new(w[0] as i32, w[1] as i32, w[2] as i32)
    }

    /// World unit step of each local axis.
    #[inline]
    pub fn world_steps(&self) -> [IVec3; 3] {
        // Compares, not `s[perm[k]] = …`: a run-time index into a vector
        // is a checked branch and a round trip through memory, per ray.
        std::array::from_fn(|k| {
            let sign = self.sign[k] as i32;
            IVec3::from_array(std::array::from_fn(|w| {
                if self.perm[k] == w { sign } else { 0 }
            }))
        })
    }

    /// World steps of all eight local move masks.
    #[inline]
    pub fn mask_steps(&self) -> [IVec3; 8] {
        let [a, b, c] = self.world_steps();
        [IVec3::ZERO, a, b, a + b, c, a + c, b + c, a + b + c]
    }

    /// Distance from the start point to the exit face of local voxel `c` along
    /// local axis `k`, fixed point.
    #[inline]
    pub fn r(&self, k: usize, ck: i64) -> i128 {
        ck as i128 * ONE as i128 + HALF as i128 - self.a[k] as i128
    }

    /// Biased tripod decision variables `[e_mu, e_mv, e_vu]` at local voxel `c`.
    pub fn tripod_e(&self, c: [i64; 3]) -> [i128; 3] {
        let mut out = [0i128; 3];
        for (n, &(i, j)) in PAIRS.iter().enumerate() {
            out[n] = self.d[j] as i128 * self.r(i, c[i])
                - self.d[i] as i128 * self.r(j, c[j])
                - self.bias[n] as i128;
        }
        out
    }

    /// [`Frame::tripod_e`] in `i64`, for narrow frames (`!wide`) and voxels `c`
    /// on the tripod path of the line.
    ///
    /// Bound: a path voxel is touched by the closed segment, at a point
    /// `a + t·D` with `0 ≤ r_k − t·D_k ≤ S` on every axis, so
    /// `e_ij = D_j (r_i − t D_i) − D_i (r_j − t D_j)` lies in `[−D_i·S, D_j·S]`
    /// and `|e − bias| ≤ S·D_m + 1 ≤ 2^60 + 1` (`D_m ≤ 2^40`). The products are
    /// formed in wrapping `i64`: they may overflow for far voxels, but the
    /// result is exact modulo 2^64 and fits, hence exact.
    #[inline]
    pub fn tripod_e64(&self, c: [i64; 3]) -> [i64; 3] {
        debug_assert!(!self.wide, "i64 set-up on a wide frame");
        let r = |k: usize| c[k].wrapping_mul(ONE).wrapping_add(HALF - self.a[k]);
        let (rm, ru, rv) = (r(0), r(1), r(2));
        let [dm, du, dv] = self.d;
        let e = [
            du.wrapping_mul(rm)
                .wrapping_sub(dm.wrapping_mul(ru))
                .wrapping_sub(self.bias[0]),
            dv.wrapping_mul(rm)
                .wrapping_sub(dm.wrapping_mul(rv))
                .wrapping_sub(self.bias[1]),
            du.wrapping_mul(rv)
                .wrapping_sub(dv.wrapping_mul(ru))
                .wrapping_sub(self.bias[2]),
        ];
        debug_assert_eq!(
            e.map(i128::from),
            self.tripod_e(c),
            "i64 tripod set-up at {c:?}"
        );
        e
    }

    /// Biased tripod variables in `T`: the `i64` formulas for `i64`, the
    /// general `i128` ones otherwise.
    #[inline]
    pub fn tripod_e_t<T: DecisionInt>(&self, c: [i64; 3]) -> [T; 3] {
        if T::WIDE {
            self.tripod_e(c).map(T::from_i128)
        } else {
            self.tripod_e64(c).map(T::from_i64)
        }
    }

    /// Direction components times `S` in `T` (`≤ 2^60` on narrow frames).
    #[inline]
    pub fn scaled_d<T: DecisionInt>(&self) -> [T; 3] {
        if T::WIDE {
            self.d.map(|x| T::from_i128(x as i128 * ONE as i128))
        } else {
            self.d.map(|x| T::from_i64(x * ONE))
        }
    }

    /// [`Frame::mid_e`] in `T` (narrow: `|E| ≤ 1.5·2^60 + 1` at the line's
    /// voxels, see [`Frame::tripod_e64`]).
    #[inline]
    pub fn mid_e_t<T: DecisionInt>(&self, c: [i64; 3]) -> [T; 2] {
        if T::WIDE {
            self.mid_e(c).map(T::from_i128)
        } else {
            let e = self.tripod_e64(c);
            [
                T::from_i64(e[0] + self.d[1] * HALF),
                T::from_i64(e[1] + self.d[2] * HALF),
            ]
        }
    }

    /// Biased 26-line midpoint variables `[E_mu, E_mv]` at local voxel `c`:
    /// `E ≥ 0` iff the next column's centre rounds one voxel up on that axis.
    pub fn mid_e(&self, c: [i64; 3]) -> [i128; 2] {
        let e = self.tripod_e(c);
        [
            e[0] + self.d[1] as i128 * HALF as i128,
            e[1] + self.d[2] as i128 * HALF as i128,
        ]
    }

    /// [`Frame::centre`] of column 1 (the line's `M ≥ 2`), without division
    /// on narrow frames.
    ///
    /// The numerator `n_k = D_k (S − a_m) + D_m (a_k + S/2) − bias` lies in
    /// `[−1, 2.5·D_m·S] ⊂ (−D_m S, 3 D_m S)` (`|a| ≤ S/2`, `D_k ≤ D_m`), so the
    /// floor of `n_k / (D_m S)` is one of −1, 0, 1, 2: three comparisons,
    /// `i64` (`≤ 2.5·2^60`).
    #[inline]
    pub fn centre_first(&self) -> [i64; 3] {
        debug_assert!(self.end[0] >= 2);
        if self.wide {
            return self.centre(1);
        }
        let den = self.d[0] * ONE;
        let q = |k: usize, bias: i64| -> i64 {
            let n = self.d[k] * (ONE - self.a[0]) + self.d[0] * (self.a[k] + HALF) - bias;
            debug_assert!(n > -den && n < 3 * den);
            i64::from(n >= den) + i64::from(n >= 2 * den) - i64::from(n < 0)
        };
        let c = [1, q(1, self.bias[0]), q(2, self.bias[1])];
        debug_assert_eq!(c, self.centre(1));
        c
    }

    /// [`Frame::centre`] of column `M − 1` (the line's `M ≥ 2`), without
    /// division on narrow frames.
    ///
    /// Measured from the end point `B = a + D` (local) the numerator is
    /// `n_k − V1_k·D_m·S = D_m (B_k − V1_k S + S/2) − D_k (B_m − (M − 1) S) − bias`
    /// with `B_k − V1_k S + S/2 ∈ [0, S]` and `B_m − (M − 1) S ∈ [S/2, 3S/2]`:
    /// in `[−1.5·D_m S − 1, D_m S]`, so the floor relative to `V1_k` is one of
    /// −2, −1, 0, 1.
    #[inline]
    pub fn centre_last(&self) -> [i64; 3] {
        let m = self.end[0];
        debug_assert!(m >= 2);
        if self.wide {
            return self.centre(m - 1);
        }
        let den = self.d[0] * ONE;
        let bm = self.a[0] + self.d[0] - (m - 1) * ONE;
        let q = |k: usize, bias: i64| -> i64 {
            let bk = self.a[k] + self.d[k] - self.end[k] * ONE + HALF;
            let n = self.d[0] * bk - self.d[k] * bm - bias;
            debug_assert!(n >= -2 * den && n < 2 * den);
            self.end[k] - 2 + i64::from(n >= -den) + i64::from(n >= 0) + i64::from(n >= den)
        };
        let c = [m - 1, q(1, self.bias[0]), q(2, self.bias[1])];
        debug_assert_eq!(c, self.centre(m - 1));
        c
    }

    /// The 26-line's voxel of column `c` (local): the line's minor
    /// coordinates at the column centre, rounded by the tie rule. General
    /// (`i128`, one division per axis); the line's set-up uses
    /// [`Frame::centre_first`] / [`Frame::centre_last`].
    pub fn centre(&self, c: i64) -> [i64; 3] {
        let s = ONE as i128;
        let dm = self.d[0] as i128;
        let am = self.a[0] as i128;
        let minor = |k: usize, bias: i64| -> i64 {
            let n = self.d[k] as i128 * (c as i128 * s - am)
                + dm * self.a[k] as i128
                + dm * HALF as i128
                - bias as i128;
            n.div_euclid(dm * s) as i64
        };
        [c, minor(1, self.bias[0]), minor(2, self.bias[1])]
    }

    /// Number of tripod steps (faces crossed).
    pub fn tripod_steps(&self) -> u64 {
        self.end.iter().map(|&e| e as u64).sum()
    }
}
