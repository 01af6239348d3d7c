//! Tests of the topology oracles against independent exact checks:
//! hand-computed cases, a separating-axis test (an independent exact
//! segment–box decision), exact witness points, and symmetry properties.

use glam::IVec3;
use proptest::prelude::*;
use proptest::test_runner::{Config as ProptestConfig, RngSeed};

use crate::strategies::point;
use voxkit::Connectivity;
use voxkit::fixed::{FixedPoint, HALF, ONE};
use voxkit::topology::{
    Rational, connectivity_break, containment_gap, covers_segment, first_untouched,
    is_connected_path, segment_touches_voxel, segment_voxel_interval, touched_voxels,
};

/// Independent oracle: the separating-axis theorem for a closed segment and a
/// closed axis-aligned cube. Everything doubled so that the midpoint and half
/// extents are integers. Candidate axes: the 3 cube normals and the 3 cross
/// products of the segment direction with the cube edges; the sets are
/// disjoint iff one of them strictly separates.
fn sat_touches(a: FixedPoint, b: FixedPoint, v: IVec3) -> bool {
    let m: [i128; 3] =
        std::array::from_fn(|i| a[i] as i128 + b[i] as i128 - 2 * v[i] as i128 * ONE as i128);
    let w: [i128; 3] = std::array::from_fn(|i| b[i] as i128 - a[i] as i128);
    let h = ONE as i128; // doubled half-extent
    for i in 0..3 {
        if m[i].abs() > h + w[i].abs() {
            return false;
        }
    }
    for i in 0..3 {
        // L = w × e_i
        let mut e = [0i128; 3];
        e[i] = 1;
        let l = [
            w[1] * e[2] - w[2] * e[1],
            w[2] * e[0] - w[0] * e[2],
            w[0] * e[1] - w[1] * e[0],
        ];
        let proj = (l[0] * m[0] + l[1] * m[1] + l[2] * m[2]).abs();
        let radius = h * (l[0].abs() + l[1].abs() + l[2].abs());
        if proj > radius {
            return false;
        }
    }
    true
}

/// Whether the point at exact parameter `t` of segment a–b lies in the closed cube of `v`.
fn point_in_voxel(a: FixedPoint, b: FixedPoint, t: Rational, v: IVec3) -> bool {
    (0..3).all(|i| {
        let num = a[i] as i128 * t.den + t.num * (b[i] as i128 - a[i] as i128);
        let c = v[i] as i128 * ONE as i128;
        (c - HALF as i128) * t.den <= num && num <= (c + HALF as i128) * t.den
    })
}

/// A parameter strictly between `s < e` (the mediant keeps denominators small).
fn mediant(s: Rational, e: Rational) -> Rational {
    Rational::new(s.num + e.num, s.den + e.den)
}

fn fx(p: [f64; 3]) -> FixedPoint {
    voxkit::fixed::point_to_fixed(p).unwrap()
}

fn sorted(mut v: Vec<IVec3>) -> Vec<[i32; 3]> {
    let mut out: Vec<[i32; 3]> = v.drain(..).map(|v| v.to_array()).collect();
    out.sort();
    out
}

fn set(list: &[[i32; 3]]) -> Vec<[i32; 3]> {
    let mut v = list.to_vec();
    v.sort();
    v
}

