//! Solid mode's interior against independent references: the dense parity
//! fill and the brute-force generalized winding number, on closed meshes and
//! on damaged ones (holes, flipped faces, duplicated sheets, overlapping
//! copies, open sheets).
//!
//! Exclusion criterion (the only place parity and winding number may
//! disagree): voxel centres whose Euclidean distance to the closest triangle is
//! below `NEAR = 1e-6` voxel. Exactly on the surface the two rules legitimately
//! differ (parity uses a half-open tie rule, the winding number gives 1/2 on a
//! face); off it, a closed mesh has winding number 0 or 1 and the f64 sum is
//! accurate to ~1e-12, so any other disagreement is a bug.

use glam::{DVec3, IVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::fixed::to_f64;
use voxkit::grid::BrickGrid;
use voxkit::grid::{BitGrid, MemoryLimit};
use voxkit::mesh::Mesh;
use voxkit::voxelize::conservative::FixedTriangle;
use voxkit::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, to_reference, voxelize_mesh};
use voxkit::voxelize::shapes::{IndexedMesh, random_rotation};
use voxkit::voxelize::solid::{
    AMBIGUITY_BAND, Axis, InsideTest, SolidStats, WINDING_THRESHOLD, solid_interior,
    solid_voxels_parity, solid_voxels_parity_axis, solid_voxels_winding, winding_number,
};
use voxkit::voxelize::surface::SurfaceTriangle;

const NEAR: f64 = 1e-6;

fn f64_tri(t: &FixedTriangle) -> [DVec3; 3] {
    t.map(|p| DVec3::new(to_f64(p[0]), to_f64(p[1]), to_f64(p[2])))
}

/// Closest point on a triangle (Ericson, *Real-Time Collision Detection* 5.1.5).
fn closest_point(p: DVec3, [a, b, c]: [DVec3; 3]) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let den = va + vb + vc;
    if den == 0.0 {
        return a; // degenerate triangle (none in the generated closed meshes)
    }
    a + ab * (vb / den) + ac * (vc / den)
}

fn distance_to_mesh(p: DVec3, mesh: &[FixedTriangle]) -> f64 {
    mesh.iter()
        .map(|t| (closest_point(p, f64_tri(t)) - p).length())
        .fold(f64::INFINITY, f64::min)
}

fn centre(i: usize, dims: [usize; 3]) -> IVec3 {
    IVec3::new(
        (i % dims[0]) as i32,
        ((i / dims[0]) % dims[1]) as i32,
        (i / (dims[0] * dims[1])) as i32,
    )
}

fn differing(a: &BitGrid, b: &BitGrid) -> Vec<IVec3> {
    (0..a.len())
        .filter(|&i| a.get_index(i) != b.get_index(i))
        .map(|i| centre(i, a.dims()))
        .collect()
}

/// Closed test meshes: rotated/offset spheres and tori, a rotated box, and an
/// axis-aligned box whose faces pass exactly through voxel centres.
fn closed_meshes() -> Vec<(String, Vec<FixedTriangle>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let mut out = Vec::new();
    for k in 0..5 {
        let rot = random_rotation([rng.random(), rng.random(), rng.random()]);
        let off = DVec3::splat(11.0) + DVec3::new(rng.random(), rng.random(), rng.random());
        let (name, m) = match k {
            0 | 3 => ("sphere", IndexedMesh::uv_sphere(DVec3::ZERO, 8.7, 10, 16)),
            1 | 4 => ("torus", IndexedMesh::torus(DVec3::ZERO, 7.5, 2.9, 22, 10)),
            _ => (
                "box",
                IndexedMesh::cuboid(DVec3::splat(-6.2), DVec3::new(5.1, 4.4, 6.9)),
            ),
        };
        out.push((
            format!("{name}{k}"),
            m.transformed(rot, off).to_fixed_triangles().unwrap(),
        ));
    }
    // Faces through centres, edges and corners on centres.
    let aligned = IndexedMesh::cuboid(DVec3::splat(4.0), DVec3::new(15.0, 12.0, 18.0));
    out.push(("aligned box".into(), aligned.to_fixed_triangles().unwrap()));
    out
}

