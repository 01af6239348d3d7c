//! The exact triangle–box test and the conservative sets against an
//! independent oracle: 2D linear-programming feasibility by vertex
//! enumeration in exact integer rationals (no separating axes).
//!
//! Oracle: the triangle `p0 + s·e1 + t·e2` (s, t ≥ 0, s + t ≤ 1) meets the
//! closed cube iff the 2D polygon of feasible (s, t) under those 3 plus the 6
//! box constraints is non-empty. That polygon is bounded, so if non-empty it
//! has a vertex where two non-parallel constraint lines meet: try all 36 pairs,
//! each candidate an exact rational checked against all 9 constraints.

use glam::IVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::fixed::{HALF, ONE};
use voxkit::voxelize::conservative::{
    FixedTriangle, TriangleBoxTest, conservative_reference, conservative_voxels,
    triangle_meets_voxel,
};

/// The independent oracle. Exact for coordinate differences below 2^40.
fn oracle_meets(tri: &FixedTriangle, v: IVec3) -> bool {
    // Relative to the voxel centre: |values| stay small whatever the position.
    let c = [v.x as i64 * ONE, v.y as i64 * ONE, v.z as i64 * ONE];
    let p: Vec<[i128; 3]> = tri
        .iter()
        .map(|q| {
            [
                (q[0] - c[0]) as i128,
                (q[1] - c[1]) as i128,
                (q[2] - c[2]) as i128,
            ]
        })
        .collect();
    let e1: Vec<i128> = (0..3).map(|a| p[1][a] - p[0][a]).collect();
    let e2: Vec<i128> = (0..3).map(|a| p[2][a] - p[0][a]).collect();
    // Constraints A·s + B·t ≤ C; barycentric ones scaled to stay integer.
    let mut cons: Vec<(i128, i128, i128)> = vec![(-1, 0, 0), (0, -1, 0), (1, 1, 1)];
    for a in 0..3 {
        // p0 + s e1 + t e2 ≤ HALF  and  ≥ −HALF
        cons.push((e1[a], e2[a], HALF as i128 - p[0][a]));
        cons.push((-e1[a], -e2[a], HALF as i128 + p[0][a]));
    }
    for i in 0..cons.len() {
        for j in i + 1..cons.len() {
            let (a1, b1, c1) = cons[i];
            let (a2, b2, c2) = cons[j];
            let mut det = a1 * b2 - a2 * b1;
            if det == 0 {
                continue;
            }
            let mut sn = c1 * b2 - c2 * b1;
            let mut tn = a1 * c2 - a2 * c1;
            if det < 0 {
                det = -det;
                sn = -sn;
                tn = -tn;
            }
            if cons.iter().all(|&(a, b, c)| a * sn + b * tn <= c * det) {
                return true;
            }
        }
    }
    false
}

fn bbox_scan(tri: &FixedTriangle) -> Vec<IVec3> {
    let (lo, hi) = TriangleBoxTest::new(tri).unwrap().voxel_bbox();
    let mut out = Vec::new();
    // One voxel beyond the bbox on each side: the oracle must reject those.
    for z in lo.z - 1..=hi.z + 1 {
        for y in lo.y - 1..=hi.y + 1 {
            for x in lo.x - 1..=hi.x + 1 {
                let v = IVec3::new(x, y, z);
                if oracle_meets(tri, v) {
                    out.push(v);
                }
            }
        }
    }
    out
}

/// A random coordinate near `c` (fixed units) of the given kind.
fn coord(rng: &mut ChaCha8Rng, c: i64, spread: f64, lattice: i64) -> i64 {
    let x = c + (rng.random_range(-spread..spread) * ONE as f64) as i64;
    if lattice > 0 {
        // Snap to multiples of ONE / lattice: hits voxel faces (±1/2),
        // edges and corners exactly.
        let step = ONE / lattice;
        x.div_euclid(step) * step
    } else {
        x
    }
}

