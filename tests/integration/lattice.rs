//! Fitting by voxel size (`Lattice::VoxelSize`, `voxkit voxelize
//! --voxel-size H [--origin X,Y,Z]`): the same frame and voxels as `-r N`
//! for `h` = the longest side / N, lattices pinned anywhere, bad sizes
//! refused before any work.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::scratch::temp_dir;
use glam::DVec3;
use voxkit::VoxkitError;
use voxkit::grid::MemoryLimit;
use voxkit::io::read_voxels;
use voxkit::mesh::{FIT_SLACK, Mesh, fit_frame_voxel_size};
use voxkit::voxelize::pipeline::{Lattice, VoxelizeMode, VoxelizeOptions, voxelize_mesh};

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn by_size(
    mesh: &Mesh,
    h: f64,
    origin: Option<DVec3>,
    mode: VoxelizeMode,
) -> voxkit::Result<voxkit::voxelize::pipeline::Voxelization> {
    voxelize_mesh(
        mesh,
        &VoxelizeOptions::on_lattice(
            Lattice::VoxelSize {
                voxel_size: h,
                origin,
            },
            mode,
        ),
    )
}

#[test]
fn voxel_size_of_the_longest_side_over_n_equals_resolution_n() {
    for name in ["spot.obj", "fandisk.obj", "teapot.obj"] {
        let mesh = Mesh::load(&data(&format!("data/meshes/obj/{name}"))).unwrap();
        let (lo, hi) = mesh.bounds();
        for n in [17, 64, 100] {
            let h = (hi - lo).max_element() / n as f64;
            for mode in [VoxelizeMode::Thin, VoxelizeMode::Conservative] {
                let r = voxelize_mesh(&mesh, &VoxelizeOptions::new(n, mode)).unwrap();
                let s = by_size(&mesh, h, None, mode).unwrap();
                assert_eq!(s.frame, r.frame, "{name} {n}");
                assert_eq!(s.grid, r.grid, "{name} {n} {mode:?}");
            }
        }
    }
}

#[test]
fn pinned_lattices_cover_the_mesh_and_keep_their_corners() {
    let mesh = Mesh::load(&data("data/meshes/obj/spot.obj")).unwrap();
    let (lo, hi) = mesh.bounds();
    let h = 0.013;
    let base = by_size(
        &mesh,
        h,
        Some(DVec3::new(0.1, -2.0, 7.0)),
        VoxelizeMode::Thin,
    )
    .unwrap();
    let f = base.frame;
    for a in 0..3 {
        // The min corner is a lattice corner at or below the box, less
        // than one voxel below it; the grid reaches the box's max.
        let k = (f.origin[a] - [0.1, -2.0, 7.0][a]) / h;
        assert!((k - k.round()).abs() < 1e-6, "axis {a}: {k}");
        assert!(f.origin[a] <= lo[a] + FIT_SLACK * h && f.origin[a] > lo[a] - h);
        let top = f.origin[a] + f.dims[a] as f64 * h;
        assert!(top >= hi[a] - FIT_SLACK * h && top < hi[a] + h, "axis {a}");
    }
    // Any corner of the same lattice gives the same grid.
    let same = by_size(
        &mesh,
        h,
        Some(DVec3::new(0.1 + 5.0 * h, -2.0 - 40.0 * h, 7.0 - 9.0 * h)),
        VoxelizeMode::Thin,
    )
    .unwrap();
    assert!((same.frame.origin - f.origin).length() < 1e-9);
    assert_eq!(same.frame.dims, f.dims);
    assert_eq!(same.grid, base.grid);
    // The default origin is the box's min corner.
    let d = by_size(&mesh, h, None, VoxelizeMode::Thin).unwrap();
    assert_eq!(d.frame.origin, lo);
}

#[test]
fn bad_voxel_sizes_and_origins_are_refused() {
    let mesh = Mesh::load(&data("data/meshes/obj/spot.obj")).unwrap();
    for h in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        match by_size(&mesh, h, None, VoxelizeMode::Thin) {
            Err(VoxkitError::Invalid(m)) => assert!(m.contains("voxel size"), "{m}"),
            other => panic!("h = {h}: {other:?}"),
        }
    }
    let nan = Some(DVec3::new(0.0, f64::NAN, 0.0));
    assert!(matches!(
        by_size(&mesh, 0.1, nan, VoxelizeMode::Thin),
        Err(VoxkitError::Invalid(_))
    ));
    // Past 2^22 voxels per axis: unsupported; below that, the memory
    // estimate refuses a grid too large for the limit.
    assert!(matches!(
        by_size(&mesh, 1e-300, None, VoxelizeMode::Thin),
        Err(VoxkitError::Unsupported(_))
    ));
    assert!(matches!(
        by_size(&mesh, 1e-5, None, VoxelizeMode::Thin),
        Err(VoxkitError::Limits { .. })
    ));
    assert!(fit_frame_voxel_size((DVec3::ONE, DVec3::ZERO), 0.1, None).is_err());
}

#[test]
fn cli_voxel_size_and_origin() {
    let dir = temp_dir("it-lattice");
    let spot = data("data/meshes/obj/spot.obj");
    let out = dir.join("spot.binvox");
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_voxkit"))
            .arg("voxelize")
            .arg(&spot)
            .arg("-o")
            .arg(&out)
            .args(["-q", "--force", "--json"])
            .args(args)
            .output()
            .unwrap()
    };
    let o = run(&["--voxel-size", "0.02", "--origin", "-1,0.005,2"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["resolution"], serde_json::Value::Null);
    assert_eq!(j["voxel_size"], serde_json::json!(0.02));
    let mesh = Mesh::load(&spot).unwrap();
    let lib = by_size(
        &mesh,
        0.02,
        Some(DVec3::new(-1.0, 0.005, 2.0)),
        VoxelizeMode::Thin,
    )
    .unwrap();
    assert_eq!(j["dims"], serde_json::json!(lib.frame.dims));
    assert_eq!(j["origin"], serde_json::json!(lib.frame.origin.to_array()));
    let (grid, _) = read_voxels(&out, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(grid, lib.grid);
    // -r and --voxel-size conflict; --origin needs --voxel-size; a bad size
    // is bad input; one of -r / --voxel-size is needed.
    for args in [
        &["-r", "32", "--voxel-size", "0.1"][..],
        &["-r", "32", "--origin", "0,0,0"][..],
        &["--voxel-size", "0"][..],
        &["--voxel-size", "nan"][..],
        &[][..],
    ] {
        let o = run(args);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