#[test]
fn hand_computed_touched_sets() {
    type Case = ([f64; 3], [f64; 3], Vec<[i32; 3]>);
    let cases: Vec<Case> = vec![
        // Inside one voxel.
        ([0.1, -0.2, 0.3], [0.4, 0.4, -0.4], vec![[0, 0, 0]]),
        // Centre to centre along x.
        (
            [0.0; 3],
            [2.0, 0.0, 0.0],
            vec![[0, 0, 0], [1, 0, 0], [2, 0, 0]],
        ),
        // Through the shared edge at (½, ½, 0).
        (
            [0.0; 3],
            [1.0, 1.0, 0.0],
            vec![[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]],
        ),
        // Through the shared corner (½, ½, ½): all 8 around it.
        (
            [0.0; 3],
            [1.0; 3],
            vec![
                [0, 0, 0],
                [1, 0, 0],
                [0, 1, 0],
                [1, 1, 0],
                [0, 0, 1],
                [1, 0, 1],
                [0, 1, 1],
                [1, 1, 1],
            ],
        ),
        // Slope ½: crosses x = ½ at y = ¼, y = ½ at x = 1 (a face), x = 1.5 at y = ¾.
        (
            [0.0; 3],
            [2.0, 1.0, 0.0],
            vec![[0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 1, 0]],
        ),
        // Lying in the face y = ½ from x = −½ to ½: touches both sides.
        (
            [-0.5, 0.5, 0.0],
            [0.5, 0.5, 0.0],
            vec![
                [-1, 0, 0],
                [0, 0, 0],
                [1, 0, 0],
                [-1, 1, 0],
                [0, 1, 0],
                [1, 1, 0],
            ],
        ),
        // Along the edge y = z = ½ inside x ∈ [0.1, 0.2]: the 4 voxels around the edge.
        (
            [0.1, 0.5, 0.5],
            [0.2, 0.5, 0.5],
            vec![[0, 0, 0], [0, 1, 0], [0, 0, 1], [0, 1, 1]],
        ),
        // Ends exactly on a face: the voxel beyond is touched at one point.
        ([0.0; 3], [0.5, 0.0, 0.0], vec![[0, 0, 0], [1, 0, 0]]),
        // Misses the corner (½, ½) by passing just below it: x = ½ at y = 0.49.
        (
            [0.0, -0.01, 0.0],
            [1.0, 0.99, 0.0],
            vec![[0, 0, 0], [1, 0, 0], [1, 1, 0]],
        ),
        // Negative side, touches the corner (−½, −½, −½) from outside.
        ([-1.0, -1.0, -1.0], [-0.5, -0.5, -0.5], {
            let mut v = vec![[-1, -1, -1]];
            for z in -1..=0 {
                for y in -1..=0 {
                    for x in -1..=0 {
                        if [x, y, z] != [-1, -1, -1] {
                            v.push([x, y, z]);
                        }
                    }
                }
            }
            v
        }),
    ];
    for (a, b, expected) in cases {
        let (fa, fb) = (fx(a), fx(b));
        let got = sorted(touched_voxels(fa, fb).unwrap());
        assert_eq!(got, set(&expected), "{a:?} -> {b:?}");
        let got_rev = sorted(touched_voxels(fb, fa).unwrap());
        assert_eq!(got_rev, set(&expected), "reversed {a:?} -> {b:?}");
    }
}

#[test]
fn hand_computed_containment() {
    let v = |x, y, z| IVec3::new(x, y, z);
    // Through an edge: the two diagonal voxels suffice (closed cubes touch there).
    let (a, b) = (fx([0.0; 3]), fx([1.0, 1.0, 0.0]));
    assert!(covers_segment(a, b, &[v(0, 0, 0), v(1, 1, 0)]));
    // Slope ½: the part x ∈ [½, 1], y ∈ [¼, ½] lies only in voxel (1,0,0).
    let (a, b) = (fx([0.0; 3]), fx([2.0, 1.0, 0.0]));
    let all = [v(0, 0, 0), v(1, 0, 0), v(1, 1, 0), v(2, 1, 0)];
    assert!(covers_segment(a, b, &all));
    let gap = containment_gap(a, b, &[all[0], all[2], all[3]]).unwrap();
    assert_eq!(
        (gap.start, gap.end),
        (Rational::new(1, 4), Rational::new(1, 2))
    );
    // Dropping (1,1,0) leaves x ∈ (1, 1.5) uncovered: t ∈ (1/2, 3/4).
    let gap = containment_gap(a, b, &[all[0], all[1], all[3]]).unwrap();
    assert_eq!(
        (gap.start, gap.end),
        (Rational::new(1, 2), Rational::new(3, 4))
    );
    // Order and duplicates of the list do not matter.
    assert!(covers_segment(
        a,
        b,
        &[all[3], all[1], all[3], all[0], all[2], all[1]]
    ));
    // Last voxel missing: gap up to t = 1.
    let gap = containment_gap(a, b, &all[..3]).unwrap();
    assert_eq!((gap.start, gap.end), (Rational::new(3, 4), Rational::ONE));
    // Zero-length segment on a corner: any one of the 8 voxels covers it.
    let p = [HALF; 3];
    assert!(covers_segment(p, p, &[v(1, 0, 1)]));
    assert!(!covers_segment(p, p, &[v(2, 0, 0)]));
    // first_untouched finds the stray voxel.
    assert_eq!(
        first_untouched(a, b, &[all[0], v(0, 1, 0), all[1]]),
        Some(1)
    );
    assert_eq!(first_untouched(a, b, &all), None);
}

