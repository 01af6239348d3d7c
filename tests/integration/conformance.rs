//! Files other tools write (issue 23): lenient OBJ (continuations, CRLF,
//! Latin-1 bytes, broken or missing material libraries, partial vertex
//! colours), binvox headers with comments, NRRD with bzip2 (attached and
//! detached), 2-D images and 4-D volumes with a size-1 axis; one-line
//! refusals for bad PLY / STL / OFF / OBJ; ascii STL read as exact f64 and
//! as exporters write it; the CLI's warnings, a closed
//! stdout and `demo --help`. Each OBJ case is generated from one base mesh
//! and must give the base mesh's triangles; the parser is also checked
//! against tobj on random valid files.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

use crate::scratch::temp_dir;
use glam::DVec3;
use proptest::prelude::*;
use voxkit::VoxkitError;
use voxkit::grid::MemoryLimit;
use voxkit::io::read_voxels;
use voxkit::io::volume::read_volume;
use voxkit::mesh::{Mesh, obj, off, ply, stl};

/// The triangles of a mesh as corner coordinates, in order.
fn corners(m: &Mesh) -> Vec<[DVec3; 3]> {
    (0..m.triangles.len()).map(|t| m.triangle(t)).collect()
}

/// A cube (8 vertices, 6 quads, negative indices in half the faces).
const CUBE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf -8 -7 -3 -4\nf 2 3 7 6\nf -5 -1 -2 -6\nf 1 5 8 4\n";

fn cube() -> Mesh {
    obj::parse_str(CUBE, "cube.obj").unwrap()
}

#[test]
fn obj_base_cube_is_twelve_triangles() {
    let m = cube();
    assert_eq!(m.triangles.len(), 12);
    assert_eq!(m.bounds(), (DVec3::ZERO, DVec3::ONE));
    assert!(m.summary.warnings.is_empty());
}

