//! Scalar-volume readers: NRRD (`.nrrd` attached, `.nhdr` detached),
//! MetaImage (`.mhd` with a separate data file, `.mha` with the data
//! attached), NIfTI-1/2 (`.nii`, `.nii.gz`, `.hdr` + `.img`; its header in
//! `nifti.rs`, its samples through the reader here) and NumPy `.npy`, all
//! into a [`ScalarVolume`] that keeps the file's element type (NIfTI's
//! scaled samples excepted).
//!
//! What is accepted:
//! - **NRRD** `NRRD0001`–`NRRD0005`, `dimension: 3`; `dimension: 2` (an
//!   image, read as a one-voxel-thick volume whose third axis is normal to
//!   the image, of the mean in-plane spacing); `dimension` 4 and more when
//!   the extra axes have size 1 (squeezed, non-spatial `none` axes first);
//!   every NRRD spelling of
//!   the 8/16/32-bit integer types, `float` and `double`, and of the 64-bit
//!   integers, held in the narrowest type that holds every sample exactly
//!   (as text, only integers below 2⁵³ in magnitude; `block` is
//!   [`VoxkitError::Unsupported`]); encodings `raw`,
//!   `gzip`/`gz`, `bzip2`/`bz2` (pure-Rust decoder) and `ascii`/`text`/`txt`
//!   (`hex`, `zrl` are unsupported); `endian` (required for multi-byte binary data);
//!   `space directions` (any invertible 3×3, `none` entries unsupported) or
//!   `spacings`, and `space origin`; `space`/`space dimension` for 3-D
//!   spaces (RAS, LAS and LPS kept as the volume's
//!   [`AnatomicalSpace`], which orients the
//!   default view); `line skip`; `byte skip` (≥ 0, or −1 = "the data ends the
//!   file", raw only; for gzip and bzip2 it skips decompressed bytes, as the NRRD
//!   format says); `data file` as one file, `LIST [subdim]` or
//!   `fmt min max step [subdim]` (`%d`-style, e.g. `slice%03d.raw 1 93 1`).
//!   Relative data paths are relative to the header's directory.
//! - **MetaImage** `NDims = 3`, `DimSize`, `ElementType` `MET_CHAR` …
//!   `MET_DOUBLE`, `MET_ASCII_CHAR` (a signed byte, as ITK reads it),
//!   `MET_LONG`/`MET_ULONG` (4 bytes, as MetaIO sizes them),
//!   `MET_LONG_LONG`/`MET_ULONG_LONG` (narrowed as NRRD's 64-bit integers)
//!   and each one's `_ARRAY` form with one channel, `ElementSpacing` (else
//!   `ElementSize`),
//!   `Offset`/`Position`/`Origin`, `TransformMatrix`/`Orientation`/`Rotation`
//!   (its first three numbers are the direction of grid axis 0, as ITK
//!   reads it), `BinaryDataByteOrderMSB`/`ElementByteOrderMSB`,
//!   `CompressedData` (zlib), `BinaryData = False` (text), `HeaderSize`
//!   (−1 = the data ends the file), `ElementDataFile` (`LOCAL`, a path,
//!   `LIST`, or a `%d` pattern) as the last field; an
//!   `AnatomicalOrientation` (other than MetaIO's `???`) marks the world as
//!   ITK's LPS. Keys are matched without
//!   regard to case; `ObjectType` may be missing.
//! - **`.npy`** 3-D arrays of `i1 u1 b1 i2 u2 i4 u4 i8 u8 f2 f4 f8`, either byte
//!   order, C or Fortran order, with shape `[nx, ny, nz]` and `a[x, y, z]`
//!   = voxel `(x, y, z)` (see [`super::npy`]); C order (z fastest in the
//!   file) is transposed to x fastest. `bool` arrays read as `uint8` 0/1;
//!   64-bit integers (NumPy's default) in the narrowest type that holds
//!   every sample exactly ([`VolumeData::from_i64`]); `float16` as
//!   `float32`, exactly.
//!   Axes of size 1 before or after the three are dropped (`(1, 1, nx, ny,
//!   nz)`, as machine-learning tools save a volume); a 2-D array is an
//!   image one voxel thick. Origin 0, unit spacing.
//!
//! Every header number is checked, the sample count is checked against
//! the [`MemoryLimit`] before anything is allocated, and the data must
//! match the header exactly: too little or too much raw data, or a
//! decompressed stream of the wrong length, is [`VoxkitError::Invalid`]
//! naming both sizes. Compressed streams are inflated only up to the
//! expected size plus one byte (to detect excess), never unbounded.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use flate2::read::{MultiGzDecoder, ZlibDecoder};
use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::error::{Result, VoxkitError};
use crate::grid::volume::Sample;
use crate::grid::{
    AnatomicalSpace, Dims, MemoryLimit, ScalarType, ScalarVolume, VolumeData, VolumeFrame,
};

/// Headers longer than this are refused (a text header of a volume is a
/// few hundred bytes; a LIST of file names may be longer).
const MAX_HEADER: usize = 1 << 20;

/// Bytes read per call when decoding binary samples.
const CHUNK: usize = 1 << 16;

/// Target size of the buffer of x-slabs that a C-order `.npy` is
/// transposed through.
const NPY_BLOCK_BYTES: usize = 8 << 20;

/// Most data files a header may name (a `LIST` or a `%d` pattern): a
/// pattern's names are built in memory, and each file is opened in turn.
const MAX_DATA_FILES: u128 = 1 << 16;

/// Longest text sample accepted in ASCII data.
const MAX_TOKEN: usize = 64;

/// The volume formats, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Nrrd,
    MetaImage,
    Npy,
    Nifti,
}

fn format_of(path: &Path) -> Option<Format> {
    if super::nifti::is_nifti_name(path) {
        return Some(Format::Nifti);
    }
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "nrrd" | "nhdr" => Some(Format::Nrrd),
        "mhd" | "mha" => Some(Format::MetaImage),
        "npy" => Some(Format::Npy),
        _ => None,
    }
}

/// Whether `path` has a scalar-volume extension (`.nrrd`, `.nhdr`, `.mhd`,
/// `.mha`, `.nii`, `.nii.gz`, `.hdr`, `.npy`, any case). `.npy` and `.nrrd` are voxel formats too:
/// callers that accept both decide by what they need.
pub fn is_volume_path(path: &Path) -> bool {
    format_of(path).is_some()
}

/// Reads a scalar volume, choosing the format by extension (see the module
/// docs for what each reader accepts). Samples keep the file's element
/// type; their count is checked against `limit` before allocating. Every
/// error names the file.
pub fn read_volume(path: &Path, limit: MemoryLimit) -> Result<ScalarVolume> {
    read_from(&Files::Disk, path, limit)
}

/// [`read_volume`] from memory: `header` is the content of the file `name`
/// (whose extension chooses the format), and every data file its header
/// names, whatever the name, reads as `data` (so a detached `.nhdr` or
/// `.mhd` with a `LIST` of slices reads `data` once per slice). Attached
/// formats ignore `data`. For tests and fuzzing: no file is opened.
///
/// ```
/// use voxkit::{grid::MemoryLimit, io::volume::read_volume_bytes};
/// let header = b"NDims = 3\nDimSize = 2 1 1\nElementType = MET_UCHAR\nElementDataFile = v.raw\n";
/// let v = read_volume_bytes("v.mhd".as_ref(), header, &[7, 9], MemoryLimit::DEFAULT).unwrap();
/// assert_eq!((v.get(0, 0, 0), v.get(1, 0, 0)), (7.0, 9.0));
/// // Data of the wrong size is an error naming both sizes.
/// assert!(read_volume_bytes("v.mhd".as_ref(), header, &[7], MemoryLimit::DEFAULT).is_err());
/// ```
pub fn read_volume_bytes(
    name: &Path,
    header: &[u8],
    data: &[u8],
    limit: MemoryLimit,
) -> Result<ScalarVolume> {
    let files = Files::Memory {
        header_path: name,
        header,
        data,
    };
    read_from(&files, name, limit)
}

fn read_from(files: &Files, path: &Path, limit: MemoryLimit) -> Result<ScalarVolume> {
    let result = match format_of(path) {
        Some(Format::Nrrd) => read_nrrd(files, path, limit),
        Some(Format::MetaImage) => read_metaimage(files, path, limit),
        Some(Format::Npy) => read_npy(files, path, limit),
        Some(Format::Nifti) => super::nifti::read_nifti(files, path, limit),
        None => Err(VoxkitError::Unsupported(
            "not a volume file (expected .nrrd, .nhdr, .mhd, .mha, .nii, .nii.gz, .hdr or .npy)"
                .into(),
        )),
    };
    result.map_err(|e| name_file(path, e))
}

/// Puts the file's name into an error that does not carry it yet.
fn name_file(path: &Path, e: VoxkitError) -> VoxkitError {
    let name = path.display().to_string();
    let prefix = |m: String| {
        if m.contains(&name) {
            m
        } else {
            format!("{name}: {m}")
        }
    };
    match e {
        VoxkitError::Invalid(m) => VoxkitError::Invalid(prefix(m)),
        VoxkitError::Unsupported(m) => VoxkitError::Unsupported(prefix(m)),
        VoxkitError::Limits {
            what,
            needed,
            limit,
        } => VoxkitError::Limits {
            what: prefix(what),
            needed,
            limit,
        },
        VoxkitError::Io { path: p, source } if p.as_os_str().is_empty() => VoxkitError::Io {
            path: path.to_path_buf(),
            source,
        },
        other => other,
    }
}

/// Where the readers' files come from.
pub(super) enum Files<'a> {
    /// The file system.
    Disk,
    /// Memory: the header file, and one content for every other file.
    Memory {
        header_path: &'a Path,
        header: &'a [u8],
        data: &'a [u8],
    },
}

/// A readable, seekable file content.
pub(super) trait ReadSeek: Read + Seek {}
impl<T: Read + Seek> ReadSeek for T {}

/// An open file of [`Files`] and its length.
pub(super) type Opened<'a> = (Box<dyn ReadSeek + 'a>, u64);

/// A file content read at byte offsets from several threads at once.
enum Positioned<'a> {
    Disk(File),
    Memory(&'a [u8]),
}

impl Positioned<'_> {
    /// The `len` bytes at `at`, read into `buf` where they are not in
    /// memory already; an `UnexpectedEof` error where the content is
    /// shorter.
    fn read_at<'b>(&'b self, at: u64, len: usize, buf: &'b mut Vec<u8>) -> io::Result<&'b [u8]> {
        let eof = || io::Error::from(io::ErrorKind::UnexpectedEof);
        match self {
            Positioned::Disk(file) => {
                buf.resize(len, 0);
                #[cfg(unix)]
                std::os::unix::fs::FileExt::read_exact_at(file, buf, at)?;
                #[cfg(windows)]
                {
                    let mut done = 0;
                    while done < len {
                        let n = std::os::windows::fs::FileExt::seek_read(
                            file,
                            &mut buf[done..],
                            at + done as u64,
                        )?;
                        if n == 0 {
                            return Err(eof());
                        }
                        done += n;
                    }
                }
                Ok(&buf[..])
            }
            Positioned::Memory(bytes) => {
                let at = usize::try_from(at).map_err(|_| eof())?;
                bytes
                    .get(at..at.checked_add(len).ok_or_else(eof)?)
                    .ok_or_else(eof)
            }
        }
    }
}

