//! NIfTI-1 and NIfTI-2 volumes against nibabel: the files of
//! `tests/data/formats/nifti/` and the answers nibabel read back from them
//! (`nifti_expected.json`, both written by `make_nifti.py`): every sample
//! type, both byte orders, gzip, a `.hdr`/`.img` pair, sform, qform with
//! `qfac = −1`, method 1, scaled samples, 2-D and 4-D shapes, and a real
//! MR volume that must read as its MetaImage does. Bad and cut-short files
//! fail with a typed error naming the file, never a panic.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::scratch::temp_dir;
use glam::{DMat3, DVec3};
use serde_json::Value;
use voxkit::VoxkitError;
use voxkit::grid::{AnatomicalSpace, MemoryLimit, ScalarType};
use voxkit::io::volume::{is_volume_path, read_volume, read_volume_bytes};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats/nifti")
}

fn vec3(v: &Value) -> DVec3 {
    DVec3::from_array(serde_json::from_value(v.clone()).expect("three numbers"))
}

fn type_named(name: &str) -> ScalarType {
    ScalarType::ALL
        .into_iter()
        .find(|t| t.name() == name)
        .unwrap_or_else(|| panic!("no type {name}"))
}

#[test]
fn files_written_by_nibabel_read_as_nibabel_reads_them() {
    let text = std::fs::read_to_string(corpus().join("../nifti_expected.json")).unwrap();
    let answers: Vec<Value> = serde_json::from_str(&text).unwrap();
    assert!(answers.len() >= 9);
    for a in &answers {
        let name = a["file"].as_str().unwrap();
        let path = corpus().join(name);
        assert!(is_volume_path(&path), "{name}");
        let v = read_volume(&path, MemoryLimit::DEFAULT).unwrap_or_else(|e| panic!("{name}: {e}"));
        let dims: Vec<usize> = a["dims"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| d.as_u64().unwrap() as usize)
            .collect();
        assert_eq!(v.dims.to_vec(), dims, "{name}");
        let stored = type_named(a["stored"].as_str().unwrap());
        let scaled = a["scaled"].as_bool().unwrap();
        let expected_type = match (scaled, stored) {
            (false, t) => t,
            (true, ScalarType::I32 | ScalarType::U32 | ScalarType::F64) => ScalarType::F64,
            (true, _) => ScalarType::F32,
        };
        assert_eq!(v.source_type(), expected_type, "{name}");
        let values = a["values"].as_array().unwrap();
        assert_eq!(values.len(), v.len(), "{name}");
        for (i, want) in values.iter().enumerate() {
            let want = want.as_f64().unwrap();
            let got = v.data.value(i).unwrap();
            // Scaled samples are float32 of nibabel's float64 product.
            let tolerance = if scaled {
                want.abs() * 1e-7 + 1e-9
            } else {
                0.0
            };
            assert!(
                (got - want).abs() <= tolerance,
                "{name} sample {i}: {got} against nibabel's {want}"
            );
        }
        let origin = vec3(&a["origin"]);
        let axes: Vec<DVec3> = a["axes"].as_array().unwrap().iter().map(vec3).collect();
        let axes = DMat3::from_cols(axes[0], axes[1], axes[2]);
        assert!(
            (v.frame.origin - origin).abs().max_element() < 1e-9,
            "{name}: origin {} against {origin}",
            v.frame.origin
        );
        // The quaternion is float32 in NIfTI-1 files: both readers expand
        // it in float64, by different formulas.
        let diff = (v.frame.axes - axes).to_cols_array();
        assert!(
            diff.iter().all(|d| d.abs() < 1e-6),
            "{name}: axes {:?} against {:?}",
            v.frame.axes,
            axes
        );
        let space = a["space"].as_str().map(|_| AnatomicalSpace::Ras);
        assert_eq!(v.space, space, "{name}");
    }
}

#[test]
fn a_real_mr_volume_reads_as_its_metaimage() {
    let mhd =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data/volumes/HeadMRVolume/HeadMRVolume.mhd");
    let a = read_volume(&mhd, MemoryLimit::DEFAULT).unwrap();
    let b = read_volume(&corpus().join("headmr.nii.gz"), MemoryLimit::DEFAULT).unwrap();
    assert_eq!((a.dims, &a.data, a.frame), (b.dims, &b.data, b.frame));
    assert_eq!(b.space, Some(AnatomicalSpace::Ras));
}

fn expect_error(path: &Path, unsupported: bool, needle: &str) {
    let name = path.file_name().unwrap().to_string_lossy().to_string();
    match read_volume(path, MemoryLimit::DEFAULT) {
        Err(VoxkitError::Unsupported(m)) if unsupported => {
            assert!(m.contains(&name) && m.contains(needle), "{m}")
        }
        Err(VoxkitError::Invalid(m)) if !unsupported => {
            assert!(m.contains(&name) && m.contains(needle), "{m}")
        }
        other => panic!("{name}: expected an error with {needle:?}, got {other:?}"),
    }
}

