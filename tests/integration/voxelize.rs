//! Mesh voxelization pipeline (`voxelize::pipeline`, `voxelize::measure`) and
//! the `voxelize` / `check` commands.
//!
//! Oracles: the tunnel search of `topology::tunnels` with inside seeds from
//! the exact parity interior (via `measure_voxelization`), a brute-force scan of every
//! grid voxel with the exact `triangle_meets_voxel`, the winding-number
//! solid, a single-threaded rayon pool, and file round trips.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::scratch::temp_dir;
use glam::{DQuat, DVec3, IVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::VoxkitError;
use voxkit::grid::{BrickGrid, MemoryLimit};
use voxkit::io::{read_voxels, write_voxels};
use voxkit::line::{Line26, Segment, Tripod6};
use voxkit::mesh::Mesh;
use voxkit::voxelize::conservative::triangle_meets_voxel;
use voxkit::voxelize::measure::{is_closed, measure_external, measure_voxelization};
use voxkit::voxelize::pipeline::{
    Lattice, Voxelization, VoxelizeMode, VoxelizeOptions, segment_to_reference, to_reference,
    voxelize_mesh,
};
use voxkit::voxelize::shapes::{IndexedMesh, random_rotation};
use voxkit::voxelize::solid::winding_number;

const MODES: [VoxelizeMode; 4] = [
    VoxelizeMode::Thin,
    VoxelizeMode::Thick,
    VoxelizeMode::Conservative,
    VoxelizeMode::Solid,
];

fn mesh_of(m: &IndexedMesh, name: &str) -> Mesh {
    Mesh::from_parts(name, m.vertices.clone(), m.faces.clone(), vec![]).unwrap()
}

fn run(mesh: &Mesh, r: u32, mode: VoxelizeMode, snap: bool) -> Voxelization {
    let mut o = VoxelizeOptions::new(r, mode);
    o.snap = snap;
    voxelize_mesh(mesh, &o).unwrap()
}

fn subset(a: &BrickGrid, b: &BrickGrid) -> bool {
    a.bricks().all(|(k, m)| {
        let o = b.brick(k).copied().unwrap_or([0; 8]);
        (0..8).all(|w| m[w] & !o[w] == 0)
    })
}

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

/// Generated closed meshes: spheres, tori, boxes with seeded random
/// rotations and offsets.
fn generated(rng: &mut ChaCha8Rng) -> Vec<(String, Mesh)> {
    let mut out = Vec::new();
    for k in 0..9 {
        let rot = random_rotation([rng.random(), rng.random(), rng.random()]);
        let off = DVec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
        let m = match k % 3 {
            0 => IndexedMesh::uv_sphere(DVec3::ZERO, 5.0 + rng.random::<f64>(), 12 + k, 20 + 2 * k),
            1 => IndexedMesh::torus(
                DVec3::ZERO,
                6.0,
                1.5 + rng.random::<f64>(),
                24 + 2 * k,
                10 + k,
            ),
            _ => IndexedMesh::cuboid(DVec3::ZERO, DVec3::new(3.0, 5.0, 4.0 + rng.random::<f64>())),
        };
        let m = m.transformed(if k == 2 { DQuat::IDENTITY } else { rot }, off);
        out.push((format!("shape{k}"), mesh_of(&m, "generated")));
    }
    out
}

#[test]
fn thin_and_thick_are_tunnel_free_and_inside_conservative_on_generated_meshes() {
    let mut rng = ChaCha8Rng::seed_from_u64(4041);
    let shapes = generated(&mut rng);
    let mut ratios = Vec::new();
    for (i, (name, mesh)) in shapes.iter().enumerate() {
        for (ri, r) in [16u32, 28, 44, 64, 96].into_iter().enumerate() {
            // Keep the runtime modest: every shape at two resolutions.
            if (i + ri) % 3 == 2 {
                continue;
            }
            let snap = (i + ri) % 4 == 3;
            let cons = run(mesh, r, VoxelizeMode::Conservative, snap);
            assert!(
                is_closed(&cons.mesh.triangles, &cons.mesh.degenerate),
                "{name} r{r}: {} degenerate",
                cons.stats.skipped_triangles
            );
            let thin = run(mesh, r, VoxelizeMode::Thin, snap);
            let thick = run(mesh, r, VoxelizeMode::Thick, snap);
            assert!(
                subset(&thin.grid, &cons.grid),
                "{name} r{r}: thin ⊄ conservative"
            );
            assert!(
                subset(&thick.grid, &cons.grid),
                "{name} r{r}: thick ⊄ conservative"
            );
            let mt = measure_voxelization(&thin, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(
                mt.tunnel6,
                Some(false),
                "{name} r{r} snap {snap}: thin has a 6-tunnel"
            );
            // Measures are against the 1/256 mesh: exact for unsnapped runs;
            // snapping moves vertices by at most √3/2, so voxels stay within
            // √3/2 + √3/2 of the exact surface.
            assert_eq!(mt.far_voxels, 0);
            if snap {
                assert!(
                    mt.max_distance <= 3f64.sqrt() + 1e-9,
                    "{name}: {}",
                    mt.max_distance
                );
            } else {
                assert_eq!(mt.extra, 0);
                assert!(
                    mt.max_distance <= 0.75f64.sqrt() + 1e-9,
                    "{name}: {}",
                    mt.max_distance
                );
            }
            let mk = measure_voxelization(&thick, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(
                mk.tunnel26,
                Some(false),
                "{name} r{r} snap {snap}: thick has a 26-tunnel"
            );
            assert_eq!(mk.tunnel6, Some(false));
            let mc = measure_voxelization(&cons, MemoryLimit::DEFAULT).unwrap();
            if snap && i != 2 {
                // Snapping is an error the measure sees (on rotated shapes).
                assert!(mc.missing + mc.extra > 0, "{name} r{r}");
            } else if !snap {
                assert_eq!((mc.missing, mc.extra), (0, 0));
            }
            assert_eq!(mc.tunnel26, Some(false));
            // Shape 2 is an unrotated box with faces on the grid box's faces:
            // there the conservative set is one layer thick too (ratio 1).
            if i == 2 {
                continue;
            }
            ratios.push((
                thin.stats.voxels as f64 / cons.stats.voxels as f64,
                thick.stats.voxels as f64 / cons.stats.voxels as f64,
            ));
        }
    }
    let n = ratios.len() as f64;
    let thin_mean = ratios.iter().map(|r| r.0).sum::<f64>() / n;
    let thick_mean = ratios.iter().map(|r| r.1).sum::<f64>() / n;
    eprintln!(
        "generated meshes: thin/conservative mean {thin_mean:.3}, thick/conservative mean {thick_mean:.3}"
    );
    assert!(thin_mean < 0.75, "thin is not thin: {thin_mean}");
    eprintln!("ratios (thin, thick): {ratios:.3?}");
    assert!(ratios.iter().all(|r| r.0 < 0.9 && r.1 <= 1.0));
}

#[test]
fn real_meshes_are_tunnel_free() {
    for (file, r) in [
        ("data/meshes/obj/spot.obj", 72),
        ("data/meshes/obj/fandisk.obj", 56),
    ] {
        let mesh = Mesh::load(&data(file)).unwrap();
        let thin = run(&mesh, r, VoxelizeMode::Thin, false);
        let thick = run(&mesh, r, VoxelizeMode::Thick, false);
        let cons = run(&mesh, r, VoxelizeMode::Conservative, false);
        assert!(
            subset(&thin.grid, &cons.grid) && subset(&thick.grid, &cons.grid),
            "{file}"
        );
        let mt = measure_voxelization(&thin, MemoryLimit::DEFAULT).unwrap();
        let mk = measure_voxelization(&thick, MemoryLimit::DEFAULT).unwrap();
        assert!(mt.closed, "{file} is expected to be closed");
        assert_eq!(mt.tunnel6, Some(false), "{file}: thin 6-tunnel");
        assert_eq!(mk.tunnel26, Some(false), "{file}: thick 26-tunnel");
        eprintln!(
            "{file} r{r}: thin {} thick {} conservative {} (thin/cons {:.3}, thick/cons {:.3})",
            thin.stats.voxels,
            thick.stats.voxels,
            cons.stats.voxels,
            thin.stats.voxels as f64 / cons.stats.voxels as f64,
            thick.stats.voxels as f64 / cons.stats.voxels as f64
        );
    }
}

/// Random small meshes: general triangles, slivers, axis-aligned faces and
/// faces in grid planes, plus polylines.
fn random_mesh(rng: &mut ChaCha8Rng) -> Mesh {
    let mut pos = vec![DVec3::ZERO, DVec3::splat(9.0)]; // fixes the frame: r = 9 → h = 1
    let mut tris = Vec::new();
    for _ in 0..6 {
        let kind = rng.random_range(0..4);
        let p = |rng: &mut ChaCha8Rng| {
            DVec3::new(
                rng.random_range(0.0..9.0),
                rng.random_range(0.0..9.0),
                rng.random_range(0.0..9.0),
            )
        };
        let (a, mut b, mut c) = (p(rng), p(rng), p(rng));
        match kind {
            // Sliver: c close to segment ab.
            1 => c = a.lerp(b, 0.37) + DVec3::splat(1e-3),
            // Axis-aligned face.
            2 => {
                b.z = a.z;
                c.z = a.z;
            }
            // Face in a grid plane: grid coordinate x = g − 0.5 is a voxel
            // face plane for integer world g, a lattice plane for g + 0.5.
            3 => {
                let x = rng.random_range(1..8) as f64 + if rng.random() { 0.5 } else { 0.0 };
                b.x = x;
                c.x = x;
                let mut a2 = a;
                a2.x = x;
                let base = pos.len() as u32;
                pos.extend([a2, b, c]);
                tris.push([base, base + 1, base + 2]);
                continue;
            }
            _ => {}
        }
        let base = pos.len() as u32;
        pos.extend([a, b, c]);
        tris.push([base, base + 1, base + 2]);
    }
    let base = pos.len() as u32;
    pos.extend([
        DVec3::new(0.5, 0.5, 0.5),
        DVec3::new(8.5, 3.25, 6.0),
        DVec3::new(2.0, 8.0, 1.0),
    ]);
    let lines = vec![vec![base, base + 1, base + 2], vec![0, 1]];
    Mesh::from_parts("random", pos, tris, lines).unwrap()
}

#[test]
fn conservative_equals_brute_force_scan_and_contains_thin_and_thick() {
    let mut rng = ChaCha8Rng::seed_from_u64(4042);
    for case in 0..40 {
        let mesh = random_mesh(&mut rng);
        let snap = case % 5 == 4;
        let cons = run(&mesh, 9, VoxelizeMode::Conservative, snap);
        assert_eq!(cons.frame.dims, [9, 9, 9]);
        let refs: Vec<_> = cons
            .mesh
            .triangles
            .iter()
            .map(to_reference)
            .chain(cons.mesh.segments.iter().map(segment_to_reference))
            .collect();
        let mut brute = BrickGrid::new();
        for z in 0..9 {
            for y in 0..9 {
                for x in 0..9 {
                    let v = IVec3::new(x, y, z);
                    if refs.iter().any(|t| triangle_meets_voxel(t, v).unwrap()) {
                        brute.insert(v);
                    }
                }
            }
        }
        assert_eq!(cons.grid, brute, "case {case}");
        for mode in [VoxelizeMode::Thin, VoxelizeMode::Thick] {
            let s = run(&mesh, 9, mode, snap);
            assert!(subset(&s.grid, &cons.grid), "case {case} {mode:?}");
            // Polylines: thin draws the 26-connected line, thick the tripod
            // 6-line, both through the same 1/256-voxel endpoints.
            for seg in &s.mesh.segments {
                let shift = |p: [i64; 3]| p.map(|c| c << 12);
                let line = Segment::from_fixed(shift(seg[0]), shift(seg[1])).unwrap();
                let voxels: Vec<IVec3> = if mode == VoxelizeMode::Thin {
                    Line26::new(&line).collect()
                } else {
                    Tripod6::new(&line).collect()
                };
                let conn = if mode == VoxelizeMode::Thin {
                    voxkit::Connectivity::TwentySix
                } else {
                    voxkit::Connectivity::Six
                };
                assert!(
                    voxkit::topology::is_connected_path(&voxels, conn),
                    "case {case} {mode:?}"
                );
                for v in voxels {
                    let v = v.clamp(IVec3::ZERO, IVec3::splat(8));
                    assert!(
                        s.grid.contains(v),
                        "case {case} {mode:?}: line voxel {v} missing"
                    );
                }
            }
        }
    }
}

#[test]
fn solid_contains_surface_and_matches_winding_number_off_the_surface() {
    let mut rng = ChaCha8Rng::seed_from_u64(4043);
    for (k, (name, mesh)) in generated(&mut rng).into_iter().enumerate().take(6) {
        let r = [20, 26, 32][k % 3];
        let solid = run(&mesh, r, VoxelizeMode::Solid, false);
        let thin = run(&mesh, r, VoxelizeMode::Thin, false);
        let cons = run(&mesh, r, VoxelizeMode::Conservative, false);
        assert!(subset(&thin.grid, &solid.grid), "{name}");
        let fixed: Vec<_> = solid.mesh.triangles.iter().map(to_reference).collect();
        let [nx, ny, nz] = solid.frame.dims.map(|d| d as i32);
        let mut checked = 0;
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let v = IVec3::new(x, y, z);
                    if cons.grid.contains(v) {
                        continue; // on the surface: the rules may differ there
                    }
                    let inside = winding_number(v.as_dvec3(), &fixed) >= 0.5;
                    assert_eq!(solid.grid.contains(v), inside, "{name} r{r} {v}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000);
    }
}

#[test]
fn parallel_equals_single_threaded() {
    let mut rng = ChaCha8Rng::seed_from_u64(4044);
    let spot = Mesh::load(&data("data/meshes/obj/spot.obj")).unwrap();
    let mut meshes: Vec<Mesh> = generated(&mut rng)
        .into_iter()
        .take(3)
        .map(|x| x.1)
        .collect();
    meshes.push(spot);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let four = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    for mesh in &meshes {
        for mode in MODES {
            let a = one.install(|| run(mesh, 48, mode, false));
            let b = four.install(|| run(mesh, 48, mode, false));
            let c = run(mesh, 48, mode, false);
            assert_eq!(a.grid, b.grid, "{mode:?}");
            assert_eq!(a.grid, c.grid, "{mode:?}");
            assert_eq!(a.grid.count(), c.stats.voxels);
        }
    }
}

#[test]
fn max_face_voxels_are_clamped_not_dropped() {
    // A box spanning exactly 4 voxels: its faces lie on the grid box's faces
    // (grid coordinates −1/2 and 7/2). Every mode must keep all six faces:
    // the 4³ box's shell (56 voxels); solid fills it (64).
    let mesh = mesh_of(&IndexedMesh::cuboid(DVec3::ZERO, DVec3::splat(4.0)), "box");
    for mode in MODES {
        let v = run(&mesh, 4, mode, false);
        assert_eq!(v.frame.dims, [4, 4, 4]);
        assert!(v.grid.check_inside(v.frame.dims).is_ok());
        let want = if mode == VoxelizeMode::Solid { 64 } else { 56 };
        // Thick marks body-diagonal crossings: all shell voxels too.
        assert_eq!(v.stats.voxels, want, "{mode:?}");
        for c in [
            IVec3::new(3, 1, 2),
            IVec3::new(1, 3, 2),
            IVec3::new(2, 1, 3),
            IVec3::new(3, 3, 3),
        ] {
            assert!(v.grid.contains(c), "{mode:?}: {c} lost on a max face");
        }
    }
}

#[test]
fn files_round_trip() {
    let mesh = Mesh::load(&data("data/meshes/obj/spot.obj")).unwrap();
    let v = run(&mesh, 40, VoxelizeMode::Thin, false);
    let dir = temp_dir("it-voxelize");
    for ext in ["binvox", "vox", "npy", "nrrd"] {
        let p = dir.join(format!("spot.{ext}"));
        write_voxels(&p, &v.grid, &v.frame, true).unwrap();
        let (back, _) = read_voxels(&p, MemoryLimit::DEFAULT).unwrap();
        assert_eq!(back, v.grid, "{ext}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn memory_limit_refuses_before_allocating() {
    let mesh = mesh_of(&IndexedMesh::uv_sphere(DVec3::ZERO, 1.0, 8, 12), "s");
    let mut o = VoxelizeOptions::new(4000, VoxelizeMode::Solid);
    o.limit = MemoryLimit::new(64 << 20);
    match voxelize_mesh(&mesh, &o) {
        Err(VoxkitError::Limits { needed, limit, .. }) => assert!(needed > limit as u128),
        other => panic!("expected a limits error, got {other:?}"),
    }
    o.mode = VoxelizeMode::Thin;
    o.lattice = Lattice::Resolution(64);
    assert!(voxelize_mesh(&mesh, &o).is_ok());
}

#[test]
fn progress_reports_every_phase() {
    use std::sync::{Arc, Mutex};
    let mesh = mesh_of(&IndexedMesh::uv_sphere(DVec3::ZERO, 1.0, 8, 12), "s");
    let seen = Arc::new(Mutex::new(Vec::new()));
    let s2 = seen.clone();
    let mut o = VoxelizeOptions::new(16, VoxelizeMode::Solid);
    o.progress = Some(Arc::new(move |p| s2.lock().unwrap().push(p.phase)));
    voxelize_mesh(&mesh, &o).unwrap();
    assert_eq!(
        *seen.lock().unwrap(),
        ["quantize", "surface", "solid", "polylines", "done"]
    );
}

// ---------------------------------------------------------------- CLI

fn voxkit(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args(args)
        .output()
        .unwrap()
}

/// Runs voxkit, asserts exit code 0 (showing stderr otherwise) and parses
/// its one line of JSON.
fn voxkit_json(args: &[&str]) -> serde_json::Value {
    let o = voxkit(args);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).unwrap()
}

/// A path in the folder this file's CLI tests share (each test writes its
/// own file names there).
fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("voxkit-it-cli-vox-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn cli_voxelize_json_errors_and_force() {
    let out = tmp("spot.binvox");
    let _ = std::fs::remove_file(&out);
    let spot = data("data/meshes/obj/spot.obj");
    let (spot, outs) = (spot.to_str().unwrap(), out.to_str().unwrap());
    let o = voxkit(&[
        "voxelize",
        spot,
        "-r",
        "32",
        "-o",
        outs,
        "--json",
        "--measure",
        "-q",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let text = String::from_utf8(o.stdout).unwrap();
    assert_eq!(text.lines().count(), 1);
    let j: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
    for k in [
        "triangles",
        "voxels",
        "bricks",
        "load_ms",
        "voxelize_ms",
        "write_ms",
        "peak_rss_mib",
        "missing",
        "extra",
        "max_distance",
        "mean_distance",
        "tunnel6",
        "tunnel26",
    ] {
        assert!(j.get(k).is_some(), "key {k} missing in {j}");
    }
    assert_eq!(j["tunnel6"], serde_json::json!(false));
    assert_eq!(j["extra"], serde_json::json!(0));
    let (grid, _) = read_voxels(&out, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(serde_json::json!(grid.count()), j["voxels"]);

    // Existing output without --force: exit 2, file untouched.
    let before = std::fs::read(&out).unwrap();
    let o = voxkit(&["voxelize", spot, "-r", "20", "-o", outs, "-q"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--force"));
    assert_eq!(std::fs::read(&out).unwrap(), before);
    let o = voxkit(&[
        "voxelize", spot, "-r", "20", "-o", outs, "-q", "--force", "--mode", "thick",
    ]);
    assert_eq!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stdout).contains("voxels"));

    // A bad mesh file: exit 2 with a message naming it.
    let bad = tmp("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n").unwrap();
    let o = voxkit(&[
        "voxelize",
        bad.to_str().unwrap(),
        "-r",
        "8",
        "-o",
        tmp("bad.npy").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.obj"), "{err}");
    assert!(!tmp("bad.npy").exists());
    let o = voxkit(&[
        "voxelize",
        "/nonexistent/x.obj",
        "-r",
        "8",
        "-o",
        tmp("none.npy").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    // Over the memory limit: exit 2.
    let o = voxkit(&[
        "voxelize",
        spot,
        "-r",
        "3000",
        "--mode",
        "solid",
        "--max-memory",
        "16",
        "-o",
        tmp("big.npy").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("memory limit"));
}

#[test]
fn cli_check_finds_punched_hole() {
    let sphere = mesh_of(&IndexedMesh::uv_sphere(DVec3::ZERO, 10.0, 16, 24), "sphere");
    let v = run(&sphere, 32, VoxelizeMode::Thin, false);
    let good = tmp("sphere.binvox");
    write_voxels(&good, &v.grid, &v.frame, true).unwrap();
    let o = voxkit(&["check", good.to_str().unwrap(), "--tunnels", "6", "--json"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["tunnel"], serde_json::json!(false));
    assert!(j["enclosed"].as_u64().unwrap() > 1000);

    // Punch a hole: clear the surface voxels on the column through the
    // centre above it; the column itself is then a 6-path from inside out.
    let mut punched = v.grid.clone();
    let c = v.frame.dims.map(|d| d as i32 / 2);
    for z in c[2]..v.frame.dims[2] as i32 {
        punched.remove(IVec3::new(c[0], c[1], z));
    }
    assert!(punched.count() < v.grid.count());
    let bad = tmp("punched.nrrd");
    write_voxels(&bad, &punched, &v.frame, true).unwrap();
    let o = voxkit(&["check", bad.to_str().unwrap(), "--tunnels", "6"]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["tunnel"], serde_json::json!(true));
    // Bad input: exit 2.
    let o = voxkit(&["check", "/nonexistent.binvox", "--tunnels", "6"]);
    assert_eq!(o.status.code(), Some(2));
    let o = voxkit(&["check", good.to_str().unwrap(), "--tunnels", "7"]);
    assert_eq!(o.status.code(), Some(2));
}

// ------------------------------------------------ measuring other tools

/// A closed tetrahedron with dyadic vertices, so that every frame below maps
/// it to fixed point exactly, and its conservative set on a lattice with
/// corner `origin` and unit voxels by brute force over every nearby voxel.
fn tetrahedron_and_reference(origin: DVec3) -> (Mesh, Vec<[i64; 3]>) {
    let p = vec![
        DVec3::new(0.25, 0.5, 0.125),
        DVec3::new(6.375, 1.25, 0.75),
        DVec3::new(1.5, 5.625, 1.0),
        DVec3::new(2.0, 2.5, 6.5),
    ];
    let faces = vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
    let mesh = Mesh::from_parts("tetrahedron", p.clone(), faces.clone(), vec![]).unwrap();
    // Grid coordinate of world w on this lattice: w − origin − 1/2.
    let fixed = |w: DVec3| {
        let g = (w - origin - DVec3::splat(0.5)) * (1u64 << voxkit::fixed::FRAC_BITS) as f64;
        [g.x as i64, g.y as i64, g.z as i64]
    };
    let mut reference = Vec::new();
    for x in -3..10 {
        for y in -3..10 {
            for z in -3..10 {
                let v = IVec3::new(x, y, z);
                let hit = faces.iter().any(|f| {
                    let t = f.map(|i| fixed(p[i as usize]));
                    triangle_meets_voxel(&t, v).unwrap()
                });
                if hit {
                    reference.push([x as i64, y as i64, z as i64]);
                }
            }
        }
    }
    (mesh, reference)
}

#[test]
fn measure_external_against_brute_force_on_a_shifted_lattice() {
    // Open3D's lattice is half a voxel off ours; any origin must work.
    for origin in [DVec3::ZERO, DVec3::new(-0.5, 0.25, -1.5)] {
        let (mesh, reference) = tetrahedron_and_reference(origin);
        let limit = MemoryLimit::default();
        let (m, frame) = measure_external(&mesh, origin, 1.0, &reference, limit).unwrap();
        assert_eq!(m.reference_voxels, reference.len() as u64, "{origin}");
        assert_eq!((m.missing, m.extra, m.far_voxels), (0, 0, 0));
        assert!(m.closed);
        assert_eq!((m.tunnel6, m.tunnel26), (Some(false), Some(false)));
        assert!(m.max_distance <= 3f64.sqrt() / 2.0 + 1e-9);
        // The widened frame keeps the lattice: its origin moved by whole voxels.
        let shift = (frame.origin - origin) / frame.voxel_size;
        assert_eq!(shift, shift.round());

        // Drop 5 voxels and add a far one: exactly 5 missing, 1 extra and far.
        let mut edited = reference[5..].to_vec();
        edited.push([40, 40, 40]);
        let (m, _) = measure_external(&mesh, origin, 1.0, &edited, limit).unwrap();
        assert_eq!((m.missing, m.extra, m.far_voxels), (5, 1, 1));
    }
    let (mesh, reference) = tetrahedron_and_reference(DVec3::ZERO);
    let bad = measure_external(&mesh, DVec3::ZERO, 0.0, &reference, MemoryLimit::default());
    assert!(matches!(bad, Err(VoxkitError::Invalid(_))));
}

#[test]
fn cli_measure_reads_index_lists_and_voxel_files() {
    use ndarray_npy::WriteNpyExt;
    let origin = DVec3::new(-0.5, 0.25, -1.5);
    let (mesh, reference) = tetrahedron_and_reference(origin);
    let obj = tmp("tet.obj");
    let mut text = String::new();
    for p in &mesh.positions {
        text += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for t in &mesh.triangles {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(&obj, text).unwrap();
    let coords =
        ndarray::Array2::from_shape_fn((reference.len(), 3), |(i, a)| reference[i][a] as i32);
    let npy = tmp("tet_coords.npy");
    coords
        .write_npy(std::fs::File::create(&npy).unwrap())
        .unwrap();
    let (objs, npys) = (obj.to_str().unwrap(), npy.to_str().unwrap());
    let j = voxkit_json(&[
        "measure",
        objs,
        npys,
        "--origin",
        "-0.5",
        "0.25",
        "-1.5",
        "--voxel-size",
        "1",
    ]);
    assert_eq!(j["voxels"], serde_json::json!(reference.len()));
    assert_eq!(j["missing"], serde_json::json!(0));
    assert_eq!(j["extra"], serde_json::json!(0));
    assert_eq!(j["tunnel6"], serde_json::json!(false));
    // An index list without a frame is refused with exit 2.
    let o = voxkit(&["measure", objs, npys]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--origin"));
    // Our own voxel file carries its frame: voxelize, then measure the file.
    let vox = tmp("tet.binvox");
    let v = voxkit_json(&[
        "voxelize",
        objs,
        "-r",
        "16",
        "-o",
        vox.to_str().unwrap(),
        "--mode",
        "conservative",
        "--force",
        "--json",
        "--measure",
    ]);
    let j = voxkit_json(&["measure", objs, vox.to_str().unwrap()]);
    assert_eq!(j["voxels"], v["voxels"]);
    assert_eq!(j["extra"], serde_json::json!(0));
    assert_eq!(j["tunnel6"], serde_json::json!(false));
}

#[test]
fn kahan_kelsen_route_equals_the_crossing_kernel_on_snapped_input() {
    let spot = Mesh::load(&data("data/meshes/obj/spot.obj")).unwrap();
    for mode in [VoxelizeMode::Thin, VoxelizeMode::Thick, VoxelizeMode::Solid] {
        let mut o = VoxelizeOptions::new(48, mode);
        o.snap = true;
        let kernel = voxelize_mesh(&spot, &o).unwrap();
        o.kahan_kelsen = true;
        let kk = voxelize_mesh(&spot, &o).unwrap();
        assert_eq!(kk.grid, kernel.grid, "{mode:?}");
        assert!(kk.grid.count() > 1000);
    }
    // The CLI flag needs --snap and gives the same voxel count.
    let out = tmp("spot_kk.binvox");
    let (spot, outs) = (data("data/meshes/obj/spot.obj"), out.to_str().unwrap());
    let args = [
        "voxelize",
        spot.to_str().unwrap(),
        "-r",
        "40",
        "-o",
        outs,
        "--force",
        "--json",
    ];
    let o = voxkit(&[&args[..], &["--kahan-kelsen"]].concat());
    assert_eq!(
        o.status.code(),
        Some(2),
        "--kahan-kelsen without --snap is refused"
    );
    let kk = voxkit_json(&[&args[..], &["--snap", "--kahan-kelsen"]].concat());
    assert_eq!(kk["kahan_kelsen"], serde_json::json!(true));
    let plain = voxkit_json(&[&args[..], &["--snap"]].concat());
    assert_eq!(kk["voxels"], plain["voxels"]);
}

/// The binary installs `voxkit::alloc::HugePageAlloc` (huge pages for blocks
/// of 512 KiB and more); at 1024³ the bunny's quantized triangles, slab
/// tables, slab brick lists and grid arrays all take that path. Its file
/// holds the same voxels as the library run in this process, which uses the
/// system allocator.
#[test]
fn cli_with_its_huge_page_allocator_matches_the_library() {
    let mesh = data("data/meshes/obj/stanford-bunny.obj");
    let out = tmp("bunny-1024.binvox");
    let j = voxkit_json(&[
        "voxelize",
        mesh.to_str().unwrap(),
        "-r",
        "1024",
        "-o",
        out.to_str().unwrap(),
        "--force",
        "--json",
        "-q",
    ]);
    let (cli, _) = read_voxels(&out, MemoryLimit::DEFAULT).unwrap();
    let lib = voxelize_mesh(
        &Mesh::load(&mesh).unwrap(),
        &VoxelizeOptions::new(1024, VoxelizeMode::Thin),
    )
    .unwrap();
    assert_eq!(j["voxels"].as_u64(), Some(lib.grid.count()));
    assert!(
        cli == lib.grid,
        "the CLI's voxels differ from the library's"
    );
    let _ = std::fs::remove_file(&out);
}