impl Files<'_> {
    /// `path`'s content where the files are in memory: the header, or the
    /// one data content for every other name.
    fn in_memory(&self, path: &Path) -> Option<&[u8]> {
        match self {
            Files::Disk => None,
            Files::Memory {
                header_path,
                header,
                data,
            } => Some(if path == *header_path { header } else { data }),
        }
    }

    /// `path`'s content for reads at offsets ([`Positioned`]).
    fn positioned(&self, path: &Path) -> Result<Positioned<'_>> {
        Ok(match self.in_memory(path) {
            Some(bytes) => Positioned::Memory(bytes),
            None => Positioned::Disk(File::open(path).map_err(io_at(path))?),
        })
    }

    /// Whether the files are on disk (not in memory).
    pub(super) fn is_disk(&self) -> bool {
        matches!(self, Files::Disk)
    }

    pub(super) fn open(&self, path: &Path) -> Result<Opened<'_>> {
        if let Some(bytes) = self.in_memory(path) {
            return Ok((Box::new(io::Cursor::new(bytes)), bytes.len() as u64));
        }
        let file = File::open(path).map_err(io_at(path))?;
        let len = file.metadata().map_err(io_at(path))?.len();
        Ok((Box::new(file), len))
    }
}

pub(super) fn io_at(path: &Path) -> impl Fn(io::Error) -> VoxkitError + '_ {
    move |source| VoxkitError::Io {
        path: path.to_path_buf(),
        source,
    }
}

pub(super) fn invalid(m: impl Into<String>) -> VoxkitError {
    VoxkitError::Invalid(m.into())
}

pub(super) fn unsupported(m: impl Into<String>) -> VoxkitError {
    VoxkitError::Unsupported(m.into())
}

// ---------------------------------------------------------------------------
// Sizes and the memory limit
// ---------------------------------------------------------------------------

/// Checks header sizes and the limit before anything is allocated:
/// positive sides, `n · bytes` within `limit`, and indexable dims.
pub(super) fn checked_dims(sizes: [u64; 3], ty: ScalarType, limit: MemoryLimit) -> Result<Dims> {
    if sizes.contains(&0) {
        return Err(invalid(format!("sizes {sizes:?} must be positive")));
    }
    let n = sizes
        .iter()
        .fold(1u128, |a, &s| a.saturating_mul(u128::from(s)));
    limit.check(
        &format!(
            "{} volume of {}x{}x{}",
            ty.name(),
            sizes[0],
            sizes[1],
            sizes[2]
        ),
        n,
        ty.bytes() as u128,
    )?;
    let dims = sizes.map(|s| usize::try_from(s).unwrap_or(usize::MAX));
    crate::grid::cell_count(dims)?;
    Ok(dims)
}

/// Parses `n` whitespace-separated numbers.
fn numbers<T: std::str::FromStr, const N: usize>(what: &str, s: &str) -> Result<[T; N]> {
    let v: Vec<T> = s
        .split_whitespace()
        .map(|t| t.parse().ok())
        .collect::<Option<_>>()
        .ok_or_else(|| invalid(format!("{what}: {s:?} is not a list of numbers")))?;
    let len = v.len();
    v.try_into()
        .map_err(|_| invalid(format!("{what}: {s:?} has {len} numbers, {N} are needed")))
}

fn finite<const N: usize>(what: &str, v: [f64; N]) -> Result<[f64; N]> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(invalid(format!("{what} {v:?} is not finite")))
    }
}

fn sizes3(what: &str, s: &str) -> Result<[u64; 3]> {
    // Parsed as i64 first so that a negative size reads as one.
    let v: [i64; 3] = numbers(what, s)?;
    if v.iter().any(|&x| x <= 0) {
        return Err(invalid(format!("{what} {v:?} must be positive")));
    }
    Ok(v.map(|x| x as u64))
}

// ---------------------------------------------------------------------------
// Header text
// ---------------------------------------------------------------------------

/// The first bytes of a file, enough for any header we accept.
struct Head {
    bytes: Vec<u8>,
    /// Whether `bytes` is the whole file (so a header may end at EOF).
    whole_file: bool,
}

fn read_head(files: &Files, path: &Path) -> Result<Head> {
    let (file, _) = files.open(path)?;
    let mut bytes = Vec::new();
    file.take(MAX_HEADER as u64 + 1)
        .read_to_end(&mut bytes)
        .map_err(io_at(path))?;
    let whole_file = bytes.len() <= MAX_HEADER;
    bytes.truncate(MAX_HEADER);
    Ok(Head { bytes, whole_file })
}

/// One header line: its text (without `\r\n`) and the offset just past it.
struct Line<'a> {
    text: &'a str,
    end: u64,
}

impl Head {
    /// The lines of the header, in order. A last line without `\n` counts
    /// only if the buffer is the whole file; otherwise the header is too
    /// long.
    fn lines(&self) -> impl Iterator<Item = Result<Line<'_>>> + '_ {
        let mut pos = 0usize;
        let mut number = 0usize;
        std::iter::from_fn(move || {
            if pos >= self.bytes.len() {
                return None;
            }
            number += 1;
            let rest = &self.bytes[pos..];
            let (raw, next) = match rest.iter().position(|&b| b == b'\n') {
                Some(i) => (&rest[..i], pos + i + 1),
                None if self.whole_file => (rest, self.bytes.len()),
                None => {
                    pos = self.bytes.len();
                    return Some(Err(invalid(format!(
                        "header is longer than {MAX_HEADER} bytes"
                    ))));
                }
            };
            pos = next;
            let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
            Some(
                std::str::from_utf8(raw)
                    .map(|text| Line {
                        text,
                        end: next as u64,
                    })
                    .map_err(|_| invalid(format!("header line {number} is not text"))),
            )
        })
    }
}

/// Header fields with normalised keys (lower case, spaces removed, so
/// NRRD's `data file` and `datafile` are one key), the file names of a
/// `LIST` data file, and where attached data starts.
#[derive(Debug, Default)]
struct Fields {
    fields: Vec<(String, String)>,
    list: Vec<String>,
    data_start: Option<u64>,
}

fn normalise_key(k: &str) -> String {
    k.chars()
        .filter(|c| !c.is_whitespace())
        .flat_map(char::to_lowercase)
        .collect()
}

impl Fields {
    fn insert(&mut self, key: &str, value: &str) -> Result<()> {
        let key = normalise_key(key);
        if self.fields.iter().any(|(k, _)| *k == key) {
            return Err(invalid(format!("field {key:?} is given twice")));
        }
        self.fields.push((key, value.trim().to_string()));
        Ok(())
    }

    /// The value of the first of `keys` present (already normalised).
    fn get(&self, keys: &[&str]) -> Option<&str> {
        keys.iter().find_map(|k| {
            self.fields
                .iter()
                .find(|(key, _)| key == k)
                .map(|(_, v)| v.as_str())
        })
    }

    fn require(&self, key: &str, shown: &str) -> Result<&str> {
        self.get(&[key])
            .ok_or_else(|| invalid(format!("header has no {shown:?} field")))
    }
}

/// Whether a `data file` / `ElementDataFile` value is `LIST`, whose file
/// names follow on the next lines.
fn is_list(value: &str) -> bool {
    value.split_whitespace().next() == Some("LIST")
}

// ---------------------------------------------------------------------------
// Where the samples are and how they are stored
// ---------------------------------------------------------------------------

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Encoding {
    Raw,
    Gzip,
    Bzip2,
    Zlib,
    Ascii,
}

impl Encoding {
    fn name(self) -> &'static str {
        match self {
            Encoding::Raw => "raw",
            Encoding::Gzip => "gzip",
            Encoding::Bzip2 => "bzip2",
            Encoding::Zlib => "zlib",
            Encoding::Ascii => "ascii",
        }
    }
}

/// Bytes to skip in a data file before its samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Skip {
    Bytes(u64),
    /// The samples are the last bytes of the file (NRRD `byte skip: -1`,
    /// MetaImage `HeaderSize = -1`).
    ToEnd,
}

impl Skip {
    fn from_header(what: &str, v: i64) -> Result<Skip> {
        match v {
            -1 => Ok(Skip::ToEnd),
            v if v >= 0 => Ok(Skip::Bytes(v as u64)),
            v => Err(invalid(format!("{what} {v} must be -1 or more"))),
        }
    }
}

/// How the samples are stored, common to NRRD, MetaImage and NIfTI.
#[derive(Clone, Copy, Debug)]
pub(super) struct Storage {
    pub(super) ty: ScalarType,
    pub(super) big_endian: bool,
    pub(super) encoding: Encoding,
    /// Lines skipped at the start of each piece (NRRD `line skip`).
    pub(super) line_skip: u64,
    /// Bytes skipped in the file, after the lines, before decoding.
    pub(super) file_skip: Skip,
    /// Bytes of the decompressed stream skipped (NRRD `byte skip` with
    /// gzip, which the format defines on the decompressed data).
    pub(super) decoded_skip: u64,
    /// 64-bit integer samples (`ty` is then [`ScalarType::F64`], their
    /// width), narrowed after reading.
    pub(super) int64: Option<Int64>,
}

/// 64-bit integer samples, which no [`ScalarType`] holds: binary data is
/// read as `f64` *bit patterns* of the same width (the reader moves them,
/// never computes on them), text as numbers, and the samples are then held
/// in the narrowest type that holds every one exactly
/// ([`VolumeData::from_i64`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Int64 {
    /// `int64`.
    Signed,
    /// `uint64`.
    Unsigned,
}

impl Int64 {
    /// Checks the memory of `n` samples and their narrowed copy, at most
    /// as wide.
    fn check(n: usize, limit: MemoryLimit) -> Result<()> {
        limit.check(
            &format!("{n} 64-bit integer samples, narrowed"),
            n as u128,
            16,
        )
    }

    /// The samples `v` as read (bit patterns, or numbers from `text`) in
    /// the narrowest exact type. A text sample must be an integer of
    /// magnitude below 2⁵³ (every one of those parses exactly; a larger
    /// one may have been rounded) and, unsigned, not negative.
    fn narrow(self, v: Vec<f64>, text: bool) -> Result<VolumeData> {
        const EXACT: f64 = 9_007_199_254_740_992.0; // 2^53
        if text {
            let signed = self == Int64::Signed;
            if let Some(&x) = v
                .iter()
                .find(|&&x| !(x.fract() == 0.0 && x.abs() < EXACT && (signed || x >= 0.0)))
            {
                return Err(unsupported(format!(
                    "{} text sample {x}: 64-bit integers are read from text only as integers \
                     below 2^53 in magnitude{}",
                    self.name(),
                    if signed { "" } else { ", not negative" }
                )));
            }
            // Integers below 2^53 in magnitude: the casts are exact.
            return Ok(VolumeData::from_i64(
                v.into_iter().map(|x| x as i64).collect(),
            ));
        }
        Ok(match self {
            Int64::Signed => {
                VolumeData::from_i64(v.into_iter().map(|x| x.to_bits() as i64).collect())
            }
            Int64::Unsigned => VolumeData::from_u64(v.into_iter().map(f64::to_bits).collect()),
        })
    }

    fn name(self) -> &'static str {
        match self {
            Int64::Signed => "int64",
            Int64::Unsigned => "uint64",
        }
    }
}

/// One file holding a run of the samples, from byte `start` on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Piece {
    pub(super) path: PathBuf,
    pub(super) start: u64,
}

