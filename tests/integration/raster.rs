//! Rasterization: tiling (every pixel exactly once), scanline = edge
//! functions = brute-force oracle, exact Gouraud at vertices, z-buffer =
//! painter's on layered scenes, batched = scalar point tests, mesh render.

use crate::scratch::temp_dir;
use glam::{DVec3, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::camera::Camera;
use voxkit::triangle::{
    DepthTest, FixedTriangle, Fragments, Framebuffer, INSIDE_I32_MAX, InsideF32, InsideI32,
    Interpolator, Lighting, MAX_FIXED_COORD, MeshRenderOptions, RenderTarget, SUB_HALF, SUB_ONE,
    ShadedVertex, Shading, TriangleSetup, draw_painter, draw_shaded, draw_zbuffer, edge_spans,
    fill_triangle_edge, fill_triangle_scanline, painter_order, render_mesh, scanline_spans,
    walk_fragments,
};

/// Pixels of a triangle, sorted, from either rasterizer.
fn edge_pixels(t: &FixedTriangle, w: u32, h: u32) -> Vec<(u32, u32)> {
    let mut v = Vec::new();
    edge_spans(t, w, h, |y, a, b| v.extend((a..=b).map(|x| (y, x))));
    v.sort_unstable();
    v
}

fn scan_pixels(t: &FixedTriangle, w: u32, h: u32) -> Vec<(u32, u32)> {
    let mut v = Vec::new();
    scanline_spans(t, w, h, |y, a, b| v.extend((a..=b).map(|x| (y, x))));
    v.sort_unstable();
    v
}

/// Brute-force oracle in i128, written from the definition: orient the
/// triangle positively, a centre is covered iff every edge value is > 0,
/// or = 0 on an edge whose inward normal points right (left edge) or, for
/// a horizontal edge, down (top edge, y down).
fn oracle_pixels(t: &FixedTriangle, w: u32, h: u32) -> Vec<(u32, u32)> {
    let v = t.vertices().map(|p| p.map(|c| c as i128));
    let cross = |a: [i128; 2], b: [i128; 2], p: [i128; 2]| {
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    };
    let area = cross(v[0], v[1], v[2]);
    let mut out = Vec::new();
    if area == 0 {
        return out;
    }
    let s = area.signum();
    for y in 0..h {
        for x in 0..w {
            let p = [
                (x as i128) * SUB_ONE as i128 + SUB_HALF as i128,
                (y as i128) * SUB_ONE as i128 + SUB_HALF as i128,
            ];
            let ok = (0..3).all(|i| {
                let (a, b) = (v[i], v[(i + 1) % 3]);
                let e = s * cross(a, b, p);
                // inward normal of s·cross(a, b, ·) is s·(a.y − b.y, b.x − a.x)
                let (nx, ny) = (s * (a[1] - b[1]), s * (b[0] - a[0]));
                e > 0 || (e == 0 && (nx > 0 || (nx == 0 && ny > 0)))
            });
            if ok {
                out.push((y, x));
            }
        }
    }
    out
}

fn px(v: f64) -> i64 {
    (v * SUB_ONE as f64).round() as i64
}

/// A random fixed-point coordinate of a few kinds: on a pixel centre, on a
/// pixel corner, on a quarter-pixel lattice, or anywhere.
fn coord(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> i64 {
    let c = px(rng.random_range(lo..hi));
    match rng.random_range(0..4) {
        0 => c.div_euclid(SUB_ONE) * SUB_ONE + SUB_HALF,
        1 => c.div_euclid(SUB_ONE) * SUB_ONE,
        2 => c.div_euclid(SUB_ONE / 4) * (SUB_ONE / 4),
        _ => c,
    }
}

/// Random triangles of many shapes, including degenerate and skinny ones.
fn random_triangle(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> FixedTriangle {
    let mut p = || [coord(rng, lo, hi), coord(rng, lo, hi)];
    let (a, b, c) = (p(), p(), p());
    let v = match rng.random_range(0..10) {
        0 => [a, a, a],                                     // single point
        1 => [a, a, b],                                     // collapsed vertices
        2 => [a, b, [2 * b[0] - a[0], 2 * b[1] - a[1]]],    // collinear
        3 => [a, b, [c[0], a[1]]],                          // horizontal edge
        4 => [a, [a[0], b[1]], c],                          // vertical edge
        5 => [a, b, [b[0] + (a[1] - b[1]).signum(), b[1]]], // skinny
        6 => [a, [a[0] + 1, a[1] + 3 * SUB_ONE], c],        // near-vertical sliver side
        _ => [a, b, c],
    };
    FixedTriangle::from_fixed(v).unwrap()
}

#[test]
fn scanline_edge_and_oracle_agree_on_random_triangles() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5ca1);
    let (w, h) = (40, 33);
    for i in 0..3000 {
        let t = random_triangle(&mut rng, -8.0, 48.0);
        let e = edge_pixels(&t, w, h);
        let s = scan_pixels(&t, w, h);
        assert_eq!(e, s, "case {i}: {t:?}");
        if i % 3 == 0 {
            assert_eq!(e, oracle_pixels(&t, w, h), "oracle, case {i}: {t:?}");
        }
        // The iterator yields what the visitor visits, weights included.
        if let Some(setup) = TriangleSetup::new(&t, w, h) {
            let mut walked = Vec::new();
            walk_fragments(&setup, |f| walked.push(f));
            assert_eq!(Fragments::new(&setup).collect::<Vec<_>>(), walked);
            for f in &walked {
                assert_eq!(f.w, setup.weights_at(f.x as i64, f.y as i64));
                assert_eq!(f.w.iter().sum::<i64>(), setup.area2);
            }
        }
        // The fill functions report the same counts.
        let mut fb = Framebuffer::new(w, h, 0u8).unwrap();
        assert_eq!(fill_triangle_edge(&mut fb, &t, 1), e.len());
        assert_eq!(fill_triangle_scanline(&mut fb, &t, 1), e.len());
        if t.area2() == 0 {
            assert!(e.is_empty(), "degenerate triangle drew pixels: {t:?}");
        }
    }
}

#[test]
fn scanline_and_edge_agree_near_the_range_ends() {
    let mut rng = ChaCha8Rng::seed_from_u64(0xed9e);
    let m = MAX_FIXED_COORD;
    let (w, h) = (24, 20);
    let corners = [[-m, -m], [m, -m], [m, m], [-m, m]];
    // The square [−2^20, 2^20]² in two triangles covers every pixel once,
    // and its diagonal y = x runs through pixel centres.
    for (a, b, c, d) in [(0, 1, 2, 3), (1, 2, 3, 0)] {
        let t1 = FixedTriangle::from_fixed([corners[a], corners[b], corners[c]]).unwrap();
        let t2 = FixedTriangle::from_fixed([corners[a], corners[c], corners[d]]).unwrap();
        let mut n = edge_pixels(&t1, w, h);
        n.extend(edge_pixels(&t2, w, h));
        assert_eq!(n.len(), (w * h) as usize);
        n.sort_unstable();
        n.dedup();
        assert_eq!(n.len(), (w * h) as usize);
        assert_eq!(edge_pixels(&t1, w, h), scan_pixels(&t1, w, h));
    }
    for i in 0..400 {
        let far = |rng: &mut ChaCha8Rng| {
            let k = rng.random_range(0..3);
            [
                if rng.random_bool(0.5) { m - k } else { -m + k },
                rng.random_range(-m..=m),
            ]
        };
        let near = |rng: &mut ChaCha8Rng| [coord(rng, -2.0, 26.0), coord(rng, -2.0, 22.0)];
        let v = match i % 3 {
            0 => [far(&mut rng), near(&mut rng), near(&mut rng)],
            1 => [far(&mut rng), far(&mut rng), near(&mut rng)],
            _ => [far(&mut rng), far(&mut rng), far(&mut rng)],
        };
        let v = if rng.random_bool(0.5) {
            v
        } else {
            v.map(|p| [p[1], p[0]])
        };
        let t = FixedTriangle::from_fixed(v).unwrap();
        let e = edge_pixels(&t, w, h);
        assert_eq!(e, scan_pixels(&t, w, h), "case {i}: {t:?}");
        assert_eq!(e, oracle_pixels(&t, w, h), "oracle, case {i}: {t:?}");
    }
    assert!(FixedTriangle::from_fixed([[m + 1, 0], [0, 0], [0, m]]).is_err());
}

/// Adds each triangle to a per-pixel counter with both rasterizers.
fn count_cover(tris: &[FixedTriangle], w: u32, h: u32) -> (Vec<u8>, Vec<u8>) {
    let mut ce = vec![0u8; (w * h) as usize];
    let mut cs = vec![0u8; (w * h) as usize];
    for t in tris {
        edge_spans(t, w, h, |y, a, b| {
            for x in a..=b {
                ce[(x + w * y) as usize] += 1;
            }
        });
        scanline_spans(t, w, h, |y, a, b| {
            for x in a..=b {
                cs[(x + w * y) as usize] += 1;
            }
        });
    }
    (ce, cs)
}

fn maybe_flip(rng: &mut ChaCha8Rng, v: [[i64; 2]; 3]) -> FixedTriangle {
    let v = if rng.random_bool(0.5) {
        v
    } else {
        [v[0], v[2], v[1]]
    };
    FixedTriangle::from_fixed(v).unwrap()
}

#[test]
fn jittered_grid_covers_every_pixel_exactly_once() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (w, h) = (61, 47);
    for case in 0..40 {
        let cell = [8.0, 10.0, 13.0][case % 3];
        // Jitter (plus up to one pixel of lattice snapping) keeps every
        // quad strictly convex; asserted below.
        let jit = cell * 0.12;
        let (nx, ny) = (
            (w as f64 / cell).ceil() as i64 + 3,
            (h as f64 / cell).ceil() as i64 + 3,
        );
        let mut g = vec![[0i64; 2]; ((nx + 1) * (ny + 1)) as usize];
        for j in 0..=ny {
            for i in 0..=nx {
                let bx = (i - 1) as f64 * cell;
                let by = (j - 1) as f64 * cell;
                let x = coord(&mut rng, bx - jit, bx + jit);
                let y = coord(&mut rng, by - jit, by + jit);
                g[(i + (nx + 1) * j) as usize] = [x, y];
            }
        }
        let at = |i: i64, j: i64| g[(i + (nx + 1) * j) as usize];
        let mut tris = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                let q = [a, b, c, d];
                assert!((0..4).all(|k| {
                    let (p0, p1, p2) = (q[k], q[(k + 1) % 4], q[(k + 2) % 4]);
                    (p1[0] - p0[0]) * (p2[1] - p0[1]) - (p1[1] - p0[1]) * (p2[0] - p0[0]) > 0
                }));
                if rng.random_bool(0.5) {
                    tris.push(maybe_flip(&mut rng, [a, b, c]));
                    tris.push(maybe_flip(&mut rng, [a, c, d]));
                } else {
                    tris.push(maybe_flip(&mut rng, [a, b, d]));
                    tris.push(maybe_flip(&mut rng, [b, c, d]));
                }
            }
        }
        let (ce, cs) = count_cover(&tris, w, h);
        assert!(ce.iter().all(|&c| c == 1), "case {case}: edge cover {ce:?}");
        assert!(cs.iter().all(|&c| c == 1), "case {case}: scanline cover");
    }
}

