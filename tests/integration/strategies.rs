//! Proptest strategies shared by the integration tests.

use proptest::prelude::*;
use voxkit::fixed::{FixedPoint, HALF, ONE};

/// A fixed-point coordinate `k·ONE + f` with fractions biased towards
/// faces, centres and quarter points so that ties are common.
fn coord(range: i64) -> impl Strategy<Value = i64> {
    (
        -range..=range,
        prop_oneof![
            Just(0i64),
            Just(HALF),
            Just(-HALF),
            Just(ONE / 4),
            -HALF..HALF
        ],
    )
        .prop_map(|(k, f)| k * ONE + f)
}

/// A fixed-point point with coordinates from [`coord`].
pub fn point(range: i64) -> impl Strategy<Value = FixedPoint> {
    [coord(range), coord(range), coord(range)]
}
