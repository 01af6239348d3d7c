//! Exact segment–voxel touching and containment.
//!
//! A segment `a–b` is given by fixed-point endpoints ([`FixedPoint`],
//! `FRAC_BITS` = 20) and parametrised as `P(t) = a + t (b − a)`, `t ∈ [0, 1]`.
//! Voxel `v` is the closed cube `[v − ½, v + ½]³` of grid space, i.e.
//! `[v·ONE − HALF, v·ONE + HALF]` per axis in fixed point.
//!
//! The set of parameters at which the segment lies in the cube is a closed
//! interval (the intersection of three slabs and `[0, 1]`) whose ends are
//! rationals `(face − a_i) / (b_i − a_i)`; [`segment_voxel_interval`]
//! computes it exactly ([`Rational`], compared by cross-multiplication in
//! `i128`). Touching is "the interval is non-empty"; containment is "the
//! union of the intervals of the listed voxels is all of `[0, 1]`", decided
//! by sorting the intervals and sweeping once. Closed intervals that merely
//! touch (the segment passing through a shared face, edge or corner) count
//! as covering.
//!
//! # Range
//! Exact for fixed-point coordinates up to `2^60` in magnitude (numerators and
//! denominators stay below `2^62`, their products below `2^124`): far beyond
//! the supported grid range of `±2^30` voxels (`±2^50` in fixed point).
//!
//! A zero-length segment (`a == b`) is the single point `a`: every interval is
//! then `[0, 1]` or empty, and the point touches 1, 2, 4 or 8 voxels.

use std::cmp::Ordering;

use crate::error::{Result, VoxkitError};
use crate::fixed::{FixedPoint, HALF, MAX_COORD, ONE};
use crate::grid::Voxel;

/// A non-negative-denominator rational `num / den` (`den > 0`), the exact
/// parameter of a point along a segment. Equality and order compare values
/// (by cross-multiplication), so `1/2 == 2/4`.
#[derive(Clone, Copy, Debug)]
pub struct Rational {
    /// Numerator.
    pub num: i128,
    /// Denominator, always positive.
    pub den: i128,
}

impl Rational {
    /// The value 0.
    pub const ZERO: Rational = Rational { num: 0, den: 1 };
    /// The value 1.
    pub const ONE: Rational = Rational { num: 1, den: 1 };

    /// `num / den`; `den` must be positive (debug-asserted: every caller in
    /// this module produces a positive denominator by construction).
    #[inline]
    pub fn new(num: i128, den: i128) -> Self {
        debug_assert!(den > 0, "Rational denominator must be positive");
        Rational { num, den }
    }

    /// The nearest `f64` (for diagnostics only; decisions never use it).
    pub fn to_f64(self) -> f64 {
        self.num as f64 / self.den as f64
    }
}

impl PartialEq for Rational {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Rational {}

impl PartialOrd for Rational {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Rational {
    fn cmp(&self, other: &Self) -> Ordering {
        // Both denominators are positive, so cross-multiplying keeps the order.
        (self.num * other.den).cmp(&(other.num * self.den))
    }
}

impl std::fmt::Display for Rational {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.num, self.den)
    }
}

/// Largest fixed-point coordinate magnitude the rational arithmetic here is
/// exact for (see the module docs).
const EXACT_RANGE: i64 = 1 << 60;

/// The closed parameter interval `[t0, t1] ⊆ [0, 1]` over which segment
/// `a–b` lies in the closed cube of voxel `v`, or `None` if they do not meet.
///
/// Parametric slab intersection: per axis the segment is inside the slab
/// `[v_i·ONE − HALF, v_i·ONE + HALF]` for `t` between `(face − a_i) / d_i` for
/// the two faces (`d = b − a`); an axis with `d_i = 0` either keeps every `t`
/// or none.
///
/// ```
/// use glam::IVec3;
/// use voxkit::fixed::ONE;
/// use voxkit::topology::{segment_voxel_interval, Rational};
/// // Along x from the centre of voxel 0 to the centre of voxel 2:
/// // voxel 1 spans x in [0.5, 1.5], i.e. t in [1/4, 3/4].
/// let (t0, t1) = segment_voxel_interval([0, 0, 0], [2 * ONE, 0, 0], IVec3::X).unwrap();
/// assert_eq!((t0, t1), (Rational::new(1, 4), Rational::new(3, 4)));
/// ```
pub fn segment_voxel_interval(
    a: FixedPoint,
    b: FixedPoint,
    v: Voxel,
) -> Option<(Rational, Rational)> {
    debug_assert!(
        a.iter().chain(b.iter()).all(|c| c.abs() <= EXACT_RANGE),
        "fixed-point coordinates beyond 2^60 are outside the exact range"
    );
    let mut lo = Rational::ZERO;
    let mut hi = Rational::ONE;
    for i in 0..3 {
        let centre = v[i] as i128 * ONE as i128;
        let (face_min, face_max) = (centre - HALF as i128, centre + HALF as i128);
        let ai = a[i] as i128;
        let d = b[i] as i128 - ai;
        let (enter, exit) = match d.cmp(&0) {
            Ordering::Equal => {
                if ai < face_min || ai > face_max {
                    return None;
                }
                continue;
            }
            Ordering::Greater => (
                Rational::new(face_min - ai, d),
                Rational::new(face_max - ai, d),
            ),
            // Negate numerator and denominator to keep the denominator positive.
            Ordering::Less => (
                Rational::new(ai - face_max, -d),
                Rational::new(ai - face_min, -d),
            ),
        };
        lo = lo.max(enter);
        hi = hi.min(exit);
    }
    (lo <= hi).then_some((lo, hi))
}

