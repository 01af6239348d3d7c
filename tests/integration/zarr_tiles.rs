//! Tiles: the union of a mesh's tiles is its whole-grid run, voxel for
//! voxel, in every mode, on meshes crossing tile faces and lying exactly on
//! them; the plan lists every tile that holds a voxel.

use std::collections::HashSet;

use crate::scratch::temp_dir;
use glam::{DQuat, DVec3, IVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::grid::BrickGrid;
use voxkit::mesh::Mesh;
use voxkit::voxelize::pipeline::{
    Lattice, VoxelizeMode, VoxelizeOptions, quantize_mesh, voxelize_mesh,
};
use voxkit::voxelize::shapes::{IndexedMesh, random_rotation};
use voxkit::voxelize::solid::InsideTest;
use voxkit::voxelize::tile::{plan_tiles, tile_box, voxelize_tile};

fn mesh_of(name: &str, m: &IndexedMesh) -> Mesh {
    Mesh::from_parts(name, m.vertices.clone(), m.faces.clone(), vec![]).unwrap()
}

const MODES: [VoxelizeMode; 4] = [
    VoxelizeMode::Thin,
    VoxelizeMode::Thick,
    VoxelizeMode::Conservative,
    VoxelizeMode::Solid,
];

/// Checks merged tiles against the whole run for every mode.
fn check(
    name: &str,
    mesh: &Mesh,
    voxel_size: f64,
    origin: DVec3,
    tile_size: u32,
    inside: InsideTest,
) {
    for mode in MODES {
        let mut opts = VoxelizeOptions::on_lattice(
            Lattice::VoxelSize {
                voxel_size,
                origin: Some(origin),
            },
            mode,
        );
        opts.inside = inside;
        let whole = voxelize_mesh(mesh, &opts).unwrap();
        let frame = whole.frame;
        let q = quantize_mesh(mesh, &frame, false);
        let plan = plan_tiles(&q, frame.dims, tile_size, mode);
        let planned: HashSet<[u32; 3]> = plan.iter().copied().collect();
        let mut merged = BrickGrid::new();
        for &t in &plan {
            let (g, _) = voxelize_tile(&q, &frame, &opts, t, tile_size).unwrap();
            let (lo, hi) = tile_box(t, tile_size, frame.dims);
            assert!(
                g.iter().all(|v| v.cmpge(lo).all() && v.cmplt(hi).all()),
                "{} {mode:?}: tile {t:?} wrote outside its box",
                name
            );
            merged.union_with(&g);
        }
        for v in whole.grid.iter() {
            let t = (v / tile_size as i32).to_array().map(|c| c as u32);
            assert!(
                planned.contains(&t),
                "{} {mode:?}: {v} in unplanned tile {t:?}",
                name
            );
        }
        if merged != whole.grid {
            let a: HashSet<IVec3> = merged.iter().collect();
            let b: HashSet<IVec3> = whole.grid.iter().collect();
            let extra: Vec<_> = a.difference(&b).take(5).collect();
            let missing: Vec<_> = b.difference(&a).take(5).collect();
            panic!(
                "{} {mode:?} tiles of {tile_size} in {:?}: {} vs {} voxels, extra {extra:?}, missing {missing:?}",
                name,
                frame.dims,
                merged.count(),
                whole.grid.count()
            );
        }
        assert!(whole.grid.count() > 0);
    }
}

#[test]
fn merged_tiles_equal_the_whole_run_for_random_closed_shapes() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x711E);
    for case in 0..4 {
        let rot = random_rotation([rng.random(), rng.random(), rng.random()]);
        let c = DVec3::new(
            rng.random_range(20.0..40.0),
            rng.random_range(20.0..40.0),
            rng.random_range(20.0..40.0),
        );
        let shape = match case % 2 {
            0 => IndexedMesh::uv_sphere(DVec3::ZERO, rng.random_range(12.0..22.0), 12, 20),
            _ => IndexedMesh::torus(DVec3::ZERO, 16.0, 5.5, 24, 12),
        };
        let m = mesh_of("shape", &shape.transformed(rot, c));
        let origin = DVec3::new(
            rng.random_range(-3.0..0.0),
            rng.random_range(-3.0..0.0),
            rng.random_range(-3.0..0.0),
        );
        let tile = [8, 16, 24][case % 3];
        check("shape", &m, 1.0, origin, tile, InsideTest::Winding);
    }
}

