//! NIfTI-1 and NIfTI-2 scalar volumes, the neuroimaging formats: `.nii`
//! (header and samples in one file), `.nii.gz` (the same, gzipped) and a
//! `.hdr` header with its `.img` (or `.img.gz`) samples, into a
//! [`ScalarVolume`].
//!
//! What is read, after the standard (`nifti1.h`, `nifti2.h`):
//! - the version and byte order from `sizeof_hdr` (348 or 540, either byte
//!   order); gzip is recognised by its magic bytes, whatever the name says;
//!   a header without NIfTI's magic (Analyze 7.5) reads as NIfTI-1 placed
//!   by method 1 (its bytes where NIfTI keeps orientation codes mean
//!   other things);
//! - `dim`: 1 to 7 axes, the first three spatial; axes beyond the third
//!   must have size 1 (a time series is
//!   [`VoxkitError::Unsupported`](crate::VoxkitError::Unsupported));
//! - `datatype` `UINT8` … `FLOAT64` (the eight [`ScalarType`]s), and
//!   `INT64`/`UINT64` held in the narrowest type that holds every sample
//!   exactly; the rest (binary, complex, RGB, `float128`) are unsupported;
//! - placement, as the standard orders it: the `sform` affine where
//!   `sform_code > 0`, else the `qform` quaternion with `pixdim` and `qfac`
//!   where `qform_code > 0` (both in NIfTI's RAS world, kept as the
//!   volume's [`AnatomicalSpace::Ras`]); else "method 1", the spacings
//!   alone from the origin, with no anatomical space. Voxel centres sit on
//!   the integer indices, as in [`VolumeFrame`];
//! - `scl_slope`/`scl_inter`: where the slope is finite, nonzero and the
//!   pair not (1, 0), the samples are scaled as the standard says and kept
//!   as `float32` (from 8- and 16-bit integers and `float32`, where it is
//!   exact up to float32's rounding of the product) or `float64` (from
//!   32-bit integers and `float64`); otherwise the file's type is kept;
//! - `vox_offset`: where the samples start in the `.nii` (after the header
//!   and its extensions, which are skipped; an offset inside the header
//!   reads as the least the standard allows, 352 or 544) or the `.img`.
//!
//! As for the other volume readers, every header number is checked, the
//! memory limit is checked before any allocation, and the data must have
//! exactly the size the header gives.

use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use flate2::read::MultiGzDecoder;
use glam::{DMat3, DQuat, DVec3};
use rayon::prelude::*;

use super::volume::{
    Encoding, Files, Int64, Piece, Skip, Storage, checked_dims, invalid, io_at, read_samples,
    stream_error, unsupported,
};
use crate::error::Result;
use crate::grid::volume::Sample;
use crate::grid::{
    AnatomicalSpace, MemoryLimit, ScalarType, ScalarVolume, VolumeData, VolumeFrame,
};

/// `sizeof_hdr` of NIfTI-1 (and Analyze 7.5).
const NIFTI1_HEADER: usize = 348;
/// `sizeof_hdr` of NIfTI-2.
const NIFTI2_HEADER: usize = 540;

/// Whether a file name is a NIfTI one: `.nii`, `.nii.gz` or `.hdr` (any
/// case).
pub(super) fn is_nifti_name(path: &Path) -> bool {
    let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
        return false;
    };
    let name = name.to_ascii_lowercase();
    [".nii", ".nii.gz", ".hdr"]
        .iter()
        .any(|ext| name.len() > ext.len() && name.ends_with(ext))
}

/// What a NIfTI header says, in NIfTI-2's widths whatever the version.
#[derive(Clone, Debug, PartialEq)]
struct Header {
    big_endian: bool,
    /// `dim[0..8]`.
    dim: [i64; 8],
    datatype: i64,
    /// `pixdim[0..8]` (`pixdim[0]` is `qfac`).
    pixdim: [f64; 8],
    vox_offset: f64,
    scl_slope: f64,
    scl_inter: f64,
    qform_code: i64,
    sform_code: i64,
    /// `quatern_b, quatern_c, quatern_d`.
    quatern: [f64; 3],
    /// `qoffset_x, qoffset_y, qoffset_z`.
    qoffset: [f64; 3],
    /// `srow_x, srow_y, srow_z`.
    srow: [[f64; 4]; 3],
    /// Header and samples in one file (magic `n+1`/`n+2`), or a `.hdr`
    /// and `.img` pair (`ni1`/`ni2`); `None` without a NIfTI magic.
    single_file: Option<bool>,
    /// The header's own size: the least `vox_offset` of a single file.
    size: usize,
}

