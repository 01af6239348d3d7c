//! Amanatides–Woo against the exact topology oracles and an exact rational
//! re-implementation of the same merge rule.

use std::ops::ControlFlow;

use glam::{DVec3, IVec3};
use proptest::prelude::*;
use proptest::test_runner::{Config as ProptestConfig, RngSeed};

use crate::strategies::point;
use voxkit::Connectivity;
use voxkit::fixed::{FixedPoint, HALF, ONE, to_f64, voxel_of};
use voxkit::grid::{DenseGrid, MemoryLimit};
use voxkit::line::amanatides_woo::{AwStepper, aw_line, aw_walk, aw_walk_mut};
use voxkit::topology::{
    Rational, covers_segment, first_untouched, is_connected_path, touched_voxels,
};

fn config(seed: u64, cases: u32) -> ProptestConfig {
    ProptestConfig {
        rng_seed: RngSeed::Fixed(seed),
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn to_dvec(p: FixedPoint) -> DVec3 {
    DVec3::new(to_f64(p[0]), to_f64(p[1]), to_f64(p[2]))
}

fn voxel_of_fixed(p: FixedPoint) -> IVec3 {
    IVec3::new(
        voxel_of(p[0]) as i32,
        voxel_of(p[1]) as i32,
        voxel_of(p[2]) as i32,
    )
}

/// The exact 6-line with A–W's rule, in rationals: merge the three sequences
/// of face-crossing times `(face − a_i) / d_i`, ties to y, then z, then x.
fn exact_six_line(a: FixedPoint, b: FixedPoint) -> Vec<IVec3> {
    let v0 = voxel_of_fixed(a);
    let v1 = voxel_of_fixed(b);
    let mut v = [v0.x as i64, v0.y as i64, v0.z as i64];
    let sign: [i64; 3] = std::array::from_fn(|i| (b[i] - a[i]).signum());
    let mut left: [i64; 3] = std::array::from_fn(|i| (v1[i] as i64 - v[i]).abs());
    let time = |i: usize, vi: i64| {
        let face = vi as i128 * ONE as i128 + sign[i] as i128 * HALF as i128;
        let (num, den) = (face - a[i] as i128, b[i] as i128 - a[i] as i128);
        if den > 0 {
            Rational::new(num, den)
        } else {
            Rational::new(-num, -den)
        }
    };
    let mut out = vec![v0];
    while left.iter().any(|&n| n > 0) {
        let mut best: Option<(Rational, u8, usize)> = None;
        for i in 0..3 {
            if left[i] == 0 {
                continue;
            }
            let key = (time(i, v[i]), [2u8, 0, 1][i], i);
            if best.is_none_or(|b| (key.0, key.1) < (b.0, b.1)) {
                best = Some(key);
            }
        }
        let i = best.unwrap().2;
        v[i] += sign[i];
        left[i] -= 1;
        out.push(IVec3::new(v[0] as i32, v[1] as i32, v[2] as i32));
    }
    out
}

/// Checks every property of an A–W path that holds exactly for lattice endpoints.
fn check_path(a: FixedPoint, b: FixedPoint, path: &[IVec3]) -> Result<(), TestCaseError> {
    let v0 = voxel_of_fixed(a);
    let v1 = voxel_of_fixed(b);
    prop_assert_eq!(path.first().copied(), Some(v0));
    prop_assert_eq!(path.last().copied(), Some(v1));
    prop_assert_eq!(path.len() as u64, 1 + voxkit::metric::d6(v0, v1));
    prop_assert!(is_connected_path(path, Connectivity::Six));
    prop_assert_eq!(first_untouched(a, b, path), None);
    prop_assert!(covers_segment(a, b, path));
    Ok(())
}

proptest! {
    #![proptest_config(config(0xA3_0001, 400))]

    /// Short lattice segments: no near-ties exist (distinct crossing times
    /// differ by more than 2 ulps), so A–W in f64 equals the exact merge,
    /// ties included, and has all the oracle properties.
    #[test]
    fn equals_exact_merge_on_short_lattice_segments(a in point(20), b in point(20)) {
        let line = aw_line(to_dvec(a), to_dvec(b)).unwrap();
        let n = line.len();
        let mut it = line;
        let mut path = Vec::new();
        while let Some(v) = it.next() {
            path.push(v);
            prop_assert_eq!(it.len(), n - path.len());
        }
        prop_assert_eq!(path.len(), n);
        check_path(a, b, &path)?;
        prop_assert_eq!(&path, &exact_six_line(a, b));
        // Reversal: b→a is a valid path too, and the same voxel set unless
        // the segment passes through an edge or corner (ties go in a fixed
        // axis order, not symmetrically), i.e. touches more voxels than the path.
        let mut back: Vec<IVec3> = aw_line(to_dvec(b), to_dvec(a)).unwrap().collect();
        check_path(b, a, &back)?;
        back.reverse();
        let mut fwd_set = path.clone();
        fwd_set.sort_by_key(|v| v.to_array());
        back.sort_by_key(|v| v.to_array());
        if back != fwd_set {
            prop_assert!(touched_voxels(a, b).unwrap().len() > path.len());
        }
    }

    /// Segments that start or end exactly on faces, edges and corners, and
    /// axis-parallel ones.
    #[test]
    fn boundary_and_axis_parallel(k in point(6), dk in (-6i64..=6, -6i64..=6, -6i64..=6), mask in 0u8..8, flat in 0u8..8) {
        let mut a = k;
        let mut b = [k[0] + dk.0 * ONE, k[1] + dk.1 * ONE, k[2] + dk.2 * ONE];
        for i in 0..3 {
            if mask & (1 << i) != 0 {
                a[i] = (a[i].div_euclid(ONE)) * ONE + HALF;
            }
            if flat & (1 << i) != 0 {
                b[i] = a[i];
            }
        }
        let path: Vec<IVec3> = aw_line(to_dvec(a), to_dvec(b)).unwrap().collect();
        check_path(a, b, &path)?;
        prop_assert_eq!(&path, &exact_six_line(a, b));
    }

    /// The grid walk visits exactly the iterator's in-grid voxels, in order,
    /// and stops where the visitor says.
    #[test]
    fn walk_equals_iterator_in_grid(a in point(12), b in point(12), nx in 1usize..9, ny in 1usize..9, nz in 1usize..9, stop in 0u64..30) {
        let dims = [nx, ny, nz];
        let n = nx * ny * nz;
        let mut grid = DenseGrid::from_vec(dims, (0..n).collect::<Vec<usize>>()).unwrap();
        let (da, db) = (to_dvec(a), to_dvec(b));
        let expected: Vec<IVec3> = aw_line(da, db).unwrap().filter(|&v| grid.contains(v)).collect();
        let mut seen = Vec::new();
        let out = aw_walk(&grid, da, db, |&i| { seen.push(i); ControlFlow::Continue(()) }).unwrap();
        let seen_voxels: Vec<IVec3> = seen.iter().map(|&i| grid.voxel_of_index(i)).collect();
        prop_assert_eq!(&seen_voxels, &expected);
        prop_assert_eq!(out.visited, expected.len() as u64);
        prop_assert_eq!(out.stopped_at, None);
        // Early stop after `stop + 1` cells, through the mutable walk.
        let mut count = 0u64;
        let out = aw_walk_mut(&mut grid, da, db, |c| {
            *c += n;
            count += 1;
            if count > stop { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
        }).unwrap();
        let k = expected.len().min(stop as usize + 1);
        prop_assert_eq!(out.visited, k as u64);
        prop_assert_eq!(out.stopped_at, if (stop as usize) < expected.len() { Some(expected[stop as usize]) } else { None });
        let touched: Vec<IVec3> = (0..n).filter(|&i| grid[i] >= n).map(|i| grid.voxel_of_index(i)).collect();
        let mut want = expected[..k].to_vec();
        want.sort_by_key(|v| (v.z, v.y, v.x));
        prop_assert_eq!(touched, want);
    }
}

proptest! {
    #![proptest_config(config(0xA3_0003, 300))]

    /// Diagonal segments between integer or half-integer points: every
    /// crossing is an exact tie, including where the segment enters and
    /// leaves the grid, so the clipping must apply the tie order too.
    #[test]
    fn walk_equals_iterator_on_tied_diagonals(
        a in (-6i64..=6, -6i64..=6, -6i64..=6),
        half in 0u8..8,
        s in (-1i64..=1, -1i64..=1, -1i64..=1),
        m in 1i64..12,
        dims in (1usize..7, 1usize..7, 1usize..7),
    ) {
        let mut fa = [a.0 * ONE, a.1 * ONE, a.2 * ONE];
        for (i, c) in fa.iter_mut().enumerate() {
            if half & (1 << i) != 0 {
                *c += HALF;
            }
        }
        let fb = [fa[0] + s.0 * m * ONE, fa[1] + s.1 * m * ONE, fa[2] + s.2 * m * ONE];
        let (da, db) = (to_dvec(fa), to_dvec(fb));
        let path: Vec<IVec3> = aw_line(da, db).unwrap().collect();
        check_path(fa, fb, &path)?;
        prop_assert_eq!(&path, &exact_six_line(fa, fb));
        let dims = [dims.0, dims.1, dims.2];
        let n = dims[0] * dims[1] * dims[2];
        let grid = DenseGrid::from_vec(dims, (0..n).collect::<Vec<usize>>()).unwrap();
        let expected: Vec<IVec3> = path.iter().copied().filter(|&v| grid.contains(v)).collect();
        let mut seen = Vec::new();
        aw_walk(&grid, da, db, |&i| { seen.push(grid.voxel_of_index(i)); ControlFlow::Continue(()) }).unwrap();
        prop_assert_eq!(seen, expected);
    }
}

#[test]
fn regression_long_diagonal_terminates_and_starts_right() {
    // From the brief: naive A–W (accumulated tMax, open-ended loop) hangs or
    // skips the start voxel on this ray.
    let a = [-41.75, -21.25, 4.8125];
    let b = [25.25, -4.0, -49.0];
    let fa = voxkit::fixed::point_to_fixed(a).unwrap();
    let fb = voxkit::fixed::point_to_fixed(b).unwrap();
    let path: Vec<IVec3> = aw_line(DVec3::from_array(a), DVec3::from_array(b))
        .unwrap()
        .collect();
    assert_eq!(path[0], IVec3::new(-42, -21, 5));
    assert_eq!(*path.last().unwrap(), IVec3::new(25, -4, -49));
    assert_eq!(path.len(), 1 + 67 + 17 + 54);
    check_path(fa, fb, &path).unwrap();
    assert_eq!(path, exact_six_line(fa, fb));
}

#[test]
fn zero_length_and_degenerate() {
    for p in [[0.0; 3], [0.5, 0.5, 0.5], [-3.25, 7.5, 1e-6]] {
        let d = DVec3::from_array(p);
        let path: Vec<IVec3> = aw_line(d, d).unwrap().collect();
        assert_eq!(path.len(), 1);
        assert_eq!(path[0], (d + 0.5).floor().as_ivec3());
    }
    // Inside one voxel.
    let line = aw_line(DVec3::new(0.1, 0.2, 0.3), DVec3::new(-0.4, 0.4, 0.0)).unwrap();
    assert_eq!(line.collect::<Vec<_>>(), vec![IVec3::ZERO]);
}

#[test]
fn hand_picked_ties() {
    let v = |x, y, z| IVec3::new(x, y, z);
    let line = |a: [f64; 3], b: [f64; 3]| -> Vec<IVec3> {
        aw_line(DVec3::from_array(a), DVec3::from_array(b))
            .unwrap()
            .collect()
    };
    // Through the edge (½, ½, 0): y first, then x.
    assert_eq!(
        line([0.0; 3], [1.0, 1.0, 0.0]),
        vec![v(0, 0, 0), v(0, 1, 0), v(1, 1, 0)]
    );
    // Reversed: y first again (tie order is by axis, not by direction).
    assert_eq!(
        line([1.0, 1.0, 0.0], [0.0; 3]),
        vec![v(1, 1, 0), v(1, 0, 0), v(0, 0, 0)]
    );
    // Through the corner (½, ½, ½): y, z, x.
    assert_eq!(
        line([0.0; 3], [1.0; 3]),
        vec![v(0, 0, 0), v(0, 1, 0), v(0, 1, 1), v(1, 1, 1)]
    );
    // x–z edge: z before x.
    assert_eq!(
        line([0.0; 3], [-1.0, 0.0, 1.0]),
        vec![v(0, 0, 0), v(0, 0, 1), v(-1, 0, 1)]
    );
    // Start exactly on a face moving backwards: step out at t = 0.
    assert_eq!(
        line([0.5, 0.0, 0.0], [-0.2, 0.0, 0.0]),
        vec![v(1, 0, 0), v(0, 0, 0)]
    );
    // End exactly on a face: the last voxel is the one on the positive side.
    assert_eq!(
        line([0.0; 3], [1.5, 0.0, 0.0]),
        vec![v(0, 0, 0), v(1, 0, 0), v(2, 0, 0)]
    );
    assert_eq!(
        line([0.0; 3], [-1.5, 0.0, 0.0]),
        vec![v(0, 0, 0), v(-1, 0, 0)]
    );
}

#[test]
fn rejects_bad_input_loudly() {
    let ok = DVec3::ZERO;
    for bad in [
        DVec3::new(f64::NAN, 0.0, 0.0),
        DVec3::new(0.0, f64::INFINITY, 0.0),
        DVec3::new(0.0, 0.0, 1.0e9 * 2.0),
        DVec3::new(-(2f64.powi(30)) - 1.0, 0.0, 0.0),
    ] {
        assert!(matches!(
            aw_line(ok, bad),
            Err(voxkit::VoxkitError::Invalid(_))
        ));
        assert!(matches!(
            AwStepper::new(bad, ok),
            Err(voxkit::VoxkitError::Invalid(_))
        ));
        let g = DenseGrid::new([2, 2, 2], 0u8, MemoryLimit::DEFAULT).unwrap();
        assert!(aw_walk(&g, bad, ok, |_| ControlFlow::Continue(())).is_err());
    }
}

proptest! {
    #![proptest_config(config(0xA3_0002, 150))]

    /// Near the ends of the range (±2^30) lattice endpoints are still exact
    /// in f64; short segments there equal the exact merge.
    #[test]
    fn exact_near_range_ends(a in point(30), b in point(30), sx in prop::bool::ANY, sy in prop::bool::ANY, sz in prop::bool::ANY) {
        let far = (1i64 << 30) - 40;
        let signs: [i64; 3] = [sx, sy, sz].map(|s| if s { 1 } else { -1 });
        let place = |p: FixedPoint| -> FixedPoint { std::array::from_fn(|i| p[i] + signs[i] * far * ONE) };
        let (fa, fb) = (place(a), place(b));
        let path: Vec<IVec3> = aw_line(to_dvec(fa), to_dvec(fb)).unwrap().collect();
        check_path(fa, fb, &path)?;
        prop_assert_eq!(&path, &exact_six_line(fa, fb));
    }
}

#[test]
fn range_ends_exactly() {
    let m = 2f64.powi(30);
    // The extreme corner is accepted; the walk across the whole range only
    // visits the grid's voxels, after jumping to where it enters.
    let a = DVec3::new(-m, -m + 0.25, -m + 0.5);
    let b = DVec3::new(m, m - 0.125, m);
    let line = aw_line(a, b).unwrap();
    assert_eq!(line.len() as u64, 1 + 3 * (1u64 << 31) - 1);
    // The visited voxels, recovered by a walk over an index grid, are a
    // 6-path of voxels the exact segment touches, entering at the grid's
    // min corner region and leaving at the max corner region.
    let idx = DenseGrid::from_vec([16, 16, 16], (0..4096usize).collect()).unwrap();
    let mut path = Vec::new();
    let out = aw_walk(&idx, a, b, |&i| {
        path.push(idx.voxel_of_index(i));
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(out.visited as usize, path.len());
    assert!(path.len() >= 3 * 15 + 1 - 3 && path.len() <= 3 * 16);
    assert!(is_connected_path(&path, Connectivity::Six));
    assert_eq!(path[0].min_element(), 0);
    assert_eq!(path.last().unwrap().max_element(), 15);
    let fa = voxkit::fixed::point_to_fixed(a.to_array()).unwrap();
    let fb = voxkit::fixed::point_to_fixed(b.to_array()).unwrap();
    assert_eq!(first_untouched(fa, fb, &path), None);
}

/// The f64 crossing time A–W uses for the face ahead of voxel coordinate `v`
/// (duplicated here on purpose: the test checks the divergence claim).
fn f64_crossing(v: i64, s: i64, a: f64, d: f64) -> f64 {
    ((v as f64 + 0.5 * s as f64) - a) / d
}

/// Incremental A–W (`tMax += tDelta`), the paper's recurrence, for comparison.
fn incremental_aw(a: DVec3, b: DVec3) -> Vec<IVec3> {
    let v0 = (a + 0.5).floor().as_i64vec3();
    let v1 = (b + 0.5).floor().as_i64vec3();
    let d = b - a;
    let mut v = v0.to_array();
    let s: [i64; 3] = std::array::from_fn(|i| d[i].signum() as i64 * (d[i] != 0.0) as i64);
    let mut left: [i64; 3] = std::array::from_fn(|i| (v1[i] - v0[i]).abs());
    let delta: [f64; 3] = std::array::from_fn(|i| 1.0 / d[i].abs());
    let mut t: [f64; 3] = std::array::from_fn(|i| {
        if left[i] > 0 {
            f64_crossing(v[i], s[i], a[i], d[i])
        } else {
            f64::INFINITY
        }
    });
    let mut out = vec![IVec3::new(v[0] as i32, v[1] as i32, v[2] as i32)];
    while left.iter().any(|&n| n > 0) {
        let i = if t[1] <= t[0] && t[1] <= t[2] {
            1
        } else if t[2] <= t[0] {
            2
        } else {
            0
        };
        v[i] += s[i];
        left[i] -= 1;
        t[i] = if left[i] > 0 {
            t[i] + delta[i]
        } else {
            f64::INFINITY
        };
        out.push(IVec3::new(v[0] as i32, v[1] as i32, v[2] as i32));
    }
    out
}

/// First index where two equally long paths differ.
fn divergence(p: &[IVec3], q: &[IVec3]) -> Option<usize> {
    p.iter().zip(q).position(|(x, y)| x != y)
}

/// Long random lattice lines (also near ±2^30): wherever recomputed A–W
/// differs from the exact merge, the two competing f64 crossing times were
/// equal (a near-tie the tie rule settled): never a reversed order.
/// Returns (lines differing from exact, recomputed / incremental).
fn long_line_study(seed: u64, lines: usize, max_len: i64, far: i64) -> (usize, usize) {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let (mut bad_re, mut bad_inc) = (0, 0);
    for _ in 0..lines {
        let mut rnd = |r: i64| rng.random_range(-r * ONE..=r * ONE);
        let centre = [rnd(far), rnd(far), rnd(far)];
        let a: FixedPoint =
            std::array::from_fn(|i| (centre[i] + rnd(max_len / 2)).clamp(-(1 << 50), 1 << 50));
        let b: FixedPoint =
            std::array::from_fn(|i| (centre[i] + rnd(max_len / 2)).clamp(-(1 << 50), 1 << 50));
        let (da, db) = (to_dvec(a), to_dvec(b));
        let exact = exact_six_line(a, b);
        let re: Vec<IVec3> = aw_line(da, db).unwrap().collect();
        assert_eq!(re.len(), exact.len());
        if let Some(k) = divergence(&re, &exact) {
            bad_re += 1;
            // At the common voxel exact[k-1], both took different axes: their
            // f64 crossing times must be equal.
            let v = exact[k - 1];
            let axis = |w: IVec3| (0..3).find(|&i| w[i] != v[i]).unwrap();
            let (i, j) = (axis(re[k]), axis(exact[k]));
            let d = db - da;
            let t = |i: usize| f64_crossing(v[i] as i64, d[i].signum() as i64, da[i], d[i]);
            assert_eq!(t(i), t(j), "reversed order at step {k} of {a:?} -> {b:?}");
        }
        if divergence(&incremental_aw(da, db), &exact).is_some() {
            bad_inc += 1;
        }
    }
    (bad_re, bad_inc)
}

#[test]
fn long_lines_differ_only_at_f64_ties() {
    let (re, inc) = long_line_study(0xA3_0004, 12, 4_000, 1_000);
    eprintln!("near origin: recomputed differs on {re}/12, incremental on {inc}/12");
    let (re, inc) = long_line_study(0xA3_0005, 12, 4_000, (1 << 30) - 5_000);
    eprintln!("near ±2^30: recomputed differs on {re}/12, incremental on {inc}/12");
}

/// Measurement (run with `--ignored --nocapture` in release): how often
/// recomputed and incremental A–W differ from the exact merge on long lines.
#[test]
#[ignore]
fn measure_recomputed_vs_incremental() {
    for (len, far) in [
        (20_000, 1_000),
        (200_000, 1_000),
        (200_000, (1 << 30) - 200_000),
    ] {
        let n = 100;
        let (re, inc) = long_line_study(0xA3_0006, n, len, far);
        eprintln!(
            "length ≲ {len}·√3, centre within ±{far}: recomputed differs on {re}/{n} lines, incremental on {inc}/{n}"
        );
    }
}
