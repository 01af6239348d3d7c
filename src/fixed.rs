//! Fixed-point grid coordinates for sub-voxel endpoints.
//!
//! A grid-space coordinate `x` is stored as the integer `round(x · 2^FRAC_BITS)`
//! (nearest, ties away from zero). With [`FRAC_BITS`] = 20 a coordinate is
//! exact to 1/1,048,576 voxel; the supported range is `|x| ≤ 2^30` voxels
//! ([`MAX_COORD`]), so a fixed value has at most 51 significant bits and the
//! difference of two fits in 52. Products of two differences need up to 104
//! bits: stepping code uses `i128` wherever such a product can occur (or proves
//! an `i64` bound for the segment at hand first).

use crate::error::{Result, VoxkitError};

/// Fraction bits of a fixed-point grid coordinate.
pub const FRAC_BITS: u32 = 20;

/// The fixed-point value of 1 voxel.
pub const ONE: i64 = 1 << FRAC_BITS;

/// The fixed-point value of half a voxel (voxel faces lie at `k·ONE ± HALF`).
pub const HALF: i64 = ONE / 2;

/// Largest supported magnitude of a grid coordinate, in voxels.
pub const MAX_COORD: f64 = (1u64 << 30) as f64;

/// A fixed-point grid-space point.
pub type FixedPoint = [i64; 3];

/// Converts a grid coordinate to fixed point, rejecting NaN, infinities and
/// magnitudes beyond [`MAX_COORD`].
///
/// ```
/// use voxkit::fixed::{to_fixed, ONE};
/// assert_eq!(to_fixed(1.5).unwrap(), ONE + ONE / 2);
/// assert!(to_fixed(f64::NAN).is_err());
/// assert!(to_fixed(2e9).is_err());
/// ```
pub fn to_fixed(x: f64) -> Result<i64> {
    if !x.is_finite() {
        return Err(VoxkitError::invalid(format!(
            "coordinate {x} is not finite"
        )));
    }
    if x.abs() > MAX_COORD {
        return Err(VoxkitError::invalid(format!(
            "coordinate {x} is outside the supported range ±2^30"
        )));
    }
    Ok((x * ONE as f64).round() as i64)
}

/// Converts a point to fixed point (see [`to_fixed`]).
pub fn point_to_fixed(p: [f64; 3]) -> Result<FixedPoint> {
    Ok([to_fixed(p[0])?, to_fixed(p[1])?, to_fixed(p[2])?])
}

/// Converts a fixed-point coordinate back to `f64` (exact: 51 bits fit).
#[inline]
pub fn to_f64(v: i64) -> f64 {
    v as f64 / ONE as f64
}

/// The voxel containing fixed-point coordinate `v`: `floor(v / ONE + 1/2)`.
#[inline]
pub fn voxel_of(v: i64) -> i64 {
    (v + HALF).div_euclid(ONE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_ends_convert_exactly() {
        for x in [
            MAX_COORD,
            -MAX_COORD,
            MAX_COORD - 0.5,
            -MAX_COORD + 1.0 / ONE as f64,
        ] {
            assert_eq!(to_f64(to_fixed(x).unwrap()), x);
        }
        assert!(to_fixed(MAX_COORD + 1.0).is_err());
        assert!(to_fixed(f64::INFINITY).is_err());
    }

    #[test]
    fn voxel_rule_rounds_half_up() {
        assert_eq!(voxel_of(HALF), 1);
        assert_eq!(voxel_of(HALF - 1), 0);
        assert_eq!(voxel_of(-HALF), 0);
        assert_eq!(voxel_of(-HALF - 1), -1);
    }
}