/// Whether the closed segment `a–b` meets the closed cube of voxel `v`
/// (decided exactly; see [`segment_voxel_interval`]).
///
/// ```
/// use glam::IVec3;
/// use voxkit::fixed::ONE;
/// use voxkit::topology::segment_touches_voxel;
/// // The diagonal from (0,0,0) to (1,1,1) passes through the corner
/// // (½,½,½): it touches all eight voxels around that corner.
/// let (a, b) = ([0, 0, 0], [ONE; 3]);
/// assert!(segment_touches_voxel(a, b, IVec3::new(1, 0, 0)));
/// assert!(segment_touches_voxel(a, b, IVec3::new(0, 1, 1)));
/// assert!(!segment_touches_voxel(a, b, IVec3::new(2, 0, 0)));
/// ```
pub fn segment_touches_voxel(a: FixedPoint, b: FixedPoint, v: Voxel) -> bool {
    segment_voxel_interval(a, b, v).is_some()
}

/// The index of the first voxel of `path` that the closed segment `a–b` does
/// not touch, or `None` if it touches them all.
pub fn first_untouched(a: FixedPoint, b: FixedPoint, path: &[Voxel]) -> Option<usize> {
    path.iter().position(|&v| !segment_touches_voxel(a, b, v))
}

/// An uncovered stretch of a segment: every parameter `t` with
/// `start < t < end` (and `start < end`) lies in none of the given cubes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ContainmentGap {
    /// Start of the uncovered open parameter interval.
    pub start: Rational,
    /// End of the uncovered open parameter interval.
    pub end: Rational,
}

impl ContainmentGap {
    /// The grid-space point at the middle of the gap, for diagnostics (`f64`).
    pub fn midpoint(&self, a: FixedPoint, b: FixedPoint) -> [f64; 3] {
        let t = 0.5 * (self.start.to_f64() + self.end.to_f64());
        std::array::from_fn(|i| {
            let (ai, bi) = (a[i] as f64, b[i] as f64);
            (ai + t * (bi - ai)) / ONE as f64
        })
    }
}

/// The first uncovered stretch of segment `a–b` by the union of the closed
/// cubes of `voxels` (duplicates and voxels far from the segment are
/// harmless), or `None` if the union covers every point of the closed segment.
///
/// Each voxel contributes its exact parameter interval
/// ([`segment_voxel_interval`]); the intervals are sorted by start and swept
/// once, `O(n log n)`. Closed intervals that share only an end point (the
/// segment crossing from one cube to the next through a shared face, edge
/// or corner) leave no gap.
///
/// ```
/// use glam::IVec3;
/// use voxkit::fixed::ONE;
/// use voxkit::topology::{containment_gap, Rational};
/// // From voxel 0 to voxel 2 along x, with voxel 1 missing: t in (1/4, 3/4) is uncovered.
/// let gap = containment_gap([0; 3], [2 * ONE, 0, 0], &[IVec3::ZERO, IVec3::new(2, 0, 0)]).unwrap();
/// assert_eq!((gap.start, gap.end), (Rational::new(1, 4), Rational::new(3, 4)));
/// ```
pub fn containment_gap(a: FixedPoint, b: FixedPoint, voxels: &[Voxel]) -> Option<ContainmentGap> {
    let mut intervals: Vec<(Rational, Rational)> = voxels
        .iter()
        .filter_map(|&v| segment_voxel_interval(a, b, v))
        .collect();
    intervals.sort_unstable_by_key(|iv| iv.0);
    let gap = |start, end| Some(ContainmentGap { start, end });
    // `reach`: [0, reach] is covered; None while nothing has covered t = 0.
    let mut reach: Option<Rational> = None;
    for (lo, hi) in intervals {
        match reach {
            None if lo > Rational::ZERO => return gap(Rational::ZERO, lo),
            Some(r) if lo > r => return gap(r, lo),
            None => reach = Some(hi),
            Some(r) => reach = Some(r.max(hi)),
        }
    }
    match reach {
        None => gap(Rational::ZERO, Rational::ONE),
        Some(r) if r < Rational::ONE => gap(r, Rational::ONE),
        Some(_) => None,
    }
}