/// Random triangles of many kinds (see the match arms).
fn random_triangle(rng: &mut ChaCha8Rng, kind: u32) -> FixedTriangle {
    let spread = [0.3, 1.0, 2.5, 6.0][rng.random_range(0..4)];
    let centre = [0i64; 3];
    let pt = |rng: &mut ChaCha8Rng, lat: i64| {
        [
            coord(rng, centre[0], spread, lat),
            coord(rng, centre[1], spread, lat),
            coord(rng, centre[2], spread, lat),
        ]
    };
    match kind % 8 {
        // General position.
        0 => [pt(rng, 0), pt(rng, 0), pt(rng, 0)],
        // Vertices on the half- and quarter-voxel lattice: faces, edges, corners.
        1 => [pt(rng, 2), pt(rng, 2), pt(rng, 2)],
        2 => [pt(rng, 4), pt(rng, 1), pt(rng, 2)],
        // Axis-aligned face; half the time in a voxel face plane k ± 1/2.
        3 => {
            let axis = rng.random_range(0..3);
            let plane = if rng.random_bool(0.5) {
                rng.random_range(-3..3) * ONE + HALF
            } else {
                coord(rng, 0, spread, 4)
            };
            let mut t = [pt(rng, 0), pt(rng, 2), pt(rng, 0)];
            for p in &mut t {
                p[axis] = plane;
            }
            t
        }
        // Sliver: third vertex within a few fixed units of the first edge.
        4 => {
            let (a, b) = (pt(rng, 2), pt(rng, 0));
            let num = rng.random_range(0..=16i64);
            let mut c = [0i64; 3];
            for k in 0..3 {
                c[k] = a[k] + (b[k] - a[k]) * num / 16 + rng.random_range(-2..=2);
            }
            [a, b, c]
        }
        // Exactly collinear (a segment), with vertices on the half lattice.
        5 => {
            let (a, b) = (pt(rng, 2), pt(rng, 2));
            let c = [2 * b[0] - a[0], 2 * b[1] - a[1], 2 * b[2] - a[2]];
            [a, b, c]
        }
        // Coincident vertices (a point) or two coincident (a segment).
        6 => {
            let lat = if rng.random_bool(0.5) { 2 } else { 0 };
            let a = pt(rng, lat);
            if rng.random_bool(0.5) {
                [a, a, a]
            } else {
                [a, pt(rng, 2), a]
            }
        }
        // Edge along a voxel edge line (two coordinates on face planes).
        _ => {
            let (ya, za) = (
                rng.random_range(-2..2) * ONE + HALF,
                rng.random_range(-2..2) * ONE + HALF,
            );
            let (x0, x1) = (coord(rng, 0, spread, 0), coord(rng, 0, spread, 0));
            [[x0, ya, za], [x1, ya, za], pt(rng, 0)]
        }
    }
}

fn translate(t: FixedTriangle, d: [i64; 3]) -> FixedTriangle {
    t.map(|p| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
}

fn sorted(mut v: Vec<IVec3>) -> Vec<IVec3> {
    v.sort_unstable_by_key(|p| (p.z, p.y, p.x));
    v
}

/// Random triangles of every kind: the per-triangle enumeration equals the
/// oracle's scan of the (enlarged) bounding box, voxel for voxel.
#[test]
fn enumeration_matches_oracle_on_random_triangles() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5a7);
    let mut hits = 0;
    for case in 0..2400u32 {
        let tri = random_triangle(&mut rng, case);
        let got: Vec<IVec3> = conservative_voxels(&tri).unwrap().collect();
        let want = sorted(bbox_scan(&tri));
        assert_eq!(got, want, "case {case} kind {} tri {tri:?}", case % 8);
        hits += got.len();
    }
    assert!(hits > 10_000, "too few voxels exercised: {hits}");
}

/// The same triangles far from the origin (up to the ±2^30 range ends):
/// an integer translation changes nothing but the voxel indices.
#[test]
fn translation_to_range_ends_is_exact() {
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let far = (1i64 << 30) - 16;
    for case in 0..400u32 {
        let tri = random_triangle(&mut rng, case);
        let base = sorted(conservative_voxels(&tri).unwrap().collect());
        let sx = if case % 2 == 0 { far } else { -far };
        let d = [sx, -sx, if case % 3 == 0 { far } else { 5 }];
        let moved = translate(tri, d.map(|x| x * ONE));
        let got: Vec<IVec3> = conservative_voxels(&moved).unwrap().collect();
        let dv = IVec3::new(d[0] as i32, d[1] as i32, d[2] as i32);
        let want: Vec<IVec3> = base.iter().map(|&v| v + dv).collect();
        assert_eq!(got, want, "case {case}");
        for v in got.iter().take(3) {
            assert!(oracle_meets(&moved, *v));
        }
    }
    // Beyond the range: a typed error, not a panic.
    let bad = [[(1i64 << 50) + 1, 0, 0], [0, 0, 0], [0, 0, ONE]];
    assert!(conservative_voxels(&bad).is_err());
    assert!(conservative_reference(&[bad]).is_err());
}

