//! PLY, STL and OFF: files written here from the bundled OBJ meshes load to
//! the OBJ's triangles and voxelize to the OBJ's voxels; malformed variants
//! (every truncation, header counts beyond the data, bad magic, NaN, bad
//! indices, short faces, non-UTF-8 text, empty meshes) are typed errors and
//! never panics; a panic inside a dependency (the gltf validator) is
//! contained, also on the command line (exit 2, one stderr line).
//!
//! Precision: OFF and ascii PLY are written with Rust's shortest round-trip
//! `f64` text and PLY `double` as bytes, so positions must be *equal* to the
//! OBJ's. STL and PLY `float` store f32: there the oracle is the OBJ mesh
//! with its positions rounded to f32.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::scratch::temp_dir;
use glam::{DQuat, DVec3};
use proptest::prelude::*;
use proptest::test_runner::{Config as ProptestConfig, RngSeed};
use voxkit::VoxkitError;
use voxkit::mesh::{Mesh, gltf, off, ply, stl};
use voxkit::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, voxelize_mesh};
use voxkit::voxelize::shapes::IndexedMesh;

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/meshes")
        .join(rel)
}

// ---------------------------------------------------------------- writers

/// Polygons of a mesh as written: its triangles.
fn polys(m: &Mesh) -> Vec<Vec<u32>> {
    m.triangles.iter().map(|t| t.to_vec()).collect()
}

fn write_off(p: &[DVec3], faces: &[Vec<u32>]) -> Vec<u8> {
    let mut s = format!(
        "OFF\n# written by the test\n{} {} 0\n",
        p.len(),
        faces.len()
    );
    for v in p {
        s += &format!("{:?} {:?} {:?}\n", v.x, v.y, v.z);
    }
    for f in faces {
        s += &f.len().to_string();
        for i in f {
            s += &format!(" {i}");
        }
        s += "\n";
    }
    s.into_bytes()
}

#[derive(Clone, Copy, Debug)]
enum PlyEnc {
    Ascii,
    Le,
    Be,
}

/// PLY with an extra per-vertex property (a colour, ignored) and an extra
/// element (ignored); `double` chooses the coordinate type.
fn write_ply(p: &[DVec3], faces: &[Vec<u32>], enc: PlyEnc, double: bool) -> Vec<u8> {
    let (fmt, ty) = (
        match enc {
            PlyEnc::Ascii => "ascii",
            PlyEnc::Le => "binary_little_endian",
            PlyEnc::Be => "binary_big_endian",
        },
        if double { "double" } else { "float" },
    );
    let mut out = format!(
        "ply\nformat {fmt} 1.0\ncomment written by the test\nelement vertex {}\n\
         property {ty} x\nproperty {ty} y\nproperty {ty} z\nproperty uchar red\n\
         element face {}\nproperty list uchar int vertex_indices\n\
         element extra 1\nproperty short tag\nend_header\n",
        p.len(),
        faces.len()
    )
    .into_bytes();
    let num = |out: &mut Vec<u8>, x: f64| match (enc, double) {
        (PlyEnc::Ascii, true) => out.extend(format!("{x:?} ").bytes()),
        (PlyEnc::Ascii, false) => out.extend(format!("{:?} ", x as f32).bytes()),
        (PlyEnc::Le, true) => out.extend(x.to_le_bytes()),
        (PlyEnc::Le, false) => out.extend((x as f32).to_le_bytes()),
        (PlyEnc::Be, true) => out.extend(x.to_be_bytes()),
        (PlyEnc::Be, false) => out.extend((x as f32).to_be_bytes()),
    };
    for v in p {
        for c in v.to_array() {
            num(&mut out, c);
        }
        match enc {
            PlyEnc::Ascii => out.extend(b"7\n"),
            _ => out.push(7),
        }
    }
    for f in faces {
        match enc {
            PlyEnc::Ascii => {
                let mut s = f.len().to_string();
                for i in f {
                    s += &format!(" {i}");
                }
                out.extend(s.bytes());
                out.push(b'\n');
            }
            PlyEnc::Le => {
                out.push(f.len() as u8);
                f.iter().for_each(|i| out.extend((*i as i32).to_le_bytes()));
            }
            PlyEnc::Be => {
                out.push(f.len() as u8);
                f.iter().for_each(|i| out.extend((*i as i32).to_be_bytes()));
            }
        }
    }
    match enc {
        PlyEnc::Ascii => out.extend(b"-3\n"),
        PlyEnc::Le => out.extend((-3i16).to_le_bytes()),
        PlyEnc::Be => out.extend((-3i16).to_be_bytes()),
    }
    out
}