/// The pieces a header names: the attached data (`value` absent or
/// `LOCAL`), one data file, a `LIST` of files (`list`), or a
/// `fmt min max step [subdim]` pattern. Each file of several holds
/// `subdim`-dimensional slabs (default: slices), checked against `dims`.
fn data_pieces(
    header: &Path,
    value: Option<&str>,
    list: &[String],
    attached: Option<u64>,
    dims: Dims,
) -> Result<Vec<Piece>> {
    let attached_piece = || {
        attached
            .map(|start| Piece {
                path: header.to_path_buf(),
                start,
            })
            .ok_or_else(|| {
                invalid("no data: the header neither ends with a blank line nor names a data file")
            })
    };
    let dir = header
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let detached = |name: &str| Piece {
        path: dir.join(name),
        start: 0,
    };
    let Some(value) = value.filter(|v| !v.eq_ignore_ascii_case("LOCAL")) else {
        return Ok(vec![attached_piece()?]);
    };
    let names: Vec<String> = if is_list(value) {
        let subdim = value.split_whitespace().nth(1);
        let expected = files_expected(dims, subdim)?;
        if list.len() as u128 != expected {
            return Err(invalid(format!(
                "data file LIST names {} files, the sizes need {expected}",
                list.len()
            )));
        }
        list.to_vec()
    } else if value.contains('%') {
        let t: Vec<&str> = value.split_whitespace().collect();
        if !(4..=5).contains(&t.len()) {
            return Err(invalid(format!(
                "data file pattern {value:?} needs `format min max step [subdim]`"
            )));
        }
        let [min, max, step]: [i64; 3] = numbers("data file range", &t[1..4].join(" "))?;
        let expected = files_expected(dims, t.get(4).copied())?;
        expand_pattern(t[0], min, max, step, expected)?
    } else {
        vec![value.to_string()]
    };
    if names.iter().any(|n| n.trim().is_empty()) {
        return Err(invalid("empty data file name"));
    }
    Ok(names.iter().map(|n| detached(n)).collect())
}

/// How many files `dims` split into `subdim`-dimensional slabs make
/// (`subdim` default 2: one file per z slice; `2D` is MetaImage's
/// spelling).
fn files_expected(dims: Dims, subdim: Option<&str>) -> Result<u128> {
    let sub = match subdim {
        None => 2,
        Some(s) => s
            .trim_end_matches(['d', 'D'])
            .parse::<usize>()
            .ok()
            .filter(|d| (1..=3).contains(d))
            .ok_or_else(|| invalid(format!("data file subdimension {s:?} is not 1, 2 or 3")))?,
    };
    Ok(dims[sub..].iter().map(|&d| d as u128).product())
}

/// The file names of a `%d`-style pattern for `min..=max` by `step`,
/// after checking that there are exactly `expected` of them (before
/// building any).
fn expand_pattern(fmt: &str, min: i64, max: i64, step: i64, expected: u128) -> Result<Vec<String>> {
    let count: i128 = match step {
        s if s > 0 && max >= min => (i128::from(max) - i128::from(min)) / i128::from(s) + 1,
        s if s < 0 && min >= max => (i128::from(min) - i128::from(max)) / -i128::from(s) + 1,
        _ => {
            return Err(invalid(format!(
                "data file range {min}..{max} by {step} is empty"
            )));
        }
    };
    if count as u128 != expected {
        return Err(invalid(format!(
            "data file pattern names {count} files, the sizes need {expected}"
        )));
    }
    if count as u128 > MAX_DATA_FILES {
        return Err(unsupported(format!(
            "data file pattern names {count} files; at most {MAX_DATA_FILES} are read"
        )));
    }
    let (head, zero_pad, width, tail) = parse_int_format(fmt)?;
    Ok((0..count)
        .map(|i| {
            // |min + i·step| stays within the range checked above.
            let v = i128::from(min) + i * i128::from(step);
            let n = if zero_pad {
                format!("{v:0width$}")
            } else {
                format!("{v:width$}")
            };
            format!("{head}{n}{tail}")
        })
        .collect())
}

/// Splits `pre%[0][width]d post` (also `%i`, `%u`) into its parts.
fn parse_int_format(fmt: &str) -> Result<(&str, bool, usize, &str)> {
    let bad = || {
        unsupported(format!(
            "data file format {fmt:?}: only one %d-style integer conversion is supported"
        ))
    };
    let (head, spec) = fmt.split_once('%').ok_or_else(bad)?;
    let zero_pad = spec.starts_with('0');
    let digits = spec.chars().take_while(char::is_ascii_digit).count();
    let width: usize = if digits == 0 {
        0
    } else {
        spec[..digits]
            .parse()
            .ok()
            .filter(|&w| w <= 64)
            .ok_or_else(bad)?
    };
    let rest = &spec[digits..];
    let tail = rest
        .strip_prefix(['d', 'i', 'u'])
        .filter(|t| !t.contains('%'))
        .ok_or_else(bad)?;
    Ok((head, zero_pad, width, tail))
}

/// Dispatches a generic function on a [`ScalarType`].
macro_rules! by_type {
    ($ty:expr, $f:ident($($a:expr),*)) => {
        match $ty {
            ScalarType::I8 => $f::<i8>($($a),*),
            ScalarType::U8 => $f::<u8>($($a),*),
            ScalarType::I16 => $f::<i16>($($a),*),
            ScalarType::U16 => $f::<u16>($($a),*),
            ScalarType::I32 => $f::<i32>($($a),*),
            ScalarType::U32 => $f::<u32>($($a),*),
            ScalarType::F32 => $f::<f32>($($a),*),
            ScalarType::F64 => $f::<f64>($($a),*),
        }
    };
}

/// Reads the `nx·ny·nz` samples (the limit was checked by
/// [`checked_dims`]) from `pieces`, each holding an equal share.
pub(super) fn read_samples(
    files: &Files,
    pieces: &[Piece],
    s: &Storage,
    dims: Dims,
    limit: MemoryLimit,
) -> Result<crate::grid::VolumeData> {
    let Some(int64) = s.int64 else {
        return by_type!(s.ty, read_typed(files, pieces, s, dims, limit));
    };
    Int64::check(dims.iter().product(), limit)?;
    let v = read_vec::<f64>(files, pieces, s, dims, limit)?;
    int64.narrow(v, s.encoding == Encoding::Ascii)
}

fn read_typed<T: Sample>(
    files: &Files,
    pieces: &[Piece],
    s: &Storage,
    dims: Dims,
    limit: MemoryLimit,
) -> Result<crate::grid::VolumeData> {
    read_vec::<T>(files, pieces, s, dims, limit).map(T::wrap)
}

/// The samples of `pieces`, in file order.
fn read_vec<T: Sample>(
    files: &Files,
    pieces: &[Piece],
    s: &Storage,
    dims: Dims,
    limit: MemoryLimit,
) -> Result<Vec<T>> {
    let n: usize = dims.iter().product();
    let per = n / pieces.len().max(1);
    if per * pieces.len() != n {
        return Err(invalid(format!(
            "{n} samples do not split evenly into {} data files",
            pieces.len()
        )));
    }
    let mut out = reserve::<T>(n, limit)?;
    for p in pieces {
        read_piece(files, p, s, per, &mut out)?;
    }
    Ok(out)
}

/// An empty vector with room for `n` samples; an allocation the system
/// refuses is a [`VoxkitError::Limits`], not an abort.
fn reserve<T>(n: usize, limit: MemoryLimit) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| VoxkitError::Limits {
        what: format!("{n} volume samples (the system refused the allocation)"),
        needed: n as u128 * std::mem::size_of::<T>() as u128,
        limit: limit.bytes,
    })?;
    Ok(v)
}

