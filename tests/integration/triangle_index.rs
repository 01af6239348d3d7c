//! Kahan–Kelsen triangle indexing against brute force, Pick's theorem and the
//! scanline enumerator; inverse, sampler, parallel and mesh enumeration.

use std::collections::HashSet;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use voxkit::triangle::{
    COORD_LIMIT, LatticePoint, MeshIndex, ScanlineLattice, TriangleIndex, TriangleShape,
};

type Tri = [LatticePoint; 3];

fn cross(o: LatticePoint, a: LatticePoint, b: LatticePoint) -> i128 {
    (a[0] as i128 - o[0] as i128) * (b[1] as i128 - o[1] as i128)
        - (a[1] as i128 - o[1] as i128) * (b[0] as i128 - o[0] as i128)
}

/// Exact closed-triangle (or, if collinear, closed-segment) membership.
fn inside(v: &Tri, p: LatticePoint) -> bool {
    let d = cross(v[0], v[1], v[2]);
    if d != 0 {
        let s = d.signum();
        (0..3).all(|e| s * cross(v[e], v[(e + 1) % 3], p) >= 0)
    } else {
        // p collinear with all three and within their bounding box.
        let lo = *v.iter().min().unwrap();
        let hi = *v.iter().max().unwrap();
        cross(lo, hi, p) == 0
            && (0..2).all(|k| {
                let (a, b) = (lo[k].min(hi[k]), lo[k].max(hi[k]));
                (a..=b).contains(&p[k])
            })
            && (lo != hi || p == lo)
    }
}

fn gcd(a: i128, b: i128) -> i128 {
    let (mut a, mut b) = (a.abs(), b.abs());
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Pick's theorem: `K = (|2A| + B)/2 + 1`; collinear: the segment's points.
fn pick(v: &Tri) -> u64 {
    let e = |p: LatticePoint, q: LatticePoint| {
        gcd(q[0] as i128 - p[0] as i128, q[1] as i128 - p[1] as i128)
    };
    let d = cross(v[0], v[1], v[2]).abs();
    if d == 0 {
        let m = e(v[0], v[1]).max(e(v[1], v[2])).max(e(v[0], v[2]));
        return (m + 1) as u64;
    }
    let b = e(v[0], v[1]) + e(v[1], v[2]) + e(v[2], v[0]);
    ((d + b) / 2 + 1) as u64
}

fn brute(v: &Tri) -> Vec<LatticePoint> {
    let (x0, x1) = (
        v.iter().map(|p| p[0]).min().unwrap(),
        v.iter().map(|p| p[0]).max().unwrap(),
    );
    let (y0, y1) = (
        v.iter().map(|p| p[1]).min().unwrap(),
        v.iter().map(|p| p[1]).max().unwrap(),
    );
    let mut out = Vec::new();
    for y in y0..=y1 {
        for x in x0..=x1 {
            if inside(v, [x, y]) {
                out.push([x, y]);
            }
        }
    }
    out
}

/// Full check of one triangle small enough to enumerate its bounding box.
fn check_exhaustive(v: Tri) {
    let t = TriangleIndex::new(v).unwrap();
    let mut expect = brute(&v);
    assert_eq!(t.len(), expect.len() as u64, "count {v:?}");
    assert_eq!(t.len(), pick(&v), "pick {v:?}");
    let pts: Vec<_> = (0..t.len()).map(|i| t.point(i).unwrap()).collect();
    assert_eq!(t.point(t.len()), None);
    // Iterator and visitor give the same sequence.
    assert_eq!(t.iter().collect::<Vec<_>>(), pts, "iter {v:?}");
    let mut vis = Vec::new();
    t.for_each_point(|p| vis.push(p));
    assert_eq!(vis, pts, "visitor {v:?}");
    for (i, p) in pts.iter().enumerate() {
        assert_eq!(t.index_of(*p), Some(i as u64), "index_of {v:?} {p:?}");
    }
    let mut sorted = pts.clone();
    sorted.sort();
    expect.sort();
    assert_eq!(sorted, expect, "point set {v:?}");
    // Every other point of the (grown) bounding box is rejected by index_of.
    let set: HashSet<_> = pts.iter().copied().collect();
    let (x0, x1) = (
        v.iter().map(|p| p[0]).min().unwrap(),
        v.iter().map(|p| p[0]).max().unwrap(),
    );
    let (y0, y1) = (
        v.iter().map(|p| p[1]).min().unwrap(),
        v.iter().map(|p| p[1]).max().unwrap(),
    );
    for y in y0 - 1..=y1 + 1 {
        for x in x0 - 1..=x1 + 1 {
            if !set.contains(&[x, y]) {
                assert_eq!(t.index_of([x, y]), None, "outside {v:?} {x} {y}");
            }
        }
    }
    // Scanline oracle.
    let s = ScanlineLattice::new(v).unwrap();
    let mut sc = Vec::new();
    s.for_each(|p| sc.push(p));
    sc.sort();
    assert_eq!(sc, expect, "scanline {v:?}");
    assert_eq!(s.count(), t.len());
}

fn rand_tri(rng: &mut ChaCha8Rng, r: i64, offset: LatticePoint) -> Tri {
    let mut p = || {
        [
            offset[0] + rng.random_range(-r..=r),
            offset[1] + rng.random_range(-r..=r),
        ]
    };
    [p(), p(), p()]
}

#[test]
fn bijection_random_small_triangles() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5eed_0001);
    let l = COORD_LIMIT;
    let offsets = [
        [0, 0],
        [l - 20, l - 20],
        [-l + 20, l - 20],
        [-l + 20, -l + 20],
        [12345, -987],
    ];
    for n in 0..4000 {
        let r = [1, 2, 4, 9, 25][n % 5];
        let off = offsets[n % offsets.len()];
        check_exhaustive(rand_tri(&mut rng, r, off));
    }
}