/// Reads fixed-width numbers of one byte order from a header.
struct Fields<'a> {
    bytes: &'a [u8],
    big_endian: bool,
}

impl Fields<'_> {
    fn array<const N: usize>(&self, at: usize) -> [u8; N] {
        let mut a: [u8; N] = self.bytes[at..at + N].try_into().expect("N bytes");
        if self.big_endian {
            a.reverse();
        }
        a
    }
    fn i16(&self, at: usize) -> i64 {
        i64::from(i16::from_le_bytes(self.array(at)))
    }
    fn i32(&self, at: usize) -> i64 {
        i64::from(i32::from_le_bytes(self.array(at)))
    }
    fn i64(&self, at: usize) -> i64 {
        i64::from_le_bytes(self.array(at))
    }
    fn f32(&self, at: usize) -> f64 {
        f64::from(f32::from_le_bytes(self.array(at)))
    }
    fn f64(&self, at: usize) -> f64 {
        f64::from_le_bytes(self.array(at))
    }
}

/// Parses a NIfTI-1 or NIfTI-2 header from the first bytes of a file (at
/// most [`NIFTI2_HEADER`]; fewer if the file is shorter).
fn parse_header(bytes: &[u8]) -> Result<Header> {
    let first = |big: bool| {
        bytes
            .get(..4)
            .map(|b| {
                let a: [u8; 4] = b.try_into().expect("4 bytes");
                if big {
                    i32::from_be_bytes(a)
                } else {
                    i32::from_le_bytes(a)
                }
            })
            .unwrap_or(0)
    };
    let (size, big_endian) = [false, true]
        .into_iter()
        .find_map(|big| match first(big) {
            348 => Some((NIFTI1_HEADER, big)),
            540 => Some((NIFTI2_HEADER, big)),
            _ => None,
        })
        .ok_or_else(|| {
            invalid(format!(
                "not a NIfTI header: it starts with sizeof_hdr {}, not 348 (NIfTI-1) or 540 (NIfTI-2)",
                first(false)
            ))
        })?;
    if bytes.len() < size {
        return Err(invalid(format!(
            "NIfTI header is cut short: {} bytes of {size}",
            bytes.len()
        )));
    }
    let f = Fields { bytes, big_endian };
    let h = if size == NIFTI1_HEADER {
        let single_file = match &bytes[344..348] {
            b"n+1\0" => Some(true),
            b"ni1\0" => Some(false),
            _ => None,
        };
        // Analyze 7.5 (no magic) keeps other fields where NIfTI has its
        // orientation codes: its volumes are placed by method 1.
        let code = |at: usize| if single_file.is_some() { f.i16(at) } else { 0 };
        Header {
            big_endian,
            dim: std::array::from_fn(|i| f.i16(40 + 2 * i)),
            datatype: f.i16(70),
            pixdim: std::array::from_fn(|i| f.f32(76 + 4 * i)),
            vox_offset: f.f32(108),
            scl_slope: f.f32(112),
            scl_inter: f.f32(116),
            qform_code: code(252),
            sform_code: code(254),
            quatern: std::array::from_fn(|i| f.f32(256 + 4 * i)),
            qoffset: std::array::from_fn(|i| f.f32(268 + 4 * i)),
            srow: std::array::from_fn(|r| std::array::from_fn(|c| f.f32(280 + 16 * r + 4 * c))),
            single_file,
            size,
        }
    } else {
        let single_file = match &bytes[4..8] {
            b"n+2\0" => true,
            b"ni2\0" => false,
            m => {
                return Err(invalid(format!(
                    "NIfTI-2 header with magic {m:?}, not \"n+2\" or \"ni2\""
                )));
            }
        };
        Header {
            big_endian,
            datatype: f.i16(12),
            dim: std::array::from_fn(|i| f.i64(16 + 8 * i)),
            pixdim: std::array::from_fn(|i| f.f64(104 + 8 * i)),
            vox_offset: f.i64(168) as f64,
            scl_slope: f.f64(176),
            scl_inter: f.f64(184),
            qform_code: f.i32(344),
            sform_code: f.i32(348),
            quatern: std::array::from_fn(|i| f.f64(352 + 8 * i)),
            qoffset: std::array::from_fn(|i| f.f64(376 + 8 * i)),
            srow: std::array::from_fn(|r| std::array::from_fn(|c| f.f64(400 + 32 * r + 8 * c))),
            single_file: Some(single_file),
            size,
        }
    };
    Ok(h)
}

