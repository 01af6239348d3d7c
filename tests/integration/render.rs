//! The ray caster against oracles: adaptive == 6-ray first hits on random
//! grids and on scenes built to trap 26-rays; skipping on == off bit for
//! bit; 6-ray hits == the first voxel along the segment found by brute
//! force (exact segment–cube tests); cameras inside the grid, inside an
//! occupied voxel, along axes and diagonals; empty and 1×1×1 grids.

use glam::{DVec3, IVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::camera::Camera;
use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
use voxkit::render::{
    GridTransform, NormalMode, OccupancyGrid, RayKind, RenderImage, RenderOptions, render_grid,
};

fn opts(w: u32, h: u32, ray: RayKind, skip: bool) -> RenderOptions {
    RenderOptions {
        width: w,
        height: h,
        ray,
        skip,
        ..RenderOptions::default()
    }
}

fn render(grid: &BrickGrid, dims: [usize; 3], cam: &Camera, o: &RenderOptions) -> RenderImage {
    let occ = OccupancyGrid::new(grid, dims, MemoryLimit::DEFAULT).unwrap();
    let xf = GridTransform::from_frame(&GridFrame::new(DVec3::ZERO, 1.0, dims)).unwrap();
    render_grid(&occ, &xf, cam, o).unwrap().0
}

/// A random camera around (or inside) a grid of `dims` (world = grid + ½).
fn random_camera(rng: &mut ChaCha8Rng, dims: [usize; 3]) -> Camera {
    let size = DVec3::from_array(dims.map(|d| d as f64));
    let centre = size * 0.5;
    let eye = loop {
        let dir = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if dir.length() > 0.1 {
            let r = rng.random_range(0.2..2.5) * size.length();
            break centre + dir.normalize() * r;
        }
    };
    let target = centre
        + DVec3::new(
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
            0.0,
        );
    let up = if rng.random_bool(0.5) {
        DVec3::Y
    } else {
        DVec3::Z
    };
    let up = if (target - eye).normalize().cross(up).length() < 1e-3 {
        DVec3::X
    } else {
        up
    };
    if rng.random_bool(0.3) {
        Camera::orthographic(eye, target, up, size.length())
    } else {
        Camera::perspective(eye, target, up, rng.random_range(20.0..90.0))
    }
}

/// Scenes that trap 26-rays: one-voxel diagonal walls, leaky thin shells
/// (a sphere's 26-connected surface), scattered single voxels.
fn trap_scenes(rng: &mut ChaCha8Rng) -> Vec<(BrickGrid, [usize; 3])> {
    let mut scenes = Vec::new();
    // Diagonal wall x + y = 20, one voxel thick (26-rays slip through).
    let dims = [40, 40, 24];
    let mut g = BrickGrid::new();
    for x in 0..40 {
        for z in 0..24 {
            let y = 20 - x;
            if (0..40).contains(&y) {
                g.insert(IVec3::new(x, y, z));
            }
        }
    }
    scenes.push((g, dims));
    // A body-diagonal plane x + y + z = 30.
    let dims = [32, 32, 32];
    let mut g = BrickGrid::new();
    for x in 0..32 {
        for y in 0..32 {
            let z = 30 - x - y;
            if (0..32).contains(&z) {
                g.insert(IVec3::new(x, y, z));
            }
        }
    }
    scenes.push((g, dims));
    // A thin spherical shell: voxels whose centre is within 0.5 of radius 12.
    let dims = [30, 30, 30];
    let mut g = BrickGrid::new();
    for x in 0..30 {
        for y in 0..30 {
            for z in 0..30 {
                let r = (IVec3::new(x, y, z) - 15).as_dvec3().length();
                if (r - 12.0).abs() < 0.5 {
                    g.insert(IVec3::new(x, y, z));
                }
            }
        }
    }
    scenes.push((g, dims));
    // Scattered single voxels.
    let dims = [37, 29, 45];
    let mut g = BrickGrid::new();
    for _ in 0..150 {
        g.insert(IVec3::new(
            rng.random_range(0..37),
            rng.random_range(0..29),
            rng.random_range(0..45),
        ));
    }
    scenes.push((g, dims));
    // Two small clusters far apart in a large box: most bricks are two or
    // more bricks from anything occupied (inert: stepped through without
    // flag tests), with flagged bricks between.
    let dims = [96, 80, 104];
    let mut g = BrickGrid::new();
    for c in [IVec3::new(20, 18, 25), IVec3::new(70, 60, 80)] {
        for d in 0..27 {
            let o = IVec3::new(d % 3, d / 3 % 3, d / 9) - 1;
            if (d * 7) % 3 != 0 {
                g.insert(c + o * 2);
            }
        }
    }
    scenes.push((g, dims));
    scenes
}

fn random_grid(rng: &mut ChaCha8Rng) -> (BrickGrid, [usize; 3]) {
    let dims = [
        rng.random_range(1..50),
        rng.random_range(1..50),
        rng.random_range(1..50),
    ];
    let density = [0.0005, 0.005, 0.05][rng.random_range(0..3)];
    let mut g = BrickGrid::new();
    for x in 0..dims[0] as i32 {
        for y in 0..dims[1] as i32 {
            for z in 0..dims[2] as i32 {
                if rng.random_bool(density) {
                    g.insert(IVec3::new(x, y, z));
                }
            }
        }
    }
    (g, dims)
}

/// Tiles culled before casting (no brick with an occupied voxel within
/// their rays' reach) hold exactly the pixels the cast rays give: sparse
/// clusters in larger grids, every ray kind, smooth and face normals,
/// cameras near and far, perspective and orthographic.
#[test]
fn culled_tiles_equal_cast_rays() {
    let mut rng = ChaCha8Rng::seed_from_u64(909);
    let (mut culled, mut rays) = (0, 0);
    for round in 0..12 {
        let dims = [
            rng.random_range(30..120),
            rng.random_range(30..120),
            rng.random_range(30..120),
        ];
        let mut g = BrickGrid::new();
        for _ in 0..rng.random_range(1..4) {
            let c = IVec3::from_array(dims.map(|d| rng.random_range(0..d as i32)));
            for _ in 0..rng.random_range(1..60) {
                let v = c + IVec3::new(
                    rng.random_range(-4..5),
                    rng.random_range(-4..5),
                    rng.random_range(-4..5),
                );
                if (0..3).all(|k| v[k] >= 0 && v[k] < dims[k] as i32) {
                    g.insert(v);
                }
            }
        }
        let occ = OccupancyGrid::new(&g, dims, MemoryLimit::DEFAULT).unwrap();
        let xf = GridTransform::from_frame(&GridFrame::new(DVec3::ZERO, 1.0, dims)).unwrap();
        for _ in 0..3 {
            let cam = random_camera(&mut rng, dims);
            for kind in RayKind::ALL {
                for normals in [NormalMode::Smooth, NormalMode::Face] {
                    let o = |skip| RenderOptions {
                        normals,
                        ..opts(88, 64, kind, skip)
                    };
                    let (with, st) = render_grid(&occ, &xf, &cam, &o(true)).unwrap();
                    let without = render_grid(&occ, &xf, &cam, &o(false)).unwrap().0;
                    assert_eq!(
                        with, without,
                        "round {round} {kind:?} {cam:?}: culling changed the image"
                    );
                    culled += st.rays_culled;
                    rays += st.rays;
                }
            }
        }
    }
    assert!(culled * 4 > rays, "only {culled} of {rays} rays culled");
}

/// Adaptive (and A–W) first hits equal the 6-ray's on every pixel, with and
/// without skipping, and skipping changes no pixel of any kind.
#[test]
fn adaptive_equals_six_and_skipping_changes_nothing() {
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let mut scenes = trap_scenes(&mut rng);
    for _ in 0..12 {
        scenes.push(random_grid(&mut rng));
    }
    let mut leaks26 = 0;
    for (g, dims) in &scenes {
        for _ in 0..3 {
            let cam = random_camera(&mut rng, *dims);
            let six = render(g, *dims, &cam, &opts(48, 40, RayKind::Six, false));
            for kind in RayKind::ALL {
                let with = render(g, *dims, &cam, &opts(48, 40, kind, true));
                let without = render(g, *dims, &cam, &opts(48, 40, kind, false));
                assert_eq!(with, without, "{kind:?}: skipping changed the image");
                match kind {
                    RayKind::Six | RayKind::Adaptive => {
                        assert_eq!(with.hit, six.hit, "{kind:?} differs from the 6-ray");
                        assert_eq!(with.depth, six.depth);
                    }
                    RayKind::TwentySix => leaks26 += with.differing_hits(&six),
                    RayKind::AmanatidesWoo => assert!(
                        with.differing_hits(&six) <= 2,
                        "A–W differs from the 6-ray in {} pixels",
                        with.differing_hits(&six)
                    ),
                }
            }
        }
    }
    // The traps do trap the 26-ray.
    assert!(leaks26 > 50, "26-rays leaked in only {leaks26} pixels");
}

/// Brute force: the first voxel along the segment whose closed cube it
/// meets, in order of entry, by exact slab tests on the fixed-point
/// segment (f64 holds its values exactly).
fn brute_first_hit(g: &BrickGrid, a: DVec3, b: DVec3) -> Option<IVec3> {
    let d = b - a;
    let mut best: Option<(f64, IVec3)> = None;
    for v in g.iter() {
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let mut ok = true;
        for k in 0..3 {
            let (lo, hi) = (v[k] as f64 - 0.5, v[k] as f64 + 0.5);
            if d[k] == 0.0 {
                ok &= a[k] >= lo && a[k] <= hi;
            } else {
                let (p, q) = ((lo - a[k]) / d[k], (hi - a[k]) / d[k]);
                t0 = t0.max(p.min(q));
                t1 = t1.min(p.max(q));
            }
        }
        if ok && t0 <= t1 && best.is_none_or(|(t, _)| t0 < t) {
            best = Some((t0, v));
        }
    }
    best.map(|(_, v)| v)
}

/// The 6-ray's hit is the first voxel the continuous segment meets (where
/// the entry point is unique: no two cubes entered at the same `t`).
#[test]
fn six_ray_hits_the_first_voxel_the_segment_meets() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut checked = 0;
    for _ in 0..300 {
        let (g, dims) = random_grid(&mut rng);
        if g.is_empty() {
            continue;
        }
        let occ = OccupancyGrid::new(&g, dims, MemoryLimit::DEFAULT).unwrap();
        let (lo, hi) = occ.bounds().unwrap();
        let inset = 1.0 / 4096.0;
        let (lo, hi) = (lo.as_dvec3() - 0.5 + inset, hi.as_dvec3() + 0.5 - inset);
        for _ in 0..20 {
            let p = |rng: &mut ChaCha8Rng| {
                DVec3::new(
                    rng.random_range(lo.x..=hi.x),
                    rng.random_range(lo.y..=hi.y),
                    rng.random_range(lo.z..=hi.z),
                )
            };
            let (a, b) = (p(&mut rng), p(&mut rng));
            let seg = voxkit::line::Segment::from_f64(a.to_array(), b.to_array()).unwrap();
            let (fa, fb) = (
                seg.a().map(voxkit::fixed::to_f64),
                seg.b().map(voxkit::fixed::to_f64),
            );
            let (fa, fb) = (DVec3::from_array(fa), DVec3::from_array(fb));
            let want = brute_first_hit(&g, fa, fb);
            let got = voxkit::render::first_hit(&occ, &seg, RayKind::Six, true);
            // Ties (two cubes entered at the same t: through an edge or a
            // corner) are settled by the tie rule, not by entry order.
            if want != got {
                let tw = want.map(|v| entry_t(fa, fb, v));
                let tg = got.map(|v| entry_t(fa, fb, v));
                assert_eq!(tw, tg, "{a} → {b}: brute {want:?}, 6-ray {got:?}");
            }
            checked += 1;
        }
    }
    assert!(checked > 3000);
}