/// Whether the union of the closed cubes of `voxels` contains every point of
/// the closed segment `a–b` (see [`containment_gap`]).
///
/// ```
/// use glam::IVec3;
/// use voxkit::fixed::ONE;
/// use voxkit::topology::covers_segment;
/// // Centre to centre through the shared edge at (½, ½): the two end voxels
/// // meet at that edge, so together they cover the segment.
/// let ends = [IVec3::new(0, 0, 0), IVec3::new(1, 1, 0)];
/// assert!(covers_segment([0; 3], [ONE, ONE, 0], &ends));
/// assert!(!covers_segment([0; 3], [ONE, ONE, 0], &ends[..1]));
/// ```
pub fn covers_segment(a: FixedPoint, b: FixedPoint, voxels: &[Voxel]) -> bool {
    containment_gap(a, b, voxels).is_none()
}

/// Most cells [`touched_voxels`] will scan (its bounding box of candidates).
pub const TOUCHED_VOXELS_MAX_BOX: u128 = 1 << 22;

/// Every voxel whose closed cube meets the closed segment `a–b`, in scan
/// order (z outermost, x fastest).
///
/// A brute-force reference for tests and short segments: it scans every voxel
/// of the segment's bounding box (including the voxels on the far side of a
/// face the box ends on) and keeps those for which [`segment_touches_voxel`]
/// holds, so its cost is the box volume. It refuses boxes of more than
/// [`TOUCHED_VOXELS_MAX_BOX`] cells with [`VoxkitError::Unsupported`], and
/// coordinates beyond `±2^30` voxels with [`VoxkitError::Invalid`].
///
/// ```
/// use voxkit::fixed::{ONE, HALF};
/// use voxkit::topology::touched_voxels;
/// // A point on a corner touches 8 voxels, on an edge 4, on a face 2.
/// assert_eq!(touched_voxels([HALF; 3], [HALF; 3]).unwrap().len(), 8);
/// assert_eq!(touched_voxels([HALF, HALF, 0], [HALF, HALF, 0]).unwrap().len(), 4);
/// assert_eq!(touched_voxels([HALF, 0, 0], [HALF, 0, 0]).unwrap().len(), 2);
/// assert_eq!(touched_voxels([0; 3], [0; 3]).unwrap().len(), 1);
/// assert!(touched_voxels([0; 3], [1000 * ONE; 3]).is_err());
/// ```
pub fn touched_voxels(a: FixedPoint, b: FixedPoint) -> Result<Vec<Voxel>> {
    let limit = (MAX_COORD as i64) * ONE;
    if let Some(c) = a.iter().chain(b.iter()).find(|c| c.abs() > limit) {
        return Err(VoxkitError::invalid(format!(
            "fixed-point coordinate {c} is outside the supported range ±2^30 voxels"
        )));
    }
    // Voxel k touches coordinate x iff k·ONE − HALF ≤ x ≤ k·ONE + HALF, i.e.
    // ceil((x − HALF)/ONE) ≤ k ≤ floor((x + HALF)/ONE).
    let mut range = [(0i64, 0i64); 3];
    let mut cells: u128 = 1;
    for i in 0..3 {
        let (lo, hi) = (a[i].min(b[i]), a[i].max(b[i]));
        let kmin = -(HALF - lo).div_euclid(ONE);
        let kmax = (hi + HALF).div_euclid(ONE);
        range[i] = (kmin, kmax);
        cells *= (kmax - kmin + 1) as u128;
    }
    if cells > TOUCHED_VOXELS_MAX_BOX {
        return Err(VoxkitError::Unsupported(format!(
            "touched_voxels is a brute-force reference for short segments: \
             its bounding box has {cells} cells, the cap is {TOUCHED_VOXELS_MAX_BOX}"
        )));
    }
    let mut out = Vec::new();
    for z in range[2].0..=range[2].1 {
        for y in range[1].0..=range[1].1 {
            for x in range[0].0..=range[0].1 {
                // In range: |k| ≤ 2^30 + 1 by the coordinate check above.
                let v = Voxel::new(x as i32, y as i32, z as i32);
                if segment_touches_voxel(a, b, v) {
                    out.push(v);
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rational_order_is_by_value() {
        assert_eq!(Rational::new(1, 2), Rational::new(2, 4));
        assert!(Rational::new(-1, 3) < Rational::ZERO);
        assert!(Rational::new(2, 3) > Rational::new(3, 5));
        let big = 1i128 << 61;
        assert!(Rational::new(big - 1, big) < Rational::new(big, big + 1));
    }

    #[test]
    fn empty_voxel_list_leaves_whole_segment_uncovered() {
        let g = containment_gap([0; 3], [ONE; 3], &[]).unwrap();
        assert_eq!((g.start, g.end), (Rational::ZERO, Rational::ONE));
        let g = containment_gap([0; 3], [0; 3], &[Voxel::X]).unwrap();
        assert_eq!((g.start, g.end), (Rational::ZERO, Rational::ONE));
        assert!(covers_segment([0; 3], [0; 3], &[Voxel::ZERO]));
    }

    #[test]
    fn gap_at_the_start() {
        // x from 0 to 2 covered by voxels 1 and 2 only: t in [0, 1/4) uncovered.
        let g = containment_gap([0; 3], [2 * ONE, 0, 0], &[Voxel::X, Voxel::new(2, 0, 0)]).unwrap();
        assert_eq!((g.start, g.end), (Rational::ZERO, Rational::new(1, 4)));
    }
}