/// Binary STL; the header starts with "solid" as some exporters write it.
fn write_stl_binary(p: &[DVec3], tris: &[[u32; 3]]) -> Vec<u8> {
    let mut out = b"solid written by the test".to_vec();
    out.resize(80, b' ');
    out.extend((tris.len() as u32).to_le_bytes());
    for t in tris {
        out.extend([0f32; 3].iter().flat_map(|c| c.to_le_bytes()));
        for &i in t {
            for c in p[i as usize].to_array() {
                out.extend((c as f32).to_le_bytes());
            }
        }
        out.extend([0u8; 2]);
    }
    out
}

/// Ascii STL (shortest round-trip f32 text); `bare` writes `solid` without
/// a name, as some exporters do.
fn write_stl_ascii(p: &[DVec3], tris: &[[u32; 3]], bare: bool) -> Vec<u8> {
    let mut s = String::from(if bare { "solid\n" } else { "solid test\n" });
    for t in tris {
        s += "  facet normal 0 0 1\n    outer loop\n";
        for &i in t {
            // `{:?}` prints the shortest text that reads back to the same f64.
            let v = p[i as usize];
            s += &format!("      vertex {:?} {:?} {:?}\n", v.x, v.y, v.z);
        }
        s += "    endloop\n  endfacet\n";
    }
    s += if bare {
        "endsolid\n"
    } else {
        "endsolid test\n"
    };
    s.into_bytes()
}

// ---------------------------------------------------------------- oracles

/// The mesh with its positions rounded to f32 (what an f32 format holds).
fn rounded_f32(m: &Mesh) -> Mesh {
    let p = m.positions.iter().map(|v| v.as_vec3().as_dvec3()).collect();
    Mesh::from_parts("f32", p, m.triangles.clone(), Vec::new()).unwrap()
}

/// Same triangles corner by corner, in the same order (indices may differ).
fn assert_same_triangles(a: &Mesh, b: &Mesh, what: &str) {
    assert_eq!(
        a.triangles.len(),
        b.triangles.len(),
        "{what}: triangle count"
    );
    for t in 0..a.triangles.len() {
        assert_eq!(a.triangle(t), b.triangle(t), "{what}: triangle {t}");
    }
}

fn voxels(m: &Mesh, mode: VoxelizeMode) -> (Vec<voxkit::grid::Voxel>, String, Option<usize>) {
    let v = voxelize_mesh(m, &VoxelizeOptions::new(64, mode)).unwrap();
    let frame = format!(
        "{:?} {} {:?}",
        v.frame.origin, v.frame.voxel_size, v.frame.dims
    );
    let caps = v.stats.solid.as_ref().map(|s| s.caps);
    (v.grid.iter().collect(), frame, caps)
}

fn obj(rel: &str) -> Mesh {
    Mesh::load(&data(rel)).unwrap()
}

// ---------------------------------------------------------------- round trips

