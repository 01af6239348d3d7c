//! 2D lines against an independent exact segment–square test, the 3D
//! containment oracle (embedded at z = 0) and the `line_drawing` crate.

use glam::{I64Vec2, IVec3};
use proptest::prelude::*;
use proptest::test_runner::{Config as ProptestConfig, RngSeed};
use voxkit::fixed::ONE;
use voxkit::line::line2d::{
    Line4Stepper, Line8Stepper, MAX_COORD_2D, Pixel, alternating_line, line4, line8,
};

fn config(seed: u64, cases: u32) -> ProptestConfig {
    ProptestConfig {
        rng_seed: RngSeed::Fixed(seed),
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Exact 2D separating-axis test: does the closed segment p–q meet the
/// closed unit square centred on `c`? Doubled so the midpoint is integral.
fn touches(p: Pixel, q: Pixel, c: Pixel) -> bool {
    let m = [(p.x + q.x - 2 * c.x) as i128, (p.y + q.y - 2 * c.y) as i128];
    let w = [(q.x - p.x) as i128, (q.y - p.y) as i128];
    if m[0].abs() > 1 + w[0].abs() || m[1].abs() > 1 + w[1].abs() {
        return false;
    }
    let n = [-w[1], w[0]];
    (n[0] * m[0] + n[1] * m[1]).abs() <= n[0].abs() + n[1].abs()
}

/// Every pixel the segment touches, by brute force over its box.
fn touched(p: Pixel, q: Pixel) -> Vec<[i64; 2]> {
    let mut out = Vec::new();
    for y in p.y.min(q.y) - 1..=p.y.max(q.y) + 1 {
        for x in p.x.min(q.x) - 1..=p.x.max(q.x) + 1 {
            if touches(p, q, Pixel::new(x, y)) {
                out.push([x, y]);
            }
        }
    }
    out.sort();
    out
}

/// Containment by the exact 3D oracle, the plane embedded at z = 0.
fn covers(p: Pixel, q: Pixel, pixels: &[Pixel]) -> bool {
    let fx = |p: Pixel| [p.x * ONE, p.y * ONE, 0];
    let voxels: Vec<IVec3> = pixels
        .iter()
        .map(|p| IVec3::new(p.x as i32, p.y as i32, 0))
        .collect();
    voxkit::topology::covers_segment(fx(p), fx(q), &voxels)
}

fn sorted(p: &[Pixel]) -> Vec<[i64; 2]> {
    let mut v: Vec<[i64; 2]> = p.iter().map(|p| p.to_array()).collect();
    v.sort();
    v
}

fn chebyshev(a: Pixel, b: Pixel) -> i64 {
    (a - b).abs().max_element()
}

fn manhattan(a: Pixel, b: Pixel) -> i64 {
    (a - b).abs().element_sum()
}

/// Major extent A, minor extent B and whether the line is x-major.
fn extents(p: Pixel, q: Pixel) -> (i64, i64, bool) {
    let d = (q - p).abs();
    if d.y > d.x {
        (d.y, d.x, false)
    } else {
        (d.x, d.y, true)
    }
}

/// Whether the line passes exactly through a midpoint between two pixels of
/// a column (the 8-line's tie): 2B·u ≡ A (mod 2A) for some u in 1..=A.
fn has_midpoint_tie(p: Pixel, q: Pixel) -> bool {
    let (a, b, _) = extents(p, q);
    a > 0 && (1..=a).any(|u| (2 * b * u - a).rem_euclid(2 * a) == 0)
}

/// Whether the line passes exactly through a pixel corner (the 4-line's tie):
/// B(2u + 1) = A(2v + 1) for some u < A.
fn has_corner_tie(p: Pixel, q: Pixel) -> bool {
    let (a, b, _) = extents(p, q);
    a > 0 && b > 0 && (0..a).any(|u| (b * (2 * u + 1)) % a == 0 && (b * (2 * u + 1) / a) % 2 == 1)
}

fn collect_checked<I: ExactSizeIterator<Item = Pixel>>(
    mut it: I,
) -> Result<Vec<Pixel>, TestCaseError> {
    let n = it.len();
    let mut out = Vec::new();
    while let Some(p) = it.next() {
        out.push(p);
        prop_assert_eq!(it.len(), n - out.len());
    }
    prop_assert_eq!(out.len(), n);
    Ok(out)
}

fn pixel(range: i64) -> impl Strategy<Value = Pixel> {
    (-range..=range, -range..=range).prop_map(|(x, y)| Pixel::new(x, y))
}

proptest! {
    #![proptest_config(config(0x2D_0001, 500))]

    #[test]
    fn eight_line_properties(p in pixel(40), q in pixel(40)) {
        let line = collect_checked(line8(p, q).unwrap())?;
        prop_assert_eq!(line[0], p);
        prop_assert_eq!(*line.last().unwrap(), q);
        prop_assert_eq!(line.len() as i64, chebyshev(p, q) + 1);
        prop_assert!(line.windows(2).all(|w| chebyshev(w[0], w[1]) == 1));
        let (a, _, x_major) = extents(p, q);
        for (k, &c) in line.iter().enumerate() {
            prop_assert!(touches(p, q, c), "pixel {} not touched", c);
            // One pixel per column, the one nearest the line:
            // |2 (minor offset · A − major offset · B)| ≤ A.
            let (d, o) = (q - p, c - p);
            let err = if x_major { 2 * (o.y * d.x - o.x * d.y) } else { 2 * (o.x * d.y - o.y * d.x) };
            prop_assert!(err.abs() <= a, "pixel {} is not nearest in its column", c);
            let major = if x_major { o.x.abs() } else { o.y.abs() };
            prop_assert_eq!(major, k as i64);
        }
        // Reversal: the same set unless the line has a midpoint tie.
        let back: Vec<Pixel> = line8(q, p).unwrap().collect();
        if sorted(&back) != sorted(&line) {
            prop_assert!(has_midpoint_tie(p, q));
        }
    }

    #[test]
    fn four_line_properties(p in pixel(40), q in pixel(40)) {
        let line = collect_checked(line4(p, q).unwrap())?;
        prop_assert_eq!(line[0], p);
        prop_assert_eq!(*line.last().unwrap(), q);
        prop_assert_eq!(line.len() as i64, manhattan(p, q) + 1);
        prop_assert!(line.windows(2).all(|w| manhattan(w[0], w[1]) == 1));
        prop_assert!(line.iter().all(|&c| touches(p, q, c)));
        prop_assert!(covers(p, q, &line));
        if has_corner_tie(p, q) {
            // Through a corner two 4-paths are valid; this one is still minimal.
            prop_assert!(touched(p, q).len() > line.len());
        } else {
            // No corner: the 4-line is exactly the set of touched pixels,
            // and reversal gives the same set.
            prop_assert_eq!(sorted(&line), touched(p, q));
            let back: Vec<Pixel> = line4(q, p).unwrap().collect();
            prop_assert_eq!(sorted(&back), sorted(&line));
            // Cross-check with line_drawing's WalkGrid (f32, exact enough at
            // this size), which only differs from us in its corner tie order.
            let theirs: Vec<Pixel> = line_drawing::WalkGrid::new((p.x, p.y), (q.x, q.y)).map(|(x, y)| Pixel::new(x, y)).collect();
            prop_assert_eq!(&theirs, &line);
        }
    }

    /// The alternation is the 8-line up to the switch pixel and the 4-line
    /// from that pixel on, with the seed's step count.
    #[test]
    fn alternation_is_eight_then_four(p in pixel(30), q in pixel(30), k in 0usize..70) {
        let eight: Vec<Pixel> = line8(p, q).unwrap().collect();
        let four: Vec<Pixel> = line4(p, q).unwrap().collect();
        let k = k % (eight.len() + 1); // k == len: never switches
        let switch_at = eight.get(k).copied();
        let mut asked = Vec::new();
        let mut it = alternating_line(p, q, |c| { asked.push(c); Some(c) == switch_at }).unwrap();
        let mut out = Vec::new();
        loop {
            let (lo, hi) = it.size_hint();
            let Some(c) = it.next() else { break };
            out.push(c);
            prop_assert!(lo >= 1 && hi.is_some_and(|h| h >= 1));
            let rest = it.size_hint();
            prop_assert!(rest.0 < hi.unwrap() && rest.1.unwrap() < hi.unwrap());
        }
        match switch_at {
            None => prop_assert_eq!(&out, &eight),
            Some(s) => {
                prop_assert_eq!(&out[..=k], &eight[..=k]);
                let j = four.iter().position(|&c| c == s);
                prop_assert!(j.is_some(), "switch pixel {} is not on the 4-line", s);
                let j = j.unwrap();
                prop_assert_eq!(&out[k..], &four[j..]);
                // Seed count: k 8-steps, then (A − u) + (B − v) 4-steps.
                let (a, b, x_major) = extents(p, q);
                let o = (s - p).abs();
                let (u, v) = if x_major { (o.x, o.y) } else { (o.y, o.x) };
                prop_assert_eq!(out.len() as i64, 1 + k as i64 + (a - u) + (b - v));
                // The predicate was asked only while 8-connected.
                prop_assert_eq!(&asked[..], &eight[..=k]);
                // The 4-part covers the rest of the segment from the switch pixel.
                prop_assert!(out[k..].windows(2).all(|w| manhattan(w[0], w[1]) == 1));
            }
        }
        prop_assert!(out.iter().all(|&c| touches(p, q, c)));
    }

    /// Translation invariance up to the ends of the range.
    #[test]
    fn near_range_ends(p in pixel(20), q in pixel(20), sx in prop::bool::ANY, sy in prop::bool::ANY) {
        let far = Pixel::new(if sx { 1 } else { -1 }, if sy { 1 } else { -1 }) * (MAX_COORD_2D - 20);
        let shift = |v: Vec<Pixel>| v.into_iter().map(|c| c + far).collect::<Vec<_>>();
        prop_assert_eq!(line8(p + far, q + far).unwrap().collect::<Vec<_>>(), shift(line8(p, q).unwrap().collect()));
        prop_assert_eq!(line4(p + far, q + far).unwrap().collect::<Vec<_>>(), shift(line4(p, q).unwrap().collect()));
    }
}

#[test]
fn hand_picked_lines_and_ties() {
    let px = |v: &[[i64; 2]]| v.iter().map(|&a| Pixel::from_array(a)).collect::<Vec<_>>();
    let l8 = |a: [i64; 2], b: [i64; 2]| {
        line8(Pixel::from_array(a), Pixel::from_array(b))
            .unwrap()
            .collect::<Vec<_>>()
    };
    let l4 = |a: [i64; 2], b: [i64; 2]| {
        line4(Pixel::from_array(a), Pixel::from_array(b))
            .unwrap()
            .collect::<Vec<_>>()
    };
    // Single point, axis-parallel, 45°.
    assert_eq!(l8([3, -2], [3, -2]), px(&[[3, -2]]));
    assert_eq!(l4([3, -2], [3, -2]), px(&[[3, -2]]));
    assert_eq!(
        l8([0, 0], [0, -3]),
        px(&[[0, 0], [0, -1], [0, -2], [0, -3]])
    );
    assert_eq!(
        l4([0, 0], [-3, 0]),
        px(&[[0, 0], [-1, 0], [-2, 0], [-3, 0]])
    );
    assert_eq!(l8([0, 0], [2, 2]), px(&[[0, 0], [1, 1], [2, 2]]));
    // 45° 4-line: every step passes a corner; the minor axis (y) goes first.
    assert_eq!(
        l4([0, 0], [2, 2]),
        px(&[[0, 0], [0, 1], [1, 1], [1, 2], [2, 2]])
    );
    // 8-line midpoint tie at (1, ½): rounds toward the direction of travel,
    // so the reversed line differs.
    assert_eq!(l8([0, 0], [2, 1]), px(&[[0, 0], [1, 1], [2, 1]]));
    assert_eq!(l8([2, 1], [0, 0]), px(&[[2, 1], [1, 0], [0, 0]]));
    // 4-line corner tie at (1½, ½) on (0,0)→(3,1): y first.
    assert_eq!(
        l4([0, 0], [3, 1]),
        px(&[[0, 0], [1, 0], [1, 1], [2, 1], [3, 1]])
    );
    assert_eq!(
        l4([3, 1], [0, 0]),
        px(&[[3, 1], [2, 1], [2, 0], [1, 0], [0, 0]])
    );
    // Steep, negative octant.
    assert_eq!(
        l8([0, 0], [-1, -3]),
        px(&[[0, 0], [0, -1], [-1, -2], [-1, -3]])
    );
    assert_eq!(
        l4([0, 0], [-1, -3]),
        px(&[[0, 0], [0, -1], [-1, -1], [-1, -2], [-1, -3]])
    );
}

#[test]
fn steppers_are_small_and_copy() {
    fn is_copy<T: Copy>() {}
    is_copy::<Line8Stepper>();
    is_copy::<Line4Stepper>();
    assert!(std::mem::size_of::<Line8Stepper>() <= 128);
    let s = Line8Stepper::new(Pixel::ZERO, I64Vec2::new(5, 2)).unwrap();
    let mut t = s;
    assert!(t.step());
    assert_ne!(s, t);
    assert_eq!(s.remaining_steps(), 5);
}

/// `line_drawing` 1.0.1's `Bresenham` is not the midpoint (nearest-pixel)
/// line: it initialises its error to `dy − dx` instead of `2dy − dx`, so it
/// rounds late. Benchmarks against it compare different pixel sets.
#[test]
fn line_drawing_bresenham_differs_from_midpoint() {
    let ours: Vec<[i64; 2]> = line8(Pixel::ZERO, Pixel::new(3, 1))
        .unwrap()
        .map(|p| p.to_array())
        .collect();
    let theirs: Vec<[i64; 2]> = line_drawing::Bresenham::new((0i64, 0i64), (3, 1))
        .map(|(x, y)| [x, y])
        .collect();
    // At x = 2 the line is at y = ⅔: the nearest pixel is (2, 1).
    assert_eq!(ours, [[0, 0], [1, 0], [2, 1], [3, 1]]);
    assert_eq!(theirs, [[0, 0], [1, 0], [2, 0], [3, 1]]);
}