/// Appends the `count` samples of one piece to `out`.
fn read_piece<T: Sample>(
    files: &Files,
    p: &Piece,
    s: &Storage,
    count: usize,
    out: &mut Vec<T>,
) -> Result<()> {
    let path = &p.path;
    let (mut file, len) = files.open(path)?;
    file.seek(SeekFrom::Start(p.start)).map_err(io_at(path))?;
    let mut r = BufReader::new(file);
    let skipped = skip_lines(&mut r, s.line_skip)
        .map_err(io_at(path))?
        .ok_or_else(|| {
            invalid(format!(
                "{}: ends within the {} lines to skip",
                path.display(),
                s.line_skip
            ))
        })?;
    let pos = p.start + skipped;
    if s.encoding != Encoding::Raw {
        // One thread decodes these; the pages they fill are mapped in by
        // all threads first (raw pieces are read in parallel).
        crate::alloc::prefault_spare(out);
    }
    let need = (count as u64)
        .checked_mul(std::mem::size_of::<T>() as u64)
        .ok_or_else(|| invalid("data size overflows"))?;
    match s.encoding {
        Encoding::Raw => read_raw(files, path, pos, len, need, s, count, out),
        Encoding::Gzip | Encoding::Bzip2 | Encoding::Zlib => {
            read_compressed(path, r, pos, len, need, s, count, out)
        }
        Encoding::Ascii => {
            if s.file_skip != Skip::Bytes(0) {
                return Err(unsupported("byte skip with ascii data"));
            }
            decode_ascii(path, &mut r, count, out)
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn read_raw<T: Sample>(
    files: &Files,
    path: &Path,
    pos: u64,
    len: u64,
    need: u64,
    s: &Storage,
    count: usize,
    out: &mut Vec<T>,
) -> Result<()> {
    let available = len.saturating_sub(pos);
    let start = match s.file_skip {
        Skip::Bytes(b) => pos.saturating_add(b),
        // The data ends the file: it starts `need` bytes before the end,
        // which must not reach back into the header.
        Skip::ToEnd if available >= need => len - need,
        Skip::ToEnd => {
            return Err(size_error(path, "raw data", available, need, s.ty));
        }
    };
    let have = len.saturating_sub(start);
    if have != need {
        return Err(size_error(path, "raw data", have, need, s.ty));
    }
    let source = files.positioned(path)?;
    decode_raw_at(&source, start, count, s.big_endian, out).map_err(|e| {
        if e.kind() == io::ErrorKind::UnexpectedEof {
            // The file shrank while we read it.
            invalid(format!("{}: data ended early", path.display()))
        } else {
            io_at(path)(e)
        }
    })
}

/// Bytes of a raw piece each task of [`decode_raw_at`] reads and decodes.
const RAW_TASK_BYTES: usize = 1 << 20;

/// Appends the `count` samples stored raw at byte `start` of `source` to
/// `out`, read and decoded in parallel, piece by piece (one thread read and
/// decoded 512 MiB of float32 in ~165 ms, a seventh of a whole `voxkit
/// render` of it).
fn decode_raw_at<T: Sample>(
    source: &Positioned,
    start: u64,
    count: usize,
    big_endian: bool,
    out: &mut Vec<T>,
) -> io::Result<()> {
    let size = std::mem::size_of::<T>();
    let per = (RAW_TASK_BYTES / size).max(1);
    out.try_reserve_exact(count)
        .map_err(|_| io::Error::new(io::ErrorKind::OutOfMemory, "sample buffer"))?;
    let before = out.len();
    out.spare_capacity_mut()[..count]
        .par_chunks_mut(per)
        .enumerate()
        .try_for_each_init(Vec::new, |bytes, (k, chunk)| {
            let at = start + (k * per * size) as u64;
            let data = source.read_at(at, chunk.len() * size, bytes)?;
            for (o, b) in chunk.iter_mut().zip(data.chunks_exact(size)) {
                o.write(T::from_bytes(b, big_endian));
            }
            Ok::<_, io::Error>(())
        })?;
    // SAFETY: the `count` slots after the first `before` are the chunks
    // just filled: `try_for_each_init` returned `Ok`, so every chunk was
    // read in full (`read_at` fails short of its length) and each of its
    // slots written once; the capacity was reserved above.
    unsafe { out.set_len(before + count) };
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn read_compressed<T: Sample>(
    path: &Path,
    mut r: BufReader<Box<dyn ReadSeek + '_>>,
    pos: u64,
    len: u64,
    need: u64,
    s: &Storage,
    count: usize,
    out: &mut Vec<T>,
) -> Result<()> {
    let Skip::Bytes(skip) = s.file_skip else {
        return Err(invalid(format!(
            "a skip of -1 (data at the end of the file) needs raw data, not {}",
            s.encoding.name()
        )));
    };
    let start = pos.saturating_add(skip);
    if start > len {
        return Err(invalid(format!(
            "{}: skipping {skip} bytes passes the end of the file",
            path.display()
        )));
    }
    r.seek(SeekFrom::Start(start)).map_err(io_at(path))?;
    let mut dec: Box<dyn Read> = match s.encoding {
        Encoding::Gzip => Box::new(MultiGzDecoder::new(r)),
        Encoding::Bzip2 => Box::new(bzip2::read::MultiBzDecoder::new(r)),
        _ => Box::new(ZlibDecoder::new(r)),
    };
    let what = format!("{} data", s.encoding.name());
    let stream_err = |e: io::Error| stream_error(path, &what, e);
    let skipped =
        io::copy(&mut (&mut dec).take(s.decoded_skip), &mut io::sink()).map_err(stream_err)?;
    if skipped < s.decoded_skip {
        return Err(invalid(format!(
            "{}: decompressed data has {skipped} bytes, fewer than the {} to skip",
            path.display(),
            s.decoded_skip
        )));
    }
    let before = out.len();
    decode_raw(&mut dec, count, s.big_endian, out).map_err(stream_err)?;
    let got = (out.len() - before) as u64 * std::mem::size_of::<T>() as u64;
    if got < need {
        return Err(size_error(path, "decompressed data", got, need, s.ty));
    }
    // One byte more is enough to know there is too much: inflating the
    // rest could be unbounded.
    if read_some(&mut dec, &mut [0u8; 1]).map_err(stream_err)? > 0 {
        return Err(invalid(format!(
            "{}: decompressed data is longer than the {need} bytes the sizes need",
            path.display()
        )));
    }
    Ok(())
}

fn size_error(path: &Path, what: &str, have: u64, need: u64, ty: ScalarType) -> VoxkitError {
    let size = ty.bytes() as u64;
    invalid(format!(
        "{}: {what} has {have} bytes, the header's sizes need {need} ({} {} samples)",
        path.display(),
        need / size,
        ty.name()
    ))
}

/// A decoder's failure on bad input is [`VoxkitError::Invalid`]; a real
/// I/O failure stays I/O.
pub(super) fn stream_error(path: &Path, what: &str, e: io::Error) -> VoxkitError {
    match e.kind() {
        // Decoders report bad streams as these (bzip2 also as Other).
        io::ErrorKind::InvalidData
        | io::ErrorKind::InvalidInput
        | io::ErrorKind::UnexpectedEof
        | io::ErrorKind::Other => invalid(format!("{}: corrupt {what}: {e}", path.display())),
        _ => io_at(path)(e),
    }
}

/// `read` that retries on interruption.
fn read_some(r: &mut dyn Read, buf: &mut [u8]) -> io::Result<usize> {
    loop {
        match r.read(buf) {
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            other => return other,
        }
    }
}

/// Skips `n` lines; the bytes skipped, or `None` if the input ends first.
fn skip_lines(r: &mut impl BufRead, n: u64) -> io::Result<Option<u64>> {
    let mut skipped = 0u64;
    for _ in 0..n {
        loop {
            let buf = r.fill_buf()?;
            if buf.is_empty() {
                return Ok(None);
            }
            let (used, done) = match buf.iter().position(|&b| b == b'\n') {
                Some(i) => (i + 1, true),
                None => (buf.len(), false),
            };
            r.consume(used);
            skipped += used as u64;
            if done {
                break;
            }
        }
    }
    Ok(Some(skipped))
}

/// Appends up to `count` binary samples read from `r` (fewer if it ends
/// first), converting byte order on the way through a small buffer.
fn decode_raw<T: Sample>(
    r: &mut dyn Read,
    count: usize,
    big_endian: bool,
    out: &mut Vec<T>,
) -> io::Result<()> {
    let size = std::mem::size_of::<T>();
    let target = out.len() + count;
    let mut buf = vec![0u8; CHUNK];
    // Bytes of a sample split across two reads wait at the buffer's start.
    let mut pending = 0;
    while out.len() < target {
        let want = ((target - out.len()) * size).min(CHUNK);
        let n = read_some(r, &mut buf[pending..want])?;
        if n == 0 {
            break;
        }
        pending += n;
        let whole = pending / size * size;
        out.extend(
            buf[..whole]
                .chunks_exact(size)
                .map(|b| T::from_bytes(b, big_endian)),
        );
        buf.copy_within(whole..pending, 0);
        pending -= whole;
    }
    Ok(())
}

/// Appends exactly `count` text samples separated by whitespace (or
/// commas); fewer or more is an error.
fn decode_ascii<T: Sample>(
    path: &Path,
    r: &mut impl BufRead,
    count: usize,
    out: &mut Vec<T>,
) -> Result<()> {
    let target = out.len() + count;
    let mut token = Vec::with_capacity(MAX_TOKEN);
    let flush = |token: &mut Vec<u8>, out: &mut Vec<T>| -> Result<()> {
        if token.is_empty() {
            return Ok(());
        }
        if out.len() == target {
            return Err(invalid(format!(
                "{}: text data has more than the {count} values the sizes need",
                path.display()
            )));
        }
        let v = std::str::from_utf8(token)
            .ok()
            .and_then(|t| T::parse(t))
            .ok_or_else(|| {
                invalid(format!(
                    "{}: {:?} is not a {} value",
                    path.display(),
                    String::from_utf8_lossy(token),
                    T::TYPE.name()
                ))
            })?;
        out.push(v);
        token.clear();
        Ok(())
    };
    loop {
        let buf = r.fill_buf().map_err(io_at(path))?;
        if buf.is_empty() {
            break;
        }
        let used = buf.len();
        for &b in buf {
            if b.is_ascii_whitespace() || b == b',' {
                flush(&mut token, out)?;
            } else if token.len() < MAX_TOKEN {
                token.push(b);
            } else {
                return Err(invalid(format!(
                    "{}: text value longer than {MAX_TOKEN} characters",
                    path.display()
                )));
            }
        }
        r.consume(used);
    }
    flush(&mut token, out)?;
    let got = count - (target - out.len());
    if got != count {
        return Err(invalid(format!(
            "{}: text data has {got} values, the sizes need {count}",
            path.display()
        )));
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// NRRD
// ---------------------------------------------------------------------------

/// Splits a NRRD header into fields. Comments (`#`) and key/value pairs
/// (`key:=value`) are skipped; attached data starts after the first empty
/// line; the names of a `data file: LIST` follow it to the end of the
/// header.
fn nrrd_fields(head: &Head) -> Result<Fields> {
    let mut lines = head.lines();
    let magic = lines
        .next()
        .transpose()?
        .map(|l| l.text.trim())
        .unwrap_or("");
    match magic
        .strip_prefix("NRRD000")
        .and_then(|v| v.parse::<u8>().ok())
    {
        Some(1..=5) => {}
        Some(6..=9) => return Err(unsupported(format!("NRRD version {magic:?}"))),
        _ => return Err(invalid("not a NRRD file (no NRRD000x magic)")),
    }
    let mut f = Fields::default();
    let mut in_list = false;
    for line in lines {
        let Line { text, end } = line?;
        if text.trim().is_empty() {
            f.data_start = Some(end);
            break;
        }
        if in_list {
            f.list.push(text.trim().to_string());
            continue;
        }
        if text.starts_with('#') {
            continue;
        }
        let field = text.find(": ");
        if let Some(kv) = text.find(":=")
            && field.is_none_or(|c| kv < c)
        {
            continue; // key/value pair: free-form metadata
        }
        let (k, v) = text
            .split_once(": ")
            .ok_or_else(|| invalid(format!("header line {text:?} is not `field: value`")))?;
        f.insert(k, v)?;
        in_list = normalise_key(k) == "datafile" && is_list(v.trim());
    }
    Ok(f)
}

/// The sample type a NRRD `type` names, in any of its spellings (NRRD
/// format spec, "type"), and whether it is a 64-bit integer (then read as
/// [`ScalarType::F64`]-wide samples).
fn nrrd_type(s: &str) -> Result<(ScalarType, Option<Int64>)> {
    let s = s
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_lowercase();
    let wide = |int64| Ok((ScalarType::F64, Some(int64)));
    let ty = match s.as_str() {
        "signed char" | "int8" | "int8_t" => ScalarType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => ScalarType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            ScalarType::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            ScalarType::U16
        }
        "int" | "signed int" | "int32" | "int32_t" => ScalarType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => ScalarType::U32,
        "float" => ScalarType::F32,
        "double" => ScalarType::F64,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => return wide(Int64::Signed),
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            return wide(Int64::Unsigned);
        }
        "block" => return Err(unsupported("NRRD type \"block\"")),
        _ => return Err(invalid(format!("unknown NRRD type {s:?}"))),
    };
    Ok((ty, None))
}

fn nrrd_encoding(s: &str) -> Result<Encoding> {
    match s.to_lowercase().as_str() {
        "raw" => Ok(Encoding::Raw),
        "gzip" | "gz" => Ok(Encoding::Gzip),
        "bzip2" | "bz2" => Ok(Encoding::Bzip2),
        "ascii" | "text" | "txt" => Ok(Encoding::Ascii),
        "hex" | "zrl" => Err(unsupported(format!(
            "NRRD encoding {s:?} (raw, gzip, bzip2 and ascii are read)"
        ))),
        _ => Err(invalid(format!("unknown NRRD encoding {s:?}"))),
    }
}

/// Parses NRRD vectors `(a,b,c) none (d,e,f)`; `none` is `None`.
fn nrrd_vectors(s: &str) -> Result<Vec<Option<DVec3>>> {
    let bad = || invalid(format!("bad vector list {s:?}"));
    let mut out = Vec::new();
    let mut rest = s.trim();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("none") {
            out.push(None);
            rest = r.trim_start();
            continue;
        }
        let inner = rest.strip_prefix('(').ok_or_else(bad)?;
        let close = inner.find(')').ok_or_else(bad)?;
        let c: Vec<f64> = inner[..close]
            .split(',')
            .map(|x| x.trim().parse().ok())
            .collect::<Option<_>>()
            .ok_or_else(bad)?;
        // A 2-D space's vectors lie in the z = 0 plane.
        let [x, y, z] = match c[..] {
            [x, y] => [x, y, 0.0],
            [x, y, z] => [x, y, z],
            _ => {
                return Err(unsupported(format!(
                    "vector {:?} has {} components; only 2-D and 3-D spaces are supported",
                    &rest[..close + 2],
                    c.len()
                )));
            }
        };
        out.push(Some(DVec3::new(x, y, z)));
        rest = inner[close + 1..].trim_start();
    }
    Ok(out)
}

/// 3-D NRRD spaces; `-time` spaces are 4-D.
const NRRD_SPACES: &[&str] = &[
    "right-anterior-superior",
    "ras",
    "left-anterior-superior",
    "las",
    "left-posterior-superior",
    "lps",
    "scanner-xyz",
    "3d-right-handed",
    "3d-left-handed",
];

/// Which of an N-D NRRD's axes make the 3-D volume. A 2-D image is read as
/// a one-voxel-thick volume (a third axis of size 1 is added); in more than
/// three dimensions, axes of size 1 are squeezed out (those whose space
/// direction is `none`, i.e. not spatial, first) until three are left.
/// Anything else is refused in one line.
struct NrrdShape {
    /// Every axis's size, in the file's order.
    sizes: Vec<u64>,
    /// The axes kept, in order (two for a 2-D image).
    keep: Vec<usize>,
}

impl NrrdShape {
    fn new(f: &Fields, dimension: i64) -> Result<NrrdShape> {
        let s = f.require("sizes", "sizes")?;
        let sizes: Vec<u64> = s
            .split_whitespace()
            .map(|t| t.parse::<i64>().ok().filter(|&v| v > 0).map(|v| v as u64))
            .collect::<Option<_>>()
            .ok_or_else(|| invalid(format!("sizes {s:?} must be positive integers")))?;
        if sizes.len() as i64 != dimension {
            return Err(invalid(format!(
                "sizes {s:?} has {} numbers, dimension is {dimension}",
                sizes.len()
            )));
        }
        let refuse = || {
            unsupported(format!(
                "dimension {dimension} with sizes {s}: voxkit reads 2-D images, 3-D volumes, \
                 and 4-D or higher volumes whose extra axes have size 1"
            ))
        };
        let keep: Vec<usize> = match dimension {
            2 | 3 => (0..dimension as usize).collect(),
            4..=16 => {
                // Non-spatial size-1 axes go first, then any size-1 axis.
                let spatial: Vec<bool> = match f.get(&["spacedirections"]) {
                    Some(d) => nrrd_vectors(d)?.iter().map(Option::is_some).collect(),
                    None => vec![true; sizes.len()],
                };
                let mut drop: Vec<usize> = (0..sizes.len()).filter(|&a| sizes[a] == 1).collect();
                drop.sort_by_key(|&a| spatial.get(a).copied().unwrap_or(true));
                let extra = sizes.len() - 3;
                if drop.len() < extra {
                    return Err(refuse());
                }
                drop.truncate(extra);
                (0..sizes.len()).filter(|a| !drop.contains(a)).collect()
            }
            _ => return Err(refuse()),
        };
        Ok(NrrdShape { sizes, keep })
    }

    /// The volume's three sizes (a 2-D image's third is 1).
    fn sizes3(&self) -> [u64; 3] {
        let mut out = [1u64; 3];
        for (o, &a) in out.iter_mut().zip(&self.keep) {
            *o = self.sizes[a];
        }
        out
    }

    /// The kept entries of a per-axis list that has one entry per axis.
    fn pick<T: Copy>(&self, what: &str, all: &[T]) -> Result<Vec<T>> {
        if all.len() != self.sizes.len() {
            return Err(invalid(format!(
                "{what} has {} entries, dimension is {}",
                all.len(),
                self.sizes.len()
            )));
        }
        Ok(self.keep.iter().map(|&a| all[a]).collect())
    }
}

/// A 2-D image's two axis vectors and a third one, normal to them, of their
/// mean length: the image is one voxel thick.
fn complete_axes(a: DVec3, b: DVec3) -> Result<DMat3> {
    let n = a.cross(b);
    if n == DVec3::ZERO || !n.is_finite() {
        return Err(invalid(
            "the two space directions of the 2-D image are parallel",
        ));
    }
    Ok(DMat3::from_cols(
        a,
        b,
        n.normalize() * (a.length() + b.length()) / 2.0,
    ))
}

fn nrrd_frame(f: &Fields, shape: &NrrdShape) -> Result<VolumeFrame> {
    if let Some(d) = f.get(&["spacedimension"])
        && !matches!(d.trim(), "2" | "3")
    {
        return Err(unsupported(format!("space dimension {d}")));
    }
    if let Some(space) = f.get(&["space"]) {
        let s = space.to_lowercase();
        if !NRRD_SPACES.contains(&s.as_str()) {
            return Err(if s.ends_with("time") {
                unsupported(format!("NRRD space {space:?} (not 3-D)"))
            } else {
                invalid(format!("unknown NRRD space {space:?}"))
            });
        }
    }
    let origin = match f.get(&["spaceorigin"]) {
        None => DVec3::ZERO,
        Some(s) => match nrrd_vectors(s)?.as_slice() {
            [Some(o)] => *o,
            _ => return Err(invalid(format!("space origin {s:?} is not one vector"))),
        },
    };
    let axes = if let Some(s) = f.get(&["spacedirections"]) {
        let kept = shape.pick("space directions", &nrrd_vectors(s)?)?;
        match kept.as_slice() {
            [Some(a), Some(b), Some(c)] => DMat3::from_cols(*a, *b, *c),
            [Some(a), Some(b)] => complete_axes(*a, *b)?,
            _ => {
                return Err(unsupported(format!(
                    "space directions {s:?} with a `none` axis of size > 1"
                )));
            }
        }
    } else if let Some(s) = f.get(&["spacings"]) {
        // `nan` marks a non-spatial axis; only kept axes must be finite.
        let all: Vec<f64> = s
            .split_whitespace()
            .map(|t| t.parse().ok())
            .collect::<Option<_>>()
            .ok_or_else(|| invalid(format!("spacings: {s:?} is not a list of numbers")))?;
        let v = shape.pick("spacings", &all)?;
        if !v.iter().all(|x| x.is_finite()) {
            return Err(invalid(format!("spacings {s:?} is not finite")));
        }
        match v[..] {
            [a, b, c] => DMat3::from_diagonal(DVec3::new(a, b, c)),
            [a, b] => complete_axes(DVec3::X * a, DVec3::Y * b)?,
            _ => unreachable!("a shape keeps two or three axes"),
        }
    } else {
        DMat3::IDENTITY
    };
    let frame = VolumeFrame { origin, axes };
    frame.validate()?;
    Ok(frame)
}

fn parse_int(what: &str, s: &str) -> Result<i64> {
    s.trim()
        .parse()
        .map_err(|_| invalid(format!("{what} {s:?} is not an integer")))
}

fn read_nrrd(files: &Files, path: &Path, limit: MemoryLimit) -> Result<ScalarVolume> {
    let f = nrrd_fields(&read_head(files, path)?)?;
    let (ty, int64) = nrrd_type(f.require("type", "type")?)?;
    let dimension = parse_int("dimension", f.require("dimension", "dimension")?)?;
    let shape = NrrdShape::new(&f, dimension)?;
    let dims = checked_dims(shape.sizes3(), ty, limit)?;
    let encoding = nrrd_encoding(f.require("encoding", "encoding")?)?;
    let big_endian = match f.get(&["endian"]).map(str::to_lowercase).as_deref() {
        Some("little") => false,
        Some("big") => true,
        Some(e) => return Err(invalid(format!("endian {e:?} is not little or big"))),
        // Single bytes and text have no byte order.
        None if ty.bytes() == 1 || encoding == Encoding::Ascii => false,
        None => return Err(invalid(format!("no endian field for {} data", ty.name()))),
    };
    let line_skip = match f.get(&["lineskip"]) {
        None => 0,
        Some(s) => u64::try_from(parse_int("line skip", s)?)
            .map_err(|_| invalid(format!("line skip {s} is negative")))?,
    };
    let byte_skip = match f.get(&["byteskip"]) {
        None => Skip::Bytes(0),
        Some(s) => Skip::from_header("byte skip", parse_int("byte skip", s)?)?,
    };
    // For compressed data NRRD skips bytes after decompression.
    let (file_skip, decoded_skip) = match (encoding, byte_skip) {
        (Encoding::Gzip | Encoding::Bzip2, Skip::Bytes(b)) => (Skip::Bytes(0), b),
        (Encoding::Gzip | Encoding::Bzip2, Skip::ToEnd) => (Skip::ToEnd, 0), // refused when read
        (_, skip) => (skip, 0),
    };
    let frame = nrrd_frame(&f, &shape)?;
    let pieces = data_pieces(path, f.get(&["datafile"]), &f.list, f.data_start, dims)?;
    let storage = Storage {
        ty,
        big_endian,
        encoding,
        line_skip,
        file_skip,
        decoded_skip,
        int64,
    };
    let data = read_samples(files, &pieces, &storage, dims, limit)?;
    let space = f.get(&["space"]).and_then(AnatomicalSpace::from_nrrd);
    Ok(ScalarVolume::new(dims, data, frame)?.with_space(space))
}

// ---------------------------------------------------------------------------
// MetaImage
// ---------------------------------------------------------------------------

/// Splits a MetaImage header (`Key = Value` lines) into fields up to
/// `ElementDataFile`, which must come last; attached (`LOCAL`) data starts
/// after its line, and the names of a `LIST` follow it.
fn meta_fields(head: &Head) -> Result<Fields> {
    let mut f = Fields::default();
    let mut lines = head.lines();
    for line in lines.by_ref() {
        let Line { text, end } = line?;
        if text.trim().is_empty() || text.trim_start().starts_with('#') {
            continue;
        }
        let (k, v) = text
            .split_once('=')
            .ok_or_else(|| invalid(format!("header line {text:?} is not `Key = Value`")))?;
        f.insert(k, v)?;
        if normalise_key(k) == "elementdatafile" {
            f.data_start = Some(end);
            break;
        }
    }
    let Some(value) = f.get(&["elementdatafile"]) else {
        return Err(invalid("not a MetaImage header (no ElementDataFile field)"));
    };
    if is_list(value) {
        for line in lines {
            let name = line?.text.trim().to_string();
            if !name.is_empty() {
                f.list.push(name);
            }
        }
    }
    Ok(f)
}

/// The sample type a MetaImage `ElementType` names, and whether it is a
/// 64-bit integer (then read as [`ScalarType::F64`]-wide samples).
/// `MET_LONG` and `MET_ULONG` take 4 bytes, as MetaIO's own size table
/// (`MET_ValueTypeSize`) and ITK give them; `MET_ASCII_CHAR` is a signed
/// byte, as MetaIO converts it and ITK reads it (as `MET_CHAR`); an
/// `_ARRAY` type is its
/// element's, as MetaIO reads it (its channels are
/// `ElementNumberOfChannels`, checked apart).
fn meta_type(s: &str) -> Result<(ScalarType, Option<Int64>)> {
    let upper = s.to_uppercase();
    let ty = match upper.strip_suffix("_ARRAY").unwrap_or(&upper) {
        "MET_CHAR" | "MET_ASCII_CHAR" => ScalarType::I8,
        "MET_UCHAR" => ScalarType::U8,
        "MET_SHORT" => ScalarType::I16,
        "MET_USHORT" => ScalarType::U16,
        "MET_INT" | "MET_LONG" => ScalarType::I32,
        "MET_UINT" | "MET_ULONG" => ScalarType::U32,
        "MET_FLOAT" => ScalarType::F32,
        "MET_DOUBLE" => ScalarType::F64,
        "MET_LONG_LONG" => return Ok((ScalarType::F64, Some(Int64::Signed))),
        "MET_ULONG_LONG" => return Ok((ScalarType::F64, Some(Int64::Unsigned))),
        t if t.starts_with("MET_") => {
            return Err(unsupported(format!("MetaImage element type {s}")));
        }
        _ => return Err(invalid(format!("unknown MetaImage element type {s:?}"))),
    };
    Ok((ty, None))
}

fn meta_bool(what: &str, s: Option<&str>, default: bool) -> Result<bool> {
    let Some(s) = s else { return Ok(default) };
    match s.to_lowercase().as_str() {
        "true" | "1" => Ok(true),
        "false" | "0" => Ok(false),
        _ => Err(invalid(format!("{what} {s:?} is not True or False"))),
    }
}

fn meta_frame(f: &Fields) -> Result<VolumeFrame> {
    let spacing = match f.get(&["elementspacing", "elementsize"]) {
        Some(s) => finite("ElementSpacing", numbers("ElementSpacing", s)?)?,
        None => [1.0; 3],
    };
    let origin = match f.get(&["offset", "position", "origin"]) {
        Some(s) => finite("Offset", numbers("Offset", s)?)?,
        None => [0.0; 3],
    };
    let m = match f.get(&["transformmatrix", "orientation", "rotation"]) {
        Some(s) => finite("TransformMatrix", numbers::<f64, 9>("TransformMatrix", s)?)?,
        None => DMat3::IDENTITY.to_cols_array(),
    };
    // Three numbers per grid axis: its direction (ITK's reading).
    let col = |i: usize| DVec3::new(m[3 * i], m[3 * i + 1], m[3 * i + 2]) * spacing[i];
    let frame = VolumeFrame {
        origin: DVec3::from_array(origin),
        axes: DMat3::from_cols(col(0), col(1), col(2)),
    };
    frame.validate()?;
    Ok(frame)
}

fn read_metaimage(files: &Files, path: &Path, limit: MemoryLimit) -> Result<ScalarVolume> {
    let f = meta_fields(&read_head(files, path)?)?;
    if let Some(t) = f.get(&["objecttype"])
        && !t.eq_ignore_ascii_case("image")
    {
        return Err(unsupported(format!("MetaImage ObjectType {t}")));
    }
    let ndims = parse_int("NDims", f.require("ndims", "NDims")?)?;
    if ndims != 3 {
        return Err(unsupported(format!(
            "NDims = {ndims}; only 3-D volumes are read"
        )));
    }
    if let Some(c) = f.get(&["elementnumberofchannels"])
        && parse_int("ElementNumberOfChannels", c)? != 1
    {
        return Err(unsupported(format!("{c} channels per element")));
    }
    let (ty, int64) = meta_type(f.require("elementtype", "ElementType")?)?;
    let dims = checked_dims(
        sizes3("DimSize", f.require("dimsize", "DimSize")?)?,
        ty,
        limit,
    )?;
    let big_endian = meta_bool(
        "BinaryDataByteOrderMSB",
        f.get(&["binarydatabyteordermsb", "elementbyteordermsb"]),
        false,
    )?;
    let compressed = meta_bool("CompressedData", f.get(&["compresseddata"]), false)?;
    let binary = meta_bool("BinaryData", f.get(&["binarydata"]), true)?;
    let encoding = match (binary, compressed) {
        (true, false) => Encoding::Raw,
        (true, true) => Encoding::Zlib,
        (false, false) => Encoding::Ascii,
        (false, true) => return Err(unsupported("compressed text data")),
    };
    let file_skip = match f.get(&["headersize"]) {
        None => Skip::Bytes(0),
        Some(s) => Skip::from_header("HeaderSize", parse_int("HeaderSize", s)?)?,
    };
    let frame = meta_frame(&f)?;
    let pieces = data_pieces(
        path,
        f.get(&["elementdatafile"]),
        &f.list,
        f.data_start,
        dims,
    )?;
    let storage = Storage {
        ty,
        big_endian,
        encoding,
        line_skip: 0,
        file_skip,
        decoded_skip: 0,
        int64,
    };
    let data = read_samples(files, &pieces, &storage, dims, limit)?;
    // ITK writes `AnatomicalOrientation` (MetaIO's `???` means unknown) and
    // its physical space is LPS whatever the voxel axes' order; the
    // direction matrix already places those axes.
    let space = f
        .get(&["anatomicalorientation"])
        .filter(|o| !o.trim().is_empty() && !o.contains('?'))
        .map(|_| AnatomicalSpace::Lps);
    Ok(ScalarVolume::new(dims, data, frame)?.with_space(space))
}

// ---------------------------------------------------------------------------
// NumPy .npy
// ---------------------------------------------------------------------------

/// What an npy header says about its array.
#[derive(Debug, PartialEq)]
struct NpyHeader {
    /// The type the samples are read as.
    ty: ScalarType,
    big_endian: bool,
    kind: NpyKind,
    fortran: bool,
    shape: Vec<u64>,
}

/// What an npy array's samples, read as [`NpyHeader::ty`], still need.
#[derive(Clone, Copy, Debug, PartialEq)]
enum NpyKind {
    /// Nothing.
    Plain,
    /// `b1`, read as `u8`: any nonzero byte is 1 (NumPy's `True`).
    Bool,
    /// `i8` / `u8` (NumPy's default integers), read as `f64` *bit patterns*
    /// of the same width (the reader moves them, never computes on them),
    /// then held in the narrowest exact type ([`VolumeData::from_i64`]).
    Int64,
    /// `u8`, as `Int64` ([`VolumeData::from_u64`]).
    UInt64,
    /// `f2`, read as `u16` bit patterns, then widened to `f32` (exactly:
    /// every half is a float).
    Half,
}

/// The text after `'key':` in an npy header dict.
fn npy_value<'a>(dict: &'a str, key: &str) -> Result<&'a str> {
    let at = [format!("'{key}'"), format!("\"{key}\"")]
        .iter()
        .find_map(|k| dict.find(k.as_str()).map(|i| i + k.len()))
        .ok_or_else(|| invalid(format!("npy header has no {key:?}")))?;
    dict[at..]
        .trim_start()
        .strip_prefix(':')
        .map(str::trim_start)
        .ok_or_else(|| invalid(format!("npy header: no value for {key:?}")))
}

fn npy_dtype(descr: &str) -> Result<(ScalarType, bool, NpyKind)> {
    let (order, code) = match descr.as_bytes().first() {
        Some(b'<' | b'>' | b'|' | b'=') => (descr.as_bytes()[0], &descr[1..]),
        _ => (b'=', descr),
    };
    // `|` (no order: single bytes) and `=` (native) both mean this machine.
    let big = order == b'>' || (order != b'<' && cfg!(target_endian = "big"));
    let (ty, kind) = match code {
        "i1" => (ScalarType::I8, NpyKind::Plain),
        "u1" => (ScalarType::U8, NpyKind::Plain),
        "b1" => (ScalarType::U8, NpyKind::Bool),
        "i2" => (ScalarType::I16, NpyKind::Plain),
        "u2" => (ScalarType::U16, NpyKind::Plain),
        "i4" => (ScalarType::I32, NpyKind::Plain),
        "u4" => (ScalarType::U32, NpyKind::Plain),
        "i8" => (ScalarType::F64, NpyKind::Int64),
        "u8" => (ScalarType::F64, NpyKind::UInt64),
        "f2" => (ScalarType::U16, NpyKind::Half),
        "f4" => (ScalarType::F32, NpyKind::Plain),
        "f8" => (ScalarType::F64, NpyKind::Plain),
        _ => return Err(unsupported(format!("npy dtype {descr:?}"))),
    };
    Ok((ty, big, kind))
}

fn parse_npy_header(dict: &str) -> Result<NpyHeader> {
    let descr = npy_value(dict, "descr")?;
    let quote = descr
        .chars()
        .next()
        .filter(|c| *c == '\'' || *c == '"')
        .ok_or_else(|| unsupported("npy structured dtypes"))?;
    let descr = descr[1..]
        .split(quote)
        .next()
        .filter(|_| descr[1..].contains(quote))
        .ok_or_else(|| invalid("npy header: unterminated descr"))?;
    let (ty, big_endian, kind) = npy_dtype(descr)?;
    let fo = npy_value(dict, "fortran_order")?;
    let fortran = if fo.starts_with("True") {
        true
    } else if fo.starts_with("False") {
        false
    } else {
        return Err(invalid("npy header: fortran_order is not True or False"));
    };
    let shape = npy_value(dict, "shape")?;
    let inner = shape
        .strip_prefix('(')
        .and_then(|s| s.split_once(')'))
        .map(|(inner, _)| inner)
        .ok_or_else(|| invalid(format!("npy header: bad shape {shape:?}")))?;
    let shape = inner
        .split(',')
        .map(|t| t.trim().trim_end_matches('L'))
        .filter(|t| !t.is_empty())
        .map(|t| t.parse::<u64>().ok())
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| invalid(format!("npy header: bad shape ({inner})")))?;
    Ok(NpyHeader {
        ty,
        big_endian,
        kind,
        fortran,
        shape,
    })
}