/// `u8_sform.nii` with `edit` applied to its bytes, written as `name`.
fn edited(dir: &Path, name: &str, edit: impl FnOnce(&mut Vec<u8>)) -> PathBuf {
    let mut b = std::fs::read(corpus().join("u8_sform.nii")).unwrap();
    edit(&mut b);
    let p = dir.join(name);
    std::fs::write(&p, b).unwrap();
    p
}

/// An `INT64` / `UINT64` image (`u8_sform.nii`'s samples widened) reads
/// back as the original: the same values, in the narrowest type.
#[test]
fn sixty_four_bit_integers_read_narrowed() {
    let dir = temp_dir("int64");
    let src = std::fs::read(corpus().join("u8_sform.nii")).unwrap();
    let good = read_volume(&corpus().join("u8_sform.nii"), MemoryLimit::DEFAULT).unwrap();
    let offset = f32::from_le_bytes(src[108..112].try_into().unwrap()) as usize;
    for code in [1024i16, 1280] {
        let mut b = src[..offset].to_vec();
        b[70..72].copy_from_slice(&code.to_le_bytes());
        b[72..74].copy_from_slice(&64i16.to_le_bytes());
        for &x in &src[offset..offset + good.len()] {
            b.extend_from_slice(&u64::from(x).to_le_bytes());
        }
        let p = dir.join(format!("wide{code}.nii"));
        std::fs::write(&p, b).unwrap();
        assert_eq!(
            read_volume(&p, MemoryLimit::DEFAULT).unwrap(),
            good,
            "{code}"
        );
    }
}

#[test]
fn bad_headers_are_typed_errors_naming_the_file() {
    let dir = temp_dir("bad");
    let i16_at =
        |b: &mut Vec<u8>, at: usize, v: i16| b[at..at + 2].copy_from_slice(&v.to_le_bytes());
    // A time series: 4 volumes.
    let p = edited(&dir, "series.nii", |b| {
        i16_at(b, 40, 4);
        i16_at(b, 48, 4);
    });
    expect_error(&p, true, "only 3-D volumes");
    let p = edited(&dir, "complex.nii", |b| i16_at(b, 70, 32));
    expect_error(&p, true, "complex64");
    let p = edited(&dir, "unknown.nii", |b| i16_at(b, 70, 3));
    expect_error(&p, false, "datatype 3");
    let p = edited(&dir, "zero.nii", |b| i16_at(b, 44, 0));
    expect_error(&p, false, "not positive");
    // An offset inside the header reads as the least one, 352.
    let p = edited(&dir, "offset.nii", |b| {
        b[108..112].copy_from_slice(&0f32.to_le_bytes())
    });
    let good = read_volume(&corpus().join("u8_sform.nii"), MemoryLimit::DEFAULT).unwrap();
    assert_eq!(read_volume(&p, MemoryLimit::DEFAULT).unwrap(), good);
    let p = edited(&dir, "later.nii", |b| {
        b[108..112].copy_from_slice(&400f32.to_le_bytes())
    });
    expect_error(&p, false, "raw data has");
    let p = edited(&dir, "fraction.nii", |b| {
        b[108..112].copy_from_slice(&352.5f32.to_le_bytes())
    });
    expect_error(&p, false, "vox_offset");
    let p = edited(&dir, "nan.nii", |b| {
        b[280..284].copy_from_slice(&f32::NAN.to_le_bytes())
    });
    expect_error(&p, false, "not finite");
    let p = edited(&dir, "flat.nii", |b| b[280..328].fill(0));
    expect_error(&p, false, "singular");
    let p = edited(&dir, "size.nii", |b| {
        b[0..4].copy_from_slice(&349i32.to_le_bytes())
    });
    expect_error(&p, false, "sizeof_hdr 349");
    let p = edited(&dir, "long.nii", |b| b.push(0));
    expect_error(&p, false, "raw data has");
    // The pair's image is missing.
    std::fs::copy(corpus().join("u16_pair.hdr"), dir.join("lonely.hdr")).unwrap();
    match read_volume(&dir.join("lonely.hdr"), MemoryLimit::DEFAULT) {
        Err(VoxkitError::Io { path, .. }) => assert!(path.ends_with("lonely.img")),
        other => panic!("expected an I/O error, got {other:?}"),
    }
    // Sizes over the limit are refused before reading.
    let p = edited(&dir, "huge.nii", |b| {
        for at in [42, 44, 46] {
            i16_at(b, at, 30000);
        }
    });
    assert!(matches!(
        read_volume(&p, MemoryLimit::DEFAULT),
        Err(VoxkitError::Limits { .. })
    ));
}