const DIMS: [usize; 3] = [23, 23, 23];

#[test]
fn parity_equals_winding_number_off_the_surface() {
    for (name, mesh) in closed_meshes() {
        let wind = solid_voxels_winding(&mesh, DIMS, MemoryLimit::DEFAULT).unwrap();
        assert!(wind.count_ones() > 300, "{name}: {}", wind.count_ones());
        let mut near_total = 0;
        for axis in [Axis::X, Axis::Y, Axis::Z] {
            let par = solid_voxels_parity_axis(&mesh, DIMS, axis, MemoryLimit::DEFAULT).unwrap();
            for v in differing(&par, &wind) {
                let d = distance_to_mesh(v.as_dvec3(), &mesh);
                assert!(
                    d < NEAR,
                    "{name} {axis:?}: centre {v} at distance {d} disagrees"
                );
                near_total += 1;
            }
        }
        // The aligned box has centres on its faces; parity's half-open rule
        // keeps the min faces and drops the max faces on every axis.
        if name == "aligned box" {
            assert!(near_total > 0);
            let par = solid_voxels_parity(&mesh, DIMS, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(par.count_ones(), 11 * 8 * 14);
            assert!(par.get(IVec3::new(4, 4, 4)) && !par.get(IVec3::new(15, 5, 5)));
        }
    }
}

#[test]
fn winding_numbers_are_integers_off_the_surface() {
    let (_, mesh) = &closed_meshes()[1];
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..300 {
        let p = DVec3::new(rng.random(), rng.random(), rng.random()) * 23.0 - DVec3::ONE;
        if distance_to_mesh(p, mesh) < 1e-3 {
            continue;
        }
        let w = winding_number(p, mesh);
        assert!(
            (w - w.round()).abs() < 1e-9 && (w.round() == 0.0 || w.round() == 1.0),
            "{w}"
        );
    }
    assert_eq!(WINDING_THRESHOLD, 0.5);
}

/// Triangles beyond the grid, grids smaller than the mesh, and parallel vs
/// single-threaded runs.
#[test]
fn clipping_and_determinism() {
    let (_, mesh) = &closed_meshes()[0];
    let big = solid_voxels_parity(mesh, DIMS, MemoryLimit::DEFAULT).unwrap();
    let small_dims = [15, 9, 23];
    let small = solid_voxels_parity(mesh, small_dims, MemoryLimit::DEFAULT).unwrap();
    for i in 0..small.len() {
        let v = centre(i, small_dims);
        assert_eq!(small.get(v), big.get(v), "{v}");
    }
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| solid_voxels_parity(mesh, DIMS, MemoryLimit::DEFAULT).unwrap());
    assert_eq!(
        single,
        solid_voxels_parity(mesh, DIMS, MemoryLimit::DEFAULT).unwrap()
    );
    // A grid over the limit is refused before allocating.
    assert!(solid_voxels_parity(mesh, [1 << 12; 3], MemoryLimit::new(1 << 20)).is_err());
    // A triangle spanning 2^20 voxels is unsupported, not wrong.
    let huge = [[0, 0, 0], [1i64 << 41, 0, 0], [0, 1 << 20, 0]];
    assert!(solid_voxels_parity(&[huge], [4, 4, 4], MemoryLimit::DEFAULT).is_err());
}

/// A mesh at 1/256 voxel (what the voxelizer feeds [`solid_interior`]) and
/// the same points at 2^-20 (what the references take).
fn quantized(m: &IndexedMesh) -> (Vec<SurfaceTriangle>, Vec<FixedTriangle>) {
    let q: Vec<[i64; 3]> = m
        .vertices
        .iter()
        .map(|v| v.to_array().map(|c| (c * 256.0).round() as i64))
        .collect();
    let tris: Vec<SurfaceTriangle> = m
        .faces
        .iter()
        .map(|f| f.map(|i| q[i as usize]))
        .filter(|t| {
            let e1 = [0, 1, 2].map(|a| t[1][a] - t[0][a]);
            let e2 = [0, 1, 2].map(|a| t[2][a] - t[0][a]);
            e1[1] * e2[2] != e1[2] * e2[1]
                || e1[2] * e2[0] != e1[0] * e2[2]
                || e1[0] * e2[1] != e1[1] * e2[0]
        })
        .collect();
    let fixed = tris.iter().map(to_reference).collect();
    (tris, fixed)
}

