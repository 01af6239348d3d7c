//! Mesh loaders on the bundled real meshes (counts from data/SOURCES.md),
//! hand-made OBJ/glTF cases, bad files and their typed errors, and the `-r N`
//! fitting rule.

use std::path::{Path, PathBuf};

use crate::scratch::temp_dir;
use glam::DVec3;
use voxkit::VoxkitError;
use voxkit::mesh::{Mesh, fit_frame, fit_frame_padded, fitted_voxel, obj};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/meshes")
        .join(rel)
}

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).abs().max_element() <= tol
}

/// Input triangles = kept + degenerate; the summary must agree with the mesh.
fn assert_triangles(m: &Mesh, input: usize) {
    assert_eq!(m.summary.triangles, m.triangles.len());
    assert_eq!(
        m.triangles.len() + m.summary.degenerate_triangles,
        input,
        "{:?}",
        m.summary
    );
}

#[test]
fn obj_real_meshes_match_sources() {
    let bunny = Mesh::load(&data("obj/stanford-bunny.obj")).unwrap();
    assert_triangles(&bunny, 69_451);
    // The file has 35,947 `v` records, all kept in file order.
    let text = std::fs::read_to_string(data("obj/stanford-bunny.obj")).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), 35_947);
    assert_eq!(bunny.positions.len(), 35_947);
    assert_eq!(bunny.summary.vertices, 35_947);
    let (lo, hi) = bunny.bounds();
    assert!(
        close(lo, DVec3::new(-0.0947, 0.0330, -0.0619), 1e-4),
        "{lo}"
    );
    assert!(close(hi, DVec3::new(0.0610, 0.1873, 0.0588), 1e-4), "{hi}");

    let spot = Mesh::load(&data("obj/spot.obj")).unwrap();
    assert_triangles(&spot, 5_856);
    assert_eq!(spot.summary.degenerate_triangles, 0);
    let quads = Mesh::load(&data("obj/spot_quadrangulated.obj")).unwrap();
    assert_triangles(&quads, 5_856); // 2,928 quads, fan-triangulated
    assert_eq!(spot.bounds(), quads.bounds());
    let (lo, hi) = spot.bounds();
    assert!(
        close(lo, DVec3::new(-0.4716, -0.7368, -0.6689), 1e-4),
        "{lo}"
    );
    assert!(close(hi, DVec3::new(0.4716, 0.9536, 1.0490), 1e-4), "{hi}");

    let teapot = Mesh::load(&data("obj/teapot.obj")).unwrap();
    assert_triangles(&teapot, 6_320);
    let (lo, hi) = teapot.bounds();
    assert!(close(lo, DVec3::new(-3.0, 0.0, -2.0), 1e-9), "{lo}");
    assert!(close(hi, DVec3::new(3.434, 3.15, 2.0), 1e-3), "{hi}");

    let fandisk = Mesh::load(&data("obj/fandisk.obj")).unwrap();
    assert_triangles(&fandisk, 12_946);
    let (lo, hi) = fandisk.bounds();
    assert_eq!(lo.x, 0.0);
    assert_eq!(hi.z, 0.0);
    assert!(close(lo, DVec3::new(0.0, 12.6055, -2.6803), 1e-4), "{lo}");
    assert!(close(hi, DVec3::new(4.8279, 17.85, 0.0), 1e-4), "{hi}");
    for m in [&bunny, &spot, &quads, &teapot, &fandisk] {
        assert!(m.polylines.is_empty());
    }
}

#[test]
fn gltf_real_meshes_match_sources() {
    let boxg = Mesh::load(&data("gltf/BoxTextured/BoxTextured.gltf")).unwrap();
    assert_triangles(&boxg, 12);
    let (lo, hi) = boxg.bounds();
    assert!(close(lo, DVec3::splat(-0.5), 1e-6), "{lo}");
    assert!(close(hi, DVec3::splat(0.5), 1e-6), "{hi}");
    // Every transformed vertex is a cube corner.
    for p in &boxg.positions {
        assert!(close(p.abs(), DVec3::splat(0.5), 1e-6), "{p}");
    }
    let glb = Mesh::load(&data("gltf/BoxTextured.glb")).unwrap();
    assert_eq!(glb.triangles, boxg.triangles);
    assert_eq!(glb.positions, boxg.positions);

    let suzanne = Mesh::load(&data("gltf/Suzanne/Suzanne.gltf")).unwrap();
    assert_triangles(&suzanne, 3_936);

    // 20 root nodes, "Glass Box" instanced 9x and "Opaque Mesh" 3x.
    let tot = Mesh::load(&data(
        "gltf/TransmissionOrderTest/TransmissionOrderTest.gltf",
    ))
    .unwrap();
    assert_triangles(&tot, 50_280);
}