/// Every encoding of spot and the bunny loads to the OBJ's mesh and
/// voxelizes to the OBJ's voxels at -r 64.
#[test]
fn converted_bundled_meshes_match_the_obj() {
    for rel in ["obj/spot.obj", "obj/stanford-bunny.obj"] {
        let m = obj(rel);
        let m32 = rounded_f32(&m);
        let (want, want_frame, _) = voxels(&m, VoxelizeMode::Thin);
        let (want32, want32_frame, _) = voxels(&m32, VoxelizeMode::Thin);
        let faces = polys(&m);

        // f64 formats: exactly the OBJ's mesh.
        let exact: Vec<(&str, Vec<u8>, Parse)> = vec![
            ("off", write_off(&m.positions, &faces), off::parse),
            (
                "ply ascii double",
                write_ply(&m.positions, &faces, PlyEnc::Ascii, true),
                ply::parse,
            ),
            (
                "ply le double",
                write_ply(&m.positions, &faces, PlyEnc::Le, true),
                ply::parse,
            ),
            (
                "ply be double",
                write_ply(&m.positions, &faces, PlyEnc::Be, true),
                ply::parse,
            ),
        ];
        for (what, bytes, parse) in exact {
            let what = format!("{rel} as {what}");
            let got = parse(&bytes, &what).unwrap();
            assert_eq!(got.positions, m.positions, "{what}");
            assert_eq!(got.triangles, m.triangles, "{what}");
            let (v, frame, _) = voxels(&got, VoxelizeMode::Thin);
            assert_eq!(frame, want_frame, "{what}");
            assert!(v == want, "{what}: voxels differ");
        }

        // f32 formats: the OBJ's mesh rounded to f32.
        let single: Vec<(&str, Vec<u8>, Parse)> = vec![
            (
                "ply ascii float",
                write_ply(&m.positions, &faces, PlyEnc::Ascii, false),
                ply::parse,
            ),
            (
                "ply le float",
                write_ply(&m.positions, &faces, PlyEnc::Le, false),
                ply::parse,
            ),
            (
                "ply be float",
                write_ply(&m.positions, &faces, PlyEnc::Be, false),
                ply::parse,
            ),
            (
                "stl binary",
                write_stl_binary(&m.positions, &m.triangles),
                stl::parse,
            ),
        ];
        for (what, bytes, parse) in single {
            let what = format!("{rel} as {what}");
            let got = parse(&bytes, &what).unwrap();
            assert_same_triangles(&got, &m32, &what);
            let (v, frame, _) = voxels(&got, VoxelizeMode::Thin);
            assert_eq!(frame, want32_frame, "{what}");
            assert!(v == want32, "{what}: voxels differ");
        }
        // Ascii STL is decimal text read as f64: the OBJ's triangles exactly
        // (corners merged, so vertex order and count are STL's own).
        for bare in [false, true] {
            let what = format!("{rel} as stl ascii (bare: {bare})");
            let got =
                stl::parse(&write_stl_ascii(&m.positions, &m.triangles, bare), &what).unwrap();
            assert_same_triangles(&got, &m, &what);
            let (v, frame, _) = voxels(&got, VoxelizeMode::Thin);
            assert_eq!(frame, want_frame, "{what}");
            assert!(v == want, "{what}: voxels differ");
        }
        // The f32 oracle is not vacuous: rounding moved some vertex.
        assert_ne!(m32.positions, m.positions, "{rel}");
    }
}

/// STL merges bitwise-equal corners: the OBJ's shared vertices come back as
/// one each, so STL gives exactly as many vertices as the OBJ's distinct
/// f32 positions.
#[test]
fn stl_merges_coincident_corners() {
    let m = obj("obj/spot.obj");
    let got = stl::parse(&write_stl_binary(&m.positions, &m.triangles), "spot.stl").unwrap();
    let mut distinct: Vec<[u32; 3]> = m
        .positions
        .iter()
        .map(|v| v.as_vec3().to_array().map(|c| (c + 0.0).to_bits()))
        .collect();
    distinct.sort_unstable();
    distinct.dedup();
    assert_eq!(got.positions.len(), distinct.len());
    assert!(got.positions.len() < 3 * got.triangles.len());
    // -0.0 and 0.0 are one vertex.
    let two = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(-0.0, 0.0, -0.0),
        DVec3::new(0.0, 0.0, 1.0),
    ];
    let s = stl::parse(&write_stl_binary(&two, &[[0, 1, 2], [3, 4, 1]]), "z.stl").unwrap();
    assert_eq!(s.positions.len(), 4);
    assert_eq!(s.triangles[1][0], s.triangles[0][0]);
}

/// A closed STL cube (rotated, so no coordinate is round) is a closed mesh
/// for solid mode: 8 vertices, no caps, and the same voxels as the indexed
/// cube.
#[test]
fn closed_stl_cube_is_solid_without_caps() {
    let rot = DQuat::from_euler(glam::EulerRot::XYZ, 0.3, 0.7, 0.2);
    let cube = IndexedMesh::cuboid(DVec3::splat(-1.0), DVec3::splat(1.0))
        .transformed(rot, DVec3::new(0.25, -0.5, 3.0));
    let indexed = Mesh::from_parts(
        "cube",
        cube.vertices
            .iter()
            .map(|v| v.as_vec3().as_dvec3())
            .collect(),
        cube.faces.clone(),
        Vec::new(),
    )
    .unwrap();
    for (what, bytes) in [
        (
            "binary",
            write_stl_binary(&indexed.positions, &indexed.triangles),
        ),
        (
            "ascii",
            write_stl_ascii(&indexed.positions, &indexed.triangles, false),
        ),
    ] {
        let m = stl::parse(&bytes, what).unwrap();
        assert_eq!(m.positions.len(), 8, "{what}");
        let (v, _, caps) = voxels(&m, VoxelizeMode::Solid);
        assert_eq!(caps, Some(0), "{what}");
        let (want, _, _) = voxels(&indexed, VoxelizeMode::Solid);
        assert!(v == want, "{what}");
    }
    // The check can fail: the same STL with one triangle left out is open,
    // and solid mode caps its hole.
    let open = write_stl_binary(&indexed.positions, &indexed.triangles[1..]);
    let (_, _, caps) = voxels(&stl::parse(&open, "open").unwrap(), VoxelizeMode::Solid);
    assert!(caps.unwrap() > 0);
}