#[test]
fn connectivity_of_hand_paths() {
    let v = |x, y, z| IVec3::new(x, y, z);
    let p6 = [v(0, 0, 0), v(0, 0, 1), v(0, -1, 1), v(-1, -1, 1)];
    let p18 = [v(0, 0, 0), v(1, 1, 0), v(1, 2, 1)];
    let p26 = [v(0, 0, 0), v(1, 1, 1), v(0, 2, 2)];
    assert!(is_connected_path(&p6, Connectivity::Six));
    assert!(is_connected_path(&p6, Connectivity::TwentySix));
    assert_eq!(connectivity_break(&p18, Connectivity::Six), Some(0));
    assert!(is_connected_path(&p18, Connectivity::Eighteen));
    assert_eq!(connectivity_break(&p26, Connectivity::Eighteen), Some(0));
    assert!(is_connected_path(&p26, Connectivity::TwentySix));
    let jump = [v(0, 0, 0), v(1, 0, 0), v(3, 0, 0)];
    assert_eq!(connectivity_break(&jump, Connectivity::TwentySix), Some(1));
}

fn config(seed: u64, cases: u32) -> ProptestConfig {
    ProptestConfig {
        rng_seed: RngSeed::Fixed(seed),
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Voxels of the box around the segment, one voxel wider than any touched one.
fn neighbourhood(a: FixedPoint, b: FixedPoint) -> Vec<IVec3> {
    let lo: [i32; 3] = std::array::from_fn(|i| (a[i].min(b[i]).div_euclid(ONE) - 2) as i32);
    let hi: [i32; 3] = std::array::from_fn(|i| (a[i].max(b[i]).div_euclid(ONE) + 2) as i32);
    let mut out = Vec::new();
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                out.push(IVec3::new(x, y, z));
            }
        }
    }
    out
}

/// Checks the interval of `v` against exact witness points: its ends and a
/// point inside lie in the cube; a point before and after it (within [0, 1])
/// do not (the intersection of a convex cube and a segment is one interval).
fn check_interval(
    a: FixedPoint,
    b: FixedPoint,
    v: IVec3,
) -> std::result::Result<(), TestCaseError> {
    let Some((t0, t1)) = segment_voxel_interval(a, b, v) else {
        return Ok(());
    };
    prop_assert!(Rational::ZERO <= t0 && t0 <= t1 && t1 <= Rational::ONE);
    prop_assert!(point_in_voxel(a, b, t0, v), "start of interval outside {v}");
    prop_assert!(point_in_voxel(a, b, t1, v), "end of interval outside {v}");
    if t0 < t1 {
        prop_assert!(point_in_voxel(a, b, mediant(t0, t1), v));
    }
    if a != b {
        if t0 > Rational::ZERO {
            prop_assert!(!point_in_voxel(a, b, mediant(Rational::ZERO, t0), v));
        }
        if t1 < Rational::ONE {
            prop_assert!(!point_in_voxel(a, b, mediant(t1, Rational::ONE), v));
        }
    }
    Ok(())
}

fn mirror(p: FixedPoint, axis: usize) -> FixedPoint {
    let mut q = p;
    q[axis] = -q[axis];
    q
}