/// NIfTI's `datatype` codes of the types read, and whether the type is a
/// 64-bit integer (then read as [`ScalarType::F64`]-wide samples).
fn nifti_type(code: i64) -> Result<(ScalarType, Option<Int64>)> {
    let ty = match code {
        2 => ScalarType::U8,
        4 => ScalarType::I16,
        8 => ScalarType::I32,
        16 => ScalarType::F32,
        64 => ScalarType::F64,
        256 => ScalarType::I8,
        512 => ScalarType::U16,
        768 => ScalarType::U32,
        1024 => return Ok((ScalarType::F64, Some(Int64::Signed))),
        1280 => return Ok((ScalarType::F64, Some(Int64::Unsigned))),
        1 | 32 | 128 | 1536 | 1792 | 2048 | 2304 => {
            let name = match code {
                1 => "binary",
                32 => "complex64",
                128 => "RGB24",
                1536 => "float128",
                1792 => "complex128",
                2048 => "complex256",
                _ => "RGBA32",
            };
            return Err(unsupported(format!(
                "NIfTI datatype {code} ({name}); scalar 8/16/32/64-bit integers, float32 and float64 are read"
            )));
        }
        _ => return Err(invalid(format!("unknown NIfTI datatype {code}"))),
    };
    Ok((ty, None))
}

impl Header {
    /// The three spatial sizes; every axis beyond them must have size 1.
    fn sizes(&self) -> Result<[u64; 3]> {
        let n = self.dim[0];
        if !(1..=7).contains(&n) {
            return Err(invalid(format!("NIfTI dim[0] = {n}, not 1 to 7")));
        }
        let n = n as usize;
        let axes = &self.dim[1..=n];
        if let Some(bad) = axes.iter().find(|&&d| d < 1) {
            return Err(invalid(format!(
                "NIfTI sizes {axes:?}: {bad} is not positive"
            )));
        }
        if n > 3 && axes[3..].iter().any(|&d| d != 1) {
            return Err(unsupported(format!(
                "a {n}-D NIfTI of sizes {axes:?}: only 3-D volumes are read (axes beyond the third \
                 must have size 1)"
            )));
        }
        Ok(std::array::from_fn(|i| {
            axes.get(i).map_or(1, |&d| d as u64)
        }))
    }

    /// The spacing along spatial axis `i` where the quaternion or method 1
    /// place the voxels: `|pixdim|`, or 1 where it is 0 or not finite (as
    /// `nifti1_io` reads it).
    fn spacing(&self, i: usize) -> f64 {
        let d = self.pixdim[i + 1].abs();
        if d > 0.0 && d.is_finite() { d } else { 1.0 }
    }

    /// The frame and, where the header places the volume in NIfTI's RAS
    /// world, that space.
    fn frame(&self) -> Result<(VolumeFrame, Option<AnatomicalSpace>)> {
        let (frame, space) = if self.sform_code > 0 {
            let r = self.srow;
            let col = |c: usize| DVec3::new(r[0][c], r[1][c], r[2][c]);
            let frame = VolumeFrame {
                origin: col(3),
                axes: DMat3::from_cols(col(0), col(1), col(2)),
            };
            (frame, Some(AnatomicalSpace::Ras))
        } else if self.qform_code > 0 {
            let [b, c, d] = self.quatern;
            // `a` from the unit norm; a slightly negative square is
            // rounding (`nifti1_io` renormalises the rest then).
            let a2 = 1.0 - (b * b + c * c + d * d);
            let q = if a2 > 1e-7 {
                DQuat::from_xyzw(b, c, d, a2.sqrt())
            } else {
                DQuat::from_xyzw(b, c, d, 0.0).normalize()
            };
            if !q.is_finite() {
                return Err(invalid(format!(
                    "NIfTI quaternion ({b}, {c}, {d}) is not a rotation"
                )));
            }
            let qfac = if self.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
            let r = DMat3::from_quat(q);
            let frame = VolumeFrame {
                origin: DVec3::from_array(self.qoffset),
                axes: DMat3::from_cols(
                    r.x_axis * self.spacing(0),
                    r.y_axis * self.spacing(1),
                    r.z_axis * (qfac * self.spacing(2)),
                ),
            };
            (frame, Some(AnatomicalSpace::Ras))
        } else {
            let spacing = DVec3::new(self.spacing(0), self.spacing(1), self.spacing(2));
            (VolumeFrame::from_spacing(DVec3::ZERO, spacing), None)
        };
        frame.validate()?;
        Ok((frame, space))
    }

    /// The scaling `value = slope · stored + inter`, where the header asks
    /// for one.
    fn scaling(&self) -> Option<(f64, f64)> {
        let slope = self.scl_slope;
        let inter = if self.scl_inter.is_finite() {
            self.scl_inter
        } else {
            0.0
        };
        (slope.is_finite() && slope != 0.0 && (slope, inter) != (1.0, 0.0))
            .then_some((slope, inter))
    }
}