fn entry_t(a: DVec3, b: DVec3, v: IVec3) -> f64 {
    let d = b - a;
    (0..3)
        .filter(|&k| d[k] != 0.0)
        .map(|k| {
            let (p, q) = (
                (v[k] as f64 - 0.5 - a[k]) / d[k],
                (v[k] as f64 + 0.5 - a[k]) / d[k],
            );
            p.min(q)
        })
        .fold(0.0, f64::max)
}

/// Edge cases: an empty grid, a 1×1×1 grid, cameras along axes and exact
/// diagonals (grazing faces and edges), inside the grid and inside an
/// occupied voxel; every kind agrees with the 6-ray where it must.
#[test]
fn edge_case_cameras_and_grids() {
    let empty = BrickGrid::new();
    let cam = Camera::perspective(
        DVec3::new(2.0, 3.0, 20.0),
        DVec3::splat(2.0),
        DVec3::Y,
        40.0,
    );
    for kind in RayKind::ALL {
        let img = render(&empty, [4, 4, 4], &cam, &opts(16, 16, kind, true));
        assert!(img.hit.iter().all(|h| h.is_none()) && img.depth.iter().all(|d| d.is_infinite()));
    }
    let one: BrickGrid = [IVec3::ZERO].into_iter().collect();
    let cam = Camera::perspective(
        DVec3::new(0.5, 0.5, 10.0),
        DVec3::splat(0.5),
        DVec3::Y,
        10.0,
    );
    let img = render(&one, [1, 1, 1], &cam, &opts(9, 9, RayKind::Adaptive, true));
    assert_eq!(img.hit[4 * 9 + 4], Some(IVec3::ZERO));
    assert!((img.depth[4 * 9 + 4] - 9.0).abs() < 1e-4);

    // A slab of voxels z = 5, seen along axes and diagonals, and from inside.
    let dims = [16, 16, 16];
    let mut slab = BrickGrid::new();
    for x in 0..16 {
        for y in 0..16 {
            slab.insert(IVec3::new(x, y, 5));
        }
    }
    slab.insert(IVec3::new(8, 8, 12));
    let c = DVec3::splat(8.0);
    let cams = [
        Camera::orthographic(DVec3::new(8.0, 8.0, 40.0), c, DVec3::Y, 16.0),
        Camera::orthographic(DVec3::new(40.0, 8.0, 8.0), c, DVec3::Y, 16.0),
        Camera::perspective(DVec3::new(30.0, 30.0, 30.0), c, DVec3::Y, 60.0),
        Camera::perspective(
            DVec3::new(8.0, 8.0, 10.0),
            DVec3::new(8.0, 8.0, 0.0),
            DVec3::Y,
            90.0,
        ),
        // Inside the occupied voxel (8, 8, 12): world (8.5, 8.5, 12.5).
        Camera::perspective(DVec3::new(8.5, 8.5, 12.5), c, DVec3::Y, 60.0),
        // Grazing: the eye on the plane of voxel faces z = 5.5, looking along it.
        Camera::orthographic(
            DVec3::new(-5.0, 8.0, 6.0),
            DVec3::new(8.0, 8.0, 6.0),
            DVec3::Z,
            4.0,
        ),
    ];
    for (i, cam) in cams.iter().enumerate() {
        let six = render(&slab, dims, cam, &opts(33, 31, RayKind::Six, false));
        for kind in [RayKind::Adaptive, RayKind::AmanatidesWoo] {
            let img = render(&slab, dims, cam, &opts(33, 31, kind, true));
            let diff = img.differing_hits(&six);
            let allowed = if kind == RayKind::Adaptive {
                0
            } else {
                33 * 31 / 10
            };
            assert!(
                diff <= allowed,
                "camera {i}, {kind:?}: {diff} pixels differ"
            );
        }
        if i == 4 {
            // From inside an occupied voxel every ray hits it at depth 0.
            assert!(six.hit.iter().all(|h| *h == Some(IVec3::new(8, 8, 12))));
            assert!(six.depth.iter().all(|&d| d == 0.0));
        }
    }
    // Looking straight down z at the slab: every pixel hits layer 5 (or the
    // voxel above it) at the right depth.
    let top = render(
        &slab,
        dims,
        &cams[0],
        &opts(32, 32, RayKind::Adaptive, true),
    );
    for (h, d) in top.hit.iter().zip(&top.depth) {
        let v = h.expect("every pixel hits");
        if v.z == 5 {
            assert!((d - (40.0 - 6.0)).abs() < 1e-4, "depth {d}");
        }
    }
}

