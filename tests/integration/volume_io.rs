//! Scalar-volume readers: every element type × byte order × raw/gzip ×
//! attached/detached NRRD, MetaImage with and without compression, npy
//! dtypes in both orders, skips, text data, multi-file data, the two real
//! volumes of `data/volumes/` through both headers, and bad files (wrong
//! data sizes, unknown types and encodings, missing data files, sizes over
//! the memory limit, garbage and truncated headers) that must fail with a
//! typed error naming the file, never a panic.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::scratch::temp_dir;
use flate2::Compression;
use flate2::write::{GzEncoder, ZlibEncoder};
use glam::{DMat3, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::VoxkitError;
use voxkit::grid::{AnatomicalSpace, MemoryLimit, ScalarType, ScalarVolume, VolumeFrame};
use voxkit::io::volume::{is_volume_path, read_volume};

const DIMS: [usize; 3] = [5, 3, 7];
const N: usize = 5 * 3 * 7;

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/volumes")
}

/// `n` values exactly representable in `ty`, with the type's extremes
/// (and NaN / ±∞ for floats) among them.
fn values(ty: ScalarType, n: usize) -> Vec<f64> {
    let (lo, hi): (f64, f64) = match ty {
        ScalarType::I8 => (-128.0, 127.0),
        ScalarType::U8 => (0.0, 255.0),
        ScalarType::I16 => (-32768.0, 32767.0),
        ScalarType::U16 => (0.0, 65535.0),
        ScalarType::I32 => (i32::MIN as f64, i32::MAX as f64),
        ScalarType::U32 => (0.0, u32::MAX as f64),
        ScalarType::F32 => (f32::MIN as f64, f32::MAX as f64),
        ScalarType::F64 => (f64::MIN, f64::MAX),
    };
    (0..n)
        .map(|i| match (i, ty) {
            (0, _) => lo,
            (1, _) => hi,
            (2, ScalarType::F32 | ScalarType::F64) => f64::NAN,
            (3, ScalarType::F32 | ScalarType::F64) => f64::NEG_INFINITY,
            (_, ScalarType::F32) => ((i as f32 - 50.0) * 0.375e-3 * (1 + i % 7) as f32) as f64,
            (_, ScalarType::F64) => (i as f64 - 50.0) * 1.000_000_1e-7 * ((i % 11) as f64 + 1.0),
            _ => lo + ((i as u64 * 2_654_435_761) % ((hi - lo) as u64 + 1)) as f64,
        })
        .collect()
}

/// `vals` as binary samples of `ty`.
fn encode(ty: ScalarType, vals: &[f64], big: bool) -> Vec<u8> {
    let mut out = Vec::with_capacity(vals.len() * ty.bytes());
    for &v in vals {
        macro_rules! put {
            ($t:ty) => {{
                let x = v as $t;
                out.extend_from_slice(&if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }};
        }
        match ty {
            ScalarType::I8 => put!(i8),
            ScalarType::U8 => put!(u8),
            ScalarType::I16 => put!(i16),
            ScalarType::U16 => put!(u16),
            ScalarType::I32 => put!(i32),
            ScalarType::U32 => put!(u32),
            ScalarType::F32 => put!(f32),
            ScalarType::F64 => put!(f64),
        }
    }
    out
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut e = ZlibEncoder::new(Vec::new(), Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn write(path: &Path, parts: &[&[u8]]) {
    std::fs::write(path, parts.concat()).unwrap();
}

fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

/// Checks the samples (x fastest) and the type.
fn assert_samples(v: &ScalarVolume, ty: ScalarType, vals: &[f64], what: &str) {
    assert_eq!(v.source_type(), ty, "{what}");
    assert_eq!(v.dims, DIMS, "{what}");
    assert_eq!(v.len(), vals.len(), "{what}");
    for (i, &want) in vals.iter().enumerate() {
        let got = v.data.value(i).unwrap();
        assert!(
            same(got, want),
            "{what}: sample {i} is {got}, expected {want}"
        );
    }
}

/// Every NRRD spelling of each type, cycled through by the cases.
fn nrrd_spellings(ty: ScalarType) -> &'static [&'static str] {
    match ty {
        ScalarType::I8 => &["signed char", "int8", "int8_t"],
        ScalarType::U8 => &["uchar", "unsigned char", "uint8", "uint8_t"],
        ScalarType::I16 => &[
            "short",
            "short int",
            "signed short",
            "signed short int",
            "int16",
            "int16_t",
        ],
        ScalarType::U16 => &[
            "ushort",
            "unsigned short",
            "unsigned short int",
            "uint16",
            "uint16_t",
        ],
        ScalarType::I32 => &["int", "signed int", "int32", "int32_t"],
        ScalarType::U32 => &["uint", "unsigned int", "uint32", "uint32_t"],
        ScalarType::F32 => &["float"],
        ScalarType::F64 => &["double"],
    }
}

fn sheared_frame() -> VolumeFrame {
    VolumeFrame {
        origin: DVec3::new(10.0, -20.0, 30.5),
        axes: DMat3::from_cols(
            DVec3::new(0.5, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.25),
            DVec3::new(0.0, 0.0, -1.5),
        ),
    }
}

#[test]
fn nrrd_every_type_endian_encoding_and_placement() {
    let dir = temp_dir("nrrd");
    let mut case = 0;
    for ty in ScalarType::ALL {
        let vals = values(ty, N);
        for big in [false, true] {
            for gz in [false, true] {
                for detached in [false, true] {
                    case += 1;
                    let spelling = nrrd_spellings(ty)[case % nrrd_spellings(ty).len()];
                    let raw = encode(ty, &vals, big);
                    let data = if gz { gzip(&raw) } else { raw };
                    let (frame_lines, frame) = if case % 2 == 0 {
                        (
                            "space: left-posterior-superior\nspace directions: (0.5,0,0) (0,2,0.25) (0,0,-1.5)\nspace origin: (10,-20,30.5)\n",
                            sheared_frame(),
                        )
                    } else {
                        (
                            "spacings: 0.5 2 1.5\n",
                            VolumeFrame::from_spacing(DVec3::ZERO, DVec3::new(0.5, 2.0, 1.5)),
                        )
                    };
                    let header = format!(
                        "NRRD000{}\n# case {case}\ntype: {spelling}\ndimension: 3\nsizes: 5 3 7\n\
                         endian: {}\nencoding: {}\n{frame_lines}kinds: domain domain domain\n\
                         creator:=voxkit test\n",
                        1 + case % 5,
                        if big { "big" } else { "little" },
                        if gz { "gzip" } else { "raw" },
                    );
                    let name = format!("c{case}");
                    let path = if detached {
                        let hdr = dir.join(format!("{name}.nhdr"));
                        let data_name = format!("{name}.{}", if gz { "raw.gz" } else { "raw" });
                        write(
                            &hdr,
                            &[
                                header.as_bytes(),
                                format!("data file: {data_name}\n").as_bytes(),
                            ],
                        );
                        write(&dir.join(data_name), &[&data]);
                        hdr
                    } else {
                        let p = dir.join(format!("{name}.NRRD"));
                        write(&p, &[header.as_bytes(), b"\n", &data]);
                        p
                    };
                    let what = format!(
                        "{} ({spelling}, big {big}, gzip {gz}, detached {detached})",
                        path.display()
                    );
                    let v = read_volume(&path, MemoryLimit::DEFAULT)
                        .unwrap_or_else(|e| panic!("{what}: {e}"));
                    assert_samples(&v, ty, &vals, &what);
                    assert_eq!(v.frame, frame, "{what}");
                }
            }
        }
    }
}

#[test]
fn nrrd_single_bytes_need_no_endian_and_crlf_headers_read() {
    let dir = temp_dir("nrrd-crlf");
    let vals = values(ScalarType::U8, N);
    let p = dir.join("a.nrrd");
    write(
        &p,
        &[
            b"NRRD0004\r\ntype: uchar\r\ndimension: 3\r\nsizes: 5 3 7\r\nencoding: raw\r\n\r\n",
            &encode(ScalarType::U8, &vals, false),
        ],
    );
    let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
    assert_samples(&v, ScalarType::U8, &vals, "crlf");
    assert_eq!(v.frame, VolumeFrame::default());
}

#[test]
fn nrrd_line_and_byte_skips() {
    let dir = temp_dir("skips");
    let ty = ScalarType::I16;
    let vals = values(ty, N);
    let raw = encode(ty, &vals, false);
    let head = "NRRD0004\ntype: short\ndimension: 3\nsizes: 5 3 7\nendian: little\n";

    // Attached, byte skip 4: junk bytes between the blank line and the data.
    let p = dir.join("attached.nrrd");
    write(
        &p,
        &[
            head.as_bytes(),
            b"encoding: raw\nbyte skip: 4\n\n",
            b"JUNK",
            &raw,
        ],
    );
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals,
        "byte skip 4",
    );

    // Detached, two lines skipped, then the data at the end (byte skip -1).
    let p = dir.join("end.nhdr");
    write(
        &p,
        &[
            head.as_bytes(),
            b"encoding: raw\nline skip: 2\nbyteskip: -1\ndatafile: end.dat\n",
        ],
    );
    write(
        &dir.join("end.dat"),
        &[b"line one\nline two\n", b"some padding", &raw],
    );
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals,
        "byte skip -1",
    );

    // Byte skip -1 leaves no room for "too much data", but too little is
    // still caught (the data may not reach back into the skipped lines).
    write(&dir.join("end.dat"), &[b"line one\nline two\n", &raw[1..]]);
    assert!(matches!(
        read_volume(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Invalid(_))
    ));

    // gzip: the byte skip applies to the decompressed stream.
    let p = dir.join("gz.nrrd");
    let skipped = [b"0123456".as_slice(), &raw].concat();
    write(
        &p,
        &[
            head.as_bytes(),
            b"encoding: gz\nbyte skip: 7\n\n",
            &gzip(&skipped),
        ],
    );
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals,
        "gzip skip",
    );

    // ... and -1 is refused there.
    let p = dir.join("gz-end.nrrd");
    write(
        &p,
        &[
            head.as_bytes(),
            b"encoding: gzip\nbyte skip: -1\n\n",
            &gzip(&raw),
        ],
    );
    assert!(matches!(
        read_volume(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Invalid(_))
    ));
    let p = dir.join("neg.nrrd");
    write(
        &p,
        &[head.as_bytes(), b"encoding: raw\nbyte skip: -2\n\n", &raw],
    );
    assert!(matches!(
        read_volume(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Invalid(_))
    ));
}