/// Mesh::load dispatches by extension (any case); PLY and OFF polygons are
/// fan-triangulated.
#[test]
fn load_dispatches_and_fans_polygons() {
    let dir = temp_dir("dispatch");
    let quad = [
        DVec3::ZERO,
        DVec3::X,
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::Y,
        DVec3::new(0.5, 0.5, 1.0),
    ];
    let faces = vec![vec![0, 1, 2, 3], vec![0, 1, 4]];
    let fan = vec![[0, 1, 2], [0, 2, 3], [0, 1, 4]];
    for (file, bytes) in [
        ("q.off", write_off(&quad, &faces)),
        ("Q.PLY", write_ply(&quad, &faces, PlyEnc::Le, true)),
    ] {
        let p = dir.join(file);
        std::fs::write(&p, bytes).unwrap();
        let m = Mesh::load(&p).unwrap();
        assert_eq!(m.triangles, fan, "{file}");
        assert_eq!(m.positions, quad, "{file}");
    }
    let p = dir.join("t.Stl");
    std::fs::write(&p, write_stl_binary(&quad, &[[0, 1, 2], [0, 2, 3]])).unwrap();
    assert_eq!(Mesh::load(&p).unwrap().triangles.len(), 2);
    // A missing file is an I/O error naming it, for every format.
    for ext in ["ply", "stl", "off"] {
        let p = dir.join(format!("missing.{ext}"));
        match Mesh::load(&p) {
            Err(VoxkitError::Io { path, .. }) => assert_eq!(path, p),
            other => panic!("{ext}: {other:?}"),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------- malformed input

fn small() -> (Vec<DVec3>, Vec<Vec<u32>>) {
    let p = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.5, 0.0, 0.0),
        DVec3::new(0.0, 2.0, 0.0),
        DVec3::new(0.0, 0.0, -1.25),
    ];
    let f = vec![vec![0, 2, 1], vec![0, 1, 3], vec![1, 2, 3], vec![0, 3, 2]];
    (p, f)
}

type Parse = fn(&[u8], &str) -> voxkit::Result<Mesh>;

/// Every small test file in every format, with its parser.
fn small_files() -> Vec<(&'static str, Vec<u8>, Parse)> {
    let (p, f) = small();
    let tris: Vec<[u32; 3]> = f.iter().map(|f| [f[0], f[1], f[2]]).collect();
    vec![
        ("off", write_off(&p, &f), off::parse),
        (
            "ply ascii",
            write_ply(&p, &f, PlyEnc::Ascii, false),
            ply::parse,
        ),
        ("ply le", write_ply(&p, &f, PlyEnc::Le, true), ply::parse),
        ("ply be", write_ply(&p, &f, PlyEnc::Be, false), ply::parse),
        ("stl binary", write_stl_binary(&p, &tris), stl::parse),
        ("stl ascii", write_stl_ascii(&p, &tris, true), stl::parse),
    ]
}

/// Every prefix of every small file is an error or a mesh, never a panic;
/// a prefix never yields more than the whole file.
#[test]
fn every_truncation_is_handled() {
    for (what, bytes, parse) in small_files() {
        let whole = parse(&bytes, what).unwrap();
        assert_eq!(whole.triangles.len(), 4, "{what}");
        for n in 0..bytes.len() {
            match parse(&bytes[..n], what) {
                Ok(m) => assert!(m.triangles.len() <= 4, "{what} at {n}"),
                Err(VoxkitError::Invalid(_) | VoxkitError::Unsupported(_)) => {}
                Err(e) => panic!("{what} cut at {n}: unexpected error kind {e:?}"),
            }
        }
        assert!(parse(&[], what).is_err(), "{what}");
    }
}

/// Single-byte changes at every offset: typed results, never a panic.
#[test]
fn every_byte_flip_is_handled() {
    for (what, bytes, parse) in small_files() {
        for i in 0..bytes.len() {
            for b in [0u8, 0xff, b'9', b'-', b'\n', b' '] {
                let mut v = bytes.clone();
                v[i] = b;
                let _ = parse(&v, what);
            }
        }
    }
}

fn invalid(r: voxkit::Result<Mesh>, needle: &str) {
    match r {
        Err(VoxkitError::Invalid(msg)) => assert!(msg.contains(needle), "{msg:?} lacks {needle:?}"),
        other => panic!("expected Invalid containing {needle:?}, got {other:?}"),
    }
}

/// Header counts beyond the data fail before allocation: 10^12 vertices,
/// 2^32 - 1 STL triangles, huge face and list counts.
#[test]
fn header_counts_beyond_the_data_are_errors() {
    let (p, f) = small();
    for enc in [PlyEnc::Ascii, PlyEnc::Le, PlyEnc::Be] {
        let b = write_ply(&p, &f, enc, true);
        let text = |from: &str, to: &str| {
            let mut out = b.clone();
            let at = find(&b, from.as_bytes());
            out.splice(at..at + from.len(), to.bytes());
            out
        };
        invalid(
            ply::parse(&text("vertex 4", "vertex 1000000000000"), "big.ply"),
            "1000000000000 `vertex` elements need at least",
        );
        invalid(
            ply::parse(&text("face 4", "face 18446744073709551615"), "big.ply"),
            "`face` elements",
        );
        // A count beyond usize is a header error, not a wrap-around.
        assert!(ply::parse(&text("face 4", "face 99999999999999999999999"), "b.ply").is_err());
        // Five faces announced, four present.
        assert!(ply::parse(&text("face 4", "face 5"), "b.ply").is_err());
        // Negative counts do not parse.
        assert!(ply::parse(&text("vertex 4", "vertex -4"), "b.ply").is_err());
    }
    // A list count far beyond the data (binary: uchar 4 → 0xff; a uint
    // count of 2^32 - 1 in its own file).
    let mut b = write_ply(&p, &f, PlyEnc::Le, true);
    let faces_at = find(&b, b"end_header\n") + 11 + 4 * (3 * 8 + 1);
    assert_eq!(b[faces_at], 3);
    b[faces_at] = 0xff;
    assert!(ply::parse(&b, "list.ply").is_err());
    let mut b = String::from_utf8(write_ply(&p, &f, PlyEnc::Ascii, true))
        .unwrap()
        .replace("list uchar int", "list uint int")
        .into_bytes();
    let at = find(&b, b"\n3 0 2 1\n") + 1;
    b.splice(at..at + 1, b"4294967295".iter().copied());
    assert!(ply::parse(&b, "list.ply").is_err());

    let tris: Vec<[u32; 3]> = f.iter().map(|f| [f[0], f[1], f[2]]).collect();
    let mut s = write_stl_binary(&p, &tris);
    s[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
    invalid(stl::parse(&s, "big.stl"), "claims 4294967295 triangles");
    s[80..84].copy_from_slice(&5u32.to_le_bytes());
    invalid(stl::parse(&s, "five.stl"), "claims 5 triangles");

    let o = String::from_utf8(write_off(&p, &f)).unwrap();
    invalid(
        off::parse(
            o.replace("4 4 0", "1000000000000 4 0").as_bytes(),
            "big.off",
        ),
        "need at least",
    );
    invalid(
        off::parse(o.replace("4 4 0", "4 99999999999 0").as_bytes(), "big.off"),
        "need at least",
    );
    invalid(
        off::parse(o.replace("4 4 0", "4 5 0").as_bytes(), "five.off"),
        "ends after 4 of 5 faces",
    );
    invalid(
        off::parse(o.replace("4 4 0", "-4 4 0").as_bytes(), "neg.off"),
        "not a non-negative integer",
    );
    invalid(
        off::parse(o.replace("3 0 2 1", "4000000000 0 2 1").as_bytes(), "k.off"),
        "announces 4000000000 vertices but lists 3",
    );
}

fn find(hay: &[u8], needle: &[u8]) -> usize {
    hay.windows(needle.len())
        .position(|w| w == needle)
        .unwrap_or_else(|| panic!("{:?} not found", String::from_utf8_lossy(needle)))
}

/// Bad magic, NaN, indices out of range and negative, faces with fewer than
/// three vertices, non-UTF-8 text, empty meshes, point clouds.
#[test]
fn malformed_files_are_typed_errors() {
    let (p, f) = small();
    // Bad magic.
    let mut b = write_ply(&p, &f, PlyEnc::Le, true);
    b[..3].copy_from_slice(b"plx");
    invalid(ply::parse(&b, "m.ply"), "PLY header");
    invalid(stl::parse(b"hello", "m.stl"), "not an STL file");
    invalid(
        off::parse(b"OFX\n3 1 0\n", "m.off"),
        "expected the OFF header",
    );
    assert!(matches!(
        off::parse(b"4OFF\n", "m.off"),
        Err(VoxkitError::Unsupported(_))
    ));
    assert!(matches!(
        off::parse(b"OFF BINARY\n", "m.off"),
        Err(VoxkitError::Unsupported(_))
    ));

    // NaN coordinates.
    let mut nan = p.clone();
    nan[2].y = f64::NAN;
    invalid(
        ply::parse(&write_ply(&nan, &f, PlyEnc::Be, false), "n.ply"),
        "vertex 2 has a non-finite",
    );
    // ply-rs-bw's ascii grammar has no NaN literal: rejected while reading.
    invalid(
        ply::parse(&write_ply(&nan, &f, PlyEnc::Ascii, true), "n.ply"),
        "PLY element `vertex`",
    );
    invalid(
        off::parse(&write_off(&nan, &f), "n.off"),
        "vertex 2 has a non-finite",
    );
    let tris = [[0, 1, 2], [1, 2, 3]];
    invalid(
        stl::parse(&write_stl_binary(&nan, &tris), "n.stl"),
        "triangle 0 corner 2",
    );
    let inf = String::from_utf8(write_stl_ascii(&p, &tris, false))
        .unwrap()
        .replacen("vertex 0.0 0.0 0.0", "vertex 0.0 inf 0.0", 1);
    assert!(stl::parse(inf.as_bytes(), "i.stl").is_err());

    // Indices out of range, negative; faces with < 3 vertices.
    for (bad, needle) in [
        (vec![0, 1, 4], "vertex index 4, but there are 4 vertices"),
        (vec![0, 1], "2 vertices"),
    ] {
        let mut g = f.clone();
        g[1] = bad;
        for enc in [PlyEnc::Ascii, PlyEnc::Le, PlyEnc::Be] {
            invalid(
                ply::parse(&write_ply(&p, &g, enc, true), "i.ply"),
                "PLY face 1",
            );
            invalid(ply::parse(&write_ply(&p, &g, enc, true), "i.ply"), needle);
        }
    }
    let mut g = f.clone();
    g[2] = vec![0, u32::MAX, 2]; // written as the int -1
    invalid(
        ply::parse(&write_ply(&p, &g, PlyEnc::Le, true), "neg.ply"),
        "negative vertex index -1",
    );
    let o = String::from_utf8(write_off(&p, &f)).unwrap();
    invalid(
        off::parse(o.replace("3 1 2 3", "3 1 2 4").as_bytes(), "o.off"),
        "vertex index 4",
    );
    invalid(
        off::parse(o.replace("3 1 2 3", "3 1 -2 3").as_bytes(), "o.off"),
        "vertex index -2",
    );
    invalid(
        off::parse(o.replace("3 1 2 3", "2 1 2").as_bytes(), "o.off"),
        "face 2 has 2 vertices",
    );

    // Non-UTF-8 text.
    let mut b = o.clone().into_bytes();
    let at = find(&b, b"1.5");
    b[at] = 0xff;
    invalid(off::parse(&b, "u.off"), "not UTF-8");
    let mut b = write_ply(&p, &f, PlyEnc::Ascii, true);
    let at = find(&b, b"1.5");
    b[at] = 0xff;
    assert!(ply::parse(&b, "u.ply").is_err());
    let mut b = write_stl_ascii(&p, &tris, false);
    let at = find(&b, b"1.5");
    b[at] = 0xff;
    assert!(stl::parse(&b, "u.stl").is_err());

    // Empty meshes and point clouds.
    invalid(
        ply::parse(&write_ply(&p, &[], PlyEnc::Le, true), "e.ply"),
        "empty mesh",
    );
    invalid(off::parse(&write_off(&p, &[]), "e.off"), "empty mesh");
    invalid(
        stl::parse(&write_stl_binary(&p, &[]), "e.stl"),
        "empty mesh",
    );
    invalid(stl::parse(b"solid x\nendsolid x\n", "e.stl"), "empty mesh");
    let cloud = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
        property float z\nend_header\n0 0 0\n";
    invalid(ply::parse(cloud, "c.ply"), "point cloud");
    // Every face degenerate: empty as well.
    invalid(
        off::parse(b"OFF\n3 1 0\n0 0 0\n1 1 1\n2 2 2\n3 0 1 2\n", "d.off"),
        "empty mesh",
    );
}

/// The format quirks real collections have: ModelNet's glued header, COFF
/// with colours, comments; STL with several solids; PLY with
/// `vertex_index`, `uint` and `ushort` lists and int coordinates.
#[test]
fn format_variants_seen_in_datasets() {
    let m = off::parse(
        b"# ModelNet\nOFF4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n",
        "glued.off",
    )
    .unwrap();
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 1, 3]]);
    let m = off::parse(
        b"COFF\n3 1 3\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255 # c\n3 0 1 2 9 9 9\n",
        "c.off",
    )
    .unwrap();
    assert_eq!(m.positions[2], DVec3::Y);

    let one = |z: f32| {
        format!(
            "solid part\nfacet normal 0 0 1\nouter loop\nvertex 0 0 {z}\nvertex 1 0 {z}\n\
             vertex 0 1 {z}\nendloop\nendfacet\nendsolid part\n"
        )
    };
    let two = one(0.0) + &one(1.0);
    assert_eq!(
        stl::parse(two.as_bytes(), "two.stl")
            .unwrap()
            .triangles
            .len(),
        2
    );
    assert!(stl::parse((two + "junk\n").as_bytes(), "junk.stl").is_err());

    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty int x\nproperty short y\n\
        property uchar z\nelement face 1\nproperty list uchar ushort vertex_index\nend_header\n\
        0 0 0\n2 0 0\n0 3 1\n3 0 1 2\n";
    let m = voxkit::mesh::ply::parse(ply, "int.ply").unwrap();
    assert_eq!(
        m.positions,
        vec![DVec3::ZERO, DVec3::new(2., 0., 0.), DVec3::new(0., 3., 1.)]
    );
    let (p, f) = small();
    let b = String::from_utf8(write_ply(&p, &f, PlyEnc::Ascii, true))
        .unwrap()
        .replace("list uchar int", "list int uint");
    assert_eq!(
        ply::parse(b.as_bytes(), "u.ply").unwrap().triangles.len(),
        4
    );
    // Both face list spellings at once is ambiguous.
    let both = b.replace(
        "vertex_indices\n",
        "vertex_indices\nproperty list uchar int vertex_index\n",
    );
    invalid(ply::parse(both.as_bytes(), "both.ply"), "both");
}