/// Reads the npy preamble and header dict; returns the dict and the
/// offset of the data.
fn read_npy_preamble(r: &mut impl Read) -> Result<(String, u64)> {
    let truncated = |_| invalid("npy: truncated header");
    let mut pre = [0u8; 8];
    r.read_exact(&mut pre).map_err(truncated)?;
    if &pre[..6] != b"\x93NUMPY" {
        return Err(invalid("not an npy file (no \\x93NUMPY magic)"));
    }
    let (len, start) = match pre[6] {
        1 => {
            let mut l = [0u8; 2];
            r.read_exact(&mut l).map_err(truncated)?;
            (u16::from_le_bytes(l) as usize, 10)
        }
        2 | 3 => {
            let mut l = [0u8; 4];
            r.read_exact(&mut l).map_err(truncated)?;
            (u32::from_le_bytes(l) as usize, 12)
        }
        v => return Err(unsupported(format!("npy format version {v}"))),
    };
    if len > MAX_HEADER {
        return Err(invalid(format!("npy header of {len} bytes is too long")));
    }
    let mut dict = vec![0u8; len];
    r.read_exact(&mut dict).map_err(truncated)?;
    Ok((
        String::from_utf8_lossy(&dict).into_owned(),
        (start + len) as u64,
    ))
}