proptest! {
    #![proptest_config(config(0x7070_1001, 300))]

    /// Touching agrees with the separating-axis oracle on every voxel around
    /// the segment; touched_voxels is exactly the SAT-touched set.
    #[test]
    fn touching_matches_separating_axes(a in point(4), b in point(4)) {
        let touched = sorted(touched_voxels(a, b).unwrap());
        let mut by_sat = Vec::new();
        for v in neighbourhood(a, b) {
            let sat = sat_touches(a, b, v);
            prop_assert_eq!(segment_touches_voxel(a, b, v), sat, "voxel {}", v);
            check_interval(a, b, v)?;
            if sat {
                by_sat.push(v);
            }
        }
        prop_assert_eq!(touched, sorted(by_sat));
    }

    /// The touched set covers the segment; each voxel that alone holds some
    /// point of the segment is indispensable; extra voxels never hurt.
    #[test]
    fn touched_set_covers_and_is_tight(a in point(3), b in point(3)) {
        let touched = touched_voxels(a, b).unwrap();
        prop_assert!(covers_segment(a, b, &touched));
        let mut with_extra = touched.clone();
        with_extra.push(IVec3::new(100, 100, 100));
        with_extra.extend(touched.iter().map(|v| *v + IVec3::X));
        prop_assert!(covers_segment(a, b, &with_extra));
        for (k, &v) in touched.iter().enumerate() {
            let (t0, t1) = segment_voxel_interval(a, b, v).unwrap();
            let t = if t0 < t1 { mediant(t0, t1) } else { t0 };
            let holders = touched.iter().filter(|&&w| point_in_voxel(a, b, t, w)).count();
            prop_assert!(holders >= 1);
            let mut rest = touched.clone();
            rest.remove(k);
            match containment_gap(a, b, &rest) {
                Some(gap) => {
                    // The reported gap really is uncovered.
                    let mid = mediant(gap.start, gap.end);
                    prop_assert!(gap.start < gap.end);
                    prop_assert!(rest.iter().all(|&w| !point_in_voxel(a, b, mid, w)));
                    prop_assert!(point_in_voxel(a, b, mid, v));
                }
                None => prop_assert!(holders > 1, "sole holder {} removed yet covered", v),
            }
            if holders == 1 {
                prop_assert!(!covers_segment(a, b, &rest));
            }
        }
    }

    /// Reversal, mirroring each axis, permuting axes and integer translation
    /// map touched sets onto each other.
    #[test]
    fn touched_sets_are_symmetric(a in point(3), b in point(3), shift in -50i32..50, axis in 0usize..3) {
        let base = sorted(touched_voxels(a, b).unwrap());
        prop_assert_eq!(&sorted(touched_voxels(b, a).unwrap()), &base);
        let mirrored: Vec<[i32; 3]> = {
            let mut m: Vec<[i32; 3]> = base.iter().map(|v| { let mut w = *v; w[axis] = -w[axis]; w }).collect();
            m.sort();
            m
        };
        prop_assert_eq!(sorted(touched_voxels(mirror(a, axis), mirror(b, axis)).unwrap()), mirrored);
        let rot = |p: FixedPoint| [p[1], p[2], p[0]];
        let rotated: Vec<[i32; 3]> = {
            let mut m: Vec<[i32; 3]> = base.iter().map(|v| [v[1], v[2], v[0]]).collect();
            m.sort();
            m
        };
        prop_assert_eq!(sorted(touched_voxels(rot(a), rot(b)).unwrap()), rotated);
        let s = shift as i64 * ONE;
        let moved = |p: FixedPoint| [p[0] + s, p[1] - s, p[2] + 2 * s];
        let translated: Vec<[i32; 3]> = {
            let mut m: Vec<[i32; 3]> = base.iter().map(|v| [v[0] + shift, v[1] - shift, v[2] + 2 * shift]).collect();
            m.sort();
            m
        };
        prop_assert_eq!(sorted(touched_voxels(moved(a), moved(b)).unwrap()), translated);
    }

    /// Zero-length segments: the point touches 1, 2, 4 or 8 voxels, one per
    /// coordinate on a face doubling the count.
    #[test]
    fn points_touch_power_of_two_voxels(p in point(5)) {
        let on_face = p.iter().filter(|&&c| (c - HALF).rem_euclid(ONE) == 0).count();
        let touched = touched_voxels(p, p).unwrap();
        prop_assert_eq!(touched.len(), 1 << on_face);
        prop_assert!(covers_segment(p, p, &touched[..1]));
        let own = IVec3::from_array(std::array::from_fn(|i| voxkit::fixed::voxel_of(p[i]) as i32));
        prop_assert!(touched.contains(&own));
    }

    /// Random walks are connected under their own connectivity; one skipped
    /// voxel is found at the right index.
    #[test]
    fn random_walks_and_breaks(steps in proptest::collection::vec((-1i32..=1, -1i32..=1, -1i32..=1), 1..40), cut in 0usize..40) {
        let mut path = vec![IVec3::ZERO];
        for (x, y, z) in steps {
            let m = IVec3::new(x, y, z);
            if m != IVec3::ZERO {
                path.push(*path.last().unwrap() + m);
            }
        }
        let moved = |m: IVec3| m.abs().element_sum();
        let worst = path.windows(2).map(|w| moved(w[1] - w[0])).max().unwrap_or(0);
        for (conn, allowed) in [(Connectivity::Six, 1), (Connectivity::Eighteen, 2), (Connectivity::TwentySix, 3)] {
            prop_assert_eq!(is_connected_path(&path, conn), worst <= allowed);
        }
        if path.len() >= 3 {
            let k = 1 + cut % (path.len() - 2);
            let mut broken = path.clone();
            broken[k] = broken[k - 1] + IVec3::new(5, 0, 0);
            prop_assert_eq!(connectivity_break(&broken, Connectivity::TwentySix), Some(k - 1));
        }
    }
}