fn closed_indexed() -> Vec<(String, IndexedMesh)> {
    let mut rng = ChaCha8Rng::seed_from_u64(29);
    let mut out = Vec::new();
    for k in 0..4 {
        let rot = random_rotation([rng.random(), rng.random(), rng.random()]);
        let off = DVec3::splat(11.0) + DVec3::new(rng.random(), rng.random(), rng.random());
        let m = match k {
            0 => IndexedMesh::uv_sphere(DVec3::ZERO, 8.7, 10, 16),
            1 => IndexedMesh::torus(DVec3::ZERO, 7.5, 2.9, 22, 10),
            2 => IndexedMesh::cuboid(DVec3::splat(-6.2), DVec3::new(5.1, 4.4, 6.9)),
            _ => IndexedMesh::uv_sphere(DVec3::ZERO, 6.3, 7, 9),
        };
        out.push((format!("shape{k}"), m.transformed(rot, off)));
    }
    out.push((
        "aligned box".into(),
        IndexedMesh::cuboid(DVec3::splat(4.0), DVec3::new(15.0, 12.0, 18.0)),
    ));
    out
}

/// On closed meshes the interior (both tests) is exactly the dense parity
/// reference, tie rule included; reversing every face makes the winding
/// number −1 inside, so nothing is inside by `w ≥ ½` while parity does not
/// care.
#[test]
fn interior_equals_parity_reference_on_closed_meshes() {
    for (name, m) in closed_indexed() {
        let (tris, fixed) = quantized(&m);
        let want = solid_voxels_parity(&fixed, DIMS, MemoryLimit::DEFAULT).unwrap();
        for test in [InsideTest::Winding, InsideTest::Parity] {
            let (g, stats) = solid_interior(&tris, &[], DIMS, test, &BrickGrid::new()).unwrap();
            let got = g.to_bit_grid(DIMS, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(
                differing(&got, &want),
                Vec::<IVec3>::new(),
                "{name} {test:?}"
            );
            assert_eq!(stats.caps, 0, "{name}");
        }
        let flipped: Vec<SurfaceTriangle> = tris.iter().map(|t| [t[0], t[2], t[1]]).collect();
        let (g, _) =
            solid_interior(&flipped, &[], DIMS, InsideTest::Winding, &BrickGrid::new()).unwrap();
        assert_eq!(g.count(), 0, "{name} flipped");
        let (g, _) =
            solid_interior(&flipped, &[], DIMS, InsideTest::Parity, &BrickGrid::new()).unwrap();
        assert_eq!(g.count(), want.count_ones(), "{name} flipped parity");
    }
}

/// Damaged copies of a closed mesh: faces removed, flipped or duplicated,
/// two overlapping copies, an open sheet.
fn damaged(m: &IndexedMesh, rng: &mut ChaCha8Rng) -> Vec<(String, IndexedMesh)> {
    let mut out = Vec::new();
    for pct in [1, 5, 20, 40] {
        let mut d = m.clone();
        d.faces.retain(|_| rng.random_range(0..100) >= pct);
        out.push((format!("{pct}% removed"), d));
    }
    let mut d = m.clone();
    for f in &mut d.faces {
        if rng.random_range(0..10) == 0 {
            *f = [f[0], f[2], f[1]];
        }
    }
    out.push(("10% flipped".into(), d));
    let mut d = m.clone();
    let extra: Vec<[u32; 3]> = d
        .faces
        .iter()
        .filter(|_| rng.random_range(0..10) == 0)
        .copied()
        .collect();
    d.faces.extend(extra);
    out.push(("10% duplicated".into(), d));
    let mut d = m.clone();
    let n = d.vertices.len() as u32;
    d.vertices
        .extend(m.vertices.iter().map(|v| *v + DVec3::new(2.3, 1.1, 0.7)));
    d.faces.extend(m.faces.iter().map(|f| f.map(|i| i + n)));
    out.push(("overlapping copy".into(), d));
    let mut d = m.clone();
    d.faces.truncate(d.faces.len() / 3);
    out.push(("open sheet".into(), d));
    out
}

/// Compares an interior with `w ≥ ½` (brute force) at every centre: a
/// disagreement is allowed only within `NEAR` of the mesh (on the surface)
/// or where `|w − ½| < 1e-9` (f64 sums of the same solid angles in another
/// order). Returns the number of centres with `|w − ½| <` [`AMBIGUITY_BAND`].
fn assert_matches_winding(
    name: &str,
    g: &BrickGrid,
    fixed: &[FixedTriangle],
    dims: [usize; 3],
) -> u64 {
    let mut ambiguous = 0;
    for i in 0..dims.iter().product::<usize>() {
        let v = centre(i, dims);
        let p = v.as_dvec3();
        let w = winding_number(p, fixed);
        let on_surface = distance_to_mesh(p, fixed) < NEAR;
        if !on_surface && (w - 0.5).abs() < AMBIGUITY_BAND {
            ambiguous += 1;
        }
        if g.contains(v) != (w >= 0.5) && !on_surface {
            assert!(
                (w - 0.5).abs() < 1e-9,
                "{name}: {v} w = {w}, solid says {}",
                g.contains(v)
            );
        }
    }
    ambiguous
}

/// Solid mode's interior of `d` in `dims` against brute force
/// ([`assert_matches_winding`]), with its ambiguity count within a fifth
/// (plus ten) of the brute-force count: the count comes from bounded
/// estimates, so it may miss or add voxels whose `w` is within the
/// estimate's error of the band. Returns the fill's counts and the
/// brute-force ambiguity count.
fn solid_against_brute_force(name: &str, d: &IndexedMesh, dims: [usize; 3]) -> (SolidStats, u64) {
    let (tris, fixed) = quantized(d);
    let (g, stats) =
        solid_interior(&tris, &[], dims, InsideTest::Winding, &BrickGrid::new()).unwrap();
    let ambiguous = assert_matches_winding(name, &g, &fixed, dims);
    let slack = ambiguous / 5 + 10;
    assert!(
        stats.ambiguous.abs_diff(ambiguous) <= slack,
        "{name}: ambiguous {} vs brute force {ambiguous}",
        stats.ambiguous
    );
    (stats, ambiguous)
}

/// The generalized winding number decides, whatever the damage: the interior
/// agrees with `w ≥ ½` at every centre off the surface.
#[test]
fn winding_interior_matches_brute_force_on_damaged_meshes() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for (base, m) in closed_indexed() {
        for (damage, d) in damaged(&m, &mut rng) {
            solid_against_brute_force(&format!("{base}, {damage}"), &d, DIMS);
        }
    }
}