#[test]
fn a_pair_in_upper_case_or_with_a_gzipped_image_is_found() {
    let dir = temp_dir("pair-names");
    let want = read_volume(&corpus().join("u16_pair.hdr"), MemoryLimit::DEFAULT).unwrap();
    let img = std::fs::read(corpus().join("u16_pair.img")).unwrap();
    let hdr = std::fs::read(corpus().join("u16_pair.hdr")).unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut gz, &img).unwrap();
    let gz = gz.finish().unwrap();
    for (header, image, bytes) in [
        ("OLD.HDR", "OLD.IMG", &img),
        ("old2.hdr", "old2.IMG", &img),
        ("OLD3.HDR", "OLD3.img", &img),
        ("zipped.hdr", "zipped.img.gz", &gz),
        ("ZIPPED.HDR", "ZIPPED.IMG.GZ", &gz),
    ] {
        std::fs::write(dir.join(header), &hdr).unwrap();
        std::fs::write(dir.join(image), bytes).unwrap();
        let got = read_volume(&dir.join(header), MemoryLimit::DEFAULT)
            .unwrap_or_else(|e| panic!("{header} + {image}: {e}"));
        assert_eq!(got, want, "{header} + {image}");
    }
    // None there: the error names the image in the header's case.
    std::fs::write(dir.join("ALONE.HDR"), &hdr).unwrap();
    match read_volume(&dir.join("ALONE.HDR"), MemoryLimit::DEFAULT) {
        Err(VoxkitError::Io { path, .. }) => assert!(path.ends_with("ALONE.IMG")),
        other => panic!("expected an I/O error, got {other:?}"),
    }
}

#[test]
fn analyze_headers_read_by_method_one() {
    let dir = temp_dir("analyze");
    let mut h = std::fs::read(corpus().join("u16_pair.hdr")).unwrap();
    h[344..348].fill(0);
    std::fs::write(dir.join("old.hdr"), h).unwrap();
    std::fs::copy(corpus().join("u16_pair.img"), dir.join("old.img")).unwrap();
    let a = read_volume(&dir.join("old.hdr"), MemoryLimit::DEFAULT).unwrap();
    let b = read_volume(&corpus().join("u16_pair.hdr"), MemoryLimit::DEFAULT).unwrap();
    assert_eq!(a.data, b.data);
    assert_eq!(a.space, None);
    assert_eq!(a.frame.origin, DVec3::ZERO);
    let spacing = DVec3::new(
        b.frame.axes.x_axis.length(),
        b.frame.axes.y_axis.length(),
        b.frame.axes.z_axis.length(),
    );
    assert!((a.frame.axes.to_cols_array()[0] - spacing.x).abs() < 1e-6);
}

#[test]
fn cut_short_and_garbage_files_never_panic() {
    for name in [
        "u8_sform.nii",
        "i16_scaled.nii.gz",
        "f64_nifti2.nii",
        "f32_nifti2_be.nii.gz",
    ] {
        let bytes = std::fs::read(corpus().join(name)).unwrap();
        for len in (0..bytes.len()).step_by(7) {
            let r = read_volume_bytes(name.as_ref(), &bytes[..len], &[], MemoryLimit::DEFAULT);
            assert!(r.is_err(), "{name} cut at {len} read");
        }
        // One byte flipped at a time in the header: an error or a volume,
        // never a panic.
        for at in 0..bytes.len().min(540) {
            let mut b = bytes.clone();
            b[at] ^= 0xa5;
            let _ = read_volume_bytes(name.as_ref(), &b, &[], MemoryLimit::DEFAULT);
        }
    }
}

#[test]
fn names_that_are_nifti() {
    for n in ["a.nii", "A.NII.GZ", "b.nii.gz", "c.hdr"] {
        assert!(is_volume_path(Path::new(n)), "{n}");
    }
    for n in ["a.gz", "nii", ".nii", "a.img"] {
        assert!(!is_volume_path(Path::new(n)), "{n}");
    }
}

#[test]
fn the_command_line_renders_nifti_and_refuses_bad_files_in_one_line() {
    let dir = temp_dir("cli");
    let png = dir.join("mr.png");
    let out = Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args(["render"])
        .arg(corpus().join("headmr.nii.gz"))
        .arg("-o")
        .arg(&png)
        .args(["--volume", "mip", "--size", "64x64", "-q"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::metadata(&png).unwrap().len() > 0);
    let bad = edited(&dir, "series.nii", |b| {
        b[40..42].copy_from_slice(&4i16.to_le_bytes());
        b[48..50].copy_from_slice(&3i16.to_le_bytes());
    });
    let out = Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args(["render"])
        .arg(&bad)
        .arg("-o")
        .arg(dir.join("bad.png"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!dir.join("bad.png").exists());
}