#[test]
fn all_windings_and_vertex_orders() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..300 {
        let v = rand_tri(&mut rng, 12, [0, 0]);
        for perm in [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ] {
            check_exhaustive([v[perm[0]], v[perm[1]], v[perm[2]]]);
        }
    }
}

#[test]
fn hand_picked_cases() {
    let cases: &[Tri] = &[
        [[0, 0], [1, 0], [0, 1]],
        [[0, 0], [0, 1], [1, 0]],
        [[0, 0], [7, 0], [0, 5]],
        [[0, 0], [6, 0], [0, 6]],
        [[0, 0], [6, 6], [6, 0]],
        [[0, 0], [4, 8], [8, 4]],
        [[-3, -3], [3, -3], [0, 3]],
        [[0, 0], [30, 31], [31, 32]], // 45° sliver, D = ±1
        [[0, 0], [5, 5], [5, 6]],
        [[2, 3], [2, 3], [2, 3]],  // point
        [[0, 0], [3, 6], [1, 2]],  // collinear, middle vertex inside
        [[0, 0], [0, 0], [4, -2]], // collinear, repeated vertex
        [[5, 0], [-5, 0], [0, 0]], // collinear horizontal
        [[1, 1], [1, 9], [1, 4]],  // collinear vertical
    ];
    for v in cases {
        check_exhaustive(*v);
    }
    assert_eq!(
        TriangleIndex::new([[2, 3]; 3]).unwrap().shape(),
        TriangleShape::Point
    );
    assert_eq!(
        TriangleIndex::new([[0, 0], [3, 6], [1, 2]])
            .unwrap()
            .shape(),
        TriangleShape::Segment
    );
}

#[test]
fn collinear_random() {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    for _ in 0..1000 {
        let d = [rng.random_range(-4..=4), rng.random_range(-4..=4)];
        let o = [rng.random_range(-50..=50), rng.random_range(-50..=50)];
        let mut p = || {
            let k = rng.random_range(-6..=6);
            [o[0] + k * d[0], o[1] + k * d[1]]
        };
        check_exhaustive([p(), p(), p()]);
    }
}

#[test]
fn bm_points_come_last_from_b() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..500 {
        let v = rand_tri(&mut rng, 30, [0, 0]);
        let t = TriangleIndex::new(v).unwrap();
        if t.shape() != TriangleShape::Triangle {
            continue;
        }
        let [_, b, c] = v;
        let g = gcd(c[0] as i128 - b[0] as i128, c[1] as i128 - b[1] as i128) as i64;
        let n = (g / 2 + 1) as u64;
        for j in 0..n {
            let p = t.point(t.len() - n + j).unwrap();
            assert_eq!(
                p,
                [
                    b[0] + j as i64 * (c[0] - b[0]) / g,
                    b[1] + j as i64 * (c[1] - b[1]) / g
                ]
            );
        }
    }
}