/// Huge triangles (spanning ~2^20 voxels) take the 192-bit normal-axis path;
/// voxels near their plane are checked against the oracle.
#[test]
fn huge_triangles_use_exact_wide_arithmetic() {
    let mut rng = ChaCha8Rng::seed_from_u64(4242);
    let span = 1i64 << 39; // 2^19 voxels
    for case in 0..60 {
        let tri: FixedTriangle =
            std::array::from_fn(|_| std::array::from_fn(|_| rng.random_range(-span..span)));
        let test = TriangleBoxTest::new(&tri).unwrap();
        // Points on the triangle (exact barycentric mixes), then voxels around them.
        for _ in 0..20 {
            let (a, b) = (rng.random_range(0..=1000i64), rng.random_range(0..=1000i64));
            let (a, b) = if a + b > 1000 {
                (1000 - a, 1000 - b)
            } else {
                (a, b)
            };
            let p: [i64; 3] = std::array::from_fn(|k| {
                tri[0][k]
                    + ((tri[1][k] - tri[0][k]) as i128 * a as i128 / 1000) as i64
                    + ((tri[2][k] - tri[0][k]) as i128 * b as i128 / 1000) as i64
            });
            let v0 = IVec3::from_array(p.map(|c| voxkit::fixed::voxel_of(c) as i32));
            for dz in -2..=2 {
                for dy in -2..=2 {
                    for dx in -2..=2 {
                        let v = v0 + IVec3::new(dx, dy, dz);
                        assert_eq!(test.meets(v), oracle_meets(&tri, v), "case {case} {v}");
                    }
                }
            }
        }
    }
}

/// Hand-picked hard cases with known answers.
#[test]
fn hand_picked_touching_cases() {
    let h = HALF;
    // A face exactly in the plane z = 1/2 marks both layers, not one.
    let tri = [[0, 0, h], [4 * ONE, 0, h], [0, 4 * ONE, h]];
    let v: Vec<IVec3> = conservative_voxels(&tri).unwrap().collect();
    assert!(v.iter().any(|p| p.z == 0) && v.iter().any(|p| p.z == 1));
    assert_eq!(
        v.iter().filter(|p| p.z == 0).count(),
        v.iter().filter(|p| p.z == 1).count()
    );
    // A vertex exactly on a voxel corner: all 8 voxels around it.
    let corner = [h, h, h];
    let tri = [corner, [h + 1, h, h], [h, h + 1, h]];
    assert_eq!(conservative_voxels(&tri).unwrap().count(), 8);
    // One fixed unit away from touching: not met; touching: met.
    let tri = [[h + 1, -ONE, -ONE], [h + 1, ONE, -ONE], [h + 1, 0, ONE]];
    assert!(!triangle_meets_voxel(&tri, IVec3::ZERO).unwrap());
    assert!(triangle_meets_voxel(&tri, IVec3::X).unwrap());
    let tri = [[h, -ONE, -ONE], [h, ONE, -ONE], [h, 0, ONE]];
    assert!(triangle_meets_voxel(&tri, IVec3::ZERO).unwrap());
    // A tilted plane through a cube's corner only (x + y + z = 3/2 touches
    // voxel 0 at (h, h, h)); shifting it by one fixed unit loses the voxel.
    let s = 3 * h;
    let tri = [[s, 0, 0], [0, s, 0], [0, 0, s]];
    assert!(triangle_meets_voxel(&tri, IVec3::ZERO).unwrap());
    let tri = [[s + 1, 1, 1], [1, s + 1, 1], [1, 1, s + 1]];
    // Now x + y + z = 3h + 3 on the triangle, above the max 3h over voxel 0.
    assert!(!triangle_meets_voxel(&tri, IVec3::ZERO).unwrap());
    assert!(!oracle_meets(&tri, IVec3::ZERO));
}

/// The mesh-level reference equals the union of per-triangle sets; parallel
/// equals sequential; and it is sorted and duplicate-free.
#[test]
fn reference_is_the_union_and_deterministic() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let tris: Vec<FixedTriangle> = (0..3000u32)
        .map(|c| {
            let t = random_triangle(&mut rng, c);
            let d = [
                rng.random_range(-20..20),
                rng.random_range(-20..20),
                rng.random_range(-20..20),
            ];
            translate(t, d.map(|x: i64| x * ONE))
        })
        .collect();
    let got = conservative_reference(&tris).unwrap();
    let mut want: Vec<IVec3> = tris
        .iter()
        .flat_map(|t| conservative_voxels(t).unwrap())
        .collect();
    want = sorted(want);
    want.dedup();
    assert_eq!(got, want);
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| conservative_reference(&tris).unwrap());
    assert_eq!(got, single);
    assert!(
        got.windows(2)
            .all(|w| (w[0].z, w[0].y, w[0].x) < (w[1].z, w[1].y, w[1].x))
    );
    assert!(conservative_reference(&[]).unwrap().is_empty());
}

