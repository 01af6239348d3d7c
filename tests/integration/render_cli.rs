//! `voxkit render` end to end: every input kind, PNG / EXR / GIF outputs,
//! the JSON keys, and bad input as a typed error with exit code 2 and no
//! file left behind.

use crate::scratch::temp_dir as tmp;
use std::path::Path;
use std::process::Command;

fn voxkit(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args(args)
        .output()
        .expect("voxkit runs")
}

fn data(p: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(p)
        .display()
        .to_string()
}

fn json(out: &std::process::Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON line")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A mesh in one step, with EXR and measures; the JSON has the contract's
/// keys; the EXR's depth is finite exactly where the PNG shows a hit.
#[test]
fn mesh_to_png_and_exr() {
    let d = tmp("mesh");
    let (png, exr) = (d.join("spot.png"), d.join("spot.exr"));
    let out = voxkit(&[
        "render",
        &data("data/meshes/obj/spot.obj"),
        "-r",
        "64",
        "-o",
        s(&png),
        "--exr",
        s(&exr),
        "--size",
        "96x64",
        "--json",
        "--measure",
    ]);
    let j = json(&out);
    for k in [
        "rays",
        "voxels_visited",
        "bricks_skipped",
        "render_ms",
        "load_ms",
        "memory_bytes",
        "differing_pixels",
        "mesh_depth_mean",
        "silhouette_disagree",
    ] {
        assert!(j.get(k).is_some(), "missing {k} in {j}");
    }
    assert_eq!(j["rays"], 96 * 64);
    assert_eq!(j["differing_pixels"], 0, "adaptive differs from the 6-ray");
    assert!(j["hits"].as_u64().unwrap() > 500);
    let e = voxkit::io::image::read_exr(&exr).unwrap();
    assert_eq!((e.width, e.height), (96, 64));
    let hits = e.depth.iter().filter(|d| d.is_finite()).count() as u64;
    assert_eq!(hits, j["hits"].as_u64().unwrap());
    assert!(e.depth.iter().all(|d| d.is_finite() || *d == f32::INFINITY));
    assert!(
        e.rgba
            .iter()
            .zip(&e.depth)
            .all(|(c, d)| (c[3] == 1.0) == d.is_finite())
    );
    assert!(png.exists());
    // The JSON camera casts the EXR's rays: every hit's depth along its
    // pixel ray lands on the mesh's voxels (within the vertices' box grown
    // by two voxels; the depth is world distance along the ray).
    let c = &j["camera"];
    let vec = |k: &str| -> [f64; 3] {
        let a = c[k]
            .as_array()
            .unwrap_or_else(|| panic!("camera.{k} in {j}"));
        std::array::from_fn(|i| a[i].as_f64().unwrap())
    };
    let (eye, r, u, f) = (
        vec("eye"),
        vec("right_axis"),
        vec("up_axis"),
        vec("forward_axis"),
    );
    let su = (c["fov_y_deg"].as_f64().unwrap().to_radians() * 0.5).tan();
    let sr = su * 96.0 / 64.0;
    let obj = std::fs::read_to_string(data("data/meshes/obj/spot.obj")).unwrap();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for l in obj.lines().filter(|l| l.starts_with("v ")) {
        let p: Vec<f64> = l[2..]
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let voxel = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max) / 64.0;
    let mut checked = 0;
    for (i, &depth) in e.depth.iter().enumerate() {
        if !depth.is_finite() {
            continue;
        }
        let (x, y) = ((i % 96) as f64, (i / 96) as f64);
        let (nx, ny) = (2.0 * (x + 0.5) / 96.0 - 1.0, 1.0 - 2.0 * (y + 0.5) / 64.0);
        let d: [f64; 3] = std::array::from_fn(|k| f[k] + r[k] * nx * sr + u[k] * ny * su);
        let len = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        for k in 0..3 {
            let p = eye[k] + d[k] / len * f64::from(depth);
            assert!(
                p > lo[k] - 2.0 * voxel && p < hi[k] + 2.0 * voxel,
                "pixel ({x}, {y}) lands off the mesh"
            );
        }
        checked += 1;
    }
    assert!(checked > 500);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Every voxel format voxkit writes renders; a .vox keeps its palette's
/// colours; a turntable writes a GIF or numbered PNGs.
#[test]
fn voxel_files_and_turntables() {
    let d = tmp("files");
    let mesh = data("data/meshes/obj/spot.obj");
    for ext in ["binvox", "vox", "npy", "nrrd"] {
        let f = d.join(format!("spot.{ext}"));
        let o = voxkit(&[
            "voxelize",
            &mesh,
            "-r",
            "48",
            "-o",
            s(&f),
            "--mode",
            "thick",
        ]);
        assert!(o.status.success());
        let png = d.join(format!("{ext}.png"));
        let j = json(&voxkit(&[
            "render",
            s(&f),
            "-o",
            s(&png),
            "--size",
            "40x40",
            "--json",
            "--measure",
        ]));
        assert_eq!(j["kind"], "grid", "{ext}");
        assert!(j["hits"].as_u64().unwrap() > 100, "{ext}: {j}");
        assert_eq!(j["differing_pixels"], 0);
    }
    let gif = d.join("turn.gif");
    let j = json(&voxkit(&[
        "render",
        s(&d.join("spot.binvox")),
        "-o",
        s(&gif),
        "--turntable",
        "3",
        "--size",
        "32x24",
        "--json",
    ]));
    assert_eq!(j["frames"], 3);
    let mut dec = gif::DecodeOptions::new();
    dec.set_color_output(gif::ColorOutput::RGBA);
    let mut r = dec.read_info(std::fs::File::open(&gif).unwrap()).unwrap();
    let mut n = 0;
    while r.read_next_frame().unwrap().is_some() {
        n += 1;
    }
    assert_eq!(n, 3);
    let o = voxkit(&[
        "render",
        s(&d.join("spot.binvox")),
        "-o",
        s(&d.join("t.png")),
        "--turntable",
        "2",
        "--size",
        "16x16",
    ]);
    assert!(o.status.success());
    assert!(d.join("t_000.png").exists() && d.join("t_001.png").exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// A detached-header NRRD volume (the CT head) and the MetaImage MR head
/// render in every volume mode; a detached header written here with a
/// non-zero origin and a float type renders too.
#[test]
fn volumes_from_detached_headers() {
    let d = tmp("vol");
    for (input, modes) in [
        (
            "data/volumes/headsq_quarter/headsq_quarter.nhdr",
            &["mip", "composite", "iso"][..],
        ),
        ("data/volumes/HeadMRVolume/HeadMRVolume.mhd", &["mip"][..]),
    ] {
        for m in modes {
            let png = d.join(format!("{m}.png"));
            let j = json(&voxkit(&[
                "render",
                &data(input),
                "-o",
                s(&png),
                "--volume",
                m,
                "--size",
                "48x48",
                "--json",
                "--measure",
                "--force",
            ]));
            assert_eq!(j["kind"], "volume");
            assert!(j["hits"].as_u64().unwrap() > 200, "{input} {m}: {j}");
            assert_eq!(j["differing_pixels"], 0, "{input} {m}");
        }
    }
    // float32, origin (-5, 2, 7), spacing (0.5, 0.5, 2), 9×7×5, data in a
    // separate file named by the header.
    let (nx, ny, nz) = (9usize, 7usize, 5usize);
    let mut raw = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let v = if (x, y, z) == (4, 3, 2) {
                    10.0f32
                } else {
                    (x + y + z) as f32 * 0.01
                };
                raw.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    std::fs::write(d.join("blob.raw"), &raw).unwrap();
    std::fs::write(
        d.join("blob.nhdr"),
        format!(
            "NRRD0004\ntype: float\ndimension: 3\nsizes: {nx} {ny} {nz}\nendian: little\n\
             encoding: raw\nspace dimension: 3\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,2)\n\
             space origin: (-5,2,7)\ndata file: blob.raw\n\n"
        ),
    )
    .unwrap();
    let j = json(&voxkit(&[
        "render",
        s(&d.join("blob.nhdr")),
        "-o",
        s(&d.join("b.png")),
        "--volume",
        "iso",
        "--iso",
        "5",
        "--size",
        "64x64",
        "--json",
        "--ray",
        "6",
    ]));
    assert!(j["hits"].as_u64().unwrap() > 0, "{j}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// Uniform volumes at every magnitude render with the default window and
/// iso value, by rays and by shear-warp: a `u32` mask of `2³² − 1`, an
/// `i32` of its minimum and a `float` of `f32::MAX`, where `v ± ½` rounds
/// back to `v` (found by a sweep of odd volumes: the default window was
/// empty and the render refused a window the user never gave).
#[test]
fn uniform_volumes_of_any_magnitude_render() {
    let d = tmp("uniform");
    let volumes: [(&str, [u8; 4]); 4] = [
        ("uint", u32::MAX.to_le_bytes()),
        ("int", i32::MIN.to_le_bytes()),
        ("float", f32::MAX.to_le_bytes()),
        ("float", (-3e38f32).to_le_bytes()),
    ];
    for (n, (ty, v)) in volumes.iter().enumerate() {
        let raw = v.repeat(5 * 4 * 3);
        std::fs::write(d.join(format!("u{n}.raw")), &raw).unwrap();
        let header = d.join(format!("u{n}.nhdr"));
        std::fs::write(
            &header,
            format!(
                "NRRD0004\ntype: {ty}\ndimension: 3\nsizes: 5 4 3\nendian: little\n\
                 encoding: raw\ndata file: u{n}.raw\n\n"
            ),
        )
        .unwrap();
        for (mode, method) in [
            ("mip", "rays"),
            ("mip", "shear-warp"),
            ("composite", "shear-warp"),
            ("iso", "rays"),
        ] {
            let png = d.join(format!("u{n}-{mode}-{method}.png"));
            let args = [
                "render",
                s(&header),
                "-o",
                s(&png),
                "--volume",
                mode,
                "--method",
                method,
                "--size",
                "24x20",
                "--json",
            ];
            let j = json(&voxkit(&args));
            assert_eq!(j["rays"].as_u64(), Some(24 * 20), "{ty} {mode} {j}");
            let [lo, hi] = [0, 1].map(|k| j["window"][k].as_f64().unwrap());
            assert!(lo < hi && lo.is_finite() && hi.is_finite(), "{ty} {j}");
            assert!(png.exists());
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// A `float64` volume whose samples lie beyond `f32`'s range (a `-1e300`
/// "no data" sentinel) renders, and says how many samples turned into
/// `±∞`; one within range says nothing.
#[test]
fn float64_beyond_f32_is_a_warning() {
    let d = tmp("f64range");
    for (name, values, count) in [
        ("out", [0.5, -1e300, 2.0, 1e39], Some(12)),
        ("in", [0.5, -3e38, 2.0, 1e-300], None),
    ] {
        let raw: Vec<u8> = values
            .repeat(6)
            .iter()
            .flat_map(|x: &f64| x.to_le_bytes())
            .collect();
        std::fs::write(d.join(format!("{name}.raw")), raw).unwrap();
        let header = d.join(format!("{name}.nhdr"));
        std::fs::write(
            &header,
            format!(
                "NRRD0004\ntype: double\ndimension: 3\nsizes: 4 3 2\nendian: little\n\
                 encoding: raw\ndata file: {name}.raw\n\n"
            ),
        )
        .unwrap();
        let png = d.join(format!("{name}.png"));
        let out = voxkit(&[
            "render",
            s(&header),
            "-o",
            s(&png),
            "--size",
            "16x16",
            "--json",
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        let j = json(&out);
        let warnings = j["warnings"].as_array().unwrap();
        match count {
            Some(n) => {
                let want = format!("{n} float64 samples lie beyond float32's range");
                assert!(
                    warnings
                        .iter()
                        .any(|w| w.as_str().unwrap().starts_with(&want)),
                    "{j}"
                );
                assert!(stderr.contains(&want), "{stderr}");
            }
            None => assert!(warnings.is_empty(), "{j}"),
        }
        assert!(png.exists());
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// A volume whose extent vanishes beside its distance from the origin (a
/// spacing of 1e-30 at 1e6: its box is one point in `f64`) is refused with
/// exit 2 and one line that names the cause, not only "eye equals target".
#[test]
fn a_volume_too_small_for_its_position_names_the_cause() {
    let d = tmp("tinyfar");
    std::fs::write(d.join("v.raw"), [1u8, 2, 3, 4, 5, 6, 7, 8]).unwrap();
    let header = d.join("v.nhdr");
    std::fs::write(
        &header,
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\
         space: right-anterior-superior\n\
         space directions: (1e-30,0,0) (0,1e-30,0) (0,0,1e-30)\n\
         space origin: (1e6,1e6,1e6)\ndata file: v.raw\n\n",
    )
    .unwrap();
    for method in ["rays", "shear-warp"] {
        let png = d.join("v.png");
        let out = voxkit(&[
            "render",
            s(&header),
            "-o",
            s(&png),
            "--size",
            "16x16",
            "--volume",
            "mip",
            "--method",
            method,
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains("too small beside its distance from the origin"),
            "{stderr}"
        );
        assert!(!png.exists());
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// `--reps` on a volume times the memory floor beside the frames: `floor_ms`
/// and `frame_over_floor` (the frame's median over the floor's); a single
/// render and a voxel grid have neither.
#[test]
fn volume_reps_report_the_memory_floor() {
    let d = tmp("floor");
    let ct = data("data/volumes/headsq_quarter/headsq_quarter.nhdr");
    let run = |input: &str, reps: &str| {
        json(&voxkit(&[
            "render",
            input,
            "-o",
            s(&d.join("f.png")),
            "--size",
            "32x32",
            "--reps",
            reps,
            "--json",
            "--force",
        ]))
    };
    let j = run(&ct, "3");
    let (frame, floor) = (
        j["render_ms"].as_f64().unwrap(),
        j["floor_ms"].as_f64().unwrap(),
    );
    assert!(floor > 0.0, "{j}");
    let over = j["frame_over_floor"].as_f64().unwrap();
    assert!((over - frame / floor).abs() <= 1e-9 * over, "{j}");
    let single = run(&ct, "1");
    assert!(single.get("floor_ms").is_none() && single.get("frame_over_floor").is_none());
    let grid = json(&voxkit(&[
        "render",
        &data("data/meshes/obj/spot.obj"),
        "-r",
        "32",
        "-o",
        s(&d.join("g.png")),
        "--size",
        "32x32",
        "--reps",
        "2",
        "--json",
        "--force",
    ]));
    assert_eq!(grid["kind"], "grid");
    assert!(grid.get("floor_ms").is_none(), "{grid}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// Bad input: exit 2, one line naming the problem, no output file.
#[test]
fn bad_input_exits_2_without_output() {
    let d = tmp("bad");
    let grid = d.join("g.binvox");
    assert!(
        voxkit(&[
            "voxelize",
            &data("data/meshes/obj/spot.obj"),
            "-r",
            "16",
            "-o",
            s(&grid)
        ])
        .status
        .success()
    );
    let png = d.join("x.png");
    let cases: Vec<Vec<&str>> = vec![
        vec!["--eye", "1,2,3", "--target", "1,2,3"],
        vec!["--eye", "0,5,0", "--target", "0,0,0", "--up", "0,1,0"],
        vec!["--fov", "0"],
        vec!["--fov", "180"],
        vec!["--size", "0x10"],
        vec!["--size", "100000x100000", "--max-memory", "64"],
        vec!["--eye", "nan,0,0"],
        vec!["--volume", "mip", "--iso", "3"],
        vec!["--window", "5,1"],
    ];
    for extra in cases {
        let mut args = vec!["render", s(&grid), "-o", s(&png)];
        args.extend(extra.iter());
        let o = voxkit(&args);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{extra:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!png.exists(), "{extra:?} left a file");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim().lines().count().min(1), 1, "{extra:?}: {err}");
    }
    // A header whose sizes disagree with its data; an unsupported encoding;
    // a missing data file; an unknown extension.
    std::fs::write(d.join("short.raw"), [0u8; 10]).unwrap();
    std::fs::write(
        d.join("short.nhdr"),
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: short.raw\n\n",
    )
    .unwrap();
    std::fs::write(
        d.join("bz.nhdr"),
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: bzip2\ndata file: short.raw\n\n",
    )
    .unwrap();
    std::fs::write(
        d.join("gone.nhdr"),
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: nowhere.raw\n\n",
    )
    .unwrap();
    std::fs::write(d.join("x.xyz"), "hello").unwrap();
    for f in ["short.nhdr", "bz.nhdr", "gone.nhdr", "x.xyz"] {
        let o = voxkit(&["render", s(&d.join(f)), "-o", s(&png)]);
        assert_eq!(o.status.code(), Some(2), "{f}");
        assert!(!png.exists(), "{f} left a file");
    }
    // An existing output is refused without --force, and kept intact.
    std::fs::write(&png, b"keep").unwrap();
    let o = voxkit(&["render", s(&grid), "-o", s(&png)]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(std::fs::read(&png).unwrap(), b"keep");
    let leftovers: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    std::fs::remove_dir_all(&d).unwrap();
}