/// Identical images for 1 and N threads; smooth normals only change colour.
#[test]
fn threads_and_normals() {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let (g, dims) = trap_scenes(&mut rng).swap_remove(2);
    let cam = random_camera(&mut rng, dims);
    let o = opts(64, 48, RayKind::Adaptive, true);
    let many = render(&g, dims, &cam, &o);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let one = pool.install(|| render(&g, dims, &cam, &o));
    assert_eq!(one, many);
    let smooth = render(
        &g,
        dims,
        &cam,
        &RenderOptions {
            normals: NormalMode::Smooth,
            ..o
        },
    );
    assert_eq!(smooth.hit, many.hit);
    assert_eq!(smooth.depth, many.depth);
}

/// Bad cameras and sizes are typed errors.
#[test]
fn bad_render_input_is_an_error() {
    let g: BrickGrid = [IVec3::ONE].into_iter().collect();
    let occ = OccupancyGrid::new(&g, [3, 3, 3], MemoryLimit::DEFAULT).unwrap();
    let xf = GridTransform::from_frame(&GridFrame::new(DVec3::ZERO, 1.0, [3, 3, 3])).unwrap();
    let ok = Camera::perspective(DVec3::new(1.5, 1.5, 9.0), DVec3::splat(1.5), DVec3::Y, 40.0);
    let o = opts(8, 8, RayKind::Adaptive, true);
    let bad_cams = [
        Camera {
            target: ok.eye,
            ..ok
        },
        Camera { up: DVec3::Z, ..ok },
        Camera::perspective(ok.eye, ok.target, DVec3::Y, 0.0),
        Camera::perspective(ok.eye, ok.target, DVec3::Y, 180.0),
        Camera::perspective(DVec3::new(f64::NAN, 0.0, 0.0), ok.target, DVec3::Y, 40.0),
    ];
    for cam in bad_cams {
        assert!(render_grid(&occ, &xf, &cam, &o).is_err(), "{cam:?}");
    }
    assert!(render_grid(&occ, &xf, &ok, &opts(0, 8, RayKind::Six, true)).is_err());
    let tiny = RenderOptions {
        limit: MemoryLimit::new(1000),
        ..o
    };
    assert!(matches!(
        render_grid(&occ, &xf, &ok, &tiny),
        Err(voxkit::VoxkitError::Limits { .. })
    ));
}