/// Skinny 45° slivers with long sides, checked against scanline (brute force
/// over the bounding box would be too slow).
#[test]
fn skinny_slivers_against_scanline() {
    let mut rng = ChaCha8Rng::seed_from_u64(45);
    for _ in 0..60 {
        let n = rng.random_range(100..20_000);
        let a = [rng.random_range(-1000..1000), rng.random_range(-1000..1000)];
        let w = rng.random_range(0..3);
        let sx = if rng.random_bool(0.5) { 1 } else { -1 };
        let sy = if rng.random_bool(0.5) { 1 } else { -1 };
        let b = [a[0] + sx * n, a[1] + sy * (n + 1)];
        let c = [a[0] + sx * (n + 1 + w), a[1] + sy * (n + 2)];
        let v = [a, b, c];
        let t = TriangleIndex::new(v).unwrap();
        assert_eq!(t.len(), pick(&v));
        let mut sc = Vec::new();
        ScanlineLattice::new(v).unwrap().for_each(|p| sc.push(p));
        let mut ix: Vec<_> = t.iter().collect();
        for (i, p) in ix.iter().enumerate() {
            assert_eq!(t.index_of(*p), Some(i as u64));
            assert!(inside(&v, *p));
        }
        sc.sort();
        ix.sort();
        assert_eq!(ix, sc, "{v:?}");
    }
}

/// Huge triangles near ±2^30: Pick's count, membership and round trips at
/// random and boundary indices, and index_of on random points of the box.
#[test]
fn huge_triangles_spot_checks() {
    let mut rng = ChaCha8Rng::seed_from_u64(0xb16);
    let l = COORD_LIMIT;
    let mut tris: Vec<Tri> = vec![
        [[-l, -l], [l, -l], [-l, l]],
        [[-l, -l], [l, l], [l, -l]],
        [[l, l], [-l, l], [l, -l]],
        [[-l, -l], [l, l - 1], [l - 1, l]], // huge 45° sliver
        [[-l, -l], [l, l], [-l + 1, -l + 3]],
        [[-l, l], [l, -l], [0, 0]], // collinear diagonal
    ];
    for _ in 0..200 {
        let mut p = || [rng.random_range(-l..=l), rng.random_range(-l..=l)];
        tris.push([p(), p(), p()]);
    }
    for v in tris {
        let t = TriangleIndex::new(v).unwrap();
        assert_eq!(t.len(), pick(&v), "{v:?}");
        let k = t.len();
        let mut idx: Vec<u64> = (0..200).map(|_| rng.random_range(0..k)).collect();
        idx.extend([
            0,
            k - 1,
            k / 2,
            (k / 2).saturating_sub(1),
            k.saturating_sub(2),
        ]);
        for i in idx {
            let p = t.point(i).unwrap();
            assert!(inside(&v, p), "{v:?} {i} {p:?}");
            assert_eq!(t.index_of(p), Some(i), "{v:?} {i} {p:?}");
            // Incremental stepping agrees with direct evaluation a few steps on.
            let direct: Vec<_> = (i..(i + 5).min(k)).map(|j| t.point(j).unwrap()).collect();
            assert_eq!(t.iter_range(i..i + 5).collect::<Vec<_>>(), direct);
            let mut vis = Vec::new();
            t.for_each_in_range(i..i + 5, |p| vis.push(p));
            assert_eq!(vis, direct);
        }
        for _ in 0..300 {
            let p = [rng.random_range(-l..=l), rng.random_range(-l..=l)];
            match t.index_of(p) {
                Some(i) => assert_eq!(t.point(i), Some(p)),
                None => assert!(!inside(&v, p)),
            }
        }
    }
}

#[test]
fn out_of_range_vertices_are_errors() {
    let l = COORD_LIMIT;
    assert!(TriangleIndex::new([[0, 0], [l + 1, 0], [0, 1]]).is_err());
    assert!(TriangleIndex::new([[0, 0], [1, 0], [0, -l - 1]]).is_err());
    assert!(TriangleIndex::new([[i64::MIN, 0], [1, 0], [0, 1]]).is_err());
    assert!(ScanlineLattice::new([[0, 0], [l + 1, 0], [0, 1]]).is_err());
    assert!(MeshIndex::new(&[[[0, 0], [1, 0], [0, 1]], [[0, 0], [1, 0], [0, l + 1]]]).is_err());
    assert!(TriangleIndex::new([[-l, -l], [l, l], [l, -l]]).is_ok());
    // index_of accepts any point.
    let t = TriangleIndex::new([[-l, -l], [l, l], [l, -l]]).unwrap();
    assert_eq!(t.index_of([i64::MAX, i64::MIN]), None);
    assert_eq!(t.index_of([i64::MIN, i64::MIN]), None);
}