/// The `[nx, ny, nz]` of an npy array's `shape`: three axes as they are;
/// more when the extra axes have size 1 and come first or last (a batch or
/// channel axis of one, as machine-learning tools save volumes: `(1, 1, nx,
/// ny, nz)`), which leaves the samples' order unchanged in C and Fortran
/// order alike; two (an image) as one voxel thick, `[nx, ny, 1]`.
fn npy_volume_shape(shape: &[u64]) -> Option<[u64; 3]> {
    let mut s = shape;
    while s.len() > 3 && s[0] == 1 {
        s = &s[1..];
    }
    while s.len() > 3 && s[s.len() - 1] == 1 {
        s = &s[..s.len() - 1];
    }
    match *s {
        [nx, ny] => Some([nx, ny, 1]),
        [nx, ny, nz] => Some([nx, ny, nz]),
        _ => None,
    }
}

fn read_npy(files: &Files, path: &Path, limit: MemoryLimit) -> Result<ScalarVolume> {
    let (file, len) = files.open(path)?;
    let mut r = BufReader::new(file);
    let (dict, start) = read_npy_preamble(&mut r)?;
    let h = parse_npy_header(&dict)?;
    let sizes = npy_volume_shape(&h.shape).ok_or_else(|| {
        invalid(format!(
            "npy array has shape {:?}: 3 dimensions are needed (2 for an image; more only \
             when the extra ones, first or last, have size 1)",
            h.shape
        ))
    })?;
    let dims = checked_dims(sizes, h.ty, limit)?;
    let n = dims.iter().product::<usize>();
    match h.kind {
        // The 64-bit samples and their narrowed copy, at most as wide.
        NpyKind::Int64 | NpyKind::UInt64 => Int64::check(n, limit)?,
        // The halves and their float32 copy.
        NpyKind::Half => limit.check(&format!("{n} float16 samples, widened"), n as u128, 6)?,
        NpyKind::Plain | NpyKind::Bool => {}
    }
    let need = n as u64 * h.ty.bytes() as u64;
    let have = len.saturating_sub(start);
    if have != need {
        return Err(size_error(path, "npy data", have, need, h.ty));
    }
    let data = by_type!(h.ty, read_npy_data(path, &mut r, dims, &h, limit))?;
    let data = match (h.kind, data) {
        (NpyKind::Bool, VolumeData::U8(mut v)) => {
            // NumPy treats any nonzero byte of a bool array as True.
            v.iter_mut().for_each(|b| *b = u8::from(*b != 0));
            VolumeData::U8(v)
        }
        (NpyKind::Int64, VolumeData::F64(v)) => Int64::Signed.narrow(v, false)?,
        (NpyKind::UInt64, VolumeData::F64(v)) => Int64::Unsigned.narrow(v, false)?,
        (NpyKind::Half, VolumeData::U16(v)) => VolumeData::F32(
            v.par_iter()
                .map(|&b| half::f16::from_bits(b).to_f32())
                .collect(),
        ),
        (_, data) => data,
    };
    ScalarVolume::new(dims, data, VolumeFrame::default())
}