/// Holes wider than a brick (a scan's, an open rim): refined bricks decide
/// most of their centres from one value per 2³ cube and the rim's gradient
/// bound. Those verdicts, and the ambiguity count, against brute force.
#[test]
fn centres_decided_by_the_gradient_match_brute_force() {
    let dims = [48, 48, 48];
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    for (name, cut) in [("polar cap cut", 0.55), ("hemisphere cut", 0.0)] {
        // Twelve segments: a few large caps close each hole.
        let m = IndexedMesh::uv_sphere(DVec3::splat(24.0), 21.3, 10, 12);
        let mut d = m.clone();
        d.faces.retain(|f| {
            let c = f.iter().map(|&i| m.vertices[i as usize]).sum::<DVec3>() / 3.0;
            (c.z - 24.0) / 21.3 < cut
        });
        // And a few scattered single holes.
        d.faces.retain(|_| rng.random_range(0..40) != 0);
        let (stats, _) = solid_against_brute_force(name, &d, dims);
        // Not vacuous: the gradient decided centres.
        assert!(stats.gradient_centres > 1000, "{name}: {stats:?}");
    }
}

/// A hole many bricks wide: refined bricks far from its rim decide most of
/// their centres from a second-order Taylor expansion per 4³ box (the
/// mesh's winding number is smooth across the caps), including the centres
/// within the ambiguity band that the gradient path leaves to the near
/// field. Those verdicts, and the ambiguity count, against brute force.
#[test]
fn centres_decided_by_taylor_expansions_match_brute_force() {
    let dims = [64, 64, 64];
    for (name, cut) in [("wide polar hole", 0.3), ("open bowl", -0.2)] {
        let m = IndexedMesh::uv_sphere(DVec3::splat(32.0), 29.3, 10, 12);
        let mut d = m.clone();
        d.faces.retain(|f| {
            let c = f.iter().map(|&i| m.vertices[i as usize]).sum::<DVec3>() / 3.0;
            (c.z - 32.0) / 29.3 < cut
        });
        let (stats, ambiguous) = solid_against_brute_force(name, &d, dims);
        // Not vacuous: the expansions decided centres, ambiguous ones too.
        assert!(stats.taylor_centres > 5000, "{name}: {stats:?}");
        assert!(ambiguous > 1000, "{name}: {ambiguous}");
    }
}