#[test]
fn gltf_node_transform_is_applied() {
    // BoxTextured's root matrix swaps Y and Z: the raw mesh and the placed
    // one differ, the placed one is the unit cube either way; check that the
    // buffer's own (untransformed) coordinates differ from what we return by
    // that swap on at least one vertex by loading the same file with the
    // root matrix replaced by the identity.
    let dir = temp_dir("xform");
    let src = data("gltf/BoxTextured");
    for f in ["BoxTextured0.bin", "CesiumLogoFlat.png"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
    let json = std::fs::read_to_string(src.join("BoxTextured.gltf")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let mut plain = v.clone();
    for n in plain["nodes"].as_array_mut().unwrap() {
        n.as_object_mut().unwrap().remove("matrix");
    }
    std::fs::write(dir.join("plain.gltf"), plain.to_string()).unwrap();
    std::fs::write(dir.join("orig.gltf"), v.to_string()).unwrap();
    let a = Mesh::load(&dir.join("orig.gltf")).unwrap();
    let b = Mesh::load(&dir.join("plain.gltf")).unwrap();
    assert_eq!(a.positions.len(), b.positions.len());
    let m = &v["nodes"][0]["matrix"];
    assert!(m.is_array(), "expected a matrix on the root node");
    let cols: Vec<f64> = m
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let mat = glam::DMat4::from_cols_slice(&cols);
    for (p, q) in a.positions.iter().zip(&b.positions) {
        assert!(close(*p, mat.transform_point3(*q), 1e-6), "{p} vs {q}");
    }
    assert!(
        a.positions
            .iter()
            .zip(&b.positions)
            .any(|(p, q)| !close(*p, *q, 1e-6))
    );
}

#[test]
fn obj_polylines_negative_indices_and_missing_mtl() {
    let text = "mtllib does-not-exist.mtl\nusemtl red\n\
                v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n\
                f 1 2 3 4 5\n\
                l 1 2 3 4\n\
                l -1 -2\n\
                f -5 -4 -1\n\
                p 1 2\n";
    let m = obj::parse_str(text, "poly.obj").unwrap();
    // Pentagon fan: 3 triangles (one degenerate? no: it is a non-planar fan),
    // plus the negative-index face.
    assert_triangles(&m, 4);
    assert_eq!(
        m.polylines.len(),
        2,
        "a 4-vertex `l` is a polyline, not a quad"
    );
    let pts = |l: &Vec<u32>| -> Vec<DVec3> { l.iter().map(|&i| m.positions[i as usize]).collect() };
    assert_eq!(
        pts(&m.polylines[0]),
        vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]
    );
    assert_eq!(pts(&m.polylines[1]), vec![DVec3::Z, DVec3::Y]);
    assert_eq!(m.summary.polyline_segments, 4);
    assert_eq!(m.summary.skipped_points, 2);
    // The negative-index face is (v1, v2, v5).
    let last = m.triangle(m.triangles.len() - 1);
    assert_eq!(last, [DVec3::ZERO, DVec3::X, DVec3::Z]);
}

#[test]
fn obj_lines_only_and_degenerates() {
    let m = obj::parse_str("v 0 0 0\nv 1 2 3\nl 1 2\n", "l.obj").unwrap();
    assert!(m.triangles.is_empty());
    assert_eq!(m.polylines, vec![vec![0, 1]]);
    // Repeated index and collinear (zero area) triangles are skipped + counted.
    let m = obj::parse_str(
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 4\nf 1 2 4\n",
        "d.obj",
    )
    .unwrap();
    assert_eq!(m.triangles.len(), 1);
    assert_eq!(m.summary.degenerate_triangles, 2);
}

fn invalid_msg(r: voxkit::Result<Mesh>) -> String {
    match r {
        Err(VoxkitError::Invalid(m)) => m,
        other => panic!("expected Invalid, got {other:?}"),
    }
}

#[test]
fn bad_obj_files_give_typed_errors() {
    let dir = temp_dir("badobj");
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "nan.obj",
            "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n",
            &["line 3", "vertex 3", "non-finite"],
        ),
        (
            "inf.obj",
            "v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n",
            &["line 2", "non-finite"],
        ),
        (
            "index.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n",
            &["line 5", "index 9", "3 vertices"],
        ),
        (
            "zero.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
            &["line 4", "index 0"],
        ),
        (
            "negative.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
            &["line 4", "-4"],
        ),
        (
            "empty.obj",
            "# nothing\nv 0 0 0\nv 1 0 0\n",
            &["empty mesh"],
        ),
        (
            "alldegenerate.obj",
            "v 0 0 0\nv 1 0 0\nf 1 2 2\n",
            &["empty mesh"],
        ),
        (
            "truncated.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2",
            &["line 5", "face has 2 vertices"],
        ),
        (
            "truncv.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1",
            &["line 3", "3 coordinates"],
        ),
        (
            "garbage.obj",
            "v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n",
            &["line 3", "`x`"],
        ),
    ];
    for (name, text, needles) in cases {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        let msg = invalid_msg(Mesh::load(&p));
        assert!(msg.contains(name), "{name}: {msg}");
        for n in *needles {
            assert!(msg.contains(n), "{name}: {msg:?} lacks {n:?}");
        }
    }
    // Truncating a real file in the middle of a face line.
    let full = std::fs::read_to_string(data("obj/spot.obj")).unwrap();
    let cut = full.rfind("\nf ").unwrap() + 5;
    let p = dir.join("spot-cut.obj");
    std::fs::write(&p, &full[..cut]).unwrap();
    let msg = invalid_msg(Mesh::load(&p));
    assert!(msg.contains("face has"), "{msg}");
    // Unreadable: missing file is an I/O error naming the path; binary junk
    // is Invalid (no records in it: an empty mesh).
    match Mesh::load(&dir.join("missing.obj")) {
        Err(VoxkitError::Io { path, .. }) => assert!(path.ends_with("missing.obj")),
        other => panic!("{other:?}"),
    }
    std::fs::write(dir.join("bin.obj"), [0xff, 0xfe, 0x00, 0x80]).unwrap();
    assert!(invalid_msg(Mesh::load(&dir.join("bin.obj"))).contains("empty mesh"));
    // An extension no loader claims (.stl is one of ours now).
    assert!(matches!(
        Mesh::load(&dir.join("mesh.3ds")),
        Err(VoxkitError::Unsupported(_))
    ));
}