#[test]
fn random_fans_cover_their_interior_exactly_once() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (w, h) = (40, 40);
    let mut done = 0;
    while done < 300 {
        let c = [coord(&mut rng, 12.0, 28.0), coord(&mut rng, 12.0, 28.0)];
        let k = rng.random_range(3..12);
        let mut ang: Vec<f64> = (0..k)
            .map(|_| rng.random_range(0.0..std::f64::consts::TAU))
            .collect();
        ang.sort_by(f64::total_cmp);
        let gaps_ok = (0..k).all(|i| {
            let next = if i + 1 < k {
                ang[i + 1]
            } else {
                ang[0] + std::f64::consts::TAU
            };
            next - ang[i] < 3.0
        });
        if !gaps_ok {
            continue;
        }
        let p: Vec<[i64; 2]> = ang
            .iter()
            .map(|a| {
                let r = rng.random_range(1.0..14.0);
                let (x, y) = (
                    c[0] as f64 / SUB_ONE as f64 + r * a.cos(),
                    c[1] as f64 / SUB_ONE as f64 + r * a.sin(),
                );
                if rng.random_bool(0.3) {
                    // on the pixel-centre lattice, like c sometimes is
                    [px(x.floor() + 0.5), px(y.floor() + 0.5)]
                } else {
                    [px(x), px(y)]
                }
            })
            .collect();
        let oriented: Vec<[[i64; 2]; 3]> = (0..k).map(|i| [c, p[i], p[(i + 1) % k]]).collect();
        let areas: Vec<i64> = oriented
            .iter()
            .map(|v| FixedTriangle::from_fixed(*v).unwrap().area2())
            .collect();
        if !areas.iter().all(|&a| a > 0) {
            continue; // rounding made the fan invalid
        }
        let tris: Vec<FixedTriangle> = oriented.iter().map(|v| maybe_flip(&mut rng, *v)).collect();
        let (ce, cs) = count_cover(&tris, w, h);
        assert_eq!(ce, cs);
        // Expected: 1 for centres in the closed fan but not on its outer
        // boundary, 0 outside, 0 or 1 on the outer boundary.
        for y in 0..h {
            for x in 0..w {
                let q = [x as i64 * SUB_ONE + SUB_HALF, y as i64 * SUB_ONE + SUB_HALF];
                let cr = |a: [i64; 2], b: [i64; 2]| {
                    (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])
                };
                let mut in_closed = false;
                let mut on_outer = false;
                for v in &oriented {
                    let e = [cr(v[0], v[1]), cr(v[1], v[2]), cr(v[2], v[0])];
                    if e.iter().all(|&e| e >= 0) {
                        in_closed = true;
                        on_outer |= e[1] == 0;
                    }
                }
                let n = ce[(x + w * y) as usize];
                match (in_closed, on_outer) {
                    (true, false) => assert_eq!(n, 1, "pixel ({x},{y}) fan {oriented:?}"),
                    (true, true) => assert!(n <= 1),
                    (false, _) => assert_eq!(n, 0, "pixel ({x},{y}) outside"),
                }
            }
        }
        done += 1;
    }
}