/// Faces exactly on tile faces (grid x = 15.5 is the face between tiles 0
/// and 1 of 16) and on the centres of a tile's first voxels.
#[test]
fn merged_tiles_equal_the_whole_run_on_faces_lying_on_tile_faces() {
    for (lo, hi) in [
        (DVec3::splat(16.0), DVec3::new(48.0, 32.0, 40.0)),
        (DVec3::splat(16.5), DVec3::new(32.5, 48.5, 33.0)),
        (DVec3::new(0.0, 8.0, 16.0), DVec3::new(32.0, 40.0, 48.0)),
    ] {
        let m = mesh_of("cuboid", &IndexedMesh::cuboid(lo, hi));
        for inside in [InsideTest::Winding, InsideTest::Parity] {
            check("cuboid", &m, 1.0, DVec3::ZERO, 16, inside);
        }
        // Rotated by 90° about z: still axis-aligned, other orientation.
        let r = IndexedMesh::cuboid(lo, hi).transformed(
            DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2),
            DVec3::new(64.0, 0.0, 0.0),
        );
        check(
            "cuboid-z90",
            &mesh_of("cuboid-z90", &r),
            1.0,
            DVec3::ZERO,
            16,
            InsideTest::Winding,
        );
    }
}

/// A mesh with holes: the winding number's caps and trees come from the
/// whole mesh, so the tiles agree there too.
#[test]
fn merged_tiles_equal_the_whole_run_on_meshes_with_holes() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x401E);
    let sphere = IndexedMesh::uv_sphere(DVec3::splat(30.0), 19.0, 12, 18);
    let mut holed = sphere.clone();
    // Drop a few faces: open the mesh.
    for _ in 0..6 {
        let i = rng.random_range(0..holed.faces.len());
        holed = holed.without_face(i);
    }
    check(
        "holed-sphere",
        &mesh_of("holed-sphere", &holed),
        1.0,
        DVec3::splat(-0.25),
        16,
        InsideTest::Winding,
    );
    let bunny = voxkit::mesh::bundled::bunny().unwrap();
    let (lo, hi) = bunny.bounds();
    let h = (hi - lo).max_element() / 70.0;
    check(
        "bunny",
        &bunny,
        h,
        lo - DVec3::splat(0.3 * h),
        24,
        InsideTest::Winding,
    );
}