/// Timing check on a real mesh (not part of CI): set `VOXKIT_MESH` to an OBJ
/// and `VOXKIT_RES` (default 256), run with `--ignored --nocapture`.
#[test]
#[ignore]
fn real_mesh_reference_timing() {
    let Ok(path) = std::env::var("VOXKIT_MESH") else {
        return;
    };
    let res: f64 = std::env::var("VOXKIT_RES").map_or(256.0, |r| r.parse().unwrap());
    let (models, _) = tobj::load_obj(&path, &tobj::GPU_LOAD_OPTIONS).unwrap();
    let mut tris = Vec::new();
    let mut lo = glam::DVec3::splat(f64::INFINITY);
    let mut hi = -lo;
    for m in &models {
        for p in m.mesh.positions.chunks(3) {
            let p = glam::DVec3::new(p[0], p[1], p[2]);
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let h = (hi - lo).max_element() / res;
    for m in &models {
        let pos = &m.mesh.positions;
        for f in m.mesh.indices.chunks(3) {
            let tri: FixedTriangle = std::array::from_fn(|k| {
                let i = f[k] as usize * 3;
                let w = glam::DVec3::new(pos[i], pos[i + 1], pos[i + 2]);
                let g = (w - lo) / h - glam::DVec3::splat(0.5);
                voxkit::fixed::point_to_fixed(g.to_array()).unwrap()
            });
            tris.push(tri);
        }
    }
    let t0 = std::time::Instant::now();
    let v = conservative_reference(&tris).unwrap();
    println!(
        "{path} at {res}: {} triangles, {} voxels, {:.2} s",
        tris.len(),
        v.len(),
        t0.elapsed().as_secs_f64()
    );
}

/// Triangles spanning 2^28 voxels up to the ±2^30 range ends, where the
/// normal-axis product needs more than 128 bits: planes `z = s − a·x − b·y`
/// (a, b ∈ {−1, 0, 1}) have a closed-form answer deep inside the triangle:
/// the cube meets the plane iff `|ONE·(vz + a·vx + b·vy) − s| ≤ HALF·(1 + |a| + |b|)`.
#[test]
fn range_end_planes_have_closed_form_answers() {
    let mut rng = ChaCha8Rng::seed_from_u64(1 << 20);
    let l: i64 = 1 << 48;
    let end: i64 = 1 << 50;
    let mut met = 0;
    for case in 0..200 {
        let (a, b) = (rng.random_range(-1..=1i64), rng.random_range(-1..=1i64));
        // Corners at the range ends (either sign) or random.
        let pick = |rng: &mut ChaCha8Rng| match rng.random_range(0..3) {
            0 => end - l,
            1 => -end,
            _ => rng.random_range(-end..end - l),
        };
        let (x0, y0) = (pick(&mut rng), pick(&mut rng));
        let (xm, ym) = (x0 + l / 3, y0 + l / 3);
        // Put the plane through the centroid, give or take a few fixed units,
        // so that z stays within range.
        let s = a * xm + b * ym + rng.random_range(-3 * ONE..3 * ONE);
        let z = |x: i64, y: i64| s - a * x - b * y;
        let tri = [
            [x0, y0, z(x0, y0)],
            [x0 + l, y0, z(x0 + l, y0)],
            [x0, y0 + l, z(x0, y0 + l)],
        ];
        let test = TriangleBoxTest::new(&tri).unwrap();
        let (vx, vy) = (voxkit::fixed::voxel_of(xm), voxkit::fixed::voxel_of(ym));
        let vz0 = voxkit::fixed::voxel_of(z(xm, ym));
        for dz in -3..=3i64 {
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let v = [vx + dx, vy + dy, vz0 + dz];
                    let centre = ONE as i128 * (v[2] + a * v[0] + b * v[1]) as i128;
                    let want =
                        (centre - s as i128).abs() <= (HALF * (1 + a.abs() + b.abs())) as i128;
                    let vv = IVec3::new(v[0] as i32, v[1] as i32, v[2] as i32);
                    assert_eq!(test.meets(vv), want, "case {case} a={a} b={b} {vv}");
                    met += want as u32;
                }
            }
        }
    }
    assert!(met > 1000, "{met}");
}