proptest! {
    #![proptest_config(config(0x7070_1002, 120))]

    /// Near the ends of the supported range (±2^30 voxels) the oracles stay
    /// exact: same SAT agreement, coverage and witness checks.
    #[test]
    fn exact_near_range_ends(a in point(3), b in point(3), sx in prop::bool::ANY, sy in prop::bool::ANY, sz in prop::bool::ANY) {
        let far = (1i64 << 30) - 4;
        let signs: [i64; 3] = [sx, sy, sz].map(|s| if s { 1 } else { -1 });
        let place = |p: FixedPoint| -> FixedPoint { std::array::from_fn(|i| p[i] + signs[i] * far * ONE) };
        let (fa, fb) = (place(a), place(b));
        let touched = touched_voxels(fa, fb).unwrap();
        prop_assert!(covers_segment(fa, fb, &touched));
        for v in neighbourhood(fa, fb) {
            prop_assert_eq!(segment_touches_voxel(fa, fb, v), sat_touches(fa, fb, v));
            check_interval(fa, fb, v)?;
        }
        // Same set as at the origin, shifted.
        let shift = IVec3::from_array(signs.map(|s| (s * far) as i32));
        let mut near: Vec<[i32; 3]> = touched_voxels(a, b).unwrap().into_iter().map(|v| (v + shift).to_array()).collect();
        near.sort();
        prop_assert_eq!(sorted(touched), near);
    }
}

#[test]
fn range_limits() {
    let max = (1i64 << 30) * ONE;
    // The extreme corner of the range, a point on a face (x = 2^30 is a voxel centre,
    // y = 2^30 − ½ a face).
    let p = [max, max - HALF, -max];
    assert_eq!(touched_voxels(p, p).unwrap().len(), 2);
    // A long segment across the whole range is still decided exactly.
    let (a, b) = ([-max, -max, -max], [max, max, max]);
    let c = IVec3::new(12345, 12345, 12345);
    assert!(segment_touches_voxel(a, b, c));
    assert!(
        segment_touches_voxel(a, b, c + IVec3::new(1, 0, 0)) == sat_touches(a, b, c + IVec3::X)
    );
    assert!(!segment_touches_voxel(a, b, c + IVec3::new(2, 0, 0)));
    // Beyond the range, or too large a box: typed errors, no panic.
    assert!(matches!(
        touched_voxels([max + 1, 0, 0], [0; 3]),
        Err(voxkit::VoxkitError::Invalid(_))
    ));
    assert!(matches!(
        touched_voxels(a, b),
        Err(voxkit::VoxkitError::Unsupported(_))
    ));
    // A long but thin segment is fine: its box is small.
    assert_eq!(
        touched_voxels([0; 3], [3_000_000 * ONE, 0, 0])
            .unwrap()
            .len(),
        3_000_001
    );
}