/// Chi-square goodness of fit of the sampler on a few triangles (seeded).
#[test]
fn sampler_chi_square() {
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    for v in [
        [[0, 0], [9, 2], [3, 8]],
        [[0, 0], [30, 31], [31, 32]],
        [[-5, 4], [6, -3], [0, 0]],
    ] {
        let t = TriangleIndex::new(v).unwrap();
        let k = t.len() as usize;
        let n = 2000 * k;
        let mut counts = std::collections::HashMap::new();
        for _ in 0..n {
            let p = t.sample(&mut rng);
            assert!(inside(&v, p));
            *counts.entry(p).or_insert(0u64) += 1;
        }
        assert_eq!(counts.len(), k, "every point drawn");
        let e = n as f64 / k as f64;
        let chi2: f64 = counts.values().map(|&c| (c as f64 - e).powi(2) / e).sum();
        // Upper 0.1% point of chi-square with k − 1 dof (Wilson–Hilferty).
        let df = (k - 1) as f64;
        let z = 3.09;
        let crit = df * (1.0 - 2.0 / (9.0 * df) + z * (2.0 / (9.0 * df)).sqrt()).powi(3);
        assert!(chi2 < crit, "{v:?}: chi2 {chi2} ≥ {crit} (k = {k})");
    }
}

#[test]
fn parallel_equals_sequential() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for _ in 0..20 {
        let v = rand_tri(&mut rng, 300, [0, 0]);
        let t = TriangleIndex::new(v).unwrap();
        let seq: Vec<_> = t.iter().collect();
        let par: Vec<_> = t.par_points().collect();
        assert_eq!(par, seq);
        let got = Mutex::new(Vec::new());
        t.for_each_point_par(64, |p| got.lock().unwrap().push(p));
        let mut got = got.into_inner().unwrap();
        got.sort();
        let mut s = seq.clone();
        s.sort();
        assert_eq!(got, s);
    }
}

#[test]
fn unordered_full_enumeration_is_the_point_set() {
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let mut used_scan = 0;
    for n in 0..300 {
        let v = if n % 10 == 0 {
            [[0, 0], [400, 401], [3, 3]]
        } else {
            rand_tri(&mut rng, [2, 10, 50][n % 3], [0, 0])
        };
        let t = TriangleIndex::new(v).unwrap();
        used_scan += t.prefers_scanline() as u32;
        let mut a = Vec::new();
        t.for_each_point_unordered(|p| a.push(p));
        let mut b: Vec<_> = t.iter().collect();
        a.sort();
        b.sort();
        assert_eq!(a, b, "{v:?}");
    }
    assert!(used_scan > 50, "both paths exercised ({used_scan})");
    assert!(
        !TriangleIndex::new([[0, 0], [400, 401], [3, 3]])
            .unwrap()
            .prefers_scanline()
    );
}

#[test]
fn ranges_partition_the_index() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for _ in 0..200 {
        let v = rand_tri(&mut rng, 40, [0, 0]);
        let t = TriangleIndex::new(v).unwrap();
        let all: Vec<_> = t.iter().collect();
        let mut cuts: Vec<u64> = (0..5).map(|_| rng.random_range(0..=t.len())).collect();
        cuts.extend([0, t.len()]);
        cuts.sort();
        let mut joined = Vec::new();
        for w in cuts.windows(2) {
            t.for_each_in_range(w[0]..w[1], |p| joined.push(p));
        }
        assert_eq!(joined, all);
    }
}