/// A tiled store with a pyramid: tiles of 1024 write levels 0 and 1
/// themselves, `finish` pools the rest; every level equals the whole run's
/// store, and finishing again changes nothing.
#[test]
fn tiled_pyramid_levels_equal_the_whole_runs() {
    use voxkit::grid::MemoryLimit;
    use voxkit::io::zarr;
    let dir = temp_dir("tiled-pyramid");
    // Spheres on either side of the tile face x = 1024 and one across it.
    let mut obj = String::new();
    let mut base = 0;
    for (c, r) in [(300.0, 250.0), (1024.0, 120.0), (1800.0, 200.0)] {
        let s = IndexedMesh::uv_sphere(DVec3::new(c, 260.0, 270.0), r, 24, 40);
        for v in &s.vertices {
            obj += &format!("v {} {} {}\n", v.x, v.y, v.z);
        }
        for f in &s.faces {
            obj += &format!(
                "f {} {} {}\n",
                f[0] + 1 + base,
                f[1] + 1 + base,
                f[2] + 1 + base
            );
        }
        base += s.vertices.len() as u32;
    }
    let mesh_path = dir.join("spheres.obj");
    std::fs::write(&mesh_path, obj).unwrap();
    let opts = VoxelizeOptions::on_lattice(
        Lattice::VoxelSize {
            voxel_size: 1.0,
            origin: Some(DVec3::ZERO),
        },
        VoxelizeMode::Thin,
    );
    let store = dir.join("t.zarr");
    let plan = voxkit::tiled::plan(&mesh_path, &store, &opts, 1024, false, true).unwrap();
    assert_eq!(plan["tile_levels"], 2);
    let levels = plan["levels"].as_u64().unwrap() as u32;
    assert!(levels >= 4, "{plan}");
    for t in plan["tiles"].as_array().unwrap() {
        let t: Vec<u32> = t
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_u64().unwrap() as u32)
            .collect();
        voxkit::tiled::run_tile(&mesh_path, &store, &opts, 1024, [t[0], t[1], t[2]]).unwrap();
    }
    let fin = voxkit::tiled::finish(&store, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(fin["from_level"], 1);
    let mesh = Mesh::load(&mesh_path).unwrap();
    let whole = voxelize_mesh(&mesh, &opts).unwrap();
    let whole_store = dir.join("w.zarr");
    zarr::write(&whole_store, &whole.grid, &whole.frame, false, levels).unwrap();
    let read_all = |p: &std::path::Path| -> Vec<BrickGrid> {
        (0..levels)
            .map(|l| zarr::read_level(p, l, MemoryLimit::DEFAULT).unwrap().0)
            .collect()
    };
    let want = read_all(&whole_store);
    assert!(want[0].count() > 100_000);
    assert_eq!(read_all(&store), want);
    voxkit::tiled::finish(&store, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(read_all(&store), want);
    // A store not planned for tiles has nothing to finish: an error says so.
    assert!(voxkit::tiled::finish(&whole_store, MemoryLimit::DEFAULT).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A process keeps the mesh it loaded for the next tile; a mesh file
/// rewritten between tiles is read again, never served stale.
#[test]
fn a_rewritten_mesh_is_reloaded_between_tiles() {
    let dir = temp_dir("tile-reload");
    let mesh_path = dir.join("m.obj");
    let write_obj = |s: &IndexedMesh, extra: &str| {
        let mut obj = String::new();
        for v in &s.vertices {
            obj += &format!("v {} {} {}\n", v.x, v.y, v.z);
        }
        for f in &s.faces {
            obj += &format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
        }
        std::fs::write(&mesh_path, obj + extra).unwrap();
    };
    let opts = VoxelizeOptions::on_lattice(
        Lattice::VoxelSize {
            voxel_size: 1.0,
            origin: Some(DVec3::ZERO),
        },
        VoxelizeMode::Thin,
    );
    let store = dir.join("t.zarr");
    let big = IndexedMesh::uv_sphere(DVec3::splat(200.0), 150.0, 16, 24);
    write_obj(&big, "");
    voxkit::tiled::plan(&mesh_path, &store, &opts, 512, false, false).unwrap();
    let first = voxkit::tiled::run_tile(&mesh_path, &store, &opts, 512, [0, 0, 0]).unwrap();
    let again = voxkit::tiled::run_tile(&mesh_path, &store, &opts, 512, [0, 0, 0]).unwrap();
    assert_eq!(again["mesh_cached"], true);
    assert_eq!(again["voxels"], first["voxels"]);
    // Same bounds (the store's frame still fits), one more triangle inside.
    write_obj(
        &big,
        "v 150 150 150\nv 250 150 150\nv 150 250 160\nf -3 -2 -1\n",
    );
    let third = voxkit::tiled::run_tile(&mesh_path, &store, &opts, 512, [0, 0, 0]).unwrap();
    assert_eq!(third["mesh_cached"], false);
    let want = voxelize_mesh(&Mesh::load(&mesh_path).unwrap(), &opts).unwrap();
    assert_eq!(third["voxels"].as_u64().unwrap(), want.grid.count());
    assert!(third["voxels"].as_u64() > first["voxels"].as_u64());
    let _ = std::fs::remove_dir_all(&dir);
}