#[test]
fn nrrd_ascii_data() {
    let dir = temp_dir("ascii");
    for ty in [ScalarType::I16, ScalarType::U32, ScalarType::F64] {
        let vals: Vec<f64> = values(ty, N)
            .into_iter()
            .map(|v| if v.is_nan() { 0.0 } else { v })
            .collect();
        let text: Vec<String> = vals
            .iter()
            .map(|&v| match ty {
                ScalarType::F64 => format!("{v:?}"),
                _ => format!("{}", v as i64),
            })
            .collect();
        let p = dir.join(format!("{}.nrrd", ty.name()));
        let spelling = nrrd_spellings(ty)[0];
        // Values split over lines, as teem writes them (one row of x per line).
        let body: Vec<String> = text.chunks(5).map(|r| r.join(" ")).collect();
        write(
            &p,
            &[
                format!(
                    "NRRD0004\ntype: {spelling}\ndimension: 3\nsizes: 5 3 7\nencoding: ascii\n\n"
                )
                .as_bytes(),
                body.join("\n").as_bytes(),
                b"\n",
            ],
        );
        let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap_or_else(|e| panic!("{ty}: {e}"));
        assert_samples(&v, ty, &vals, ty.name());
    }
}

#[test]
fn nrrd_multi_file_data() {
    let dir = temp_dir("multi");
    let ty = ScalarType::U16;
    let vals = values(ty, N);
    let raw = encode(ty, &vals, true);
    let slice = 5 * 3 * 2;
    let head = "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 5 3 7\nendian: big\nencoding: raw\n";
    // One file per z slice, named by a pattern.
    for (z, chunk) in raw.chunks(slice).enumerate() {
        write(&dir.join(format!("s{:02}.raw", z + 3)), &[chunk]);
    }
    let p = dir.join("pattern.nhdr");
    write(&p, &[head.as_bytes(), b"data file: s%02d.raw 3 9 1\n"]);
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals,
        "pattern",
    );
    // Descending with a subdimension of 3: one file, the last one named.
    write(&dir.join("all07.raw"), &[&raw]);
    let p = dir.join("pattern3.nhdr");
    write(&p, &[head.as_bytes(), b"data file: all%02d.raw 7 7 -1 3\n"]);
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals,
        "pattern 3D",
    );
    // A LIST of rows (subdim 1): 21 files in a subdirectory.
    std::fs::create_dir_all(dir.join("rows")).unwrap();
    let mut names = String::new();
    for (r, chunk) in raw.chunks(5 * 2).enumerate() {
        write(&dir.join(format!("rows/r{r}.raw")), &[chunk]);
        names.push_str(&format!("rows/r{r}.raw\n"));
    }
    let p = dir.join("list.nhdr");
    write(
        &p,
        &[head.as_bytes(), b"data file: LIST 1\n", names.as_bytes()],
    );
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals,
        "list",
    );
    // Wrong file counts.
    let p = dir.join("bad.nhdr");
    write(&p, &[head.as_bytes(), b"data file: s%02d.raw 3 8 1\n"]);
    assert!(matches!(
        read_volume(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Invalid(_))
    ));
    write(&p, &[head.as_bytes(), b"data file: LIST\ns03.raw\n"]);
    assert!(matches!(
        read_volume(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Invalid(_))
    ));
    write(
        &p,
        &[head.as_bytes(), b"data file: s%02d.raw 0 99999999999 1\n"],
    );
    assert!(matches!(
        read_volume(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Invalid(_))
    ));
}

/// MetaIO's names for `ty`, the `k`-th of them (cycling): the scalar, its
/// one-channel `_ARRAY` form, for 32-bit integers `MET_LONG` and
/// `MET_ULONG`, which MetaIO sizes at 4 bytes (`MET_ValueTypeSize`), and
/// for signed bytes `MET_ASCII_CHAR` (which has no `_ARRAY` form).
fn met_type(ty: ScalarType, k: usize) -> String {
    let names: &[&str] = match ty {
        ScalarType::I8 => &["MET_CHAR", "MET_ASCII_CHAR"],
        ScalarType::U8 => &["MET_UCHAR"],
        ScalarType::I16 => &["MET_SHORT"],
        ScalarType::U16 => &["MET_USHORT"],
        ScalarType::I32 => &["MET_INT", "MET_LONG"],
        ScalarType::U32 => &["MET_UINT", "MET_ULONG"],
        ScalarType::F32 => &["MET_FLOAT"],
        ScalarType::F64 => &["MET_DOUBLE"],
    };
    let name = names[k % names.len()];
    if k / names.len() % 2 == 1 && name != "MET_ASCII_CHAR" {
        format!("{name}_ARRAY")
    } else {
        name.to_string()
    }
}