#[test]
fn gouraud_is_exact_at_vertices_and_matches_the_plane() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (w, h) = (50, 50);
    let mut checked = 0;
    for _ in 0..600 {
        let vp = [0; 3].map(|_| [rng.random_range(0..w), rng.random_range(0..h)]);
        let v = vp.map(|p| [p[0] as f32 + 0.5, p[1] as f32 + 0.5]);
        let q: [[f32; 4]; 3] = [0; 3].map(|_| [0; 4].map(|_| rng.random_range(-100.0..100.0)));
        let t = FixedTriangle::from_pixels(v).unwrap();
        let Some(ip) = Interpolator::new(&t, q, w, h) else {
            assert_eq!(t.area2(), 0);
            continue;
        };
        for k in 0..3 {
            let got = ip.at_pixel(vp[k][0] as i64, vp[k][1] as i64);
            assert_eq!(got.map(f32::to_bits), q[k].map(f32::to_bits));
        }
        // Covered pixels: the rasterizer's values equal at_pixel's, lie in
        // the vertex range, and follow the plane through the vertices
        // (Cornell's linInterp coefficients, in f64).
        let (x0, y0) = (v[0][0] as f64, v[0][1] as f64);
        let (x1, y1) = (v[1][0] as f64, v[1][1] as f64);
        let (x2, y2) = (v[2][0] as f64, v[2][1] as f64);
        let det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
        ip.for_each(|x, y, val| {
            assert_eq!(val, ip.at_pixel(x as i64, y as i64));
            for k in 0..4 {
                let (q0, q1, q2) = (q[0][k] as f64, q[1][k] as f64, q[2][k] as f64);
                let cx = ((q1 - q0) * (y2 - y0) - (q2 - q0) * (y1 - y0)) / det;
                let cy = ((q2 - q0) * (x1 - x0) - (q1 - q0) * (x2 - x0)) / det;
                let plane = q0 + cx * (x as f64 + 0.5 - x0) + cy * (y as f64 + 0.5 - y0);
                assert!(
                    (val[k] as f64 - plane).abs() < 1e-3,
                    "{} vs {plane}",
                    val[k]
                );
                let lo = q[0][k].min(q[1][k]).min(q[2][k]);
                let hi = q[0][k].max(q[1][k]).max(q[2][k]);
                assert!(val[k] >= lo && val[k] <= hi);
            }
            checked += 1;
        });
    }
    assert!(checked > 10_000);
    // A drawn vertex pixel carries the vertex colour exactly (8-bit).
    let mut tgt = RenderTarget::new(8, 8, [0, 0, 0]).unwrap();
    let vtx = |x: f32, y: f32, c: [f32; 3]| ShadedVertex {
        pos: [x, y],
        depth: 0.0,
        color: c,
    };
    // (0.5, 0.5) lies on a top edge and a left edge: covered.
    let tri = [
        vtx(0.5, 0.5, [1.0, 0.2, 0.4]),
        vtx(6.5, 0.5, [0.0, 1.0, 0.0]),
        vtx(0.5, 6.5, [0.0, 0.0, 1.0]),
    ];
    draw_shaded(&mut tgt, &tri, Shading::Gouraud, DepthTest::Less).unwrap();
    assert_eq!(tgt.color.get(0, 0), Some([255, 51, 102]));
    draw_shaded(&mut tgt, &tri, Shading::Flat, DepthTest::Always).unwrap();
    let flat = voxkit::triangle::to_rgb8([
        (1.0 + 0.0 + 0.0) / 3.0,
        (0.2 + 1.0 + 0.0) / 3.0,
        (0.4 + 0.0 + 1.0) / 3.0,
    ]);
    assert_eq!(tgt.color.get(3, 1), Some(flat));
}

