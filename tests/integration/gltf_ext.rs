//! glTF 2.0 beyond plain float triangles: sparse accessors (with and
//! without a base buffer view), `KHR_mesh_quantization` positions of every
//! component type (normalized or not, with the node scale that
//! dequantizes), `EXT_meshopt_compression` with and without uncompressed
//! fallback data, Draco and other required extensions refused in one line,
//! scenes without nodes, files without scenes. The answers are the
//! conformance corpus's (`tests/data/formats/vox_gltf_expected.json`): the
//! geometry `make_vox_gltf.py` encoded, before quantization or compression.

use std::path::{Path, PathBuf};

use glam::DVec3;
use voxkit::VoxkitError;
use voxkit::mesh::{Mesh, gltf};

use crate::mesh_formats::glb;

fn corpus(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/formats")
        .join(rel)
}

fn vec3(v: &serde_json::Value) -> DVec3 {
    let a: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    DVec3::new(a[0], a[1], a[2])
}

fn strings(v: &serde_json::Value) -> Vec<String> {
    v.as_array()
        .map(|a| a.iter().map(|s| s.as_str().unwrap().to_string()).collect())
        .unwrap_or_default()
}

/// Every corpus file loads with the encoded positions (1e-6 relative: the
/// node TRS is stored as f32, so a dequantizing scale of 1/127 is one f32
/// rounding away from the exact value the generator used),
/// the triangle count, and the warnings asked for; or is refused in one
/// short line containing the words asked for and no dependency dump.
#[test]
fn corpus_matches_its_answers() {
    let s = std::fs::read_to_string(corpus("vox_gltf_expected.json")).unwrap();
    let exp: serde_json::Value = serde_json::from_str(&s).unwrap();
    let files = exp["gltf"].as_object().unwrap();
    assert!(files.len() >= 20);
    for (name, want) in files {
        let path = corpus(&format!("gltf/{name}"));
        let r = Mesh::load(&path);
        if let Some(words) = want.get("error") {
            let e = r.err().unwrap_or_else(|| panic!("{name} loaded"));
            let msg = e.to_string();
            assert!(
                matches!(e, VoxkitError::Unsupported(_) | VoxkitError::Invalid(_)),
                "{name}: {msg}"
            );
            assert_eq!(msg.lines().count(), 1, "{name}: {msg}");
            let shown = path.display().to_string();
            assert!(msg.contains(&shown), "{name}: {msg}");
            // Short beside the path the user gave.
            assert!(
                msg.len() - shown.len() < 300,
                "{name}: {} chars: {msg}",
                msg.len()
            );
            for w in strings(words) {
                assert!(msg.contains(&w), "{name}: {w:?} not in {msg}");
            }
            for dump in [
                "accessors[",
                "Missing data",
                "{ ",
                "Error {",
                "Unsupported extension",
            ] {
                assert!(!msg.contains(dump), "{name}: {msg}");
            }
            continue;
        }
        let m = r.unwrap_or_else(|e| panic!("{name}: {e}"));
        let pos: Vec<DVec3> = want["positions"]
            .as_array()
            .unwrap()
            .iter()
            .map(vec3)
            .collect();
        assert_eq!(m.positions.len(), pos.len(), "{name}");
        for (i, (a, b)) in m.positions.iter().zip(&pos).enumerate() {
            assert!(
                (*a - *b).abs().max_element() <= 1e-6 * (1.0 + b.abs().max_element()),
                "{name}: vertex {i} is {a}, want {b}"
            );
        }
        assert_eq!(
            m.triangles.len() as u64,
            want["triangles"].as_u64().unwrap(),
            "{name}"
        );
        let w = strings(&want["warnings"]);
        for x in &w {
            assert!(
                m.summary.warnings.iter().any(|y| y.contains(x)),
                "{name}: {x:?} not in {:?}",
                m.summary.warnings
            );
        }
        assert_eq!(
            w.is_empty(),
            m.summary.warnings.is_empty(),
            "{name}: {:?}",
            m.summary.warnings
        );
    }
}