#[test]
fn obj_crlf_and_continuations_give_the_same_mesh() {
    let want = corners(&cube());
    // CRLF line ends.
    let crlf = CUBE.replace('\n', "\r\n");
    assert_eq!(corners(&obj::parse_str(&crlf, "crlf.obj").unwrap()), want);
    // Every face split over lines with a backslash, LF and CRLF, with and
    // without a space before the backslash and trailing blanks after it.
    for (i, sep) in [" \\\n", "\\\n  ", " \\  \n", " \\\r\n", "\\\r\n\t"]
        .iter()
        .enumerate()
    {
        let cont: String = CUBE
            .lines()
            .map(|l| {
                if let Some(rest) = l.strip_prefix("f ") {
                    let w: Vec<&str> = rest.split(' ').collect();
                    format!("f {} {}{sep}{} {}\n", w[0], w[1], w[2], w[3])
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        let m = obj::parse_str(&cont, "cont.obj").unwrap_or_else(|e| panic!("{i}: {e}"));
        assert_eq!(corners(&m), want, "separator {sep:?}");
    }
    // A continued vertex record, and a backslash on the very last line.
    let v = CUBE.replacen("v 0 0 0\n", "v 0 \\\n0 \\\n0\n", 1);
    let end = format!("{}\nf 1 2 \\", v.trim_end());
    let m = obj::parse_str(&end, "end.obj").unwrap_err().to_string();
    assert!(m.contains("face has 2 vertices"), "{m}");
    assert_eq!(corners(&obj::parse_str(&v, "v.obj").unwrap()), want);
}

#[test]
fn obj_errors_name_the_first_line_of_a_continued_record() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \\\n 9\n";
    let m = obj::parse_str(text, "c.obj").unwrap_err().to_string();
    assert!(m.contains("c.obj: line 4:"), "{m}");
}

#[test]
fn obj_latin1_and_other_bytes_outside_geometry_are_ignored() {
    let want = corners(&cube());
    let mut bytes =
        b"# caf\xe9 export\nmtllib mat\xe9riaux.mtl\no Cub\xe9\ng gr\xfcn \xff\xfe\n".to_vec();
    for l in CUBE.lines() {
        if l.starts_with("f ") {
            bytes.extend_from_slice(b"usemtl rouge_\xe9t\xe9\n");
        }
        bytes.extend_from_slice(l.as_bytes());
        bytes.extend_from_slice(b"\n");
    }
    // Also invalid UTF-8 inside a trailing comment of a vertex line.
    bytes.extend_from_slice(b"v 9 9 9 # \xc3\x28\n");
    let dir = temp_dir("latin1");
    let p = dir.join("latin1.obj");
    std::fs::write(&p, &bytes).unwrap();
    let m = Mesh::load(&p).unwrap();
    assert_eq!(corners(&m), want);
    assert!(m.summary.warnings.is_empty(), "{:?}", m.summary.warnings);
    // A non-UTF-8 byte inside a number is still an error naming the line.
    let bad = b"v 0 0 0\nv 1 0 0\nv 0 1 \xe9\nf 1 2 3\n";
    let e = obj::parse(bad, "bad.obj").unwrap_err().to_string();
    assert!(
        e.contains("bad.obj: line 3:") && e.contains("coordinate"),
        "{e}"
    );
}

#[test]
fn obj_material_libraries_never_block_geometry() {
    let want = corners(&cube());
    let dir = temp_dir("mtl");
    // An empty `newmtl`, a broken library, a directory, a missing one.
    std::fs::write(dir.join("empty.mtl"), "newmtl\nKd 1 0 0\nnewmtl \n").unwrap();
    std::fs::write(
        dir.join("broken.mtl"),
        b"\xff\xfe\x00garbage Kd x y z\nmap_Kd\n",
    )
    .unwrap();
    std::fs::create_dir_all(dir.join("dir.mtl")).unwrap();
    for lib in ["empty.mtl", "broken.mtl", "dir.mtl", "missing.mtl", ""] {
        let text = format!("mtllib {lib}\nusemtl\nusemtl unknown\n{CUBE}");
        let p = dir.join(format!("with-{lib}.obj"));
        std::fs::write(&p, text).unwrap();
        let m = Mesh::load(&p).unwrap_or_else(|e| panic!("{lib}: {e}"));
        assert_eq!(corners(&m), want, "{lib}");
    }
}

#[test]
fn obj_partial_vertex_colours_load_with_one_warning() {
    let want = corners(&cube());
    let coloured: String = CUBE
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if l.starts_with("v ") && i % 3 == 0 {
                format!("{l} 0.5 0.25 1\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let m = obj::parse_str(&coloured, "colours.obj").unwrap();
    assert_eq!(corners(&m), want);
    assert_eq!(m.summary.warnings.len(), 1, "{:?}", m.summary.warnings);
    assert!(
        m.summary.warnings[0].contains("3 of 8"),
        "{:?}",
        m.summary.warnings
    );
    // All coloured: nothing ignored that a reader would miss.
    let all: String = CUBE
        .lines()
        .map(|l| {
            if l.starts_with("v ") {
                format!("{l} 1 0 0\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let m = obj::parse_str(&all, "all.obj").unwrap();
    assert_eq!(corners(&m), want);
    assert!(m.summary.warnings.is_empty());
    // Odd extra values and free-form records: one warning each, with a line.
    let odd = format!("{CUBE}v 2 2 2 1 1\ncurv 0 1 1 2\nsurf 0 1 0 1 1 2 3\n");
    let m = obj::parse_str(&odd, "odd.obj").unwrap();
    assert_eq!(corners(&m), want);
    assert_eq!(m.summary.warnings.len(), 2, "{:?}", m.summary.warnings);
    assert!(m.summary.warnings[0].starts_with("line 15:"));
    assert!(m.summary.warnings[1].contains("2 free-form"));
}

#[test]
fn obj_faces_with_texture_and_normal_indices() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvn 0 0 1\n\
                f 1/1/1 2/1/1 3/1/1\nf 1//1 2//1 4//1\nf -4/-1 -2/-1 -1/-1\n";
    let m = obj::parse_str(text, "vtn.obj").unwrap();
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 1, 3], [0, 2, 3]]);
}

#[test]
fn obj_large_files_parse_in_parallel_chunks_like_serially() {
    // Over PARALLEL_MIN_BYTES, with relative indices, forward references,
    // continuations and CRLF spread over the chunk boundaries.
    let mut text = String::new();
    let mut k = 0usize;
    while text.len() < obj::PARALLEL_MIN_BYTES + (1 << 20) {
        let b = k as f64;
        text.push_str(&format!(
            "v {b} 0 0\r\nv {b} 1 0\nv {b} \\\n 0 1\nf -3 -2 \\\r\n -1\nf {} {} {}\nl -1 -3\np 1\n",
            3 * k + 1,
            3 * k + 5,
            3 * k + 3
        ));
        k += 1;
    }
    text.push_str(&format!("v 0 0 9\nv 0 9 9\nv 9 9 9\nf {} {} {}\n", 1, 2, 3));
    let big = obj::parse_str(&text, "big.obj").unwrap();
    // The serial reference: the same records fed one chunk at a time is not
    // possible from outside, so compare with a hand-resolved copy.
    let plain: String = text.replace(" \\\n", " ").replace(" \\\r\n", " ");
    let m = obj::parse_str(&plain, "plain.obj").unwrap();
    assert_eq!(big.positions, m.positions);
    assert_eq!(big.triangles, m.triangles);
    assert_eq!(big.polylines, m.polylines);
    assert_eq!(big.summary, m.summary);
    // The last face uses the vertices after the last chunk; forward refs
    // (3k+5) resolve to the next group's first vertex.
    assert_eq!(big.triangles[1], [0, 4, 2]);
    assert_eq!(big.summary.skipped_points, k);
    // An error deep in the file names its line in a parallel parse too.
    let lines = text.lines().count();
    let bad = format!("{text}f 1 2 -999999999\n");
    let e = obj::parse_str(&bad, "bad.obj").unwrap_err().to_string();
    assert!(e.contains(&format!("line {}:", lines + 1)), "{e}");
}

/// A random valid OBJ (no `l`, `p`, colours or continuations: what tobj
/// reads the same way) with groups, materials, `vt`/`vn`, positive and
/// negative indices and polygons of 3 to 6 vertices.
fn random_obj() -> impl Strategy<Value = String> {
    let vertex = (-50i32..50, -50i32..50, -50i32..50);
    (
        proptest::collection::vec(vertex, 3..30),
        proptest::collection::vec(
            (
                proptest::collection::vec((any::<u32>(), any::<bool>()), 3..7),
                0u8..4,
                0u8..6,
            ),
            1..30,
        ),
    )
        .prop_map(|(vs, faces)| {
            let mut s = String::from("mtllib none.mtl\nvt 0 0\nvt 1 1\nvn 0 0 1\n");
            for (x, y, z) in &vs {
                s.push_str(&format!(
                    "v {} {} {}\n",
                    *x as f64 / 8.0,
                    *y as f64 / 4.0,
                    z
                ));
            }
            let n = vs.len() as i64;
            for (idx, form, extra) in faces {
                match extra {
                    0 => s.push_str("g part\n"),
                    1 => s.push_str("usemtl red\n"),
                    2 => s.push_str("o thing\ns 1\n"),
                    _ => {}
                }
                s.push('f');
                for (r, neg) in idx {
                    let i = (r as i64 % n) + 1;
                    let i = if neg { i - n - 1 } else { i };
                    match form {
                        0 => s.push_str(&format!(" {i}")),
                        1 => s.push_str(&format!(" {i}/1")),
                        2 => s.push_str(&format!(" {i}//1")),
                        _ => s.push_str(&format!(" {i}/2/-1")),
                    }
                }
                s.push('\n');
            }
            s
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// The same triangles as tobj (by corner coordinates, in order), tobj's
    /// degenerate ones aside (voxkit drops and counts them).
    #[test]
    fn obj_agrees_with_tobj_on_valid_files(text in random_obj()) {
        let opts = tobj::LoadOptions { triangulate: true, single_index: false, ..Default::default() };
        let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
            Err(tobj::LoadError::OpenFileFailed)
        }).unwrap();
        let mut want = Vec::new();
        for m in &models {
            let p = |i: u32| {
                let i = i as usize * 3;
                DVec3::new(m.mesh.positions[i], m.mesh.positions[i + 1], m.mesh.positions[i + 2])
            };
            for t in m.mesh.indices.chunks_exact(3) {
                let c = [p(t[0]), p(t[1]), p(t[2])];
                if (c[1] - c[0]).cross(c[2] - c[0]) != DVec3::ZERO {
                    want.push(c);
                }
            }
        }
        match obj::parse_str(&text, "r.obj") {
            Ok(m) => prop_assert_eq!(corners(&m), want),
            Err(e) => prop_assert!(want.is_empty(), "{e}"),
        }
    }
}

// ---------------------------------------------------------------------------
// binvox
// ---------------------------------------------------------------------------

#[test]
fn binvox_headers_with_comments_are_read() {
    let data = b"\x00\x03\x01\x01\x00\x04";
    let plain = [
        b"#binvox 1\ndim 2 2 2\ntranslate 1 2 3\nscale 4\ndata\n".as_slice(),
        data,
    ]
    .concat();
    let (want, wframe) = voxkit::io::binvox::read(&plain, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(want.count(), 1);
    for header in [
        "#binvox 1\n# written by a converter\ndim 2 2 2\ntranslate 1 2 3\nscale 4\ndata\n",
        "#binvox 1\r\n#comment\r\ndim 2 2 2\r\n\r\n# another\r\ntranslate 1 2 3\r\nscale 4\r\ndata\r\n",
        "#binvox 1\n#\ndim 2 2 2\n  # indented\ntranslate 1 2 3\nscale 4\n# last\ndata\n",
    ] {
        let bytes = [header.as_bytes(), data].concat();
        let (g, f) = voxkit::io::binvox::read(&bytes, MemoryLimit::DEFAULT)
            .unwrap_or_else(|e| panic!("{header:?}: {e}"));
        assert_eq!(g, want, "{header:?}");
        assert_eq!(f, wframe, "{header:?}");
    }
}

// ---------------------------------------------------------------------------
// NRRD
// ---------------------------------------------------------------------------

fn bz2(data: &[u8]) -> Vec<u8> {
    let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

/// `n` 16-bit samples `i * 7 - 300`, little endian.
fn samples(n: usize) -> (Vec<i16>, Vec<u8>) {
    let v: Vec<i16> = (0..n as i16).map(|i| i * 7 - 300).collect();
    let b = v.iter().flat_map(|s| s.to_le_bytes()).collect();
    (v, b)
}

#[test]
fn nrrd_bzip2_attached_and_detached() {
    let dir = temp_dir("bz2");
    let (v, raw) = samples(4 * 3 * 2);
    let head =
        "NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: bzip2\n";
    let attached = dir.join("a.nrrd");
    std::fs::write(
        &attached,
        [format!("{head}\n").as_bytes(), &bz2(&raw)].concat(),
    )
    .unwrap();
    std::fs::write(dir.join("d.raw.bz2"), bz2(&raw)).unwrap();
    let detached = dir.join("d.nhdr");
    std::fs::write(&detached, format!("{head}data file: d.raw.bz2\n\n")).unwrap();
    // A concatenated (multi-stream) file, as pbzip2 writes, and a byte skip
    // counted in decompressed bytes.
    let (a, b) = raw.split_at(10);
    std::fs::write(dir.join("m.raw.bz2"), [bz2(a), bz2(b)].concat()).unwrap();
    std::fs::write(
        dir.join("m.nhdr"),
        format!("{head}data file: m.raw.bz2\n\n"),
    )
    .unwrap();
    std::fs::write(dir.join("s.raw.bz2"), bz2(&[&[9u8; 6][..], &raw].concat())).unwrap();
    std::fs::write(
        dir.join("s.nhdr"),
        format!("{head}byte skip: 6\ndata file: s.raw.bz2\n\n"),
    )
    .unwrap();
    for p in [attached, detached, dir.join("m.nhdr"), dir.join("s.nhdr")] {
        let vol = read_volume(&p, MemoryLimit::DEFAULT).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(vol.dims, [4, 3, 2]);
        for (i, &s) in v.iter().enumerate() {
            assert_eq!(
                vol.get(i % 4, i / 4 % 3, i / 12),
                s as f64,
                "{}",
                p.display()
            );
        }
    }
    // Too little, too much and corrupt data: one line naming the file.
    std::fs::write(dir.join("t.raw.bz2"), bz2(&raw[..40])).unwrap();
    std::fs::write(dir.join("l.raw.bz2"), bz2(&[&raw[..], b"xx"].concat())).unwrap();
    let mut broken = bz2(&raw);
    let k = broken.len() / 2;
    broken[k] ^= 0x55;
    std::fs::write(dir.join("c.raw.bz2"), broken).unwrap();
    for f in ["t", "l", "c"] {
        std::fs::write(
            dir.join(format!("{f}.nhdr")),
            format!("{head}data file: {f}.raw.bz2\n\n"),
        )
        .unwrap();
        match read_volume(&dir.join(format!("{f}.nhdr")), MemoryLimit::DEFAULT) {
            Err(VoxkitError::Invalid(m)) => {
                assert!(
                    m.contains(&format!("{f}.nhdr")) || m.contains(&format!("{f}.raw.bz2")),
                    "{m}"
                );
                assert!(!m.contains('\n') && !m.contains("{"), "{m}");
            }
            other => panic!("{f}: {other:?}"),
        }
    }
}

#[test]
fn nrrd_bzip2_voxel_grid_reads_like_raw() {
    let dir = temp_dir("bz2grid");
    let data: Vec<u8> = (0..5 * 4 * 3).map(|i| u8::from(i % 3 == 0)).collect();
    let head = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 5 4 3\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,0.5)\nspace origin: (1,2,3)\n";
    let raw = dir.join("raw.nrrd");
    std::fs::write(
        &raw,
        [format!("{head}encoding: raw\n\n").as_bytes(), &data].concat(),
    )
    .unwrap();
    let bz = dir.join("bz.nrrd");
    std::fs::write(
        &bz,
        [format!("{head}encoding: bzip2\n\n").as_bytes(), &bz2(&data)].concat(),
    )
    .unwrap();
    let a = read_voxels(&raw, MemoryLimit::DEFAULT).unwrap();
    let b = read_voxels(&bz, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(a.0.count(), 20);
    assert_eq!(a, b);
    assert_eq!(a.1.origin, DVec3::new(0.75, 1.75, 2.75));
}

#[test]
fn nrrd_2d_images_and_squeezed_4d_volumes() {
    let dir = temp_dir("nd");
    let (v, raw) = samples(4 * 3);
    let w = |name: &str, head: &str| {
        let p = dir.join(name);
        std::fs::write(&p, [head.as_bytes(), b"\n", &raw].concat()).unwrap();
        p
    };
    let check = |p: &Path, dims: [usize; 3]| {
        let vol = read_volume(p, MemoryLimit::DEFAULT).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(vol.dims, dims, "{}", p.display());
        for (i, &s) in v.iter().enumerate() {
            let mut at = [0usize; 3];
            let mut r = i;
            for a in 0..3 {
                at[a] = r % dims[a];
                r /= dims[a];
            }
            assert_eq!(vol.get(at[0], at[1], at[2]), s as f64, "{}", p.display());
        }
        vol
    };
    let base = "NRRD0004\ntype: short\nendian: little\nencoding: raw\n";
    // 2-D: a one-voxel-thick volume, the third axis normal to the image.
    let vol = check(
        &w(
            "img.nrrd",
            &format!(
                "{base}dimension: 2\nsizes: 4 3\nspace dimension: 2\nspace directions: (2,0) (0,3)\nspace origin: (10,20)\n"
            ),
        ),
        [4, 3, 1],
    );
    assert_eq!(vol.frame.origin, DVec3::new(10.0, 20.0, 0.0));
    assert_eq!(vol.frame.axes.z_axis, DVec3::new(0.0, 0.0, 2.5));
    let vol = check(
        &w(
            "sp.nrrd",
            &format!("{base}dimension: 2\nsizes: 4 3\nspacings: 1 1\n"),
        ),
        [4, 3, 1],
    );
    assert_eq!(vol.frame.axes.z_axis, DVec3::Z);
    // 4-D with a size-1 axis: first (a `none` vector component axis), in
    // the middle and last.
    check(
        &w(
            "c4.nrrd",
            &format!(
                "{base}dimension: 4\nsizes: 1 4 3 1\nspace dimension: 3\nspace directions: none (1,0,0) (0,1,0) (0,0,1)\nkinds: scalar domain domain domain\n"
            ),
        ),
        [4, 3, 1],
    );
    check(
        &w(
            "m4.nrrd",
            &format!("{base}dimension: 4\nsizes: 4 1 3 1\nspacings: 1 nan 1 1\n"),
        ),
        [4, 3, 1],
    );
    check(
        &w("t4.nrrd", &format!("{base}dimension: 4\nsizes: 2 2 3 1\n")),
        [2, 2, 3],
    );
    // Refused in one line: 1-D, 4-D without a size-1 axis, a `none` axis
    // that is kept.
    for (name, head) in [
        ("d1.nrrd", format!("{base}dimension: 1\nsizes: 12\n")),
        ("d4.nrrd", format!("{base}dimension: 4\nsizes: 2 2 3 2\n")),
        (
            "none.nrrd",
            format!("{base}dimension: 3\nsizes: 4 3 1\nspace directions: none (1,0,0) (0,1,0)\n"),
        ),
    ] {
        match read_volume(&w(name, &head), MemoryLimit::DEFAULT) {
            Err(VoxkitError::Unsupported(m)) => {
                assert!(m.contains(name) && !m.contains('\n'), "{m}");
            }
            other => panic!("{name}: {other:?}"),
        }
    }
}

// ---------------------------------------------------------------------------
// One-line refusals
// ---------------------------------------------------------------------------

/// One line naming the file, with no `Debug` dump of a dependency's error.
fn one_line(e: VoxkitError, name: &str, needles: &[&str]) {
    let m = e.to_string();
    assert!(m.contains(name), "{m}");
    assert!(!m.contains('\n'), "{m}");
    for bad in ["ParseError", "LineCol", "{", "Error {", "kind:"] {
        assert!(!m.contains(bad), "{m:?} contains {bad:?}");
    }
    for n in needles {
        assert!(m.contains(n), "{m:?} lacks {n:?}");
    }
}

const PLY_HEAD: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

#[test]
fn ply_refusals_are_one_human_line() {
    let cases: &[(&str, String, &[&str])] = &[
        (
            "value.ply",
            format!("{PLY_HEAD}0 0 0\n1 0 0\n0 abc 0\n3 0 1 2\n"),
            &["line 12", "abc"],
        ),
        (
            "header.ply",
            PLY_HEAD.replace("property float y", "property floaty y"),
            &["line 5", "header"],
        ),
        (
            "magic.ply",
            PLY_HEAD.replace("ply\n", "plx\n"),
            &["not a PLY file"],
        ),
        (
            "short.ply",
            format!("{PLY_HEAD}0 0 0\n1 0 0\n"),
            &["vertex"],
        ),
        (
            "few.ply",
            format!("{PLY_HEAD}0 0 0\n1 0\n0 1 0\n3 0 1 2\n"),
            &["line 11"],
        ),
        (
            "list.ply",
            format!("{PLY_HEAD}0 0 0\n1 0 0\n0 1 0\n3 0 x 2\n"),
            &["line 13"],
        ),
        (
            "noend.ply",
            PLY_HEAD.replace("end_header\n", ""),
            &["end_header"],
        ),
        (
            "orphan.ply",
            PLY_HEAD.replace("format ascii 1.0\n", "format ascii 1.0\nproperty float w\n"),
            &["property"],
        ),
    ];
    for (name, text, needles) in cases {
        let e = ply::parse(text.as_bytes(), name).unwrap_err();
        one_line(e, name, needles);
    }
    // Binary, truncated inside the vertices.
    let mut b = PLY_HEAD
        .replace("ascii", "binary_little_endian")
        .into_bytes();
    b.extend_from_slice(&[0u8; 20]);
    one_line(
        ply::parse(&b, "bin.ply").unwrap_err(),
        "bin.ply",
        &["vertex"],
    );
}

#[test]
fn stl_off_obj_refusals_are_one_human_line() {
    let stl_cases: &[(&str, &[u8])] = &[
        ("trunc.stl", &[0u8; 90]),
        (
            "ascii.stl",
            b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\n",
        ),
        ("empty.stl", b""),
    ];
    for (name, bytes) in stl_cases {
        one_line(stl::parse(bytes, name).unwrap_err(), name, &[]);
    }
    // Ascii refusals name the line and what is wrong there.
    let stl_ascii: &[(&str, &str, &[&str])] = &[
        (
            "num.stl",
            "solid\nfacet\nvertex 0 0 0\nvertex 1 0 O\n",
            &["line 4", "`O` is not a number"],
        ),
        (
            "two.stl",
            "solid\nfacet\nvertex 0 0\n",
            &["line 3", "2 coordinates"],
        ),
        (
            "inf.stl",
            "solid\nfacet\nvertex 0 inf 0\n",
            &["line 3", "non-finite"],
        ),
        (
            "open.stl",
            "solid\nfacet\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n",
            &["ends inside the facet begun on line 2"],
        ),
        (
            "short.stl",
            "solid\nfacet\nvertex 0 0 0\nvertex 1 0 0\nendfacet\nendsolid\n",
            &["line 5", "facet begun on line 2 has 2 corners"],
        ),
        (
            "stray.stl",
            "solid\nvertex 0 0 0\nendsolid\n",
            &["line 2", "`vertex` outside a facet"],
        ),
        (
            "nested.stl",
            "solid a\nfacet\nsolid b\n",
            &["line 3", "`solid` before the facet begun on line 2 ended"],
        ),
        (
            "word.stl",
            "solid\nfacet\n  colour 1 0 0\n",
            &["line 3", "`colour` is not an ascii STL keyword"],
        ),
        (
            "after.stl",
            "solid\nendsolid\nfacet\n",
            &["line 3", "outside a `solid` block"],
        ),
    ];
    for (name, text, needles) in stl_ascii {
        one_line(
            stl::parse(text.as_bytes(), name).unwrap_err(),
            name,
            needles,
        );
    }
    let off_cases: &[(&str, &[u8])] = &[
        ("head.off", b"OFX\n3 1 0\n"),
        ("count.off", b"OFF\n3 x 0\n"),
        ("short.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n"),
        ("index.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
    ];
    for (name, bytes) in off_cases {
        one_line(off::parse(bytes, name).unwrap_err(), name, &[]);
    }
    let obj_cases: &[(&str, &[u8], &str)] = &[
        ("idx.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "line 4"),
        (
            "huge.obj",
            b"v 0 0 0\nf 1 2 99999999999999999999\n",
            "line 2",
        ),
        ("w.obj", b"v 0 0 0 0\n", "line 1"),
    ];
    for (name, bytes, needle) in obj_cases {
        one_line(obj::parse(bytes, name).unwrap_err(), name, &[needle]);
    }
}

// ---------------------------------------------------------------------------
// STL as other tools write it
// ---------------------------------------------------------------------------

/// An ascii STL facet block with these corners, in the given keyword case.
fn stl_facet(corners: &[[f64; 3]], upper: bool) -> String {
    let mut s = String::from("  facet normal 0 0 0\n    outer loop\n");
    for c in corners {
        s += &format!("      vertex {:e} {:e} {:e}\n", c[0], c[1], c[2]);
    }
    s += "    endloop\n  endfacet\n";
    if upper { s.to_uppercase() } else { s }
}

/// Ascii STL is read as f64, correctly rounded: corners written with
/// enough digits come back bit for bit (a reader rounding to f32, as
/// `stl_io` did, moves all but a few of them).
#[test]
fn stl_ascii_corners_read_as_exact_f64() {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        // Magnitudes from 1e-6 to 1e6, both signs, no two equal.
        let m = (state >> 11) as f64 / (1u64 << 53) as f64;
        let e = ((state & 0xff) as f64 / 255.0) * 12.0 - 6.0;
        let sign = if state & 0x100 == 0 { 1.0 } else { -1.0 };
        sign * (1.0 + m) * 10f64.powf(e)
    };
    let want: Vec<[[f64; 3]; 3]> = (0..500)
        .map(|_| std::array::from_fn(|_| std::array::from_fn(|_| next())))
        .collect();
    let mut text = String::from("solid exact\n");
    for t in &want {
        text += &stl_facet(t, false);
    }
    text += "endsolid exact\n";
    let m = stl::parse(text.as_bytes(), "exact.stl").unwrap();
    let got: Vec<[[f64; 3]; 3]> = corners(&m)
        .iter()
        .map(|t| t.map(|c| c.to_array()))
        .collect();
    assert_eq!(got, want);
    // Not vacuous: f32 would have moved nearly every coordinate.
    let moved = want
        .iter()
        .flatten()
        .flatten()
        .filter(|&&c| f64::from(c as f32) != c)
        .count();
    assert!(moved > 4000, "{moved}");
}

/// What exporters write that the grammar allows or that readers accept:
/// upper-case keywords, CRLF, tabs, Latin-1 names, no `outer loop`, several
/// solids, polygons (fanned, with a warning), a missing `endsolid` (a
/// warning); and a binary file whose header says `solid` and whose count is
/// wrong stays binary.
#[test]
fn stl_ascii_as_exporters_write_it() {
    let a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let b = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let want = |m: &Mesh| {
        let got: Vec<[[f64; 3]; 3]> = corners(m).iter().map(|t| t.map(|c| c.to_array())).collect();
        assert_eq!(got, vec![a, b]);
        assert_eq!(m.positions.len(), 4);
    };
    let plain = format!(
        "solid p\n{}{}endsolid p\n",
        stl_facet(&a, false),
        stl_facet(&b, false)
    );
    let m = stl::parse(plain.as_bytes(), "plain.stl").unwrap();
    want(&m);
    assert!(m.summary.warnings.is_empty());

    let upper = format!(
        "SOLID P\r\n{}{}ENDSOLID P\r\n",
        stl_facet(&a, true),
        stl_facet(&b, true)
    )
    .replace('\n', "\r\n")
    .replace("\r\r", "\r")
    .replace("      ", "\t");
    want(&stl::parse(upper.as_bytes(), "upper.stl").unwrap());

    let mut latin1 = b"solid Mod\xe8le \xa9 caf\xe9\n".to_vec();
    latin1.extend_from_slice(plain.split_once('\n').unwrap().1.as_bytes());
    want(&stl::parse(&latin1, "latin1.stl").unwrap());

    let bare = plain
        .replace("    outer loop\n", "")
        .replace("    endloop\n", "");
    want(&stl::parse(bare.as_bytes(), "bare.stl").unwrap());

    let two = format!(
        "solid one\n{}endsolid one\n\nsolid two\n{}endsolid two\n",
        stl_facet(&a, false),
        stl_facet(&b, false)
    );
    want(&stl::parse(two.as_bytes(), "two.stl").unwrap());

    // A quad facet is fanned from its first corner: two triangles.
    let q = [a[0], a[1], b[1], a[2]];
    let quad = format!("solid q\n{}endsolid q\n", stl_facet(&q, false));
    let m = stl::parse(quad.as_bytes(), "quad.stl").unwrap();
    let got: Vec<[[f64; 3]; 3]> = corners(&m)
        .iter()
        .map(|t| t.map(|c| c.to_array()))
        .collect();
    assert_eq!(got, vec![[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
    assert_eq!(m.summary.warnings.len(), 1, "{:?}", m.summary.warnings);
    assert!(m.summary.warnings[0].contains("fanned"));

    let cut = plain.replace("endsolid p\n", "");
    let m = stl::parse(cut.as_bytes(), "cut.stl").unwrap();
    want(&m);
    assert_eq!(m.summary.warnings.len(), 1, "{:?}", m.summary.warnings);
    assert!(m.summary.warnings[0].contains("no `endsolid`"));

    // Binary with a `solid …` header and 7 bytes of padding after the
    // records: not text (the records hold NUL bytes), so read as binary.
    let mut bin = b"solid exported by a CAD tool".to_vec();
    bin.resize(80, b' ');
    bin.extend_from_slice(&2u32.to_le_bytes());
    for t in [a, b] {
        bin.extend_from_slice(&[0u8; 12]);
        for c in t {
            for v in c {
                bin.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        bin.extend_from_slice(&[0u8; 2]);
    }
    bin.extend_from_slice(b"padding");
    want(&stl::parse(&bin, "bin.stl").unwrap());
}

// ---------------------------------------------------------------------------
// The command line
// ---------------------------------------------------------------------------

fn voxkit() -> Command {
    Command::new(env!("CARGO_BIN_EXE_voxkit"))
}

#[test]
fn cli_prints_and_lists_mesh_warnings() {
    let dir = temp_dir("warn");
    let coloured: String = CUBE
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                format!("{l} 1 0 0\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let mesh = dir.join("c.obj");
    std::fs::write(&mesh, coloured).unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let check = |args: Vec<String>, key_in_json: bool| {
        let o = voxkit().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{args:?}: {err}");
        let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("warning: ")).collect();
        assert_eq!(lines.len(), 1, "{args:?}: {err}");
        assert!(
            lines[0].starts_with(&format!("warning: {}: ", mesh.display())),
            "{err}"
        );
        if key_in_json {
            let out = String::from_utf8_lossy(&o.stdout);
            let j: serde_json::Value = serde_json::from_str(out.lines().next().unwrap()).unwrap();
            assert_eq!(
                j["warnings"].as_array().unwrap().len(),
                1,
                "{args:?}: {out}"
            );
        }
    };
    let vox = dir.join("c.binvox");
    check(
        vec![
            "voxelize".into(),
            s(&mesh),
            "-r".into(),
            "8".into(),
            "-o".into(),
            s(&vox),
            "--json".into(),
        ],
        true,
    );
    check(
        vec!["measure".into(), s(&mesh), s(&vox), "--json".into()],
        true,
    );
    check(
        vec![
            "render".into(),
            s(&mesh),
            "-r".into(),
            "8".into(),
            "-o".into(),
            s(&dir.join("c.png")),
            "--size".into(),
            "16x16".into(),
            "--json".into(),
        ],
        true,
    );
    let outdir = dir.join("batch");
    check(
        vec![
            "voxelize".into(),
            s(&dir),
            "-r".into(),
            "8".into(),
            "-o".into(),
            s(&outdir),
            "--format".into(),
            "binvox".into(),
            "--json".into(),
        ],
        true,
    );
}

#[test]
fn cli_ends_quietly_on_a_closed_stdout() {
    // Enough output to fill the pipe many times over, read by nobody.
    let mut child = voxkit()
        .args(["line", "0", "0", "0", "100000", "37", "11"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        o.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn demo_help_says_it_voxelizes_and_renders() {
    let o = voxkit().args(["demo", "--help"]).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_lowercase();
    assert!(
        text.contains("voxelize") && text.contains("render"),
        "{text}"
    );
    let o = voxkit().arg("--help").output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_lowercase();
    let demo = text
        .lines()
        .find(|l| l.trim_start().starts_with("demo"))
        .unwrap();
    assert!(
        demo.contains("voxelize") && demo.contains("render"),
        "{demo}"
    );
}