// ---------------------------------------------------------------- round-trip property

fn config(seed: u64, cases: u32) -> ProptestConfig {
    ProptestConfig {
        rng_seed: RngSeed::Fixed(seed),
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Random vertices and polygons (3 to 6 corners, indices may repeat).
fn polygon_soup() -> impl Strategy<Value = (Vec<DVec3>, Vec<Vec<u32>>)> {
    prop::collection::vec(prop::array::uniform3(-1e3f64..1e3), 3..24).prop_flat_map(|p| {
        let n = p.len() as u32;
        let faces = prop::collection::vec(prop::collection::vec(0..n, 3..7), 1..12);
        (Just(p.into_iter().map(DVec3::from_array).collect()), faces)
    })
}

/// The independent oracle: `Mesh::from_parts` over fans written out here.
fn fan_oracle(p: &[DVec3], faces: &[Vec<u32>]) -> voxkit::Result<Mesh> {
    let mut tris = Vec::new();
    for f in faces {
        for k in 1..f.len() - 1 {
            tris.push([f[0], f[k], f[k + 1]]);
        }
    }
    Mesh::from_parts("oracle", p.to_vec(), tris, Vec::new())
}

proptest! {
    #![proptest_config(config(0xF0_0016, 96))]

    /// Writing then parsing gives the oracle's mesh (both may be the empty
    /// mesh error when every fan triangle is degenerate).
    #[test]
    fn round_trip_equals_fan_oracle((p, faces) in polygon_soup()) {
        let want = fan_oracle(&p, &faces);
        let p32: Vec<DVec3> = p.iter().map(|v| v.as_vec3().as_dvec3()).collect();
        let want32 = fan_oracle(&p32, &faces);
        let cases: Vec<(&str, voxkit::Result<Mesh>, &voxkit::Result<Mesh>)> = vec![
            ("off", off::parse(&write_off(&p, &faces), "r.off"), &want),
            ("ply ascii", ply::parse(&write_ply(&p, &faces, PlyEnc::Ascii, true), "r.ply"), &want),
            ("ply le", ply::parse(&write_ply(&p, &faces, PlyEnc::Le, true), "r.ply"), &want),
            ("ply be f32", ply::parse(&write_ply(&p, &faces, PlyEnc::Be, false), "r.ply"), &want32),
        ];
        for (what, got, want) in cases {
            match (got, want) {
                (Ok(g), Ok(w)) => {
                    prop_assert_eq!(&g.positions, &w.positions, "{}", what);
                    prop_assert_eq!(&g.triangles, &w.triangles, "{}", what);
                    prop_assert_eq!(&g.summary, &w.summary, "{}", what);
                }
                (Err(_), Err(_)) => {}
                (g, w) => prop_assert!(false, "{}: {:?} vs {:?}", what, g.map(|m| m.triangles), w.as_ref().map(|m| m.triangles.clone())),
            }
        }
        // STL: triangles only, corners compared by position.
        if let Ok(w) = &want32 {
            let got = stl::parse(&write_stl_binary(&p32, &w.triangles), "r.stl").unwrap();
            prop_assert_eq!(got.triangles.len(), w.triangles.len());
            for t in 0..w.triangles.len() {
                prop_assert_eq!(got.triangle(t), w.triangle(t));
            }
        }
    }
}

// ---------------------------------------------------------------- panic containment

/// A GLB (version 2) from a JSON document and an optional binary chunk.
pub(crate) fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + if b.is_empty() { 0 } else { 8 + b.len() };
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    if !b.is_empty() {
        out.extend((b.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(b);
    }
    out
}

/// A triangle in a GLB; `position` is the POSITION accessor index.
fn triangle_glb(position: u32) -> Vec<u8> {
    let bin: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{position}}}}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
        "min":[0,0,0],"max":[1,1,0]}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],"buffers":[{{"byteLength":36}}]}}"#
    );
    glb(&json, &bin)
}