/// Reads an npy array body into x-fastest order. Fortran order is
/// already x fastest; C order (z fastest) goes through a buffer of whole
/// x-slabs so that each output cache line is written once per block.
fn read_npy_data<T: Sample>(
    path: &Path,
    r: &mut impl Read,
    dims: Dims,
    h: &NpyHeader,
    limit: MemoryLimit,
) -> Result<crate::grid::VolumeData> {
    let n: usize = dims.iter().product();
    let io_err = |e| stream_error(path, "npy data", e);
    let short = || invalid(format!("{}: npy data ended early", path.display()));
    let mut out = reserve::<T>(n, limit)?;
    crate::alloc::prefault_spare(&mut out);
    if h.fortran {
        decode_raw(r, n, h.big_endian, &mut out).map_err(io_err)?;
        return if out.len() == n {
            Ok(T::wrap(out))
        } else {
            Err(short())
        };
    }
    let [nx, ny, nz] = dims;
    let slab = ny * nz;
    let block = (NPY_BLOCK_BYTES / (slab * std::mem::size_of::<T>())).clamp(1, nx);
    out.resize(n, T::default());
    let mut buf: Vec<T> = Vec::with_capacity(block * slab);
    for x0 in (0..nx).step_by(block) {
        let b = block.min(nx - x0);
        buf.clear();
        decode_raw(r, b * slab, h.big_endian, &mut buf).map_err(io_err)?;
        if buf.len() != b * slab {
            return Err(short());
        }
        for z in 0..nz {
            for y in 0..ny {
                let dst = x0 + nx * (y + ny * z);
                let src = y * nz + z;
                for (xb, o) in out[dst..dst + b].iter_mut().enumerate() {
                    *o = buf[xb * slab + src];
                }
            }
        }
    }
    Ok(T::wrap(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn head(text: &str) -> Head {
        Head {
            bytes: text.as_bytes().to_vec(),
            whole_file: true,
        }
    }

    #[test]
    fn nrrd_fields_skip_comments_and_key_values() {
        let f = nrrd_fields(&head(
            "NRRD0005\n# c\nkey:=a: b\ntype: short\r\nData File: x.raw\n\nDATA",
        ))
        .unwrap();
        assert_eq!(f.get(&["type"]), Some("short"));
        assert_eq!(f.get(&["datafile"]), Some("x.raw"));
        assert_eq!(f.get(&["key"]), None);
        assert_eq!(f.data_start, Some(54));
        // A header without a blank line (a detached .nhdr) ends at EOF.
        assert_eq!(
            nrrd_fields(&head("NRRD0004\ntype: int"))
                .unwrap()
                .data_start,
            None
        );
    }

    #[test]
    fn nrrd_magic_and_bad_lines() {
        assert!(matches!(
            nrrd_fields(&head("NRRD0009\n")),
            Err(VoxkitError::Unsupported(_))
        ));
        assert!(matches!(
            nrrd_fields(&head("NRRDX\n")),
            Err(VoxkitError::Invalid(_))
        ));
        assert!(matches!(
            nrrd_fields(&head("")),
            Err(VoxkitError::Invalid(_))
        ));
        assert!(matches!(
            nrrd_fields(&head("NRRD0004\nno colon\n")),
            Err(VoxkitError::Invalid(_))
        ));
        assert!(matches!(
            nrrd_fields(&head("NRRD0004\ntype: int\ntype: short\n")),
            Err(VoxkitError::Invalid(_))
        ));
        let mut bytes = b"NRRD0004\ntype: ".to_vec();
        bytes.extend([0xff, 0xfe, b'\n']);
        let h = Head {
            bytes,
            whole_file: true,
        };
        assert!(matches!(nrrd_fields(&h), Err(VoxkitError::Invalid(_))));
        // A header cut off at the buffer's end is too long.
        let h = Head {
            bytes: b"NRRD0004\ntype: sh".to_vec(),
            whole_file: false,
        };
        assert!(matches!(nrrd_fields(&h), Err(VoxkitError::Invalid(_))));
    }

    #[test]
    fn nrrd_list_collects_names() {
        let f = nrrd_fields(&head("NRRD0004\ndata file: LIST 2\na.raw\nsub/b.raw\n")).unwrap();
        assert_eq!(f.list, vec!["a.raw", "sub/b.raw"]);
    }

    #[test]
    fn nrrd_type_spellings() {
        for (s, t) in [
            ("signed char", ScalarType::I8),
            ("int8_t", ScalarType::I8),
            ("uchar", ScalarType::U8),
            ("unsigned  char", ScalarType::U8),
            ("short", ScalarType::I16),
            ("signed short int", ScalarType::I16),
            ("int16_t", ScalarType::I16),
            ("ushort", ScalarType::U16),
            ("unsigned short", ScalarType::U16),
            ("uint16", ScalarType::U16),
            ("int", ScalarType::I32),
            ("signed int", ScalarType::I32),
            ("uint", ScalarType::U32),
            ("unsigned int", ScalarType::U32),
            ("uint32_t", ScalarType::U32),
            ("float", ScalarType::F32),
            ("double", ScalarType::F64),
        ] {
            assert_eq!(nrrd_type(s).unwrap(), (t, None), "{s}");
        }
        for (s, int64) in [
            ("long long", Int64::Signed),
            ("int64", Int64::Signed),
            ("signed  long long int", Int64::Signed),
            ("uint64_t", Int64::Unsigned),
            ("unsigned long long", Int64::Unsigned),
        ] {
            assert_eq!(nrrd_type(s).unwrap(), (ScalarType::F64, Some(int64)), "{s}");
        }
        assert!(matches!(
            nrrd_type("block"),
            Err(VoxkitError::Unsupported(_))
        ));
        assert!(matches!(nrrd_type("char"), Err(VoxkitError::Invalid(_))));
    }

    #[test]
    fn nrrd_vector_lists() {
        let v = nrrd_vectors("(1,0,0) none ( 0.5 , 2 ,-1e3 )").unwrap();
        assert_eq!(
            v,
            vec![Some(DVec3::X), None, Some(DVec3::new(0.5, 2.0, -1e3))]
        );
        assert!(nrrd_vectors("(1)").is_err() && nrrd_vectors("(1,0)").is_ok());
        assert!(nrrd_vectors("(1,0,0").is_err());
        assert!(nrrd_vectors("1,0,0").is_err());
        assert!(nrrd_vectors("(a,0,0)").is_err());
    }

    #[test]
    fn nrrd_frames() {
        let fields = |s: &str| nrrd_fields(&head(&format!("NRRD0004\n{s}\n"))).unwrap();
        let three = NrrdShape {
            sizes: vec![2, 2, 2],
            keep: vec![0, 1, 2],
        };
        let nrrd_frame = |f: &Fields| nrrd_frame(f, &three);
        let f = nrrd_frame(&fields(
            "space: LPS\nspace directions: (0,2,0) (3,0,0) (0,0,-1)\nspace origin: (1,2,3)",
        ))
        .unwrap();
        assert_eq!(f.origin, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(f.grid_to_world(DVec3::X), DVec3::new(1.0, 4.0, 3.0));
        assert_eq!(f.spacing(), DVec3::new(2.0, 3.0, 1.0));
        let f = nrrd_frame(&fields("spacings: 3.2 3.2 1.5")).unwrap();
        assert_eq!(f.spacing(), DVec3::new(3.2, 3.2, 1.5));
        assert_eq!(
            nrrd_frame(&fields("type: int")).unwrap(),
            VolumeFrame::default()
        );
        let err = |s: &str| nrrd_frame(&fields(s)).unwrap_err();
        assert!(matches!(
            err("space directions: (1,0,0) none (0,0,1)"),
            VoxkitError::Unsupported(_)
        ));
        assert!(matches!(
            err("space dimension: 4"),
            VoxkitError::Unsupported(_)
        ));
        assert!(matches!(
            err("space: RAS-time"),
            VoxkitError::Unsupported(_)
        ));
        assert!(matches!(err("space: sideways"), VoxkitError::Invalid(_)));
        assert!(matches!(err("spacings: nan 1 1"), VoxkitError::Invalid(_)));
        assert!(matches!(err("spacings: 1 1"), VoxkitError::Invalid(_)));
        assert!(matches!(err("spacings: 1 0 1"), VoxkitError::Invalid(_)));
        assert!(matches!(
            err("space origin: (inf,0,0)"),
            VoxkitError::Invalid(_)
        ));
        assert!(matches!(
            err("space directions: (1,0,0) (2,0,0) (0,0,1)"),
            VoxkitError::Invalid(_)
        ));
    }

    #[test]
    fn patterns_expand_and_check_counts() {
        let names = expand_pattern("s%03d.raw", 1, 3, 1, 3).unwrap();
        assert_eq!(names, vec!["s001.raw", "s002.raw", "s003.raw"]);
        assert_eq!(
            expand_pattern("q.%d", 9, 5, -2, 3).unwrap(),
            vec!["q.9", "q.7", "q.5"]
        );
        assert_eq!(expand_pattern("%4i", 7, 7, 1, 1).unwrap(), vec!["   7"]);
        // Wrong counts are refused before anything is built.
        assert!(expand_pattern("q%d", 0, i64::MAX, 1, 5).is_err());
        assert!(expand_pattern("q%d", 0, 5, 0, 5).is_err());
        assert!(expand_pattern("q%d", 5, 0, 1, 5).is_err());
        assert!(matches!(
            expand_pattern("q%s", 1, 1, 1, 1),
            Err(VoxkitError::Unsupported(_))
        ));
        assert!(matches!(
            expand_pattern("q%d%d", 1, 1, 1, 1),
            Err(VoxkitError::Unsupported(_))
        ));
        assert!(matches!(
            expand_pattern("q", 1, 1, 1, 1),
            Err(VoxkitError::Unsupported(_))
        ));
        // A pattern whose count matches the sizes but names more files than
        // are ever read is refused before its names are built (a 1×1×2^28
        // uint8 volume is only 256 MiB).
        let many = 1i64 << 28;
        assert!(matches!(
            expand_pattern("q%d", 1, many, 1, many as u128),
            Err(VoxkitError::Unsupported(_))
        ));
        let most = MAX_DATA_FILES as i64;
        assert_eq!(
            expand_pattern("q%d", 1, most, 1, most as u128)
                .unwrap()
                .len() as i64,
            most
        );
    }

    #[test]
    fn files_per_subdimension() {
        assert_eq!(files_expected([4, 5, 6], None).unwrap(), 6);
        assert_eq!(files_expected([4, 5, 6], Some("1")).unwrap(), 30);
        assert_eq!(files_expected([4, 5, 6], Some("3D")).unwrap(), 1);
        assert!(files_expected([4, 5, 6], Some("0")).is_err());
        assert!(files_expected([4, 5, 6], Some("x")).is_err());
    }

    #[test]
    fn meta_fields_stop_at_element_data_file() {
        let f = meta_fields(&head(
            "ndims = 3\nDimSize=1 2 3\nElementDataFile = LOCAL\nBINARY",
        ))
        .unwrap();
        assert_eq!(f.get(&["dimsize"]), Some("1 2 3"));
        assert_eq!(f.data_start, Some(48));
        let f = meta_fields(&head("ElementDataFile = LIST 2D\na.raw\n\nb.raw\n")).unwrap();
        assert_eq!(f.list, vec!["a.raw", "b.raw"]);
        assert!(meta_fields(&head("NDims = 3\n")).is_err());
        assert!(meta_fields(&head("NDims 3\nElementDataFile = x\n")).is_err());
    }

    #[test]
    fn meta_frame_reads_directions_per_axis() {
        let f = meta_fields(&head(
            "ElementSpacing = 2 3 4\nOffset = 1 1 1\nTransformMatrix = 0 1 0 -1 0 0 0 0 1\nElementDataFile = x\n",
        ))
        .unwrap();
        let frame = meta_frame(&f).unwrap();
        // Axis 0 points along world +y with spacing 2.
        assert_eq!(frame.grid_to_world(DVec3::X), DVec3::new(1.0, 3.0, 1.0));
        assert_eq!(frame.grid_to_world(DVec3::Y), DVec3::new(-2.0, 1.0, 1.0));
        assert_eq!(frame.spacing(), DVec3::new(2.0, 3.0, 4.0));
    }

    #[test]
    fn npy_headers() {
        let h = parse_npy_header("{'descr': '>i2', 'fortran_order': True, 'shape': (5, 3L, 7), }")
            .unwrap();
        assert_eq!(
            h,
            NpyHeader {
                ty: ScalarType::I16,
                big_endian: true,
                kind: NpyKind::Plain,
                fortran: true,
                shape: vec![5, 3, 7]
            }
        );
        let h = parse_npy_header("{\"descr\": \"|b1\", \"fortran_order\": False, \"shape\": (2,)}")
            .unwrap();
        assert!(h.kind == NpyKind::Bool && !h.fortran && h.shape == vec![2]);
        for bad in [
            "{'descr': '<c8', 'fortran_order': False, 'shape': (1, 1, 1)}",
            "{'descr': '<U3', 'fortran_order': False, 'shape': (1, 1, 1)}",
            "{'descr': [('a', '<i4')], 'fortran_order': False, 'shape': (1, 1, 1)}",
        ] {
            assert!(
                matches!(parse_npy_header(bad), Err(VoxkitError::Unsupported(_))),
                "{bad}"
            );
        }
        for bad in [
            "{'descr': '<i4', 'fortran_order': Maybe, 'shape': (1, 1, 1)}",
            "{'descr': '<i4', 'fortran_order': False, 'shape': (1, -1, 1)}",
            "{'descr': '<i4', 'fortran_order': False}",
            "{'descr': '<i4, 'fortran_order': False, 'shape': 3}",
        ] {
            assert!(parse_npy_header(bad).is_err(), "{bad}");
        }
    }

    /// Raw data read in parallel pieces (from disk and from memory) reads
    /// back every sample exactly: volumes of several pieces and a partial
    /// one, both byte orders, a byte skip, one- to eight-byte types.
    #[test]
    fn raw_data_in_many_pieces_reads_back_exactly() {
        let dir = std::env::temp_dir().join(format!("voxkit-raw-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let dims = [131usize, 67, 197];
        let n: usize = dims.iter().product();
        let value = |i: usize| ((i * 2_654_435_761) % 65_521) as f64 - 30_000.0;
        let cases: [(&str, usize, bool); 4] = [
            ("short", 2, true),
            ("double", 8, false),
            ("uchar", 1, false),
            ("float", 4, true),
        ];
        for (ty, size, big) in cases {
            let mut bytes = vec![0xa5u8; 3];
            for i in 0..n {
                let v = value(i);
                let b: Vec<u8> = match (ty, big) {
                    ("short", true) => (v as i16).to_be_bytes().to_vec(),
                    ("double", _) => v.to_le_bytes().to_vec(),
                    ("uchar", _) => vec![(v as i64).rem_euclid(256) as u8],
                    ("float", true) => (v as f32 * 0.25).to_be_bytes().to_vec(),
                    _ => unreachable!(),
                };
                assert_eq!(b.len(), size);
                bytes.extend(b);
            }
            assert!(bytes.len() > RAW_TASK_BYTES + 3, "{ty}: one piece only");
            let want = |i: usize| match ty {
                "short" => f64::from(value(i) as i16),
                "double" => value(i),
                "uchar" => (value(i) as i64).rem_euclid(256) as f64,
                _ => f64::from(value(i) as f32 * 0.25),
            };
            let header = format!(
                "NRRD0004\ntype: {ty}\ndimension: 3\nsizes: {} {} {}\nencoding: raw\nendian: {}\nbyte skip: 3\ndata file: {ty}.raw\n",
                dims[0],
                dims[1],
                dims[2],
                if big { "big" } else { "little" }
            );
            let nhdr = dir.join(format!("{ty}.nhdr"));
            std::fs::write(&nhdr, &header).unwrap();
            std::fs::write(dir.join(format!("{ty}.raw")), &bytes).unwrap();
            let disk = read_volume(&nhdr, MemoryLimit::DEFAULT).unwrap();
            let memory =
                read_volume_bytes(&nhdr, header.as_bytes(), &bytes, MemoryLimit::DEFAULT).unwrap();
            for v in [disk, memory] {
                for (i, (z, y, x)) in (0..dims[2])
                    .flat_map(|z| {
                        (0..dims[1]).flat_map(move |y| (0..dims[0]).map(move |x| (z, y, x)))
                    })
                    .enumerate()
                {
                    assert_eq!(v.get(x, y, z), want(i), "{ty} sample {i}");
                }
            }
            // A data file one byte short is an error, not a short volume.
            std::fs::write(dir.join(format!("{ty}.raw")), &bytes[..bytes.len() - 1]).unwrap();
            assert!(read_volume(&nhdr, MemoryLimit::DEFAULT).is_err());
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn decode_raw_across_chunk_boundaries() {
        // A reader that returns 3 bytes at a time splits every f64.
        struct Trickle<'a>(&'a [u8]);
        impl Read for Trickle<'_> {
            fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
                let n = buf.len().min(3).min(self.0.len());
                buf[..n].copy_from_slice(&self.0[..n]);
                self.0 = &self.0[n..];
                Ok(n)
            }
        }
        let vals: Vec<f64> = (0..20_000).map(|i| i as f64 * 0.5 - 7.0).collect();
        let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_be_bytes()).collect();
        let mut out = Vec::new();
        decode_raw::<f64>(&mut Trickle(&bytes), vals.len(), true, &mut out).unwrap();
        assert_eq!(out, vals);
        // A short stream yields what it has.
        let mut out = Vec::new();
        decode_raw::<f64>(&mut &bytes[..20], 5, true, &mut out).unwrap();
        assert_eq!(out, vals[..2]);
    }

    #[test]
    fn ascii_values() {
        let p = Path::new("t");
        let mut out: Vec<i16> = Vec::new();
        decode_ascii(p, &mut &b" 1, -2\n3\t32767 "[..], 4, &mut out).unwrap();
        assert_eq!(out, vec![1, -2, 3, 32767]);
        let mut out: Vec<i16> = Vec::new();
        assert!(decode_ascii(p, &mut &b"1 32768"[..], 2, &mut out).is_err());
        assert!(decode_ascii(p, &mut &b"1 2 3"[..], 2, &mut Vec::<u8>::new()).is_err());
        assert!(decode_ascii(p, &mut &b"1"[..], 2, &mut Vec::<u8>::new()).is_err());
        let long = "1".repeat(100);
        assert!(decode_ascii(p, &mut long.as_bytes(), 1, &mut Vec::<f64>::new()).is_err());
        let mut out: Vec<f32> = Vec::new();
        decode_ascii(p, &mut &b"1.5e2 nan -inf"[..], 3, &mut out).unwrap();
        assert_eq!(out[0], 150.0);
        assert!(out[1].is_nan());
    }

    #[test]
    fn skip_lines_counts_bytes() {
        let mut r = &b"ab\ncd\r\nrest"[..];
        assert_eq!(skip_lines(&mut r, 2).unwrap(), Some(7));
        assert_eq!(r, b"rest");
        let mut r = &b"one line"[..];
        assert_eq!(skip_lines(&mut r, 1).unwrap(), None);
    }

    #[test]
    fn sizes_and_limits() {
        assert!(matches!(
            sizes3("sizes", "1 0 1"),
            Err(VoxkitError::Invalid(_))
        ));
        assert!(matches!(
            sizes3("sizes", "1 -3 1"),
            Err(VoxkitError::Invalid(_))
        ));
        assert!(matches!(
            sizes3("sizes", "1 2"),
            Err(VoxkitError::Invalid(_))
        ));
        assert!(matches!(
            sizes3("sizes", "1 2 99999999999999999999"),
            Err(VoxkitError::Invalid(_))
        ));
        let huge = sizes3("sizes", "4000000000 4000000000 4000000000").unwrap();
        assert!(matches!(
            checked_dims(huge, ScalarType::F64, MemoryLimit::DEFAULT),
            Err(VoxkitError::Limits { .. })
        ));
        assert!(matches!(
            checked_dims([10, 10, 10], ScalarType::I16, MemoryLimit::new(1999)),
            Err(VoxkitError::Limits { .. })
        ));
        assert_eq!(
            checked_dims([10, 10, 10], ScalarType::I16, MemoryLimit::new(2000)).unwrap(),
            [10, 10, 10]
        );
    }

    #[test]
    fn extensions() {
        for p in ["a.nrrd", "b.NHDR", "c.Mhd", "d.mha", "e.npy"] {
            assert!(is_volume_path(Path::new(p)), "{p}");
        }
        for p in ["a.raw", "b", "c.binvox", "d.nrrd.gz"] {
            assert!(!is_volume_path(Path::new(p)), "{p}");
        }
    }
}