/// Standard base64 (for data URIs in generated glTF files).
fn base64(bytes: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(T[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A one-primitive glTF with a data-URI buffer: `positions` then u16
/// `indices`, drawn with `mode`; the node carries `node_extra` JSON fields.
fn tiny_gltf(positions: &[[f32; 3]], indices: &[u16], mode: u32, node_extra: &str) -> String {
    let mut buf = Vec::new();
    for p in positions {
        for c in p {
            buf.extend_from_slice(&c.to_le_bytes());
        }
    }
    let pos_len = buf.len();
    for i in indices {
        buf.extend_from_slice(&i.to_le_bytes());
    }
    while buf.len() % 4 != 0 {
        buf.push(0);
    }
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let fmt = |v: [f32; 3]| {
        let f = |x: f32| {
            if x.is_finite() {
                format!("{x:?}")
            } else {
                "0.0".into()
            }
        };
        format!("[{},{},{}]", f(v[0]), f(v[1]), f(v[2]))
    };
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"mesh":0{node_extra}}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":{mode}}}]}}],
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{pos_len}}},{{"buffer":0,"byteOffset":{pos_len},"byteLength":{}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":{},"max":{}}},
{{"bufferView":1,"componentType":5123,"count":{},"type":"SCALAR"}}]}}"#,
        buf.len(),
        base64(&buf),
        indices.len() * 2,
        positions.len(),
        fmt(lo),
        fmt(hi),
        indices.len()
    )
}

const SQUARE: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]];