#[test]
fn mesh_enumerator_covers_every_pair_once() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let mut tris: Vec<Tri> = (0..300)
        .map(|n| {
            let off = [rng.random_range(-100..100), 0];
            rand_tri(&mut rng, [1, 3, 10, 60][n % 4], off)
        })
        .collect();
    tris.push([[0, 0], [0, 0], [0, 0]]);
    tris.push([[0, 0], [1000, 1001], [1001, 1002]]);
    let m = MeshIndex::new(&tris).unwrap();
    let mut expect: Vec<(usize, LatticePoint)> = Vec::new();
    for (i, v) in tris.iter().enumerate() {
        let t = TriangleIndex::new(*v).unwrap();
        expect.extend(t.iter().map(|p| (i, p)));
    }
    assert_eq!(m.len(), expect.len() as u64);
    // Random partitions of the global range, in order.
    for _ in 0..20 {
        let mut cuts: Vec<u64> = (0..7).map(|_| rng.random_range(0..=m.len())).collect();
        cuts.extend([0, m.len()]);
        cuts.sort();
        let mut got = Vec::new();
        for w in cuts.windows(2) {
            m.for_each_in_range(w[0]..w[1], |t, p| got.push((t, p)));
        }
        assert_eq!(got, expect);
    }
    for g in (0..m.len()).step_by(37) {
        assert_eq!(m.point(g), Some(expect[g as usize]));
    }
    assert_eq!(m.point(m.len()), None);
    // Parallel: every pair exactly once.
    let seen = Mutex::new(Vec::new());
    m.for_each_par(16, |t, p| seen.lock().unwrap().push((t, p)));
    let mut seen = seen.into_inner().unwrap();
    seen.sort();
    let mut e = expect.clone();
    e.sort();
    assert_eq!(seen, e);
    // Per-chunk states cover the range in order.
    let chunks = m.map_chunks_par(16, |_| Vec::new(), |s, t, p| s.push((t, p)));
    assert_eq!(chunks.concat(), expect);
    // Unordered variants: same multiset over any partition.
    for _ in 0..10 {
        let mut cuts: Vec<u64> = (0..5).map(|_| rng.random_range(0..=m.len())).collect();
        cuts.extend([0, m.len()]);
        cuts.sort();
        let mut got = Vec::new();
        for w in cuts.windows(2) {
            m.for_each_in_range_unordered(w[0]..w[1], |t, p| got.push((t, p)));
        }
        got.sort();
        assert_eq!(got, e);
    }
    let seen = Mutex::new(Vec::new());
    m.for_each_par_unordered(16, |t, p| seen.lock().unwrap().push((t, p)));
    let mut seen = seen.into_inner().unwrap();
    seen.sort();
    assert_eq!(seen, e);
    let n = AtomicU64::new(0);
    (0..4u64).into_par_iter().for_each(|_| {
        m.for_each_in_range(0..m.len(), |_, _| {
            n.fetch_add(1, Ordering::Relaxed);
        })
    });
    assert_eq!(n.into_inner(), 4 * m.len());
}