/// The gltf crate's validator indexes `accessors[i]` with the file's
/// POSITION index: out of range, it panics (regression: exit 101 before the
/// guard). Contained, it is a typed error naming the file and the crate.
#[test]
fn glb_validator_panic_is_a_typed_error() {
    let good = gltf::parse(&triangle_glb(0), None, "good.glb").unwrap();
    assert_eq!(good.triangles.len(), 1);
    invalid(
        gltf::parse(&triangle_glb(7), None, "bad.glb"),
        "bad.glb: the gltf reader failed on this input: index out of bounds",
    );
    // The same from many threads at once (batch mode reads in parallel).
    std::thread::scope(|s| {
        for _ in 0..8 {
            s.spawn(|| {
                for _ in 0..20 {
                    assert!(gltf::parse(&triangle_glb(7), None, "bad.glb").is_err());
                    assert!(gltf::parse(&triangle_glb(0), None, "good.glb").is_ok());
                }
            });
        }
    });
    // External buffers need a folder: none given is an error, the folder
    // that has the file reads it.
    let dir = temp_dir("gltf-ext");
    let bin: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(dir.join("tri.bin"), bin).unwrap();
    let json = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
        "min":[0,0,0],"max":[1,1,0]}],
        "bufferViews":[{"buffer":0,"byteLength":36}],"buffers":[{"byteLength":36,"uri":"tri.bin"}]}"#;
    assert!(gltf::parse(json.as_bytes(), None, "ext.gltf").is_err());
    let m = gltf::parse(json.as_bytes(), Some(&dir), "ext.gltf").unwrap();
    assert_eq!(m.triangles.len(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}

fn voxkit(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args(args)
        .output()
        .expect("voxkit runs")
}

/// On the command line a contained panic is exit 2 with exactly one line on
/// stderr (no "thread panicked" text) and no output file; so is a PLY
/// header with 10^12 vertices.
#[test]
fn cli_contained_panic_exits_2_with_one_line() {
    let dir = temp_dir("cli");
    let bad = dir.join("bad.glb");
    std::fs::write(&bad, triangle_glb(7)).unwrap();
    let big = dir.join("big.ply");
    std::fs::write(
        &big,
        b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n\
          property float x\nproperty float y\nproperty float z\nend_header\n",
    )
    .unwrap();
    for (input, needle) in [(&bad, "gltf reader failed"), (&big, "1000000000000")] {
        let out = dir.join("out.binvox");
        let o = voxkit(&[
            "voxelize",
            input.to_str().unwrap(),
            "-r",
            "16",
            "-o",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(needle) && !err.contains("panicked"), "{err}");
        assert!(!out.exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