#[test]
fn zbuffer_and_painter_agree_on_layered_triangles() {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let (w, h) = (48, 40);
    for case in 0..60 {
        let n = rng.random_range(2..25);
        // Layer i has depths in [i, i + 0.9]: disjoint ranges, so mean
        // depth orders the layers correctly and nothing intersects.
        let mut tris: Vec<[ShadedVertex; 3]> = (0..n)
            .map(|i| {
                let col = [0; 3].map(|_| rng.random_range(0.0..1.0f32));
                [0; 3].map(|_| ShadedVertex {
                    pos: [rng.random_range(-5.0..53.0), rng.random_range(-5.0..45.0)],
                    depth: i as f32 + rng.random_range(0.0..0.9),
                    color: [0; 3]
                        .map(|_| rng.random_range(0.0..1.0f32))
                        .map(|c| (c + col[0]) / 2.0),
                })
            })
            .collect();
        // Shuffle the draw order.
        for i in (1..tris.len()).rev() {
            tris.swap(i, rng.random_range(0..=i));
        }
        for shading in [Shading::Flat, Shading::Gouraud] {
            let mut z = RenderTarget::new(w, h, [9, 9, 9]).unwrap();
            let mut p = RenderTarget::new(w, h, [9, 9, 9]).unwrap();
            draw_zbuffer(&mut z, &tris, shading).unwrap();
            draw_painter(&mut p, &tris, shading).unwrap();
            assert_eq!(z.color, p.color, "case {case} {shading:?}");
        }
        let order = painter_order(&tris);
        let mean = |t: &[ShadedVertex; 3]| t.iter().map(|v| v.depth).sum::<f32>() / 3.0;
        assert!(
            order
                .windows(2)
                .all(|o| mean(&tris[o[0]]) >= mean(&tris[o[1]]))
        );
    }
}