#[test]
fn gltf_modes_and_transforms_from_data_uris() {
    let dir = temp_dir("gltfmodes");
    let load = |name: &str, text: String| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        Mesh::load(&p)
    };
    // Strip 0 1 2 3 -> two triangles; translation applied.
    let m = load(
        "strip.gltf",
        tiny_gltf(&SQUARE, &[0, 1, 2, 3], 5, r#","translation":[10,0,0]"#),
    )
    .unwrap();
    assert_eq!(m.triangles.len(), 2);
    assert_eq!(
        m.bounds(),
        (DVec3::new(10., 0., 0.), DVec3::new(11., 1., 0.))
    );
    // Fan 0 1 3 2 -> two triangles.
    let m = load("fan.gltf", tiny_gltf(&SQUARE, &[0, 1, 3, 2], 6, "")).unwrap();
    assert_eq!(m.triangles.len(), 2);
    // Line strip -> one polyline; line loop closes; lines -> pairs.
    let m = load("strip.gltf2.gltf", tiny_gltf(&SQUARE, &[0, 1, 3, 2], 3, "")).unwrap();
    assert_eq!(m.polylines.len(), 1);
    assert_eq!(m.polylines[0].len(), 4);
    let m = load("loop.gltf", tiny_gltf(&SQUARE, &[0, 1, 3, 2], 2, "")).unwrap();
    assert_eq!(m.polylines[0].len(), 5);
    assert_eq!(m.polylines[0][0], m.polylines[0][4]);
    let m = load("lines.gltf", tiny_gltf(&SQUARE, &[0, 1, 3, 2], 1, "")).unwrap();
    assert_eq!(m.polylines.len(), 2);
    // Points only: skipped and counted, leaving an empty mesh (an error).
    let msg = invalid_msg(load("points.gltf", tiny_gltf(&SQUARE, &[0, 1, 2], 0, "")));
    assert!(msg.contains("empty mesh"), "{msg}");
    // Scale and rotation (90 degrees about z) composed in TRS order.
    let m = load(
        "trs.gltf",
        tiny_gltf(
            &SQUARE,
            &[0, 1, 2],
            4,
            r#","scale":[2,2,2],"rotation":[0,0,0.70710678,0.70710678],"translation":[0,0,5]"#,
        ),
    )
    .unwrap();
    let t = m.triangle(0);
    assert!(close(t[1], DVec3::new(0., 2., 5.), 1e-6), "{}", t[1]);
    assert!(close(t[2], DVec3::new(-2., 0., 5.), 1e-6), "{}", t[2]);
}

#[test]
fn bad_gltf_files_give_typed_errors() {
    let dir = temp_dir("badgltf");
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    // Out-of-range index.
    let p = write(
        "index.gltf",
        tiny_gltf(&SQUARE, &[0, 1, 7], 4, "").as_bytes(),
    );
    let msg = invalid_msg(Mesh::load(&p));
    assert!(
        msg.contains("index.gltf") && msg.contains("mesh 0 primitive 0"),
        "{msg}"
    );
    assert!(msg.contains("is 7") && msg.contains("4 vertices"), "{msg}");
    // A triangle list whose index count is not a multiple of 3.
    let p = write(
        "ragged.gltf",
        tiny_gltf(&SQUARE, &[0, 1, 2, 3], 4, "").as_bytes(),
    );
    assert!(invalid_msg(Mesh::load(&p)).contains("not a multiple of 3"));
    // NaN coordinate.
    let nan = [[0., 0., 0.], [1., f32::NAN, 0.], [0., 1., 0.]];
    let p = write("nan.gltf", tiny_gltf(&nan, &[0, 1, 2], 4, "").as_bytes());
    let msg = invalid_msg(Mesh::load(&p));
    assert!(
        msg.contains("nan.gltf") && msg.contains("vertex 1") && msg.contains("non-finite"),
        "{msg}"
    );
    // Empty scene.
    let p = write(
        "empty.gltf",
        br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[]}]}"#,
    );
    assert!(invalid_msg(Mesh::load(&p)).contains("scene 0 is empty"));
    // Not JSON at all / truncated JSON.
    let full = std::fs::read(data("gltf/BoxTextured/BoxTextured.gltf")).unwrap();
    let p = write("cut.gltf", &full[..full.len() / 2]);
    assert!(invalid_msg(Mesh::load(&p)).contains("cut.gltf"));
    // Truncated external .bin.
    let src = data("gltf/BoxTextured");
    std::fs::write(dir.join("BoxTextured.gltf"), &full).unwrap();
    let bin = std::fs::read(src.join("BoxTextured0.bin")).unwrap();
    std::fs::write(dir.join("BoxTextured0.bin"), &bin[..bin.len() / 3]).unwrap();
    let msg = invalid_msg(Mesh::load(&dir.join("BoxTextured.gltf")));
    assert!(msg.contains("BoxTextured.gltf"), "{msg}");
    // Missing external .bin: an error, not a panic.
    std::fs::remove_file(dir.join("BoxTextured0.bin")).unwrap();
    assert!(Mesh::load(&dir.join("BoxTextured.gltf")).is_err());
    // Truncated GLB (header intact, chunks cut).
    let glb = std::fs::read(data("gltf/BoxTextured.glb")).unwrap();
    for cut in [glb.len() - 100, 700, 20, 3] {
        let p = write("cut.glb", &glb[..cut]);
        let msg = invalid_msg(Mesh::load(&p));
        assert!(msg.contains("cut.glb"), "{msg}");
    }
    // A buffer view that claims more bytes than the buffer has.
    let mut v: serde_json::Value =
        serde_json::from_str(&tiny_gltf(&SQUARE, &[0, 1, 2], 4, "")).unwrap();
    v["accessors"][0]["count"] = serde_json::json!(400);
    let p = write("overrun.gltf", v.to_string().as_bytes());
    let msg = invalid_msg(Mesh::load(&p));
    assert!(msg.contains("accessor 0"), "{msg}");
}