/// Every quantized component type read from a GLB, with a stride, every
/// representable value of the byte types and a sweep of the short ones:
/// each vertex equals the spec's dequantization (checked against the
/// formula written out here, per component, including the -1 clamp of the
/// most negative signed value).
#[test]
fn quantized_positions_of_every_type_and_value() {
    // (componentType, bytes, signed, max)
    for (ct, size, signed, max) in [
        (5120u32, 1usize, true, 127i64),
        (5121, 1, false, 255),
        (5122, 2, true, 32767),
        (5123, 2, false, 65535),
    ] {
        let lo = if signed { -max - 1 } else { 0 };
        let values: Vec<i64> = if size == 1 {
            (lo..=max).collect()
        } else {
            (lo..=max).step_by(97).chain([max]).collect()
        };
        // Triangles (v, v+1, v+2) of points (c, c', 0): only positions matter.
        let stride = if size == 1 { 4 } else { 8 };
        let n = values.len();
        let mut bin = Vec::new();
        for (k, &c) in values.iter().enumerate() {
            let c2 = values[(k * 7 + 3) % n];
            for v in [c, c2, if k % 3 == 0 { max } else { 0 }] {
                match size {
                    1 => bin.push(v as u8),
                    _ => bin.extend((v as u16).to_le_bytes()),
                }
            }
            bin.resize(bin.len() + stride - 3 * size, 0);
        }
        for normalized in [false, true] {
            let json = format!(
                r#"{{"asset":{{"version":"2.0"}},"extensionsRequired":["KHR_mesh_quantization"],
                "extensionsUsed":["KHR_mesh_quantization"],"scene":0,"scenes":[{{"nodes":[0]}}],
                "nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"mode":0}}]}}],
                "accessors":[{{"bufferView":0,"componentType":{ct},"count":{n},"type":"VEC3",
                "normalized":{normalized},"min":[{lo},{lo},0],"max":[{max},{max},{max}]}}],
                "bufferViews":[{{"buffer":0,"byteLength":{},"byteStride":{stride}}}],
                "buffers":[{{"byteLength":{}}}]}}"#,
                bin.len(),
                bin.len()
            );
            // POINTS: the loader reads the positions, then skips the points;
            // read them through a LINE_STRIP instead so they are kept.
            let json = json.replace(r#""mode":0"#, r#""mode":3"#);
            let m = gltf::parse(&glb(&json, &bin), None, "q.glb")
                .unwrap_or_else(|e| panic!("{ct} {normalized}: {e}"));
            assert_eq!(m.positions.len(), n);
            let deq = |c: i64| -> f64 {
                if !normalized {
                    c as f64
                } else if signed {
                    (c as f64 / max as f64).max(-1.0)
                } else {
                    c as f64 / max as f64
                }
            };
            for (k, (&c, p)) in values.iter().zip(&m.positions).enumerate() {
                let c2 = values[(k * 7 + 3) % n];
                let z = if k % 3 == 0 { max } else { 0 };
                assert_eq!(
                    *p,
                    DVec3::new(deq(c), deq(c2), deq(z)),
                    "{ct} {normalized} value {c}"
                );
            }
        }
    }
}