#[test]
fn batched_point_tests_equal_scalar() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    for case in 0..300 {
        let n = rng.random_range(0..200);
        // f32
        let v = [0; 3].map(|_| {
            [
                rng.random_range(-50.0..50.0f32),
                rng.random_range(-50.0..50.0f32),
            ]
        });
        if let Ok(t) = InsideF32::new(v) {
            let mut xs: Vec<f32> = (0..n).map(|_| rng.random_range(-60.0..60.0)).collect();
            let mut ys: Vec<f32> = (0..n).map(|_| rng.random_range(-60.0..60.0)).collect();
            for i in 0..n.min(6) {
                // vertices, edge midpoints, NaN
                let (a, b) = (v[i % 3], v[(i + 1) % 3]);
                (xs[i], ys[i]) = match i {
                    0..3 => (a[0], a[1]),
                    3..5 => ((a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0),
                    _ => (f32::NAN, 0.0),
                };
            }
            let mut m = vec![7u8; n];
            let cnt = t.mask(&xs, &ys, &mut m).unwrap();
            for i in 0..n {
                assert_eq!(m[i] == 1, t.contains(xs[i], ys[i]), "case {case} point {i}");
                assert!(m[i] <= 1);
            }
            assert_eq!(cnt, t.count_scalar(&xs, &ys).unwrap());
            assert_eq!(cnt, t.count(&xs, &ys).unwrap());
            assert_eq!(cnt, m.iter().map(|&b| b as usize).sum::<usize>());
            if n > 0 {
                assert!(!t.contains(f32::NAN, 0.0));
            }
        }
        // i32, against an exact i128 oracle
        let r = if case % 4 == 0 { INSIDE_I32_MAX } else { 40 };
        let v = [0; 3].map(|_| [rng.random_range(-r..=r), rng.random_range(-r..=r)]);
        let Ok(t) = InsideI32::new(v) else { continue };
        let span = if case % 5 == 0 { i32::MAX } else { r + 5 };
        let mut xs: Vec<i32> = (0..n).map(|_| rng.random_range(-span..=span)).collect();
        let mut ys: Vec<i32> = (0..n).map(|_| rng.random_range(-span..=span)).collect();
        for i in 0..n.min(3) {
            (xs[i], ys[i]) = (v[i][0], v[i][1]);
        }
        let mut m = vec![0u8; n];
        let cnt = t.mask(&xs, &ys, &mut m).unwrap();
        let cross = |a: [i32; 2], b: [i32; 2], p: [i128; 2]| {
            (b[0] as i128 - a[0] as i128) * (p[1] - a[1] as i128)
                - (b[1] as i128 - a[1] as i128) * (p[0] - a[0] as i128)
        };
        for i in 0..n {
            let p = [xs[i] as i128, ys[i] as i128];
            let e = [
                cross(v[0], v[1], p),
                cross(v[1], v[2], p),
                cross(v[2], v[0], p),
            ];
            let inside = e.iter().all(|&e| e >= 0) || e.iter().all(|&e| e <= 0);
            assert_eq!(m[i] == 1, inside, "case {case} point {i}: {v:?} {p:?}");
            assert_eq!(m[i] == 1, t.contains(xs[i], ys[i]));
        }
        assert_eq!(cnt, t.count(&xs, &ys).unwrap());
        assert_eq!(cnt, t.count_scalar(&xs, &ys).unwrap());
    }
}