#[test]
fn fitting_rule_on_fandisk_keeps_max_face_vertices() {
    let m = Mesh::load(&data("obj/fandisk.obj")).unwrap();
    let (lo, hi) = m.bounds();
    for n in [1, 7, 64, 255, 1000] {
        let f = fit_frame(m.bounds(), n).unwrap();
        let ext = hi - lo;
        // Longest side (y: 5.24) spans exactly n voxels; others ceil.
        assert_eq!(f.dims[1], n as usize);
        assert_eq!(f.origin, lo);
        for a in [0, 2] {
            let want = (ext[a] / ext[1] * n as f64).ceil().max(1.0) as usize;
            assert_eq!(f.dims[a], want, "n={n} axis {a}");
        }
        let mut on_max_z = 0;
        for p in &m.positions {
            let g = f.world_to_grid(*p);
            let v = fitted_voxel(&f, g);
            assert!(f.contains(v), "n={n}: {p} -> {v}");
            // Away from the max faces the rule is plain floor(g + 0.5).
            if p.z < hi.z && p.y < hi.y && p.x < hi.x {
                assert_eq!(v, f.voxel_of_world(*p));
            }
            if p.x == 0.0 {
                assert_eq!(v.x, 0, "min face x = 0 lands in voxel 0");
            }
            if p.z == 0.0 {
                // On the max z face: plain rounding would give dims (outside),
                // the fitted rule keeps it in the last voxel.
                on_max_z += 1;
                assert_eq!(v.z, f.dims[2] as i32 - 1);
            }
        }
        assert!(on_max_z > 0);
    }
    // Padding moves the origin and grows the dims; max-face vertices land
    // inside by plain rounding.
    let f = fit_frame_padded(m.bounds(), 64, 2).unwrap();
    assert_eq!(f.dims[1], 68);
    for p in &m.positions {
        let v = f.voxel_of_world(*p);
        assert!(f.contains(v));
        assert!(v.min_element() >= 2 && (0..3).all(|a| v[a] < f.dims[a] as i32 - 1));
    }
    // Degenerate bounds are errors.
    assert!(fit_frame((DVec3::ONE, DVec3::ONE), 10).is_err());
    assert!(fit_frame((DVec3::ZERO, DVec3::ONE), 0).is_err());
    assert!(fit_frame((DVec3::ZERO, DVec3::splat(f64::NAN)), 10).is_err());
    // A flat mesh gets one voxel on its flat axis.
    let flat = fit_frame((DVec3::ZERO, DVec3::new(1.0, 2.0, 0.0)), 4).unwrap();
    assert_eq!(flat.dims, [2, 4, 1]);
}