#[test]
fn metaimage_every_type_byte_order_and_compression() {
    let dir = temp_dir("meta");
    let mut case = 0;
    for ty in ScalarType::ALL {
        let vals = values(ty, N);
        for msb in [false, true] {
            for compressed in [false, true] {
                for local in [false, true] {
                    case += 1;
                    let raw = encode(ty, &vals, msb);
                    let data = if compressed { zlib(&raw) } else { raw };
                    // Half the cases rotated: axis 0 along world +y, axis 1
                    // along world -x.
                    let (matrix, frame) = if case % 2 == 0 {
                        (
                            "TransformMatrix = 0 1 0 -1 0 0 0 0 1\n",
                            VolumeFrame {
                                origin: DVec3::new(-1.5, 2.0, 100.0),
                                axes: DMat3::from_cols(
                                    DVec3::new(0.0, 0.5, 0.0),
                                    DVec3::new(-2.0, 0.0, 0.0),
                                    DVec3::new(0.0, 0.0, 1.5),
                                ),
                            },
                        )
                    } else {
                        (
                            "",
                            VolumeFrame::from_spacing(
                                DVec3::new(-1.5, 2.0, 100.0),
                                DVec3::new(0.5, 2.0, 1.5),
                            ),
                        )
                    };
                    let (order_key, pos_key) = if case % 3 == 0 {
                        ("ElementByteOrderMSB", "Position")
                    } else {
                        ("BinaryDataByteOrderMSB", "Offset")
                    };
                    let header = format!(
                        "ObjectType = Image\nNDims = 3\nDimSize = 5 3 7\nElementType = {}\n\
                         ElementSpacing = 0.5 2 1.5\n{pos_key} = -1.5 2 100\n{matrix}\
                         BinaryData = True\n{order_key} = {}\nCompressedData = {}\n",
                        met_type(ty, case),
                        if msb { "True" } else { "False" },
                        if compressed { "True" } else { "False" },
                    );
                    let path = if local {
                        let p = dir.join(format!("c{case}.mha"));
                        write(
                            &p,
                            &[header.as_bytes(), b"ElementDataFile = LOCAL\n", &data],
                        );
                        p
                    } else {
                        let p = dir.join(format!("c{case}.mhd"));
                        let data_name =
                            format!("c{case}.{}", if compressed { "zraw" } else { "raw" });
                        write(
                            &p,
                            &[
                                header.as_bytes(),
                                format!("ElementDataFile = {data_name}\n").as_bytes(),
                            ],
                        );
                        write(&dir.join(data_name), &[&data]);
                        p
                    };
                    let what = format!("{} (MSB {msb}, compressed {compressed})", path.display());
                    let v = read_volume(&path, MemoryLimit::DEFAULT)
                        .unwrap_or_else(|e| panic!("{what}: {e}"));
                    assert_samples(&v, ty, &vals, &what);
                    assert_eq!(v.frame, frame, "{what}");
                }
            }
        }
    }
}

#[test]
fn metaimage_header_size_text_and_list() {
    let dir = temp_dir("meta-more");
    let ty = ScalarType::F32;
    let vals = values(ty, N);
    let raw = encode(ty, &vals, false);
    let head = "NDims = 3\nDimSize = 5 3 7\nElementType = MET_FLOAT\n";
    // HeaderSize skips a file header; -1 takes the data from the end.
    write(&dir.join("h.raw"), &[b"0123456789", &raw]);
    let p = dir.join("h.mhd");
    write(
        &p,
        &[
            head.as_bytes(),
            b"HeaderSize = 10\nElementDataFile = h.raw\n",
        ],
    );
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals,
        "HeaderSize",
    );
    write(
        &p,
        &[
            head.as_bytes(),
            b"HeaderSize = -1\nElementDataFile = h.raw\n",
        ],
    );
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals,
        "HeaderSize -1",
    );
    // Without HeaderSize the 10 extra bytes are too much data.
    write(&p, &[head.as_bytes(), b"ElementDataFile = h.raw\n"]);
    let e = read_volume(&p, MemoryLimit::DEFAULT).unwrap_err();
    assert!(
        matches!(&e, VoxkitError::Invalid(m) if m.contains("430") && m.contains("420")),
        "{e}"
    );
    // Text data.
    let vals_text: Vec<f64> = vals
        .iter()
        .map(|v| if v.is_finite() { *v } else { 1.0 })
        .collect();
    let text: Vec<String> = vals_text.iter().map(|v| format!("{}", *v as f32)).collect();
    let p = dir.join("t.mha");
    write(
        &p,
        &[
            head.as_bytes(),
            b"BinaryData = False\nElementDataFile = LOCAL\n",
            text.join(" ").as_bytes(),
        ],
    );
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals_text,
        "text",
    );
    // A LIST of slices.
    let mut names = String::new();
    for (z, chunk) in raw.chunks(5 * 3 * 4).enumerate() {
        write(&dir.join(format!("z{z}.raw")), &[chunk]);
        names.push_str(&format!("z{z}.raw\n"));
    }
    let p = dir.join("l.mhd");
    write(
        &p,
        &[
            head.as_bytes(),
            b"ElementDataFile = LIST 2D\n",
            names.as_bytes(),
        ],
    );
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ty,
        &vals,
        "LIST",
    );
}

/// An npy file (version 1.0) with the given descr, order and body.
fn npy_file(descr: &str, fortran: bool, shape: &[usize], body: &[u8]) -> Vec<u8> {
    let axes: Vec<String> = shape.iter().map(usize::to_string).collect();
    let mut dict = format!(
        "{{'descr': '{descr}', 'fortran_order': {}, 'shape': ({}), }}",
        if fortran { "True" } else { "False" },
        axes.join(", ")
    );
    let unpadded = 10 + dict.len() + 1;
    dict.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    dict.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out.extend_from_slice(body);
    out
}

#[test]
fn npy_dtypes_orders_and_byte_orders() {
    let dir = temp_dir("npy");
    let cases: [(&str, ScalarType); 9] = [
        ("i1", ScalarType::I8),
        ("u1", ScalarType::U8),
        ("b1", ScalarType::U8),
        ("i2", ScalarType::I16),
        ("u2", ScalarType::U16),
        ("i4", ScalarType::I32),
        ("u4", ScalarType::U32),
        ("f4", ScalarType::F32),
        ("f8", ScalarType::F64),
    ];
    let [nx, ny, nz] = DIMS;
    for (code, ty) in cases {
        // `vals` is x fastest: vals[x + nx (y + ny z)] = a[x, y, z].
        let vals: Vec<f64> = if code == "b1" {
            (0..N).map(|i| ((i * 7) % 3 == 0) as u8 as f64).collect()
        } else {
            values(ty, N)
        };
        let orders: &[char] = if ty.bytes() == 1 {
            &['|', '<']
        } else {
            &['<', '>']
        };
        for &order in orders {
            for fortran in [false, true] {
                let file_order: Vec<f64> = if fortran {
                    vals.clone()
                } else {
                    // C order: z fastest.
                    let mut v = Vec::with_capacity(N);
                    for x in 0..nx {
                        for y in 0..ny {
                            for z in 0..nz {
                                v.push(vals[x + nx * (y + ny * z)]);
                            }
                        }
                    }
                    v
                };
                let body = encode(ty, &file_order, order == '>');
                let p = dir.join(format!(
                    "{code}-{}-{fortran}.npy",
                    if order == '>' { "be" } else { "le" }
                ));
                write(
                    &p,
                    &[&npy_file(&format!("{order}{code}"), fortran, &DIMS, &body)],
                );
                let what = format!("{}", p.display());
                let v =
                    read_volume(&p, MemoryLimit::DEFAULT).unwrap_or_else(|e| panic!("{what}: {e}"));
                assert_samples(&v, ty, &vals, &what);
                assert_eq!(v.frame, VolumeFrame::default());
                assert_eq!(v.get(4, 2, 6), vals[N - 1]);
                assert_eq!(v.is_binary(), code == "b1", "{what}");
            }
        }
    }
    // NumPy reads any nonzero byte of a bool array as True.
    let p = dir.join("bool7.npy");
    write(&p, &[&npy_file("|b1", false, &[1, 1, 2], &[0, 7])]);
    let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
    assert!(v.is_binary());
    assert_eq!(v.get(0, 0, 1), 1.0);
}