fn cube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    // Outward (counter-clockwise seen from outside) winding.
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let idx = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    (p, idx)
}

/// The set of non-background pixels is exactly the rectangle `[a, b]²`.
fn assert_square(img: &RenderTarget, a: u32, b: u32, bg: [u8; 3]) {
    for y in 0..img.height() {
        for x in 0..img.width() {
            let inside = (a..=b).contains(&x) && (a..=b).contains(&y);
            let c = img.color.get(x, y).unwrap();
            let d = img.depth.get(x, y).unwrap();
            assert_eq!(c != bg, inside, "pixel ({x},{y}) {c:?}");
            assert_eq!(d.is_finite(), inside);
        }
    }
}

#[test]
fn cube_face_on_fills_the_expected_square() {
    let (p, idx) = cube();
    let bg = [0, 0, 0];
    let opts = MeshRenderOptions::default();
    // Orthographic, 4 world units over 40 pixels: x ∈ [−1, 1] ↦ [10, 30).
    let cam = Camera::orthographic(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 4.0);
    let img = render_mesh(&p, &idx, None, &cam, 40, 40, &opts).unwrap();
    assert_square(&img, 10, 29, bg);
    // Lit: every front pixel lies between the darkest and brightest of the
    // four front vertices' Lambert values (Gouraud is a convex combination).
    let normals = voxkit::triangle::vertex_normals(&p, &idx);
    for (v, n) in p.iter().zip(&normals) {
        assert!(n.dot(*v) > 0.5, "corner normals point outwards: {v} {n}");
    }
    let lit: Vec<u8> = (4..8)
        .map(|i| {
            let k = opts.ambient + (1.0 - opts.ambient) * normals[i].z.abs();
            voxkit::triangle::to_rgb8([opts.base_color[0] * k; 3])[0]
        })
        .collect();
    let (lo, hi) = (*lit.iter().min().unwrap(), *lit.iter().max().unwrap());
    for y in 10..30 {
        for x in 10..30 {
            let [r, g, b] = img.color.get(x, y).unwrap();
            assert!(
                r == g && g == b && r + 1 >= lo && r <= hi + 1,
                "{r} not in [{lo}, {hi}]"
            );
        }
    }
    // Unlit: exactly the base colour everywhere on the face.
    let flat = MeshRenderOptions {
        lighting: Lighting::Unlit,
        base_color: [0.2, 0.4, 0.6],
        ..opts
    };
    let img = render_mesh(&p, &idx, None, &cam, 40, 40, &flat).unwrap();
    assert_square(&img, 10, 29, bg);
    let want = voxkit::triangle::to_rgb8([0.2, 0.4, 0.6]);
    assert!((10..30).all(|y| (10..30).all(|x| img.color.get(x, y) == Some(want))));
    // Perspective, 90°, eye 4 units from the front face: x = ±1 ↦ NDC ±¼
    // ↦ pixels [15, 25); the side faces hide behind the front one.
    let mut cam = Camera::perspective(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 90.0);
    cam.fit_clip(DVec3::splat(-1.0), DVec3::splat(1.0));
    let img = render_mesh(&p, &idx, None, &cam, 40, 40, &opts).unwrap();
    assert_square(&img, 15, 24, bg);
    // Per-vertex colours, unlit: the front face (z = 1) is interpolated
    // between its vertex colours; the back faces never show.
    let cols: Vec<Vec3> = p.iter().map(|v| (*v + 1.0) * 0.5).collect();
    let unlit = MeshRenderOptions {
        lighting: Lighting::Unlit,
        ..opts
    };
    let img = render_mesh(&p, &idx, Some(&cols), &cam, 40, 40, &unlit).unwrap();
    let [r, g, b] = img.color.get(15, 24).unwrap();
    assert!(r < 20 && g < 20 && b == 255, "{:?}", [r, g, b]);
    // Depth: the front face is at view distance 4 → NDC z = f(d − n)/((f − n)d).
    let z = img.depth.get(20, 20).unwrap();
    let (n, f) = (cam.near, cam.far);
    assert!((z as f64 - f * (4.0 - n) / ((f - n) * 4.0)).abs() < 1e-4);
}