/// Scenes with tiles: a solid ball (tiles inside, masks on its surface,
/// scattered voxels around) and a 3D checkerboard of tiles (every tile
/// beside empty bricks), each with the same voxels stored as masks.
fn tiled_scenes(rng: &mut ChaCha8Rng) -> Vec<(BrickGrid, BrickGrid, [usize; 3])> {
    let mut scenes = Vec::new();
    for dims in [[40, 37, 45], [64, 24, 33]] {
        scenes.push(crate::formats::tiled_ball(rng, dims));
    }
    let mut checker = BrickGrid::new();
    for z in 0..5 {
        for y in 0..4 {
            for x in 0..5 {
                if (x + y + z) % 2 == 0 {
                    checker.insert_tile(IVec3::new(x, y, z));
                }
            }
        }
    }
    checker.insert(IVec3::new(12, 3, 30));
    scenes.push(checker);
    let dims = [[40, 37, 45], [64, 24, 33], [40, 32, 40]];
    scenes
        .into_iter()
        .zip(dims)
        .map(|(g, d)| {
            assert!(g.tile_count() > 0);
            (crate::bricks::materialized(&g), g, d)
        })
        .collect()
}

/// A grid with tiles renders pixel for pixel as the same voxels stored as
/// masks, for every ray kind, with and without skipping, flat and smooth
/// normals; on it the adaptive ray still equals the 6-ray and skipping
/// changes nothing.
#[test]
fn tiled_grids_render_like_their_masks() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x711E);
    for (masks, tiled, dims) in tiled_scenes(&mut rng) {
        let occ = OccupancyGrid::new(&tiled, dims, MemoryLimit::DEFAULT).unwrap();
        assert_eq!(
            occ.full_bricks(),
            masks.bricks().filter(|(_, m)| **m == [u64::MAX; 8]).count()
        );
        for c in 0..6 {
            let cam = random_camera(&mut rng, dims);
            let six = render(&tiled, dims, &cam, &opts(40, 32, RayKind::Six, false));
            for kind in RayKind::ALL {
                for skip in [true, false] {
                    let mut o = opts(40, 32, kind, skip);
                    if c % 2 == 1 {
                        o.normals = NormalMode::Smooth;
                    }
                    let t = render(&tiled, dims, &cam, &o);
                    let m = render(&masks, dims, &cam, &o);
                    assert_eq!(t, m, "{kind:?} skip {skip}: tiles render differently");
                    if matches!(kind, RayKind::Six | RayKind::Adaptive) {
                        assert_eq!(t.hit, six.hit, "{kind:?} skip {skip}");
                    }
                }
            }
        }
    }
}