/// 64-bit integer arrays (NumPy's default) read in the narrowest type that
/// holds every sample exactly, either byte order, C and Fortran order;
/// beyond 32 bits as `float64` (rounded to nearest past 2⁵³).
#[test]
fn npy_64_bit_integers_narrow_exactly() {
    let dir = temp_dir("npy-i64");
    let [nx, ny, nz] = DIMS;
    type Case = (&'static str, fn(usize) -> i64, ScalarType);
    let signed: [Case; 4] = [
        ("labels", |i| (i % 9) as i64, ScalarType::U8),
        ("centred", |i| i as i64 - 52, ScalarType::I8),
        ("hu", |i| i as i64 * 40 - 1024, ScalarType::I16),
        ("wide", |i| (i as i64 - 52) << 40, ScalarType::F64),
    ];
    let c_index = |i: usize| {
        let (x, y, z) = (i % nx, i / nx % ny, i / (nx * ny));
        z + nz * (y + ny * x)
    };
    for (name, f, ty) in &signed {
        for big in [false, true] {
            for fortran in [false, true] {
                let mut file = vec![0i64; N];
                for i in 0..N {
                    file[if fortran { i } else { c_index(i) }] = f(i);
                }
                let body: Vec<u8> = file
                    .iter()
                    .flat_map(|x| {
                        if big {
                            x.to_be_bytes()
                        } else {
                            x.to_le_bytes()
                        }
                    })
                    .collect();
                let descr = if big { ">i8" } else { "<i8" };
                let p = dir.join(format!("{name}-{big}-{fortran}.npy"));
                write(&p, &[&npy_file(descr, fortran, &DIMS, &body)]);
                let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
                assert_eq!(v.source_type(), *ty, "{name}");
                for i in 0..N {
                    let (x, y, z) = (i % nx, i / nx % ny, i / (nx * ny));
                    assert_eq!(v.get(x, y, z), f(i) as f64, "{name} {big} {fortran}: {i}");
                }
            }
        }
    }
    // Unsigned, up to 2⁶⁴ − 1 (which rounds to 2⁶⁴ in float64).
    let f = |i: usize| if i == 0 { u64::MAX } else { i as u64 };
    let body: Vec<u8> = (0..N).flat_map(|i| f(i).to_le_bytes()).collect();
    let p = dir.join("u64.npy");
    write(&p, &[&npy_file("<u8", true, &DIMS, &body)]);
    let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(v.source_type(), ScalarType::F64);
    assert_eq!(v.get(0, 0, 0), 18446744073709551616.0);
    assert_eq!(v.get(4, 2, 6), (N - 1) as f64);
}

/// float16 arrays read as float32, exactly: normal, subnormal, largest,
/// infinite and NaN halves, either byte order.
#[test]
fn npy_float16_widens_exactly() {
    let dir = temp_dir("npy-f16");
    let halves: [(u16, f64); 8] = [
        (0x3800, 0.5),
        (0xC080, -2.25),
        (0x7BFF, 65504.0),
        (0x0001, 2f64.powi(-24)),
        (0x8000, -0.0),
        (0x7C00, f64::INFINITY),
        (0xFC00, f64::NEG_INFINITY),
        (0x7E00, f64::NAN),
    ];
    for big in [false, true] {
        let body: Vec<u8> = (0..N)
            .flat_map(|i| {
                let b = halves[i % halves.len()].0;
                if big {
                    b.to_be_bytes()
                } else {
                    b.to_le_bytes()
                }
            })
            .collect();
        let p = dir.join(format!("f16-{big}.npy"));
        let descr = if big { ">f2" } else { "<f2" };
        write(&p, &[&npy_file(descr, true, &DIMS, &body)]);
        let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
        assert_eq!(v.source_type(), ScalarType::F32);
        let [nx, ny, _] = DIMS;
        for i in 0..N {
            let (got, want) = (v.get(i % nx, i / nx % ny, i / (nx * ny)), halves[i % 8].1);
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{i}: {got} != {want}"
            );
        }
    }
}

/// Axes of size 1 before or after the three (a batch or channel axis, as
/// machine-learning tools save a volume) are dropped, in C and Fortran
/// order alike; a 2-D array reads as an image one voxel thick.
#[test]
fn npy_extra_axes_of_size_one_and_images() {
    let dir = temp_dir("npy-axes");
    let [nx, ny, nz] = DIMS;
    let vals = values(ScalarType::I16, N);
    let c_order: Vec<f64> = (0..nx)
        .flat_map(|x| (0..ny).flat_map(move |y| (0..nz).map(move |z| (x, y, z))))
        .map(|(x, y, z)| vals[x + nx * (y + ny * z)])
        .collect();
    for shape in [
        vec![1, nx, ny, nz],
        vec![nx, ny, nz, 1],
        vec![1, 1, nx, ny, nz, 1],
    ] {
        for fortran in [false, true] {
            let body = encode(
                ScalarType::I16,
                if fortran { &vals } else { &c_order },
                false,
            );
            let p = dir.join(format!("{shape:?}-{fortran}.npy"));
            write(&p, &[&npy_file("<i2", fortran, &shape, &body)]);
            let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(v.dims, DIMS, "{shape:?}");
            assert_samples(&v, ScalarType::I16, &vals, &format!("{shape:?} {fortran}"));
        }
    }
    // An image [15, 7]: a[i, j] at voxel (i, j, 0), x fastest.
    let (w, h) = (nx * ny, nz);
    let image: Vec<f64> = (0..w * h).map(|i| vals[i]).collect();
    for fortran in [false, true] {
        let file: Vec<f64> = if fortran {
            image.clone()
        } else {
            (0..w)
                .flat_map(|i| (0..h).map(move |j| (i, j)))
                .map(|(i, j)| image[i + w * j])
                .collect()
        };
        let p = dir.join(format!("image-{fortran}.npy"));
        let body = encode(ScalarType::I16, &file, false);
        write(&p, &[&npy_file("<i2", fortran, &[w, h], &body)]);
        let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
        assert_eq!((v.dims, v.source_type()), ([w, h, 1], ScalarType::I16));
        for (i, &want) in image.iter().enumerate() {
            assert_eq!(v.get(i % w, i / w, 0), want, "image {fortran}: {i}");
        }
    }
}