#[test]
fn triangle_crossing_the_near_plane_matches_ray_casting() {
    // A long ground strip from in front of the camera to behind it.
    let p = vec![
        Vec3::new(-3.0, -1.0, -20.0),
        Vec3::new(3.0, -1.0, -20.0),
        Vec3::new(0.0, -1.0, 10.0),
        Vec3::new(-1.0, -2.0, 3.0),
    ];
    let idx = vec![[0, 1, 2], [0, 3, 1]];
    let mut cam = Camera::perspective(DVec3::ZERO, DVec3::new(0.0, -0.3, -1.0), DVec3::Y, 70.0);
    cam.near = 0.1;
    cam.far = 100.0;
    let (w, h) = (64, 48);
    let img = render_mesh(&p, &idx, None, &cam, w, h, &MeshRenderOptions::default()).unwrap();
    let mut mismatches = 0;
    let mut hits = 0;
    for y in 0..h {
        for x in 0..w {
            let (o, d) = cam.pixel_ray(x as f64 + 0.5, y as f64 + 0.5, w, h);
            // Ray–triangle (Möller–Trumbore) in f64 with a margin band.
            let mut hit = false;
            let mut near_edge = false;
            for t in &idx {
                let [a, b, c] = t.map(|i| p[i as usize].as_dvec3());
                let (e1, e2) = (b - a, c - a);
                let pv = d.cross(e2);
                let det = e1.dot(pv);
                if det.abs() < 1e-12 {
                    continue;
                }
                let tv = o - a;
                let u = tv.dot(pv) / det;
                let qv = tv.cross(e1);
                let v = d.dot(qv) / det;
                let s = e2.dot(qv) / det;
                if s <= 0.0 {
                    continue;
                }
                let m = u.min(v).min(1.0 - u - v);
                if m.abs() < 1e-3 {
                    near_edge = true;
                }
                hit |= m >= 0.0;
            }
            let drawn = img.depth.get(x, y).unwrap().is_finite();
            hits += drawn as usize;
            if drawn != hit && !near_edge {
                mismatches += 1;
            }
            if drawn {
                let z = img.depth.get(x, y).unwrap();
                assert!((0.0..=1.0).contains(&z), "depth {z}");
            }
        }
    }
    assert_eq!(mismatches, 0);
    assert!(hits > 500, "{hits}");
}