/// A sparse accessor on quantized (i16) positions, with u16 and u32 sparse
/// indices, with and without a base view: the crate's sparse iterator
/// substitutes the values, then the values are dequantized.
#[test]
fn sparse_quantized_positions() {
    for (with_base, index_ct) in [(true, 5123u32), (false, 5125), (true, 5125), (false, 5123)] {
        let base: [[i16; 3]; 4] = [[0, 0, 0], [100, 0, 0], [0, 100, 0], [5, 5, 100]];
        let mut bin: Vec<u8> = Vec::new();
        for p in base {
            for c in p {
                bin.extend(c.to_le_bytes());
            }
            bin.extend([0, 0]); // stride 8
        }
        let idx_off = bin.len();
        for i in [1u32, 3] {
            if index_ct == 5123 {
                bin.extend((i as u16).to_le_bytes());
            } else {
                bin.extend(i.to_le_bytes());
            }
        }
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let val_off = bin.len();
        for p in [[-300i16, 7, 9], [1, 2, -3]] {
            for c in p {
                bin.extend(c.to_le_bytes());
            }
        }
        let base_view = if with_base { r#""bufferView":0,"# } else { "" };
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"extensionsRequired":["KHR_mesh_quantization"],
            "scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"scale":[0.5,0.5,0.5]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
            "accessors":[{{{base_view}"componentType":5122,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,1],
              "sparse":{{"count":2,"indices":{{"bufferView":1,"componentType":{index_ct}}},
              "values":{{"bufferView":2}}}}}}],
            "bufferViews":[{{"buffer":0,"byteLength":32,"byteStride":8}},
              {{"buffer":0,"byteOffset":{idx_off},"byteLength":{}}},
              {{"buffer":0,"byteOffset":{val_off},"byteLength":12}}],
            "buffers":[{{"byteLength":{}}}]}}"#,
            val_off - idx_off,
            bin.len()
        );
        // Three vertices make no triangle with four: use LINES (two segments).
        let json = json.replace(
            r#""attributes":{"POSITION":0}"#,
            r#""attributes":{"POSITION":0},"mode":1"#,
        );
        let m = gltf::parse(&glb(&json, &bin), None, "s.glb").unwrap_or_else(|e| panic!("{e}"));
        let b = |p: [i16; 3]| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) * 0.5;
        let v0 = if with_base { b(base[0]) } else { DVec3::ZERO };
        let v2 = if with_base { b(base[2]) } else { DVec3::ZERO };
        assert_eq!(m.positions, vec![v0, b([-300, 7, 9]), v2, b([1, 2, -3])]);
    }
}

/// Sparse indices out of order, repeated or past the count, and views too
/// short for the sparse count, are one-line errors naming the accessor.
#[test]
fn broken_sparse_accessors_are_errors() {
    let make = |indices: [u8; 2], count: u32, sparse_count: u32| {
        let mut bin: Vec<u8> = Vec::new();
        bin.extend(indices);
        bin.extend([0, 0]);
        for v in [1f32, 2., 3., 4., 5., 6.] {
            bin.extend(v.to_le_bytes());
        }
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
            "accessors":[{{"componentType":5126,"count":{count},"type":"VEC3","min":[0,0,0],"max":[1,1,1],
              "sparse":{{"count":{sparse_count},"indices":{{"bufferView":0,"componentType":5121}},
              "values":{{"bufferView":1}}}}}}],
            "bufferViews":[{{"buffer":0,"byteLength":2}},{{"buffer":0,"byteOffset":4,"byteLength":24}}],
            "buffers":[{{"byteLength":28}}]}}"#
        );
        gltf::parse(&glb(&json, &bin), None, "bad.glb")
    };
    assert!(make([0, 2], 3, 2).is_ok());
    for (indices, count, sc, needle) in [
        ([2, 0], 3, 2, "increase strictly"),
        ([1, 1], 3, 2, "increase strictly"),
        ([0, 3], 3, 2, "below the count"),
        ([0, 1], 3, 3, "need"),
        ([0, 1], 3, 0, "sparse count 0"),
    ] {
        let e = make(indices, count, sc).unwrap_err().to_string();
        assert!(
            e.contains("accessor 0") && e.contains(needle),
            "{indices:?} {sc}: {e}"
        );
        assert_eq!(e.lines().count(), 1);
    }
}

/// The crate's validation report (every problem of a broken file, on one
/// line of thousands of characters before) is cut to its first problem.
#[test]
fn validation_errors_are_one_short_line() {
    let mut accessors = String::new();
    for i in 0..200 {
        if i > 0 {
            accessors.push(',');
        }
        accessors.push_str(r#"{"componentType":5126,"count":3,"type":"VEC3"}"#);
    }
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],"accessors":[{accessors}]}}"#
    );
    let e = gltf::parse(json.as_bytes(), None, "v.gltf")
        .unwrap_err()
        .to_string();
    assert_eq!(e.lines().count(), 1);
    assert!(e.len() < 200, "{e}");
    assert!(e.contains("more problems"), "{e}");
}