/// On grids with tiles the 6-ray's hit is still the first voxel the
/// continuous segment meets (brute force over the voxels).
#[test]
fn six_ray_first_hits_on_tiled_grids() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x6711E);
    for (_, g, _) in tiled_scenes(&mut rng) {
        let occ = OccupancyGrid::new(
            &g,
            g.bounds()
                .map(|(_, hi)| (hi + 1).to_array().map(|d| d as usize))
                .unwrap(),
            MemoryLimit::DEFAULT,
        )
        .unwrap();
        let (lo, hi) = occ.bounds().unwrap();
        let inset = 1.0 / 4096.0;
        let (lo, hi) = (lo.as_dvec3() - 0.5 + inset, hi.as_dvec3() + 0.5 - inset);
        for _ in 0..40 {
            let p = |rng: &mut ChaCha8Rng| {
                DVec3::new(
                    rng.random_range(lo.x..=hi.x),
                    rng.random_range(lo.y..=hi.y),
                    rng.random_range(lo.z..=hi.z),
                )
            };
            let (a, b) = (p(&mut rng), p(&mut rng));
            let seg = voxkit::line::Segment::from_f64(a.to_array(), b.to_array()).unwrap();
            let (fa, fb) = (
                DVec3::from_array(seg.a().map(voxkit::fixed::to_f64)),
                DVec3::from_array(seg.b().map(voxkit::fixed::to_f64)),
            );
            let want = brute_first_hit(&g, fa, fb);
            for skip in [true, false] {
                let got = voxkit::render::first_hit(&occ, &seg, RayKind::Six, skip);
                if want != got {
                    let tw = want.map(|v| entry_t(fa, fb, v));
                    let tg = got.map(|v| entry_t(fa, fb, v));
                    assert_eq!(tw, tg, "{a} → {b}: brute {want:?}, 6-ray {got:?}");
                }
            }
        }
    }
}