/// A real mesh through the whole pipeline: Spot with a fifth of its faces
/// removed, solid at `-r 24`, against the brute-force winding number of the
/// voxelized (1/256-voxel) mesh off the thin surface.
#[test]
fn pipeline_solid_on_spot_with_holes_matches_brute_force() {
    let spot = Mesh::load(std::path::Path::new("data/meshes/obj/spot.obj")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(20);
    let mut holed = spot.clone();
    holed.triangles.retain(|_| rng.random_range(0..5) != 0);
    let v = voxelize_mesh(&holed, &VoxelizeOptions::new(24, VoxelizeMode::Solid)).unwrap();
    let fixed: Vec<FixedTriangle> = v.mesh.triangles.iter().map(to_reference).collect();
    let dims = v.frame.dims;
    let thin = voxelize_mesh(&holed, &VoxelizeOptions::new(24, VoxelizeMode::Thin)).unwrap();
    for i in 0..dims.iter().product::<usize>() {
        let c = centre(i, dims);
        if thin.grid.contains(c) {
            assert!(v.grid.contains(c), "surface voxel {c} missing");
            continue;
        }
        let w = winding_number(c.as_dvec3(), &fixed);
        if v.grid.contains(c) != (w >= 0.5) {
            assert!((w - 0.5).abs() < 1e-9, "{c}: w = {w}");
        }
    }
    // Not vacuous: there are caps, and centres whose brick bound straddled
    // ½ were decided by their 2³ cube's finer far field (checked above).
    let solid = v.stats.solid.unwrap();
    assert!(solid.caps > 0);
    assert!(solid.straddling > 0, "{solid:?}");
}

/// Same interior on one thread and on many, and interior bricks are tiles.
#[test]
fn interior_is_deterministic_and_tiled() {
    let m = IndexedMesh::uv_sphere(DVec3::splat(40.0), 37.0, 24, 40);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut d = m.clone();
    d.faces.retain(|_| rng.random_range(0..10) != 0);
    let (tris, _) = quantized(&d);
    let dims = [81, 81, 81];
    let run = || solid_interior(&tris, &[], dims, InsideTest::Winding, &BrickGrid::new()).unwrap();
    let (many, stats) = run();
    let (one, _) = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(run);
    assert_eq!(one, many);
    assert!(stats.refined_bricks > 0 && stats.caps > 0);
    assert!(many.tile_count() > 100, "{} tiles", many.tile_count());
    // A ball of radius 37: about 4/3 π 37³ centres.
    let ball = 4.0 / 3.0 * std::f64::consts::PI * 37f64.powi(3);
    assert!(
        (many.count() as f64 - ball).abs() < 0.02 * ball,
        "{}",
        many.count()
    );
}