#[test]
fn npy_c_order_larger_than_one_transpose_block() {
    // 40 x 200 x 200 f64 = 12.8 MB; an x-slab is 320 kB, so the 8 MiB
    // transpose buffer holds 26 slabs: one full block and a partial one.
    let dir = temp_dir("npy-big");
    let dims = [40usize, 200, 200];
    let f = |x: usize, y: usize, z: usize| (x * 40_000 + y * 200 + z) as f64 * 0.5;
    let mut body = Vec::with_capacity(dims.iter().product::<usize>() * 8);
    for x in 0..dims[0] {
        for y in 0..dims[1] {
            for z in 0..dims[2] {
                body.extend_from_slice(&f(x, y, z).to_le_bytes());
            }
        }
    }
    let p = dir.join("big.npy");
    write(&p, &[&npy_file("<f8", false, &dims, &body)]);
    let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(v.dims, dims);
    for x in 0..dims[0] {
        for (y, z) in [(0, 0), (199, 199), (17, 3), (1, 198)] {
            assert_eq!(v.get(x, y, z), f(x, y, z), "({x}, {y}, {z})");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn real_volumes_read_the_same_through_both_headers() {
    let ct = data_dir().join("headsq_quarter");
    let a = read_volume(&ct.join("headsq_quarter.nhdr"), MemoryLimit::DEFAULT).unwrap();
    let b = read_volume(&ct.join("headsq_quarter.mhd"), MemoryLimit::DEFAULT).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.dims, [64, 64, 93]);
    assert_eq!(a.source_type(), ScalarType::I16);
    // Both headers place it as VTK's examples view it: LPS, index x to the
    // right, z downwards, the voxel centres spanning the same box as the
    // plain spacings did.
    assert_eq!(
        a.frame,
        VolumeFrame {
            origin: DVec3::new(201.6, 0.0, 138.0),
            axes: DMat3::from_diagonal(DVec3::new(-3.2, 3.2, -1.5)),
        }
    );
    assert_eq!(a.space, Some(AnatomicalSpace::Lps));
    assert_eq!(a.range(), Some((0.0, 3926.0)));
    let mean = (0..a.len()).map(|i| a.data.value(i).unwrap()).sum::<f64>() / a.len() as f64;
    assert!((mean - 507.7).abs() < 0.05, "CT mean {mean}");
    let p = a.percentiles(&[0.0, 1.0, 99.5, 100.0]);
    assert_eq!((p[0], p[3]), (0.0, 3926.0));
    assert!(p[1] <= p[2]);

    let mr = data_dir().join("HeadMRVolume");
    let a = read_volume(&mr.join("HeadMRVolume.nhdr"), MemoryLimit::DEFAULT).unwrap();
    let b = read_volume(&mr.join("HeadMRVolume.mhd"), MemoryLimit::DEFAULT).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.dims, [48, 62, 42]);
    assert_eq!(a.source_type(), ScalarType::U8);
    assert_eq!(
        a.frame,
        VolumeFrame::from_spacing(DVec3::ZERO, DVec3::splat(4.0))
    );
    assert_eq!(a.range(), Some((0.0, 255.0)));
    let mean = (0..a.len()).map(|i| a.data.value(i).unwrap()).sum::<f64>() / a.len() as f64;
    assert!((mean - 24.5).abs() < 0.05, "MR mean {mean}");
    assert!(!a.is_binary());
}

#[test]
fn ct_head_from_its_original_slice_files() {
    // The VTKData original: 93 slice files named by `quarter.%d 1 93 1`.
    let dir = temp_dir("quarter");
    let raw = std::fs::read(data_dir().join("headsq_quarter/headsq_quarter.raw")).unwrap();
    for (i, slice) in raw.chunks(8192).enumerate() {
        write(&dir.join(format!("quarter.{}", i + 1)), &[slice]);
    }
    let p = dir.join("quarter.nhdr");
    write(
        &p,
        &[
            b"NRRD0004\ndimension: 3\nsizes: 64 64 93\nspacings: 3.2 3.2 1.5\nendian: little\n\
            type: short\nencoding: raw\nspace: 3D-left-handed\ndata file: quarter.%d 1 93 1\n",
        ],
    );
    let a = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
    let b = read_volume(
        &data_dir().join("headsq_quarter/headsq_quarter.nhdr"),
        MemoryLimit::DEFAULT,
    )
    .unwrap();
    // The same samples; the original's `3D-left-handed` is no anatomical
    // space, and its spacings no orientation (ours adds both).
    assert_eq!((a.dims, &a.data), (b.dims, &b.data));
    assert_eq!(
        a.frame,
        VolumeFrame::from_spacing(DVec3::ZERO, DVec3::new(3.2, 3.2, 1.5))
    );
    assert_eq!(a.space, None);
}

/// A valid attached NRRD of `DIMS` int16 with `extra` header lines and
/// `data` as its body.
fn nrrd_with(dir: &Path, name: &str, header: &str, data: &[u8]) -> PathBuf {
    let p = dir.join(name);
    write(&p, &[header.as_bytes(), b"\n", data]);
    p
}

fn expect_invalid(path: &Path, needles: &[&str]) {
    match read_volume(path, MemoryLimit::DEFAULT) {
        Err(VoxkitError::Invalid(m)) => {
            let name = path.file_name().unwrap().to_string_lossy();
            assert!(m.contains(&*name), "error does not name the file: {m}");
            for n in needles {
                assert!(m.contains(n), "{m:?} lacks {n:?}");
            }
        }
        other => panic!("{}: expected Invalid, got {other:?}", path.display()),
    }
}

fn expect_unsupported(path: &Path) {
    match read_volume(path, MemoryLimit::DEFAULT) {
        Err(VoxkitError::Unsupported(m)) => {
            let name = path.file_name().unwrap().to_string_lossy();
            assert!(m.contains(&*name), "error does not name the file: {m}");
        }
        other => panic!("{}: expected Unsupported, got {other:?}", path.display()),
    }
}

const GOOD_HEAD: &str =
    "NRRD0004\ntype: short\ndimension: 3\nsizes: 5 3 7\nendian: little\nencoding: raw\n";

#[test]
fn nrrd_bad_files() {
    let dir = temp_dir("bad-nrrd");
    let raw = encode(ScalarType::I16, &values(ScalarType::I16, N), false);
    // 210 bytes needed.
    expect_invalid(
        &nrrd_with(&dir, "short.nrrd", GOOD_HEAD, &raw[..209]),
        &["209", "210"],
    );
    expect_invalid(
        &nrrd_with(&dir, "long.nrrd", GOOD_HEAD, &[&raw[..], b"x"].concat()),
        &["211", "210"],
    );
    let gz_head = GOOD_HEAD.replace("raw", "gzip");
    expect_invalid(
        &nrrd_with(&dir, "gzshort.nrrd", &gz_head, &gzip(&raw[..200])),
        &["200", "210"],
    );
    expect_invalid(
        &nrrd_with(
            &dir,
            "gzlong.nrrd",
            &gz_head,
            &gzip(&[&raw[..], &[0; 5]].concat()),
        ),
        &["longer", "210"],
    );
    let mut corrupt = gzip(&raw);
    let mid = corrupt.len() / 2;
    corrupt[mid] ^= 0xff;
    corrupt.truncate(corrupt.len() - 8);
    expect_invalid(&nrrd_with(&dir, "gzcorrupt.nrrd", &gz_head, &corrupt), &[]);
    expect_invalid(&nrrd_with(&dir, "notgz.nrrd", &gz_head, &raw), &[]);
    // A gzip bomb: 64 MiB of zeros for a 210-byte volume is refused after
    // inflating 211 bytes.
    let bomb = gzip(&vec![0u8; 64 << 20]);
    expect_invalid(&nrrd_with(&dir, "bomb.nrrd", &gz_head, &bomb), &["longer"]);

    let swap = |from: &str, to: &str| GOOD_HEAD.replace(from, to);
    expect_invalid(
        &nrrd_with(&dir, "type.nrrd", &swap("short", "shortish"), &raw),
        &["shortish"],
    );
    expect_unsupported(&nrrd_with(
        &dir,
        "block.nrrd",
        &swap("short", "block"),
        &raw,
    ));
    // 64-bit samples are 8 bytes each: the short data is named.
    expect_invalid(
        &nrrd_with(&dir, "int64.nrrd", &swap("short", "int64"), &raw),
        &["210", "840"],
    );
    // Raw bytes declared as bzip2: a stream error naming the encoding.
    expect_invalid(
        &nrrd_with(
            &dir,
            "bz2.nrrd",
            &swap("encoding: raw", "encoding: bzip2"),
            &raw,
        ),
        &["bzip2"],
    );
    expect_unsupported(&nrrd_with(
        &dir,
        "hex.nrrd",
        &swap("encoding: raw", "encoding: hex"),
        &raw,
    ));
    expect_invalid(
        &nrrd_with(
            &dir,
            "enc.nrrd",
            &swap("encoding: raw", "encoding: zip"),
            &raw,
        ),
        &["zip"],
    );
    // 4-D without a size-1 axis to squeeze.
    expect_unsupported(&nrrd_with(
        &dir,
        "dim4.nrrd",
        &swap("dimension: 3\nsizes: 5 3 7", "dimension: 4\nsizes: 5 3 7 2"),
        &raw,
    ));
    expect_invalid(
        &nrrd_with(&dir, "noendian.nrrd", &swap("endian: little\n", ""), &raw),
        &["endian"],
    );
    expect_invalid(
        &nrrd_with(&dir, "endian.nrrd", &swap("little", "middle"), &raw),
        &["middle"],
    );
    expect_invalid(
        &nrrd_with(&dir, "nosizes.nrrd", &swap("sizes: 5 3 7\n", ""), &raw),
        &["sizes"],
    );
    expect_invalid(
        &nrrd_with(&dir, "zero.nrrd", &swap("5 3 7", "5 0 7"), &raw),
        &[],
    );
    expect_invalid(
        &nrrd_with(&dir, "neg.nrrd", &swap("5 3 7", "5 -3 7"), &raw),
        &[],
    );
    expect_invalid(
        &nrrd_with(&dir, "two.nrrd", &swap("5 3 7", "5 3"), &raw),
        &[],
    );
    expect_invalid(
        &nrrd_with(
            &dir,
            "nan.nrrd",
            &format!("{GOOD_HEAD}spacings: 1 nan 1\n"),
            &raw,
        ),
        &[],
    );
    expect_invalid(
        &nrrd_with(
            &dir,
            "origin.nrrd",
            &format!("{GOOD_HEAD}space origin: (0,inf,0)\n"),
            &raw,
        ),
        &[],
    );
    expect_invalid(
        &nrrd_with(
            &dir,
            "singular.nrrd",
            &format!("{GOOD_HEAD}space directions: (1,0,0) (0,1,0) (1,1,0)\n"),
            &raw,
        ),
        &["singular"],
    );
    expect_unsupported(&nrrd_with(
        &dir,
        "none.nrrd",
        &format!("{GOOD_HEAD}space directions: none (0,1,0) (0,0,1)\n"),
        &raw,
    ));
    // A detached header whose data file is missing: an I/O error naming it.
    let p = dir.join("missing.nhdr");
    write(&p, &[GOOD_HEAD.as_bytes(), b"data file: nowhere.raw\n"]);
    match read_volume(&p, MemoryLimit::DEFAULT) {
        Err(VoxkitError::Io { path, .. }) => assert!(path.ends_with("nowhere.raw")),
        other => panic!("expected Io, got {other:?}"),
    }
    // An attached header without a blank line has no data.
    let p = dir.join("nodata.nrrd");
    write(&p, &[GOOD_HEAD.as_bytes()]);
    expect_invalid(&p, &["no data"]);
    // A missing header file.
    assert!(matches!(
        read_volume(&dir.join("absent.nrrd"), MemoryLimit::DEFAULT),
        Err(VoxkitError::Io { .. })
    ));
    // Not a volume extension.
    assert!(matches!(
        read_volume(&dir.join("x.raw"), MemoryLimit::DEFAULT),
        Err(VoxkitError::Unsupported(_))
    ));
    assert!(is_volume_path(&p) && !is_volume_path(&dir.join("x.raw")));
}

#[test]
fn sizes_over_the_limit_are_refused_before_reading() {
    let dir = temp_dir("limits");
    let tiny = MemoryLimit::new(1 << 20);
    // 1000³ int16 = 2 GB declared, 4 bytes present: the limit speaks first.
    let p = nrrd_with(
        &dir,
        "huge.nrrd",
        &GOOD_HEAD.replace("5 3 7", "1000 1000 1000"),
        &[0; 4],
    );
    match read_volume(&p, tiny) {
        Err(VoxkitError::Limits {
            what,
            needed,
            limit,
        }) => {
            assert_eq!((needed, limit), (2_000_000_000, 1 << 20));
            assert!(what.contains("huge.nrrd"), "{what}");
        }
        other => panic!("expected Limits, got {other:?}"),
    }
    // Sizes whose product overflows any integer.
    let p = nrrd_with(
        &dir,
        "overflow.nrrd",
        &GOOD_HEAD.replace(
            "5 3 7",
            "9223372036854775807 9223372036854775807 9223372036854775807",
        ),
        &[0; 4],
    );
    assert!(matches!(
        read_volume(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Limits { .. })
    ));
    let p = dir.join("huge.mha");
    write(&p, &[b"NDims = 3\nDimSize = 4096 4096 4096\nElementType = MET_DOUBLE\nElementDataFile = LOCAL\n"]);
    assert!(matches!(
        read_volume(&p, tiny),
        Err(VoxkitError::Limits { .. })
    ));
    let p = dir.join("huge.npy");
    write(&p, &[&npy_file("<f8", false, &[4096, 4096, 4096], &[])]);
    assert!(matches!(
        read_volume(&p, tiny),
        Err(VoxkitError::Limits { .. })
    ));
    // Just under and over the limit.
    let raw = vec![0u8; 210];
    let p = nrrd_with(&dir, "edge.nrrd", GOOD_HEAD, &raw);
    assert!(read_volume(&p, MemoryLimit::new(210)).is_ok());
    assert!(matches!(
        read_volume(&p, MemoryLimit::new(209)),
        Err(VoxkitError::Limits { .. })
    ));
}

#[test]
fn metaimage_and_npy_bad_files() {
    let dir = temp_dir("bad-meta");
    let raw = encode(ScalarType::I16, &values(ScalarType::I16, N), false);
    let head = "NDims = 3\nDimSize = 5 3 7\nElementType = MET_SHORT\n";
    let mha = |name: &str, h: &str, data: &[u8]| {
        let p = dir.join(name);
        write(&p, &[h.as_bytes(), b"ElementDataFile = LOCAL\n", data]);
        p
    };
    expect_invalid(&mha("short.mha", head, &raw[..100]), &["100", "210"]);
    expect_invalid(
        &mha("long.mha", head, &[&raw[..], &[1, 2]].concat()),
        &["212", "210"],
    );
    let z = format!("{head}CompressedData = True\n");
    expect_invalid(&mha("zshort.mha", &z, &zlib(&raw[..10])), &["10", "210"]);
    expect_invalid(
        &mha("zlong.mha", &z, &zlib(&[&raw[..], &[0]].concat())),
        &["longer"],
    );
    expect_invalid(&mha("znot.mha", &z, &raw), &[]);
    expect_unsupported(&mha(
        "ndims.mha",
        &head.replace("NDims = 3", "NDims = 2"),
        &raw,
    ));
    expect_unsupported(&mha(
        "array.mha",
        &format!(
            "{}ElementNumberOfChannels = 2\n",
            head.replace("MET_SHORT", "MET_SHORT_ARRAY")
        ),
        &raw,
    ));
    expect_unsupported(&mha(
        "matrix.mha",
        &head.replace("MET_SHORT", "MET_FLOAT_MATRIX"),
        &raw,
    ));
    expect_invalid(
        &mha("type.mha", &head.replace("MET_SHORT", "SHORT"), &raw),
        &["SHORT"],
    );
    expect_unsupported(&mha(
        "chan.mha",
        &format!("{head}ElementNumberOfChannels = 3\n"),
        &raw,
    ));
    expect_unsupported(&mha("obj.mha", &format!("ObjectType = Mesh\n{head}"), &raw));
    expect_invalid(
        &mha("nodims.mha", &head.replace("DimSize = 5 3 7\n", ""), &raw),
        &["DimSize"],
    );
    expect_invalid(
        &mha(
            "spacing.mha",
            &format!("{head}ElementSpacing = 1 inf 1\n"),
            &raw,
        ),
        &[],
    );
    expect_invalid(
        &mha("bool.mha", &format!("{head}CompressedData = Maybe\n"), &raw),
        &["Maybe"],
    );
    expect_invalid(
        &mha(
            "matrix.mha",
            &format!("{head}TransformMatrix = 1 0 0 1 0 0 0 0 1\n"),
            &raw,
        ),
        &["singular"],
    );
    let p = dir.join("nofile.mhd");
    write(&p, &[head.as_bytes(), b"ElementDataFile = gone.raw\n"]);
    assert!(matches!(
        read_volume(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Io { .. })
    ));
    let p = dir.join("nodatafile.mhd");
    write(&p, &[head.as_bytes()]);
    expect_invalid(&p, &["ElementDataFile"]);

    let npy = |name: &str, bytes: &[u8]| {
        let p = dir.join(name);
        write(&p, &[bytes]);
        p
    };
    let body = encode(ScalarType::I16, &values(ScalarType::I16, N), false);
    expect_invalid(
        &npy("short.npy", &npy_file("<i2", false, &DIMS, &body[..209])),
        &["209", "210"],
    );
    expect_invalid(
        &npy(
            "long.npy",
            &npy_file("<i2", false, &DIMS, &[&body[..], b"zz"].concat()),
        ),
        &["212"],
    );
    expect_unsupported(&npy("c8.npy", &npy_file("<c8", false, &DIMS, &body)));
    // Same header length, an axis of size 1 between the three: not one
    // a volume may drop.
    let mut four_d = npy_file("<i2", false, &DIMS, &body);
    let at = four_d.windows(9).position(|w| w == b"(5, 3, 7)").unwrap();
    four_d[at..at + 9].copy_from_slice(b"(5,3,1,7)");
    expect_invalid(&npy("4d.npy", &four_d), &["3 dimensions"]);
    expect_invalid(
        &npy("1d.npy", &npy_file("<i2", false, &[105], &body)),
        &["3 dimensions"],
    );
    expect_invalid(
        &npy("magic.npy", b"\x93NUMPZ\x01\x00\x10\x00{}"),
        &["magic"],
    );
    expect_invalid(
        &npy("trunc.npy", b"\x93NUMPY\x01\x00\xff\x00{'descr'"),
        &["truncated"],
    );
    expect_unsupported(&npy("v9.npy", b"\x93NUMPY\x09\x00\x10\x00{}"));
}

/// Random bytes, and every prefix and many byte flips of valid files, in
/// every format: the readers return errors (or, for harmless flips, a
/// volume) but never panic.
#[test]
fn garbage_never_panics() {
    let dir = temp_dir("garbage");
    let mut rng = ChaCha8Rng::seed_from_u64(0x5EED_0001);
    let raw = encode(ScalarType::I16, &values(ScalarType::I16, N), false);
    let valid: Vec<(&str, Vec<u8>)> = vec![
        (
            "nrrd",
            [GOOD_HEAD.as_bytes(), b"space directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (1,2,3)\n\n", &raw].concat(),
        ),
        (
            "nrrd",
            [GOOD_HEAD.replace("raw", "gzip").as_bytes(), b"\n", &gzip(&raw)].concat(),
        ),
        (
            "mha",
            [
                b"NDims = 3\nDimSize = 5 3 7\nElementType = MET_SHORT\nElementSpacing = 1 2 3\nCompressedData = True\nElementDataFile = LOCAL\n".as_slice(),
                &zlib(&raw),
            ]
            .concat(),
        ),
        ("npy", npy_file("<i2", false, &DIMS, &raw)),
    ];
    let limit = MemoryLimit::new(1 << 24);
    let mut tried = 0;
    for (i, (ext, bytes)) in valid.iter().enumerate() {
        let p = dir.join(format!("v{i}.{ext}"));
        write(&p, &[bytes]);
        read_volume(&p, limit).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        let header_len = bytes.len() - raw.len().min(bytes.len() / 2);
        for cut in 0..header_len.min(300) {
            write(&p, &[&bytes[..cut]]);
            assert!(read_volume(&p, limit).is_err(), "{ext} cut at {cut}");
            tried += 1;
        }
        for _ in 0..300 {
            let mut b = bytes.clone();
            for _ in 0..rng.random_range(1..4) {
                let at = rng.random_range(0..b.len().min(header_len + 16));
                b[at] = rng.random();
            }
            write(&p, &[&b]);
            let _ = read_volume(&p, limit);
            tried += 1;
        }
    }
    for ext in ["nrrd", "nhdr", "mhd", "mha", "npy"] {
        let p = dir.join(format!("g.{ext}"));
        for _ in 0..100 {
            let n = rng.random_range(0..400);
            let b: Vec<u8> = (0..n).map(|_| rng.random()).collect();
            write(&p, &[&b]);
            assert!(read_volume(&p, limit).is_err());
            tried += 1;
        }
    }
    assert!(tried > 2000);
}

/// The anatomical space a header names is kept (NRRD `space`: RAS, LAS,
/// LPS in either spelling and any case; MetaImage: ITK's LPS where an
/// `AnatomicalOrientation` is given), and it turns the default views: the
/// front of the scene is where the patient's front is.
#[test]
fn anatomical_spaces_orient_the_default_view() {
    use voxkit::camera::SceneAxes;
    use voxkit::grid::AnatomicalSpace::{Las, Lps, Ras};
    use voxkit::io::volume::read_volume_bytes;
    use voxkit::render::VolumeScene;
    let data = [0u8; 8];
    let nrrd = |space: &str| {
        let h = format!(
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n{space}\
             data file: d.raw\n"
        );
        read_volume_bytes(
            Path::new("v.nhdr"),
            h.as_bytes(),
            &data,
            MemoryLimit::DEFAULT,
        )
        .unwrap()
        .space
    };
    for (field, want) in [
        ("space: RAS\n", Some(Ras)),
        ("space: right-anterior-superior\n", Some(Ras)),
        ("space: Left-Anterior-Superior\n", Some(Las)),
        ("space: lps\n", Some(Lps)),
        (
            "space: LPS\nspace directions: (0,1,0) (-1,0,0) (0,0,2)\n",
            Some(Lps),
        ),
        ("space: scanner-xyz\n", None),
        ("space: 3D-right-handed\n", None),
        ("space: 3D-left-handed\n", None),
        ("", None),
    ] {
        assert_eq!(nrrd(field), want, "{field:?}");
    }
    let meta = |extra: &str| {
        let h = format!(
            "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n{extra}ElementDataFile = d.raw\n"
        );
        read_volume_bytes(
            Path::new("v.mhd"),
            h.as_bytes(),
            &data,
            MemoryLimit::DEFAULT,
        )
        .unwrap()
        .space
    };
    assert_eq!(meta("AnatomicalOrientation = RAI\n"), Some(Lps));
    assert_eq!(meta("AnatomicalOrientation = ???\n"), None);
    assert_eq!(meta(""), None);

    // The scene's front: −y in LPS (and without a space, as before), +y in
    // RAS and LAS; always z up, and the viewer's right completing a
    // rotation (never a mirror).
    for (space, front_y) in [
        (None, -1.0),
        (Some(Lps), -1.0),
        (Some(Ras), 1.0),
        (Some(Las), 1.0),
    ] {
        let vol = ScalarVolume::new(
            [2, 2, 2],
            voxkit::grid::VolumeData::U8(vec![0; 8]),
            VolumeFrame::default(),
        )
        .unwrap()
        .with_space(space);
        let axes = VolumeScene::new(&vol, MemoryLimit::DEFAULT)
            .unwrap()
            .scene_axes();
        assert_eq!(axes.up, DVec3::Z);
        assert_eq!(axes.front, DVec3::new(0.0, front_y, 0.0), "{space:?}");
        assert_eq!(axes.right.cross(axes.up), axes.front, "{space:?}");
        assert_eq!(axes == SceneAxes::Z_UP, front_y < 0.0);
    }
}

/// The bundled CT head stands upright in the default views (Z up): its
/// first slice, the top of the skull, is the highest in the world.
#[test]
fn ct_head_is_upright() {
    let a = read_volume(
        &data_dir().join("headsq_quarter/headsq_quarter.nhdr"),
        MemoryLimit::DEFAULT,
    )
    .unwrap();
    let slice_z = |k: f64| (a.frame.origin + a.frame.axes * DVec3::new(0.0, 0.0, k)).z;
    assert!(slice_z(0.0) > slice_z(92.0));
}

/// 64-bit integer samples in NRRD (raw, gzip, text; either byte order) and
/// MetaImage, signed and unsigned, read back exactly in the narrowest type
/// that holds them all, as NumPy's 64-bit arrays are.
#[test]
fn sixty_four_bit_integers_read_narrowed_and_exact() {
    let dir = temp_dir("int64");
    let mut rng = ChaCha8Rng::seed_from_u64(64);
    // (values, narrowest type): each set's extremes pick the type.
    let sets: Vec<(Vec<i128>, ScalarType)> = vec![
        ((0..N).map(|i| (i % 200) as i128).collect(), ScalarType::U8),
        (
            (0..N).map(|i| i as i128 * 300 - 9_000).collect(),
            ScalarType::I16,
        ),
        (
            (0..N)
                .map(|_| rng.random_range(-(1i128 << 31)..1 << 31))
                .collect(),
            ScalarType::I32,
        ),
        (
            (0..N).map(|i| i as i128 * (1 << 20)).collect(),
            ScalarType::U32,
        ),
    ];
    for (k, (vals, ty)) in sets.iter().enumerate() {
        let want: Vec<f64> = vals.iter().map(|&v| v as f64).collect();
        let signed = vals.iter().any(|&v| v < 0);
        for (name, unsigned) in [("int64", false), ("uint64", true)] {
            if unsigned && signed {
                continue;
            }
            for big in [false, true] {
                let bytes: Vec<u8> = vals
                    .iter()
                    .flat_map(|&v| {
                        let v = v as i64;
                        if big {
                            v.to_be_bytes()
                        } else {
                            v.to_le_bytes()
                        }
                    })
                    .collect();
                let endian = if big { "big" } else { "little" };
                let head = |enc: &str| {
                    format!(
                        "NRRD0004\ntype: {name}\ndimension: 3\nsizes: 5 3 7\nendian: {endian}\nencoding: {enc}\n\n"
                    )
                };
                let what = format!("set {k} {name} {endian}");
                let p = dir.join(format!("raw{k}{name}{endian}.nrrd"));
                write(&p, &[head("raw").as_bytes(), &bytes]);
                let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
                assert_samples(&v, *ty, &want, &format!("{what} raw"));
                let p = dir.join(format!("gz{k}{name}{endian}.nrrd"));
                write(&p, &[head("gzip").as_bytes(), &gzip(&bytes)]);
                let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
                assert_samples(&v, *ty, &want, &format!("{what} gzip"));
                // The big-endian files spell it as the one-channel array.
                let elem = format!(
                    "{}{}",
                    if unsigned {
                        "MET_ULONG_LONG"
                    } else {
                        "MET_LONG_LONG"
                    },
                    if big { "_ARRAY" } else { "" }
                );
                let msb = if big { "True" } else { "False" };
                let p = dir.join(format!("m{k}{name}{endian}.mha"));
                let mh = format!(
                    "NDims = 3\nDimSize = 5 3 7\nElementType = {elem}\nBinaryDataByteOrderMSB = {msb}\nElementDataFile = LOCAL\n"
                );
                write(&p, &[mh.as_bytes(), &bytes]);
                let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
                assert_samples(&v, *ty, &want, &format!("{what} MetaImage"));
            }
            let text: String = vals.iter().map(|v| format!("{v}\n")).collect();
            let p = dir.join(format!("txt{k}{name}.nrrd"));
            let head =
                format!("NRRD0004\ntype: {name}\ndimension: 3\nsizes: 5 3 7\nencoding: ascii\n\n");
            write(&p, &[head.as_bytes(), text.as_bytes()]);
            let v = read_volume(&p, MemoryLimit::DEFAULT).unwrap();
            assert_samples(&v, *ty, &want, &format!("set {k} {name} text"));
        }
    }
    // Beyond 32 bits: float64, exact below 2^53.
    let vals: Vec<i64> = (0..N as i64).map(|i| (i - 50) * (1 << 40)).collect();
    let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
    let p = dir.join("wide.nrrd");
    write(
        &p,
        &[b"NRRD0004\ntype: long long\ndimension: 3\nsizes: 5 3 7\nendian: little\nencoding: raw\n\n", &bytes],
    );
    let want: Vec<f64> = vals.iter().map(|&v| v as f64).collect();
    assert_samples(
        &read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
        ScalarType::F64,
        &want,
        "wide",
    );
    // Text that a float64 cannot hold exactly, a fraction, or a negative
    // unsigned sample: refused, naming the sample.
    for (name, bad) in [
        ("int64", "9007199254740993"),
        ("int64", "-9007199254740992"),
        ("int64", "2.5"),
        ("uint64", "-1"),
        ("int64", "nan"),
    ] {
        let text: String = (0..N)
            .map(|i| {
                if i == 17 {
                    format!("{bad}\n")
                } else {
                    "1\n".into()
                }
            })
            .collect();
        let p = dir.join(format!("bad{name}{}.nrrd", bad.len()));
        let head =
            format!("NRRD0004\ntype: {name}\ndimension: 3\nsizes: 5 3 7\nencoding: ascii\n\n");
        write(&p, &[head.as_bytes(), text.as_bytes()]);
        match read_volume(&p, MemoryLimit::DEFAULT) {
            Err(VoxkitError::Unsupported(m)) => assert!(m.contains("64-bit"), "{bad}: {m}"),
            Err(VoxkitError::Invalid(m)) => assert!(bad == "nan" && !m.is_empty(), "{bad}: {m}"),
            other => panic!("{name} {bad}: {other:?}"),
        }
    }
}