/// Colours on tiles: full bricks keep sharing one slot where every voxel
/// has the one colour of the file, and get their own slot otherwise; either
/// way each voxel shows its colour (0 where it has none), as on masks.
#[test]
fn colours_on_tiles_match_masks() {
    let mut rng = ChaCha8Rng::seed_from_u64(0xC010);
    let (masks, tiled, dims) = tiled_scenes(&mut rng).swap_remove(0);
    let palette = voxkit::io::vox::default_palette();
    let all: Vec<(IVec3, u8)> = tiled.iter().map(|v| (v, 1)).collect();
    let mut varied = all.clone();
    for (i, e) in varied.iter_mut().enumerate() {
        if i % 997 == 0 {
            e.1 = 7;
        }
    }
    let partial: Vec<(IVec3, u8)> = all.iter().copied().filter(|(v, _)| v.x % 5 != 0).collect();
    for (case, colors) in [all, varied, partial].iter().enumerate() {
        let mut a = OccupancyGrid::new(&tiled, dims, MemoryLimit::DEFAULT).unwrap();
        let mut b = OccupancyGrid::new(&masks, dims, MemoryLimit::DEFAULT).unwrap();
        let full = a.full_bricks();
        a.set_colors(colors, palette);
        b.set_colors(colors, palette);
        for v in tiled.iter() {
            assert_eq!(a.color(v), b.color(v), "case {case} voxel {v}");
        }
        let want = colors
            .iter()
            .find(|(v, _)| *v == IVec3::new(20, 18, 22))
            .map_or(0, |e| e.1);
        assert_eq!(
            a.color(IVec3::new(20, 18, 22)),
            Some(palette[want as usize])
        );
        match case {
            0 => assert_eq!(
                a.full_bricks(),
                full,
                "uniform colours keep the shared slot"
            ),
            _ => assert!(a.full_bricks() < full),
        }
    }
}
