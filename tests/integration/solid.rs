//! Solid references: exact axis parity against the generalized winding
//! number on generated closed meshes, and 3-axis voting on meshes with a hole.
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
use voxkit::grid::{BitGrid, MemoryLimit};
use voxkit::voxelize::conservative::FixedTriangle;
use voxkit::voxelize::shapes::{IndexedMesh, random_rotation};
use voxkit::voxelize::solid::{
    Axis, WINDING_THRESHOLD, solid_voxels_parity, solid_voxels_parity_axis, solid_voxels_voting,
    solid_voxels_winding, winding_number,
};

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

/// Voting on a watertight mesh equals parity except at on-surface centres.
#[test]
fn voting_equals_parity_on_watertight_meshes() {
    for (name, mesh) in closed_meshes() {
        let vote = solid_voxels_voting(&mesh, DIMS, MemoryLimit::DEFAULT).unwrap();
        let par = solid_voxels_parity(&mesh, DIMS, MemoryLimit::DEFAULT).unwrap();
        for v in differing(&vote, &par) {
            assert!(distance_to_mesh(v.as_dvec3(), &mesh) < NEAR, "{name}: {v}");
        }
    }
}

/// Removing one triangle: parity along x goes wrong along whole lines, but
/// voting only errs where two of a voxel's three axis lines pass through the
/// hole — inside the removed triangle's bounding box — or at on-surface centres.
#[test]
fn voting_is_robust_to_one_missing_triangle() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut parity_damage = 0;
    for (name, mesh) in closed_meshes() {
        let full = solid_voxels_parity(&mesh, DIMS, MemoryLimit::DEFAULT).unwrap();
        for _ in 0..4 {
            let gone = rng.random_range(0..mesh.len());
            let mut holed = mesh.clone();
            let t = holed.remove(gone);
            let [a, b, c] = f64_tri(&t);
            let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
            let vote = solid_voxels_voting(&holed, DIMS, MemoryLimit::DEFAULT).unwrap();
            for v in differing(&vote, &full) {
                let p = v.as_dvec3();
                let in_box = p.cmpge(lo).all() && p.cmple(hi).all();
                assert!(
                    in_box || distance_to_mesh(p, &mesh) < NEAR,
                    "{name}: removing triangle {gone} changed {v}, outside its box {lo}..{hi}"
                );
            }
            let px = solid_voxels_parity(&holed, DIMS, MemoryLimit::DEFAULT).unwrap();
            parity_damage += differing(&px, &full).len();
        }
    }
    // Plain parity does suffer from the holes: voting is what saves it.
    assert!(parity_damage > 100, "{parity_damage}");
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
        .install(|| solid_voxels_voting(mesh, DIMS, MemoryLimit::DEFAULT).unwrap());
    assert_eq!(
        single,
        solid_voxels_voting(mesh, DIMS, MemoryLimit::DEFAULT).unwrap()
    );
    // A grid over the limit is refused before allocating.
    assert!(solid_voxels_parity(mesh, [1 << 12; 3], MemoryLimit::new(1 << 20)).is_err());
    // A triangle spanning 2^20 voxels is unsupported, not wrong.
    let huge = [[0, 0, 0], [1i64 << 41, 0, 0], [0, 1 << 20, 0]];
    assert!(solid_voxels_parity(&[huge], [4, 4, 4], MemoryLimit::DEFAULT).is_err());
}