#[test]
fn render_errors_and_png_output() {
    let (p, idx) = cube();
    let cam = Camera::orthographic(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 4.0);
    let o = MeshRenderOptions::default();
    assert!(render_mesh(&p, &[[0, 1, 8]], None, &cam, 8, 8, &o).is_err());
    assert!(render_mesh(&p, &idx, Some(&p[..3]), &cam, 8, 8, &o).is_err());
    assert!(render_mesh(&p, &idx, None, &cam, 0, 8, &o).is_err());
    let mut nan = p.clone();
    nan[2].x = f32::NAN;
    assert!(render_mesh(&nan, &idx, None, &cam, 8, 8, &o).is_err());
    let bad = Camera::orthographic(DVec3::ZERO, DVec3::ZERO, DVec3::Y, 4.0);
    assert!(render_mesh(&p, &idx, None, &bad, 8, 8, &o).is_err());
    let bad = Camera::perspective(DVec3::Z, DVec3::ZERO, DVec3::Z, 60.0);
    assert!(render_mesh(&p, &idx, None, &bad, 8, 8, &o).is_err());
    let img = render_mesh(&p, &idx, None, &cam, 40, 30, &o).unwrap();
    let dir = temp_dir("raster");
    let path = dir.join("cube.png");
    let img2 =
        voxkit::triangle::render_mesh_png(&p, &idx, None, &cam, 40, 30, &o, &path, true).unwrap();
    assert_eq!(img2, img);
    assert!(img.color.write_png(&path, false).is_err());
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (40, 30));
    let bytes: Vec<u8> = img.color.pixels().iter().flatten().copied().collect();
    assert_eq!(&buf[..], &bytes[..]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn pixel_rays_project_back_to_their_pixels() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (w, h) = (80, 50);
    let eye = DVec3::new(1.0, 2.0, 6.0);
    let mut cams = [
        Camera::perspective(eye, DVec3::new(0.5, 0.0, 0.0), DVec3::Y, 50.0),
        Camera::orthographic(eye, DVec3::new(0.5, 0.0, 0.0), DVec3::Y, 5.0),
    ];
    for cam in &mut cams {
        cam.near = 0.5;
        cam.far = 50.0;
        let vp = cam.view_projection(w, h);
        for _ in 0..200 {
            let (px, py) = (
                rng.random_range(0.0..w as f32),
                rng.random_range(0.0..h as f32),
            );
            let (o, d) = cam.pixel_ray(px as f64, py as f64, w, h);
            let (o, d) = (o.as_vec3(), d.as_vec3());
            assert!((d.length() - 1.0).abs() < 1e-5);
            // The origin lies on the near plane.
            let ndc = vp.project_point3(o);
            assert!(ndc.z.abs() < 1e-4, "{ndc}");
            for s in [0.0, 1.0, 10.0] {
                let q = vp.project_point3(o + d * s);
                let (qx, qy) = ((q.x + 1.0) * 0.5 * w as f32, (1.0 - q.y) * 0.5 * h as f32);
                assert!(
                    (qx - px).abs() < 1e-3 && (qy - py).abs() < 1e-3,
                    "{qx},{qy} vs {px},{py}"
                );
            }
        }
    }
}