/// The first `n` bytes of `path` (fewer if it is shorter), through gzip
/// where the file starts with gzip's magic bytes; and whether it did.
fn read_prefix(files: &Files, path: &Path, n: usize) -> Result<(Vec<u8>, bool)> {
    let (mut file, _) = files.open(path)?;
    let mut magic = [0u8; 2];
    let got = file.read(&mut magic).map_err(io_at(path))?;
    let gzip = got == 2 && magic == [0x1f, 0x8b];
    file.seek(SeekFrom::Start(0)).map_err(io_at(path))?;
    let mut bytes = Vec::with_capacity(n);
    let read = if gzip {
        MultiGzDecoder::new(file)
            .take(n as u64)
            .read_to_end(&mut bytes)
    } else {
        file.take(n as u64).read_to_end(&mut bytes)
    };
    read.map_err(|e| {
        if gzip {
            stream_error(path, "gzip data", e)
        } else {
            io_at(path)(e)
        }
    })?;
    Ok((bytes, gzip))
}

/// The `.img` beside a `.hdr`: `.img` or `.img.gz`, in the header's
/// case or the other (`SCAN.HDR` with `SCAN.IMG`, as old Analyze tools
/// wrote them), whichever exists; `.img` in the header's case if none does
/// (the error then names it).
fn image_file(files: &Files, header: &Path) -> PathBuf {
    let upper = header
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.chars().all(|c| c.is_ascii_uppercase()));
    let cases: [&[&str]; 2] = [&["img", "img.gz"], &["IMG", "IMG.GZ", "IMG.gz"]];
    let (own, other) = if upper {
        (cases[1], cases[0])
    } else {
        (cases[0], cases[1])
    };
    let first = header.with_extension(own[0]);
    if files.is_disk() {
        for ext in own.iter().chain(other) {
            let candidate = header.with_extension(ext);
            if candidate.exists() {
                return candidate;
            }
        }
    }
    first
}

/// Reads a NIfTI-1 or NIfTI-2 volume (see the [module docs](self)).
pub(super) fn read_nifti(files: &Files, path: &Path, limit: MemoryLimit) -> Result<ScalarVolume> {
    let (head, header_gzipped) = read_prefix(files, path, NIFTI2_HEADER)?;
    let h = parse_header(&head)?;
    let (ty, int64) = nifti_type(h.datatype)?;
    let sizes = h.sizes()?;
    let scaling = h.scaling();
    let scaled_type = match ty {
        ScalarType::I32 | ScalarType::U32 | ScalarType::F64 => ScalarType::F64,
        _ => ScalarType::F32,
    };
    let dims = checked_dims(sizes, ty, limit)?;
    if scaling.is_some() {
        // The stored samples and their scaled copy are held at once.
        let n = dims.iter().map(|&d| d as u128).product::<u128>();
        limit.check(
            "a scaled NIfTI volume and its stored samples",
            n,
            (ty.bytes() + scaled_type.bytes()) as u128,
        )?;
    }
    let (frame, space) = h.frame()?;
    if !(h.vox_offset.is_finite() && h.vox_offset >= 0.0 && h.vox_offset.fract() == 0.0) {
        return Err(invalid(format!(
            "NIfTI vox_offset {} is not a byte offset",
            h.vox_offset
        )));
    }
    let offset = h.vox_offset as u64;
    let named_pair = path
        .file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.to_ascii_lowercase().ends_with(".hdr"));
    let single_file = h.single_file.unwrap_or(!named_pair);
    let (data_path, gzipped, offset) = if single_file {
        // An offset inside the header (0, from some writers) means the
        // least the standard allows, after the header and the 4 bytes
        // that flag extensions, as papaya and niivue read it; the data's
        // size is checked either way.
        let least = h.size as u64 + 4;
        (path.to_path_buf(), header_gzipped, offset.max(least))
    } else {
        let img = image_file(files, path);
        let (_, gzipped) = read_prefix(files, &img, 2)?;
        (img, gzipped, offset)
    };
    // gzip's offsets count decompressed bytes.
    let (encoding, file_skip, decoded_skip) = if gzipped {
        (Encoding::Gzip, Skip::Bytes(0), offset)
    } else {
        (Encoding::Raw, Skip::Bytes(offset), 0)
    };
    let storage = Storage {
        ty,
        big_endian: h.big_endian,
        encoding,
        line_skip: 0,
        file_skip,
        decoded_skip,
        int64,
    };
    let pieces = [Piece {
        path: data_path,
        start: 0,
    }];
    let mut data = read_samples(files, &pieces, &storage, dims, limit)?;
    if let Some((slope, inter)) = scaling {
        data = scale(&data, slope, inter);
    }
    Ok(ScalarVolume::new(dims, data, frame)?.with_space(space))
}