fn cli(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .arg("triangle")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

#[test]
fn cli_outputs_and_errors() {
    let (c, o, _) = cli(&["0", "0", "4", "0", "0", "4"]);
    assert_eq!(c, 0);
    let j: serde_json::Value = serde_json::from_str(&o).unwrap();
    assert_eq!(j["count"], 15);

    let (c, o, _) = cli(&["-2", "-1", "3", "-1", "0", "4", "--all"]);
    assert_eq!(c, 0);
    let j: serde_json::Value = serde_json::from_str(&o).unwrap();
    let t = TriangleIndex::new([[-2, -1], [3, -1], [0, 4]]).unwrap();
    assert_eq!(j["count"], t.len());
    let pts: Vec<LatticePoint> = serde_json::from_value(j["points"].clone()).unwrap();
    assert_eq!(pts, t.iter().collect::<Vec<_>>());

    let (c, o, _) = cli(&["-2", "-1", "3", "-1", "0", "4", "--index", "5"]);
    assert_eq!(c, 0);
    let j: serde_json::Value = serde_json::from_str(&o).unwrap();
    let p: Vec<LatticePoint> = serde_json::from_value(j["points"].clone()).unwrap();
    assert_eq!(p, vec![t.point(5).unwrap()]);

    let (c, o, _) = cli(&["-2", "-1", "3", "-1", "0", "4", "--locate", "-1", "0"]);
    assert_eq!(c, 0);
    let j: serde_json::Value = serde_json::from_str(&o).unwrap();
    assert_eq!(j["index"], t.index_of([-1, 0]).unwrap());
    let (c, o, _) = cli(&["-2", "-1", "3", "-1", "0", "4", "--locate", "-9", "0"]);
    assert_eq!(c, 0);
    let j: serde_json::Value = serde_json::from_str(&o).unwrap();
    assert!(j["index"].is_null());

    let (c, o, _) = cli(&[
        "-2", "-1", "3", "-1", "0", "4", "--sample", "50", "--seed", "9",
    ]);
    assert_eq!(c, 0);
    let j: serde_json::Value = serde_json::from_str(&o).unwrap();
    let p: Vec<LatticePoint> = serde_json::from_value(j["points"].clone()).unwrap();
    assert_eq!(p.len(), 50);
    assert!(p.iter().all(|q| t.index_of(*q).is_some()));
    assert_eq!(
        cli(&[
            "-2", "-1", "3", "-1", "0", "4", "--sample", "50", "--seed", "9"
        ])
        .1,
        o
    );

    for bad in [
        &["0", "0", "4", "0", "0"][..],
        &["0", "0", "4", "0", "0", "x"],
        &["0", "0", "4", "0", "0", "1.5"],
        &["0", "0", "4", "0", "0", "2000000000"],
        &["0", "0", "4", "0", "0", "4", "--index", "15"],
        &["0", "0", "4", "0", "0", "4", "--index", "-1"],
        &["0", "0", "4", "0", "0", "4", "--all", "--index", "1"],
        &["0", "0", "1000000", "0", "0", "1000000", "--all"],
    ] {
        let (c, o, e) = cli(bad);
        assert_eq!(c, 2, "{bad:?}: {o} {e}");
        assert!(o.is_empty(), "{bad:?} printed {o}");
        assert!(!e.is_empty());
    }
}

/// Checks every walk of index range `a..b` against `point(i)`: the visitor,
/// the iterator, and the visitor stopped early at a random point.
fn check_range(t: &TriangleIndex, a: u64, b: u64, rng: &mut ChaCha8Rng, v: &Tri) {
    let direct: Vec<_> = (a..b).map(|i| t.point(i).unwrap()).collect();
    let mut vis = Vec::with_capacity(direct.len());
    t.for_each_in_range(a..b, |p| vis.push(p));
    assert_eq!(vis, direct, "visitor {v:?} {a}..{b}");
    assert_eq!(
        t.iter_range(a..b).collect::<Vec<_>>(),
        direct,
        "iter {v:?} {a}..{b}"
    );
    // The unordered range walk visits the same set, each point once.
    let mut un = Vec::with_capacity(direct.len());
    t.for_each_in_range_unordered(a..b, |p| un.push(p));
    un.sort();
    let mut sorted = direct.clone();
    sorted.sort();
    assert_eq!(un, sorted, "unordered {v:?} {a}..{b}");
    if b > a {
        let stop = rng.random_range(0..b - a);
        let mut n = 0u64;
        let r = t.try_for_each_in_range_unordered(a..b, |p| {
            assert!(
                sorted.binary_search(&p).is_ok(),
                "unordered stray {v:?} {p:?}"
            );
            n += 1;
            if n == stop + 1 {
                std::ops::ControlFlow::Break(())
            } else {
                std::ops::ControlFlow::Continue(())
            }
        });
        assert!(r.is_break() && n == stop + 1, "unordered early stop {v:?}");
    }
    if b > a {
        let stop = rng.random_range(0..b - a);
        let mut seen = Vec::new();
        let r = t.try_for_each_in_range(a..b, |p| {
            seen.push(p);
            if seen.len() as u64 == stop + 1 {
                std::ops::ControlFlow::Break(p)
            } else {
                std::ops::ControlFlow::Continue(())
            }
        });
        assert_eq!(r, std::ops::ControlFlow::Break(direct[stop as usize]));
        assert_eq!(seen, direct[..=stop as usize], "early stop {v:?} {a}..{b}");
    }
}

/// A triangle with `a` at `o`, edge `ac` = `g` × a random primitive vector
/// (so `gc = g`: lines of `g` or `g + 1` points) and a random `b`.
fn tri_with_gc(rng: &mut ChaCha8Rng, o: LatticePoint, r: i64, g: i64) -> Tri {
    loop {
        let d = [rng.random_range(-r..=r), rng.random_range(-r..=r)];
        if gcd(d[0] as i128, d[1] as i128) != 1 {
            continue;
        }
        let b = [
            o[0] + rng.random_range(-r * g..=r * g),
            o[1] + rng.random_range(-r * g..=r * g),
        ];
        let v = [o, b, [o[0] + g * d[0], o[1] + g * d[1]]];
        if cross(v[0], v[1], v[2]) != 0 {
            return v;
        }
    }
}

/// The range walk (one O(1) locate, then additions only; a separate loop for
/// `gc = 1`) equals `point(i)` for every `i` of random ranges: ranges starting
/// and ending mid-line, at line starts, across the mirror half `H` and into
/// the `(bm)` run, on fat, skinny, huge and collinear triangles with short
/// (`gc = 1`, `2`, `3`) and long skew lines. The unordered range walk (whole
/// lines scanned as two lattice polygons row by row) visits the same set.
#[test]
fn range_walks_equal_point_i() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x7a9e);
    let l = COORD_LIMIT;
    let mut tris: Vec<Tri> = Vec::new();
    for n in 0..240 {
        let g = [1, 1, 1, 2, 3, 7][n % 6];
        let r = [3, 12, 60][n % 3];
        let o = [rng.random_range(-99..99), 5];
        tris.push(tri_with_gc(&mut rng, o, r, g));
    }
    for n in 0..30 {
        // Fat triangles next to the coordinate limits (strip scans in i128).
        let o = [[l - 60, l - 60], [-l + 60, l - 60], [-l + 60, -l + 60]][n % 3];
        tris.push(rand_tri(&mut rng, 60, o));
    }
    for n in 0..40 {
        // Fat triangles of about 10^4 points (the benchmark's shape).
        let mut j = || rng.random_range(-3..=3);
        let s = 70 + n;
        tris.push([
            [j(), j()],
            [2 * s + j(), s / 3 + j()],
            [s / 2 + j(), 2 * s + j()],
        ]);
    }
    for _ in 0..20 {
        let n = rng.random_range(100..5000);
        tris.push([[0, 0], [n, n + 1], [n + 1 + rng.random_range(0..3), n + 2]]);
        tris.push([[0, 0], [n, n + 1], [3, 3]]);
    }
    for _ in 0..60 {
        let mut p = || [rng.random_range(-l..=l), rng.random_range(-l..=l)];
        tris.push([p(), p(), p()]);
        tris.push(tri_with_gc(
            &mut rng,
            [-l + (1 << 14) + 7, l - (1 << 14) - 9],
            1 << 14,
            1,
        ));
    }
    tris.extend([
        [[-l, -l], [l, -l], [-l, l]],
        [[-l, -l], [l, l - 1], [l - 1, l]],
        [[-l, l], [l, -l], [0, 0]],
        [[0, 0], [6, 9], [4, 6]],
        [[3, 3], [3, 3], [3, 3]],
    ]);
    for _ in 0..20 {
        let d = [rng.random_range(-5..=5), rng.random_range(-5..=5)];
        let k = rng.random_range(0..2000);
        tris.push([[0, 0], [k * d[0], k * d[1]], [-d[0], -d[1]]]);
    }
    for v in &tris {
        let t = TriangleIndex::new(*v).unwrap();
        let k = t.len();
        // Line starts: where consecutive points stop being one step apart
        // along ac — found from point(i), independently of the walk.
        let mut marks: Vec<u64> = vec![0, k, k / 2, (k / 2).saturating_sub(1), k / 2 + 1];
        let probe = k.min(400);
        let g = gcd(
            v[2][0] as i128 - v[0][0] as i128,
            v[2][1] as i128 - v[0][1] as i128,
        ) as i64;
        if g > 0 {
            let cs = [(v[2][0] - v[0][0]) / g, (v[2][1] - v[0][1]) / g];
            for i in 1..probe {
                let (p, q) = (t.point(i - 1).unwrap(), t.point(i).unwrap());
                if [q[0] - p[0], q[1] - p[1]] != cs && [p[0] - q[0], p[1] - q[1]] != cs {
                    marks.push(i);
                }
            }
        }
        for _ in 0..30 {
            marks.push(rng.random_range(0..=k));
        }
        marks.retain(|&m| m <= k);
        for _ in 0..25 {
            let a = marks[rng.random_range(0..marks.len())];
            let a = (a + rng.random_range(0..2)).min(k);
            let span = [1, 2, 3, 17, 300][rng.random_range(0..5)];
            let b = if rng.random_bool(0.3) {
                marks[rng.random_range(0..marks.len())].max(a).min(a + 3000)
            } else {
                (a + span).min(k)
            };
            check_range(&t, a, b, &mut rng, v);
        }
        if k <= 20_000 {
            check_range(&t, 0, k, &mut rng, v);
        }
    }
}
