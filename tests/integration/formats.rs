//! Voxel file formats: round trips on seeded random sparse sets (non-cubic,
//! over 256 voxels on an axis for .vox splitting), byte-level layout facts of
//! tiny hand-made grids (binvox order and RLE, npy axes, NRRD header and
//! order, vox chunks), atomic no-overwrite writes, and bad files.

use std::collections::HashSet;
use std::path::Path;

use crate::scratch::temp_dir;
use glam::{DVec3, IVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::VoxkitError;
use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
use voxkit::io::{VoxelFormat, read_voxels, write_voxels, write_voxels_limited};

fn random_grid(rng: &mut ChaCha8Rng, dims: [usize; 3], n: usize) -> BrickGrid {
    let mut g = BrickGrid::new();
    for _ in 0..n {
        g.insert(IVec3::new(
            rng.random_range(0..dims[0] as i32),
            rng.random_range(0..dims[1] as i32),
            rng.random_range(0..dims[2] as i32),
        ));
    }
    // Corners, so padding and the last models are exercised.
    g.insert(IVec3::ZERO);
    g.insert(IVec3::new(
        dims[0] as i32 - 1,
        dims[1] as i32 - 1,
        dims[2] as i32 - 1,
    ));
    g
}

fn rel_close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-14 * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn every_format_round_trips_random_sets() {
    let dir = temp_dir("rt");
    let mut rng = ChaCha8Rng::seed_from_u64(0xF0_F0);
    let cases: &[([usize; 3], usize)] = &[
        ([1, 1, 1], 0),
        ([5, 3, 2], 10),
        ([300, 17, 9], 2_000),   // > 256 in x: two .vox models
        ([20, 513, 260], 5_000), // > 256 in y and z
        ([64, 64, 64], 20_000),
    ];
    for (ci, &(dims, n)) in cases.iter().enumerate() {
        let grid = random_grid(&mut rng, dims, n);
        let frame = GridFrame::new(
            DVec3::new(
                rng.random_range(-10.0..10.0),
                rng.random_range(-10.0..10.0),
                0.1,
            ),
            rng.random_range(0.001..2.0),
            dims,
        );
        for ext in ["binvox", "vox", "npy", "nrrd", "zarr"] {
            let path = dir.join(format!("case{ci}.{ext}"));
            write_voxels(&path, &grid, &frame, false).unwrap();
            let (back, f) = read_voxels(&path, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(back, grid, "{ext} case {ci}");
            match ext {
                "binvox" => {
                    let d = *dims.iter().max().unwrap();
                    assert_eq!(f.dims, [d, d, d], "binvox pads to a cube");
                    assert_eq!(f.origin, frame.origin, "translate is exact");
                    assert!(rel_close(f.voxel_size, frame.voxel_size));
                }
                "vox" | "zarr" => assert_eq!(f, frame, "{ext} keeps the frame exactly"),
                "npy" => assert_eq!(f, GridFrame::new(DVec3::ZERO, 1.0, dims)),
                "nrrd" => {
                    assert_eq!(f.dims, dims);
                    assert_eq!(f.voxel_size, frame.voxel_size);
                    assert!((f.origin - frame.origin).abs().max_element() < 1e-12);
                }
                _ => unreachable!(),
            }
        }
    }
}

/// Splits a .vox file into (chunk id, content) pairs inside MAIN.
fn vox_chunks(bytes: &[u8]) -> Vec<([u8; 4], Vec<u8>)> {
    assert_eq!(&bytes[..4], b"VOX ");
    assert_eq!(i32::from_le_bytes(bytes[4..8].try_into().unwrap()), 150);
    assert_eq!(&bytes[8..12], b"MAIN");
    let children = u32::from_le_bytes(bytes[16..20].try_into().unwrap()) as usize;
    assert_eq!(20 + children, bytes.len());
    let mut out = Vec::new();
    let mut p = 20;
    while p < bytes.len() {
        let id: [u8; 4] = bytes[p..p + 4].try_into().unwrap();
        let n = u32::from_le_bytes(bytes[p + 4..p + 8].try_into().unwrap()) as usize;
        out.push((id, bytes[p + 12..p + 12 + n].to_vec()));
        p += 12 + n;
    }
    out
}

#[test]
fn vox_splits_large_grids_into_placed_models() {
    let dir = temp_dir("voxsplit");
    let dims = [600, 10, 300];
    let vs = [
        IVec3::new(0, 0, 0),
        IVec3::new(255, 9, 255),
        IVec3::new(256, 0, 0),
        IVec3::new(599, 5, 299),
    ];
    let grid: BrickGrid = vs.into_iter().collect();
    let frame = GridFrame::new(DVec3::ZERO, 1.0, dims);
    let path = dir.join("split.vox");
    write_voxels(&path, &grid, &frame, false).unwrap();
    let chunks = vox_chunks(&std::fs::read(&path).unwrap());
    let sizes: Vec<[i32; 3]> = chunks
        .iter()
        .filter(|(id, _)| id == b"SIZE")
        .map(|(_, c)| {
            std::array::from_fn(|a| i32::from_le_bytes(c[4 * a..4 * a + 4].try_into().unwrap()))
        })
        .collect();
    // Blocks (0,0,0), (1,0,0), (2,0,1): three non-empty models, each <= 256.
    assert_eq!(sizes, vec![[256, 10, 256], [256, 10, 256], [88, 10, 44]]);
    let xyzi: Vec<Vec<u8>> = chunks
        .iter()
        .filter(|(id, _)| id == b"XYZI")
        .map(|(_, c)| c.clone())
        .collect();
    assert_eq!(xyzi[0], [2, 0, 0, 0, 0, 0, 0, 1, 255, 9, 255, 1]);
    assert_eq!(xyzi[1], [1, 0, 0, 0, 0, 0, 0, 1]);
    assert_eq!(xyzi[2], [1, 0, 0, 0, 87, 5, 43, 1]);
    // Model translations: block offset + size / 2 (MagicaVoxel's centre pivot).
    let shapes = chunks.iter().filter(|(id, _)| id == b"nSHP").count();
    assert_eq!(shapes, 3);
    let trn: Vec<String> = chunks
        .iter()
        .filter(|(id, _)| id == b"nTRN")
        .map(|(_, c)| String::from_utf8_lossy(c).into_owned())
        .collect();
    assert!(trn[1].contains("128 5 128"), "{}", trn[1]);
    assert!(trn[2].contains("384 5 128"), "{}", trn[2]);
    assert!(trn[3].contains("556 5 278"), "{}", trn[3]);
    let (back, f) = read_voxels(&path, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(back, grid);
    assert_eq!(f, frame);
}

#[test]
fn vox_without_frame_attributes_uses_placement() {
    // A hand-made file as another tool writes it: one 3x2x1 model placed with
    // _t = (10, 0, -5) and no voxkit attributes.
    let mut main = Vec::new();
    let chunk = |out: &mut Vec<u8>, id: &[u8; 4], c: &[u8]| {
        out.extend_from_slice(id);
        out.extend_from_slice(&(c.len() as u32).to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(c);
    };
    let i = |v: i32| v.to_le_bytes();
    let mut size = Vec::new();
    [3, 2, 1]
        .iter()
        .for_each(|&v| size.extend_from_slice(&i(v)));
    chunk(&mut main, b"SIZE", &size);
    chunk(
        &mut main,
        b"XYZI",
        &[&i(2)[..], &[0, 0, 0, 7, 2, 1, 0, 7]].concat(),
    );
    let dict0 = i(0);
    let t = b"_t";
    let tv = b"10 0 -5";
    let trn1 = [&i(0)[..], &dict0, &i(1), &i(-1), &i(-1), &i(1), &dict0].concat();
    chunk(&mut main, b"nTRN", &trn1);
    let trn2 = [
        &i(1)[..],
        &dict0,
        &i(2),
        &i(-1),
        &i(0),
        &i(1),
        &i(1),
        &i(2),
        t,
        &i(7),
        tv,
    ]
    .concat();
    chunk(&mut main, b"nTRN", &trn2);
    let shp = [&i(2)[..], &dict0, &i(1), &i(0), &dict0].concat();
    chunk(&mut main, b"nSHP", &shp);
    let mut file = b"VOX ".to_vec();
    file.extend_from_slice(&i(150));
    file.extend_from_slice(b"MAIN");
    file.extend_from_slice(&i(0));
    file.extend_from_slice(&(main.len() as u32).to_le_bytes());
    file.extend_from_slice(&main);
    let dir = temp_dir("voxforeign");
    let p = dir.join("foreign.vox");
    std::fs::write(&p, &file).unwrap();
    let (g, f) = read_voxels(&p, MemoryLimit::DEFAULT).unwrap();
    // Placed box starts at _t - size/2 = (9, -1, -5); shifted to 0.
    assert_eq!(f.origin, DVec3::new(9.0, -1.0, -5.0));
    assert_eq!(f.voxel_size, 1.0);
    assert_eq!(f.dims, [3, 2, 1]);
    assert_eq!(
        g.iter().collect::<Vec<_>>(),
        vec![IVec3::ZERO, IVec3::new(2, 1, 0)]
    );
}

#[test]
fn binvox_bytes_of_tiny_grids() {
    let dir = temp_dir("binvoxbytes");
    let frame = GridFrame::new(DVec3::new(1.0, 2.0, 3.0), 0.5, [2, 2, 2]);
    let header = b"#binvox 1\ndim 2 2 2\ntranslate 1 2 3\nscale 1\ndata\n";
    // index = x*4 + z*2 + y: (0,1,0) -> 1, (1,0,1) -> 6, (0,0,1) -> 2.
    for (v, runs) in [
        (IVec3::new(0, 1, 0), vec![0u8, 1, 1, 1, 0, 6]),
        (IVec3::new(1, 0, 1), vec![0, 6, 1, 1, 0, 1]),
        (IVec3::new(0, 0, 1), vec![0, 2, 1, 1, 0, 5]),
    ] {
        let grid: BrickGrid = [v].into_iter().collect();
        let p = dir.join(format!("v{}{}{}.binvox", v.x, v.y, v.z));
        write_voxels(&p, &grid, &frame, false).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(&bytes[..header.len()], header);
        assert_eq!(&bytes[header.len()..], &runs[..], "voxel {v}");
    }
    // Non-cubic dims pad to the max; runs split at 255.
    let frame = GridFrame::new(DVec3::ZERO, 1.0, [3, 10, 1]);
    let grid: BrickGrid = [IVec3::new(2, 9, 0)].into_iter().collect();
    let p = dir.join("pad.binvox");
    write_voxels(&p, &grid, &frame, false).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    let h = b"#binvox 1\ndim 10 10 10\ntranslate 0 0 0\nscale 10\ndata\n";
    assert_eq!(&bytes[..h.len()], h);
    // (2,9,0) -> 2*100 + 0*10 + 9 = 209; then 790 zeros = 255+255+255+25.
    assert_eq!(
        &bytes[h.len()..],
        &[0, 209, 1, 1, 0, 255, 0, 255, 0, 255, 0, 25]
    );
}

#[test]
fn npy_layout_is_x_y_z_c_order() {
    let dir = temp_dir("npybytes");
    let frame = GridFrame::new(DVec3::ZERO, 1.0, [2, 3, 4]);
    let grid: BrickGrid = [IVec3::new(1, 2, 3), IVec3::new(0, 1, 0)]
        .into_iter()
        .collect();
    let p = dir.join("a.npy");
    write_voxels(&p, &grid, &frame, false).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
    let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = std::str::from_utf8(&bytes[10..10 + hlen]).unwrap();
    assert!(header.contains("'descr': '|u1'"), "{header}");
    assert!(header.contains("'fortran_order': False"), "{header}");
    assert!(header.contains("'shape': (2, 3, 4)"), "{header}");
    let data = &bytes[10 + hlen..];
    assert_eq!(data.len(), 24);
    // a[x, y, z] at x*12 + y*4 + z.
    let ones: Vec<usize> = (0..24).filter(|&i| data[i] == 1).collect();
    assert_eq!(ones, vec![4, 23]);
    assert!(data.iter().all(|&b| b <= 1));
}

#[test]
fn nrrd_header_and_x_fastest_data() {
    let dir = temp_dir("nrrdbytes");
    let frame = GridFrame::new(DVec3::new(-1.0, 0.0, 2.0), 0.5, [3, 2, 2]);
    let grid: BrickGrid = [IVec3::new(2, 1, 0), IVec3::new(0, 0, 1)]
        .into_iter()
        .collect();
    let p = dir.join("a.nrrd");
    write_voxels(&p, &grid, &frame, false).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    let text = "NRRD0004\n# voxkit voxel grid\ntype: uchar\ndimension: 3\nspace dimension: 3\n\
                sizes: 3 2 2\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,0.5)\n\
                kinds: domain domain domain\nencoding: raw\nspace origin: (-0.75,0.25,2.25)\n\n";
    assert_eq!(&bytes[..text.len()], text.as_bytes());
    let data = &bytes[text.len()..];
    assert_eq!(data.len(), 12);
    // x + 3*(y + 2*z): (2,1,0) -> 5, (0,0,1) -> 6.
    let ones: Vec<usize> = (0..12).filter(|&i| data[i] == 1).collect();
    assert_eq!(ones, vec![5, 6]);
}

#[test]
fn writes_are_atomic_and_do_not_overwrite() {
    let dir = temp_dir("atomic");
    let frame = GridFrame::new(DVec3::ZERO, 1.0, [4, 4, 4]);
    let a: BrickGrid = [IVec3::new(1, 1, 1)].into_iter().collect();
    let b: BrickGrid = [IVec3::new(2, 2, 2)].into_iter().collect();
    for ext in ["binvox", "vox", "npy", "nrrd"] {
        let p = dir.join(format!("g.{ext}"));
        write_voxels(&p, &a, &frame, false).unwrap();
        let before = std::fs::read(&p).unwrap();
        assert!(write_voxels(&p, &b, &frame, false).is_err(), "{ext}");
        assert_eq!(std::fs::read(&p).unwrap(), before);
        // A failing write (voxel outside the grid) leaves the file as it was.
        let out: BrickGrid = [IVec3::new(4, 0, 0)].into_iter().collect();
        let err = write_voxels(&p, &out, &frame, true).unwrap_err();
        assert!(matches!(err, VoxkitError::Invalid(_)), "{err}");
        assert_eq!(std::fs::read(&p).unwrap(), before);
        // Forced overwrite replaces it.
        write_voxels(&p, &b, &frame, true).unwrap();
        assert_eq!(read_voxels(&p, MemoryLimit::DEFAULT).unwrap().0, b);
    }
    // No temporary files are left behind.
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 4, "{names:?}");
    // A missing output file after a failed first write.
    let p = dir.join("never.npy");
    let out: BrickGrid = [IVec3::new(-1, 0, 0)].into_iter().collect();
    assert!(write_voxels(&p, &out, &frame, false).is_err());
    assert!(!p.exists());
    // Dense writer over its memory limit: typed error, nothing written.
    let big = GridFrame::new(DVec3::ZERO, 1.0, [1024, 1024, 1024]);
    let p = dir.join("big.npy");
    let err = write_voxels_limited(&p, &a, &big, false, MemoryLimit::new(1 << 20)).unwrap_err();
    assert!(matches!(err, VoxkitError::Limits { .. }), "{err}");
    assert!(!p.exists());
    // Unknown extension.
    assert!(matches!(
        VoxelFormat::from_path(Path::new("x.stl")),
        Err(VoxkitError::Unsupported(_))
    ));
    assert_eq!(
        VoxelFormat::from_path(Path::new("X.BINVOX")).unwrap(),
        VoxelFormat::Binvox
    );
}

fn expect_invalid(p: &Path, needle: &str) {
    match read_voxels(p, MemoryLimit::DEFAULT) {
        Err(VoxkitError::Invalid(m)) => {
            assert!(
                m.contains(needle),
                "{}: {m:?} lacks {needle:?}",
                p.display()
            );
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            assert!(m.contains(&name), "{m}");
        }
        other => panic!("{}: expected Invalid, got {other:?}", p.display()),
    }
}

#[test]
fn bad_voxel_files_give_typed_errors() {
    let dir = temp_dir("bad");
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let grid = random_grid(&mut rng, [40, 30, 20], 500);
    let frame = GridFrame::new(DVec3::ZERO, 1.0, [40, 30, 20]);
    for ext in ["binvox", "vox", "npy", "nrrd"] {
        let good = dir.join(format!("good.{ext}"));
        write_voxels(&good, &grid, &frame, false).unwrap();
        let bytes = std::fs::read(&good).unwrap();
        // Truncated at several points, header included.
        for cut in [bytes.len() - 1, bytes.len() - 2, bytes.len() / 2, 30, 5, 0] {
            let p = dir.join(format!("cut{cut}.{ext}"));
            std::fs::write(&p, &bytes[..cut]).unwrap();
            let r = read_voxels(&p, MemoryLimit::DEFAULT);
            assert!(
                matches!(r, Err(VoxkitError::Invalid(_))),
                "{ext} cut at {cut}: {r:?}"
            );
        }
    }
    let w = |name: &str, b: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, b).unwrap();
        p
    };
    expect_invalid(
        &w("magic.binvox", b"#notbinvox\ndim 1 1 1\ndata\n\x00\x01"),
        "magic",
    );
    expect_invalid(
        &w("dim.binvox", b"#binvox 1\ndim 2 2\ndata\n\x00\x08"),
        "dim",
    );
    expect_invalid(
        &w("over.binvox", b"#binvox 1\ndim 2 2 2\ndata\n\x00\x09"),
        "more than",
    );
    expect_invalid(
        &w(
            "zero.binvox",
            b"#binvox 1\ndim 1 1 1\ndata\n\x00\x00\x01\x01",
        ),
        "run 0",
    );
    expect_invalid(
        &w("short.binvox", b"#binvox 1\ndim 2 2 2\ndata\n\x00\x07"),
        "7 of 8",
    );
    expect_invalid(&w("magic.nrrd", b"NRRX0004\n\n"), "magic");
    expect_invalid(
        &w(
            "dim.nrrd",
            b"NRRD0004\ntype: uchar\ndimension: 2\nsizes: 1 1 1\nencoding: raw\n\n\x00",
        ),
        "dimension",
    );
    expect_invalid(
        &w(
            "long.nrrd",
            b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n\n\x00\x00",
        ),
        "need 1",
    );
    expect_invalid(&w("magic.vox", b"VOXX\x96\x00\x00\x00"), "magic");
    expect_invalid(
        &w("2d.npy", &{
            let mut v = b"\x93NUMPY\x01\x00".to_vec();
            let h = "{'descr': '|u1', 'fortran_order': False, 'shape': (2, 2), }          \n";
            v.extend_from_slice(&(h.len() as u16).to_le_bytes());
            v.extend_from_slice(h.as_bytes());
            v.extend_from_slice(&[0, 1, 0, 1]);
            v
        }),
        "2 dimensions",
    );
    // A NRRD encoding voxkit does not read is unsupported, not invalid.
    let p = w(
        "hex.nrrd",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: hex\n\n01",
    );
    assert!(matches!(
        read_voxels(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Unsupported(_))
    ));

    // Absurd dimensions against the memory limit: refused from the header.
    let limit = MemoryLimit::new(64 << 20);
    let huge = [
        w("huge.binvox", b"#binvox 1\ndim 100000 100000 100000\ntranslate 0 0 0\nscale 1\ndata\n\x00\xff"),
        w("huge.nrrd", b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 100000 100000 100000\nencoding: raw\n\n\x00"),
        w("huge.npy", &{
            let mut v = b"\x93NUMPY\x01\x00".to_vec();
            let h = "{'descr': '|u1', 'fortran_order': False, 'shape': (100000, 100000, 100000), }\n";
            v.extend_from_slice(&(h.len() as u16).to_le_bytes());
            v.extend_from_slice(h.as_bytes());
            v.extend_from_slice(&[0; 16]);
            v
        }),
    ];
    for p in &huge {
        let r = read_voxels(p, limit);
        assert!(
            matches!(r, Err(VoxkitError::Limits { .. })),
            "{}: {r:?}",
            p.display()
        );
    }
    // A missing file is an I/O error naming it.
    match read_voxels(&dir.join("missing.vox"), MemoryLimit::DEFAULT) {
        Err(VoxkitError::Io { path, .. }) => assert!(path.ends_with("missing.vox")),
        other => panic!("{other:?}"),
    }
}

/// Places every model of a .vox file as MagicaVoxel does, read by an
/// independent parser (`dot_vox`): walk the scene graph from the root
/// transform, add each transform's `_t`, and put model voxel `l` at
/// `_t + l − size / 2` (integer division: the model's centre pivot).
fn vox_scene_voxels(bytes: &[u8]) -> Vec<[i32; 3]> {
    use dot_vox::SceneNode;
    let data = dot_vox::load_bytes(bytes).expect("dot_vox parses the file");
    fn walk(data: &dot_vox::DotVoxData, node: u32, t: [i32; 3], out: &mut Vec<[i32; 3]>) {
        match &data.scenes[node as usize] {
            SceneNode::Transform { frames, child, .. } => {
                let mut t = t;
                if let Some(s) = frames.first().and_then(|f| f.attributes.get("_t")) {
                    let d: Vec<i32> = s.split(' ').map(|x| x.parse().unwrap()).collect();
                    t = [t[0] + d[0], t[1] + d[1], t[2] + d[2]];
                }
                walk(data, *child, t, out);
            }
            SceneNode::Group { children, .. } => {
                for &c in children {
                    walk(data, c, t, out);
                }
            }
            SceneNode::Shape { models, .. } => {
                for m in models {
                    let model = &data.models[m.model_id as usize];
                    let half = [model.size.x, model.size.y, model.size.z].map(|s| (s / 2) as i32);
                    for v in &model.voxels {
                        out.push([
                            t[0] + v.x as i32 - half[0],
                            t[1] + v.y as i32 - half[1],
                            t[2] + v.z as i32 - half[2],
                        ]);
                    }
                }
            }
        }
    }
    let mut out = Vec::new();
    walk(&data, 0, [0; 3], &mut out);
    out.sort();
    out
}

#[test]
fn vox_files_load_in_an_independent_reader_with_every_voxel_in_place() {
    let dir = temp_dir("dotvox");
    let mut rng = ChaCha8Rng::seed_from_u64(0xD07);
    // One model, several models along x, and several along all three axes.
    for (dims, n) in [
        ([40, 30, 20], 500),
        ([300, 17, 9], 2_000),
        ([520, 270, 300], 6_000),
    ] {
        let grid = random_grid(&mut rng, dims, n);
        let frame = GridFrame::new(DVec3::new(1.5, -2.0, 0.25), 0.5, dims);
        let path = dir.join(format!("{}x{}x{}.vox", dims[0], dims[1], dims[2]));
        write_voxels(&path, &grid, &frame, true).unwrap();
        let placed = vox_scene_voxels(&std::fs::read(&path).unwrap());
        let mut want: Vec<[i32; 3]> = grid.iter().map(|v| v.to_array()).collect();
        want.sort();
        assert_eq!(placed, want, "{dims:?}");
    }
}

/// A solid ball inside `dims` as tiles and masks (every full brick a tile),
/// plus scattered voxels; brick boundaries and the box's far faces are cut.
pub fn tiled_ball(rng: &mut ChaCha8Rng, dims: [usize; 3]) -> BrickGrid {
    let c = DVec3::from_array(dims.map(|d| d as f64)) * 0.5;
    let r2 = (dims.iter().min().copied().unwrap() as f64 * 0.45).powi(2);
    let mut g = BrickGrid::from_x_rows(dims, |v| {
        (0..8).fold(0u8, |r, i| {
            let p = (v + IVec3::new(i, 0, 0)).as_dvec3() + 0.5;
            r | u8::from((p - c).length_squared() <= r2) << i
        })
    });
    for _ in 0..2_000 {
        g.insert(IVec3::new(
            rng.random_range(0..dims[0] as i32),
            rng.random_range(0..dims[1] as i32),
            rng.random_range(0..dims[2] as i32),
        ));
    }
    // Full bricks at the far corner: tiles touching the last valid voxel.
    let far = IVec3::new(
        dims[0] as i32 / 8 - 1,
        dims[1] as i32 / 8 - 1,
        dims[2] as i32 / 8 - 1,
    );
    g.insert_tile(far);
    g.insert_tile(IVec3::ZERO);
    g.compact_tiles();
    g
}

/// Tiles round-trip through every format: the same voxels, and every full
/// brick comes back as a tile (so the grid read back is as small as the one
/// written). The .vox file also loads voxel for voxel in `dot_vox`.
#[test]
fn tiles_round_trip_through_every_format() {
    let dir = temp_dir("tiles");
    let mut rng = ChaCha8Rng::seed_from_u64(0x7115);
    // Non-multiples of 8, over 256 on an axis (two .vox models), cubic.
    for dims in [[70, 45, 300], [64, 64, 64], [41, 33, 45]] {
        let grid = tiled_ball(&mut rng, dims);
        assert!(
            grid.tile_count() > 4,
            "{dims:?}: {} tiles",
            grid.tile_count()
        );
        assert!(grid.mask_count() > 10);
        let full: HashSet<IVec3> = grid.tiles().collect();
        let frame = GridFrame::new(DVec3::new(-1.0, 2.0, 0.5), 0.25, dims);
        for ext in ["binvox", "vox", "npy", "nrrd", "zarr"] {
            let path = dir.join(format!("tiles.{ext}"));
            write_voxels(&path, &grid, &frame, true).unwrap();
            let (back, _) = read_voxels(&path, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(back, grid, "{ext} {dims:?}");
            assert_eq!(back.tiles().collect::<HashSet<_>>(), full, "{ext} {dims:?}");
            assert_eq!(back.mask_count(), grid.mask_count(), "{ext}");
            assert!(
                back.heap_bytes() <= 2 * grid.heap_bytes() + 4096,
                "{ext}: {} bytes read back, {} written",
                back.heap_bytes(),
                grid.heap_bytes()
            );
            if ext == "vox" {
                let placed = vox_scene_voxels(&std::fs::read(&path).unwrap());
                let mut want: Vec<[i32; 3]> = grid.iter().map(|v| v.to_array()).collect();
                want.sort();
                assert_eq!(placed, want, "{dims:?}");
            }
        }
        // The same voxels as stored masks write the same bytes.
        let mut masks = BrickGrid::new();
        masks.extend(grid.iter());
        assert_eq!(masks.tile_count(), 0);
        for ext in ["binvox", "vox", "npy", "nrrd"] {
            let (a, b) = (dir.join(format!("a.{ext}")), dir.join(format!("b.{ext}")));
            write_voxels(&a, &grid, &frame, true).unwrap();
            write_voxels(&b, &masks, &frame, true).unwrap();
            assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
                "{ext} {dims:?}: tiles and full masks write different bytes"
            );
        }
    }
}