/// `slope · v + inter` for every sample, as `float32` from the types it
/// holds exactly (8- and 16-bit integers, `float32`), else as `float64`.
fn scale(data: &VolumeData, slope: f64, inter: f64) -> VolumeData {
    fn f32s<T: Sample>(v: &[T], slope: f64, inter: f64) -> VolumeData {
        VolumeData::F32(
            v.par_iter()
                .map(|&x| (x.to_f64() * slope + inter) as f32)
                .collect(),
        )
    }
    fn f64s<T: Sample>(v: &[T], slope: f64, inter: f64) -> VolumeData {
        VolumeData::F64(v.par_iter().map(|&x| x.to_f64() * slope + inter).collect())
    }
    match data {
        VolumeData::I8(v) => f32s(v, slope, inter),
        VolumeData::U8(v) => f32s(v, slope, inter),
        VolumeData::I16(v) => f32s(v, slope, inter),
        VolumeData::U16(v) => f32s(v, slope, inter),
        VolumeData::F32(v) => f32s(v, slope, inter),
        VolumeData::I32(v) => f64s(v, slope, inter),
        VolumeData::U32(v) => f64s(v, slope, inter),
        VolumeData::F64(v) => f64s(v, slope, inter),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A NIfTI-1 header of `dim`, `datatype` and the given placement,
    /// written field by field in the standard's order.
    fn nifti1(big: bool, dim: [i16; 8], datatype: i16, pixdim: [f32; 8]) -> Vec<u8> {
        let mut b = vec![0u8; 352];
        let put = |b: &mut Vec<u8>, at: usize, bytes: &[u8]| {
            b[at..at + bytes.len()].copy_from_slice(bytes);
        };
        let i16b = |v: i16| {
            if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        let i32b = |v: i32| {
            if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        let f32b = |v: f32| {
            if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        put(&mut b, 0, &i32b(348));
        for (i, d) in dim.iter().enumerate() {
            put(&mut b, 40 + 2 * i, &i16b(*d));
        }
        put(&mut b, 70, &i16b(datatype));
        for (i, p) in pixdim.iter().enumerate() {
            put(&mut b, 76 + 4 * i, &f32b(*p));
        }
        put(&mut b, 108, &f32b(352.0));
        put(&mut b, 344, b"n+1\0");
        b
    }

    #[test]
    fn header_fields_in_both_byte_orders() {
        for big in [false, true] {
            let b = nifti1(
                big,
                [3, 4, 5, 6, 1, 1, 1, 1],
                512,
                [1.0, 0.5, 2.0, 3.0, 0.0, 0.0, 0.0, 0.0],
            );
            let h = parse_header(&b).unwrap();
            assert_eq!(h.big_endian, big);
            assert_eq!(h.sizes().unwrap(), [4, 5, 6]);
            assert_eq!(nifti_type(h.datatype).unwrap(), (ScalarType::U16, None));
            assert_eq!(h.single_file, Some(true));
            assert_eq!(h.vox_offset, 352.0);
            let (frame, space) = h.frame().unwrap();
            assert_eq!(frame.axes, DMat3::from_diagonal(DVec3::new(0.5, 2.0, 3.0)));
            assert_eq!(space, None);
        }
    }

    #[test]
    fn sizes_beyond_three_axes_must_be_one() {
        let h = |dim| {
            parse_header(&nifti1(false, dim, 2, [0.0; 8]))
                .unwrap()
                .sizes()
        };
        assert_eq!(h([4, 4, 5, 6, 1, 9, 9, 9]).unwrap(), [4, 5, 6]);
        assert_eq!(h([2, 4, 5, 9, 9, 9, 9, 9]).unwrap(), [4, 5, 1]);
        assert!(h([4, 4, 5, 6, 2, 1, 1, 1]).is_err());
        assert!(h([3, 4, 0, 6, 1, 1, 1, 1]).is_err());
        assert!(h([8, 4, 5, 6, 1, 1, 1, 1]).is_err());
    }

    #[test]
    fn short_or_foreign_headers_are_refused() {
        assert!(parse_header(b"").is_err());
        assert!(parse_header(&[0u8; 600]).is_err());
        let b = nifti1(false, [3, 1, 1, 1, 1, 1, 1, 1], 2, [0.0; 8]);
        assert!(parse_header(&b[..300]).is_err());
    }
}
