//! Scalar volumes: a dense grid of samples in the type its file stored them
//! in (a 1024³ `uint8` CT stays 1 GiB, not 4 GiB of `f32`), placed in world
//! space by a possibly anisotropic, possibly sheared [`VolumeFrame`].
//!
//! Samples are x fastest, `index = x + nx * (y + ny * z)`, like every grid of
//! the crate; sample `(i, j, k)` sits at the centre of voxel `(i, j, k)`,
//! i.e. on the integer point `(i, j, k)` of grid space.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use super::{BrickGrid, DenseGrid, Dims, GridFrame, MemoryLimit, cell_count};
use crate::error::{Result, VoxkitError};

/// The element type a volume file stores its samples in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScalarType {
    /// Signed 8-bit integer.
    I8,
    /// Unsigned 8-bit integer.
    U8,
    /// Signed 16-bit integer.
    I16,
    /// Unsigned 16-bit integer.
    U16,
    /// Signed 32-bit integer.
    I32,
    /// Unsigned 32-bit integer.
    U32,
    /// IEEE 754 single precision.
    F32,
    /// IEEE 754 double precision.
    F64,
}

impl ScalarType {
    /// Every sample type, narrowest first (signed before unsigned).
    ///
    /// ```
    /// use voxkit::grid::ScalarType;
    /// let names: Vec<_> = ScalarType::ALL.iter().map(|t| t.name()).collect();
    /// assert_eq!(names[..3], ["int8", "uint8", "int16"]);
    /// ```
    pub const ALL: [ScalarType; 8] = [
        ScalarType::I8,
        ScalarType::U8,
        ScalarType::I16,
        ScalarType::U16,
        ScalarType::I32,
        ScalarType::U32,
        ScalarType::F32,
        ScalarType::F64,
    ];

    /// The type's name as NRRD and NumPy users know it: `"int8"`, `"uint8"`,
    /// `"int16"`, `"uint16"`, `"int32"`, `"uint32"`, `"float32"`, `"float64"`.
    pub fn name(self) -> &'static str {
        match self {
            ScalarType::I8 => "int8",
            ScalarType::U8 => "uint8",
            ScalarType::I16 => "int16",
            ScalarType::U16 => "uint16",
            ScalarType::I32 => "int32",
            ScalarType::U32 => "uint32",
            ScalarType::F32 => "float32",
            ScalarType::F64 => "float64",
        }
    }

    /// Bytes per sample.
    pub fn bytes(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }
}

impl std::fmt::Display for ScalarType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The samples of a volume, x fastest, in the file's own element type.
#[derive(Clone, Debug, PartialEq)]
pub enum VolumeData {
    /// `int8` samples.
    I8(Vec<i8>),
    /// `uint8` samples (also NumPy `bool` arrays, as 0/1).
    U8(Vec<u8>),
    /// `int16` samples.
    I16(Vec<i16>),
    /// `uint16` samples.
    U16(Vec<u16>),
    /// `int32` samples.
    I32(Vec<i32>),
    /// `uint32` samples.
    U32(Vec<u32>),
    /// `float32` samples.
    F32(Vec<f32>),
    /// `float64` samples.
    F64(Vec<f64>),
}

/// Runs `$body` with `$v` bound to the typed sample vector of `$data`,
/// whatever its variant: one generic function serves all eight types.
macro_rules! with_samples {
    ($data:expr, $v:ident => $body:expr) => {
        match $data {
            VolumeData::I8($v) => $body,
            VolumeData::U8($v) => $body,
            VolumeData::I16($v) => $body,
            VolumeData::U16($v) => $body,
            VolumeData::I32($v) => $body,
            VolumeData::U32($v) => $body,
            VolumeData::F32($v) => $body,
            VolumeData::F64($v) => $body,
        }
    };
}

impl VolumeData {
    /// The element type of the samples.
    pub fn scalar_type(&self) -> ScalarType {
        match self {
            VolumeData::I8(_) => ScalarType::I8,
            VolumeData::U8(_) => ScalarType::U8,
            VolumeData::I16(_) => ScalarType::I16,
            VolumeData::U16(_) => ScalarType::U16,
            VolumeData::I32(_) => ScalarType::I32,
            VolumeData::U32(_) => ScalarType::U32,
            VolumeData::F32(_) => ScalarType::F32,
            VolumeData::F64(_) => ScalarType::F64,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        with_samples!(self, v => v.len())
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample `i` (linear index) as `f64`, or `None` past the end. Every
    /// element type converts exactly.
    #[inline]
    pub fn value(&self, i: usize) -> Option<f64> {
        with_samples!(self, v => v.get(i).map(|s| s.to_f64()))
    }

    /// 64-bit integer samples (NumPy's default integer type: `.npy` files
    /// and arrays given to the Python `render`) in the narrowest of the types here that holds every
    /// one exactly, tried in the order `uint8`, `int8`, `uint16`, `int16`,
    /// `uint32`, `int32`: a label volume of small integers takes one byte a
    /// voxel. Samples beyond 32 bits become `float64`, exact up to 2⁵³ in
    /// magnitude and rounded to nearest beyond. An empty vector is `uint8`.
    ///
    /// ```
    /// use voxkit::grid::{ScalarType, VolumeData};
    /// assert_eq!(VolumeData::from_i64(vec![0, 3, 255]), VolumeData::U8(vec![0, 3, 255]));
    /// assert_eq!(VolumeData::from_i64(vec![-1, 1000]), VolumeData::I16(vec![-1, 1000]));
    /// assert_eq!(VolumeData::from_i64(vec![-1, 1 << 40]).scalar_type(), ScalarType::F64);
    /// ```
    pub fn from_i64(v: Vec<i64>) -> VolumeData {
        narrowest(&v, i128::from)
    }

    /// [`VolumeData::from_i64`] for unsigned 64-bit samples.
    ///
    /// ```
    /// use voxkit::grid::VolumeData;
    /// assert_eq!(VolumeData::from_u64(vec![7, 1 << 32]), VolumeData::F64(vec![7.0, 4294967296.0]));
    /// ```
    pub fn from_u64(v: Vec<u64>) -> VolumeData {
        narrowest(&v, i128::from)
    }
}

/// [`VolumeData::from_i64`]'s choice: the samples `v` (each exactly
/// `wide(x)`) in the narrowest type whose range holds all of them, else as
/// `f64`.
fn narrowest<T: Copy + Send + Sync>(v: &[T], wide: impl Fn(T) -> i128 + Sync) -> VolumeData {
    // The range grown to hold 0 (the reduction's identity), which changes
    // no choice: every candidate type's range holds 0.
    let (lo, hi) = v
        .par_iter()
        .map(|&x| (wide(x), wide(x)))
        .reduce(|| (0, 0), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    let fits = |min: i128, max: i128| min <= lo && hi <= max;
    // Every cast below is exact: the samples lie in the target's range.
    macro_rules! to {
        ($variant:ident, $t:ty) => {
            VolumeData::$variant(v.par_iter().map(|&x| wide(x) as $t).collect())
        };
    }
    if fits(0, u8::MAX.into()) {
        to!(U8, u8)
    } else if fits(i8::MIN.into(), i8::MAX.into()) {
        to!(I8, i8)
    } else if fits(0, u16::MAX.into()) {
        to!(U16, u16)
    } else if fits(i16::MIN.into(), i16::MAX.into()) {
        to!(I16, i16)
    } else if fits(0, u32::MAX.into()) {
        to!(U32, u32)
    } else if fits(i32::MIN.into(), i32::MAX.into()) {
        to!(I32, i32)
    } else {
        to!(F64, f64)
    }
}

/// An element type of [`VolumeData`]: what the statistics and the readers
/// need to treat all eight alike.
pub(crate) trait Sample: Copy + Default + PartialOrd + Send + Sync + 'static {
    /// The matching [`ScalarType`].
    const TYPE: ScalarType;
    /// Bits of [`Sample::key`]: the width of the type.
    const KEY_BITS: u32;
    /// Wraps a vector of this type.
    fn wrap(v: Vec<Self>) -> VolumeData;
    /// Decodes one sample from exactly `size_of::<Self>()` bytes.
    fn from_bytes(b: &[u8], big_endian: bool) -> Self;
    /// Parses one sample written as text (integers must be in range).
    fn parse(s: &str) -> Option<Self>;
    /// The value as `f64` (exact for every type here).
    fn to_f64(self) -> f64;
    /// An unsigned key whose integer order is the numeric order of the
    /// samples; `None` for NaN and ±∞, which statistics skip.
    fn key(self) -> Option<u64>;
    /// The inverse of [`Sample::key`].
    fn from_key(k: u64) -> Self;
    /// Whether the sample counts as set in an occupancy grid: nonzero and
    /// not NaN.
    fn is_set(self) -> bool;
}

macro_rules! int_sample {
    ($t:ty, $variant:ident, $bits:expr, $flip:expr) => {
        impl Sample for $t {
            const TYPE: ScalarType = ScalarType::$variant;
            const KEY_BITS: u32 = $bits;
            fn wrap(v: Vec<Self>) -> VolumeData {
                VolumeData::$variant(v)
            }
            #[inline]
            fn from_bytes(b: &[u8], big_endian: bool) -> Self {
                let mut a = [0u8; std::mem::size_of::<$t>()];
                a.copy_from_slice(b);
                if big_endian {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }
            fn parse(s: &str) -> Option<Self> {
                s.parse::<i64>().ok().and_then(|v| <$t>::try_from(v).ok())
            }
            #[inline]
            fn to_f64(self) -> f64 {
                f64::from(self)
            }
            #[inline]
            fn key(self) -> Option<u64> {
                // Flipping the sign bit of a two's complement value orders it
                // as unsigned; unsigned types flip nothing.
                Some((self as u64 & ((1u64 << $bits) - 1)) ^ $flip)
            }
            #[inline]
            fn from_key(k: u64) -> Self {
                (k ^ $flip) as $t
            }
            #[inline]
            fn is_set(self) -> bool {
                self != 0
            }
        }
    };
}

int_sample!(i8, I8, 8, 0x80);
int_sample!(u8, U8, 8, 0);
int_sample!(i16, I16, 16, 0x8000);
int_sample!(u16, U16, 16, 0);
int_sample!(i32, I32, 32, 0x8000_0000);
int_sample!(u32, U32, 32, 0);

macro_rules! float_sample {
    ($t:ty, $variant:ident, $bits:expr, $uint:ty) => {
        impl Sample for $t {
            const TYPE: ScalarType = ScalarType::$variant;
            const KEY_BITS: u32 = $bits;
            fn wrap(v: Vec<Self>) -> VolumeData {
                VolumeData::$variant(v)
            }
            #[inline]
            fn from_bytes(b: &[u8], big_endian: bool) -> Self {
                let mut a = [0u8; std::mem::size_of::<$t>()];
                a.copy_from_slice(b);
                if big_endian {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }
            fn parse(s: &str) -> Option<Self> {
                s.parse::<$t>().ok()
            }
            #[inline]
            fn to_f64(self) -> f64 {
                f64::from(self)
            }
            #[inline]
            fn key(self) -> Option<u64> {
                if !self.is_finite() {
                    return None;
                }
                // IEEE order as unsigned order: negative values reverse
                // (flip all bits), positive ones move above them (set the
                // sign bit).
                const SIGN: $uint = 1 << ($bits - 1);
                let b = self.to_bits();
                Some((if b & SIGN != 0 { !b } else { b | SIGN }) as u64)
            }
            #[inline]
            fn from_key(k: u64) -> Self {
                const SIGN: $uint = 1 << ($bits - 1);
                let k = k as $uint;
                <$t>::from_bits(if k & SIGN != 0 { k & !SIGN } else { !k })
            }
            #[inline]
            fn is_set(self) -> bool {
                self != 0.0 && !self.is_nan()
            }
        }
    };
}

float_sample!(f32, F32, 32, u32);
float_sample!(f64, F64, 64, u64);

/// Places a volume's grid in world space.
///
/// `origin` is the world position of the **centre** of voxel `(0, 0, 0)`
/// (NRRD `space origin`, MetaImage `Offset`); column `i` of `axes` is the
/// world displacement of one voxel step along grid axis `i` (NRRD
/// `space directions`; `diag(spacing)` for axis-aligned files). So
/// `world = origin + axes · grid`, with voxel centres at integer grid points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeFrame {
    /// World position of the centre of voxel `(0, 0, 0)`.
    pub origin: DVec3,
    /// Column `i`: world step of one voxel along grid axis `i`.
    pub axes: DMat3,
}

impl Default for VolumeFrame {
    /// Origin 0, unit spacing: world = grid.
    fn default() -> Self {
        VolumeFrame {
            origin: DVec3::ZERO,
            axes: DMat3::IDENTITY,
        }
    }
}

impl VolumeFrame {
    /// The smallest `|det(axes)| / (|a0| |a1| |a2|)` accepted: the volume of
    /// the voxel relative to a cube with the same edges. Below it the
    /// inverse loses most of its digits (the axes are nearly coplanar).
    pub const MIN_CONDITION: f64 = 1e-9;

    /// An axis-aligned frame: `axes = diag(spacing)`.
    pub fn from_spacing(origin: DVec3, spacing: DVec3) -> Self {
        VolumeFrame {
            origin,
            axes: DMat3::from_diagonal(spacing),
        }
    }

    /// The frame of a voxel [`GridFrame`] (cubic voxels, origin at the min
    /// corner of voxel 0): the centre is half a voxel further in.
    pub fn from_grid_frame(frame: &GridFrame) -> Self {
        let h = frame.voxel_size;
        VolumeFrame {
            origin: frame.origin + DVec3::splat(h / 2.0),
            axes: DMat3::from_diagonal(DVec3::splat(h)),
        }
    }

    /// Voxel spacing along each grid axis: the lengths of the columns of
    /// `axes`.
    pub fn spacing(&self) -> DVec3 {
        DVec3::new(
            self.axes.x_axis.length(),
            self.axes.y_axis.length(),
            self.axes.z_axis.length(),
        )
    }

    /// Grid-space point → world point: `origin + axes · g`.
    #[inline]
    pub fn grid_to_world(&self, g: DVec3) -> DVec3 {
        self.origin + self.axes * g
    }

    /// World point → grid-space point (voxel centres at integers).
    /// Inverts `axes` on every call: a hot loop should keep
    /// `axes.inverse()` itself.
    ///
    /// ```
    /// use glam::{DMat3, DVec3};
    /// use voxkit::grid::VolumeFrame;
    /// let f = VolumeFrame::from_spacing(DVec3::new(10.0, 0.0, -5.0), DVec3::new(2.0, 3.0, 0.5));
    /// // The centre of voxel (0,0,0) is the origin; voxel (1,1,1) is one spacing further.
    /// assert_eq!(f.world_to_grid(DVec3::new(10.0, 0.0, -5.0)), DVec3::ZERO);
    /// assert_eq!(f.world_to_grid(DVec3::new(12.0, 3.0, -4.5)), DVec3::ONE);
    /// // A sheared frame round-trips too.
    /// let s = VolumeFrame { origin: DVec3::ZERO, axes: DMat3::from_cols_array(&[1.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 2.0]) };
    /// let g = DVec3::new(3.0, -1.0, 2.5);
    /// assert!((s.world_to_grid(s.grid_to_world(g)) - g).length() < 1e-12);
    /// ```
    #[inline]
    pub fn world_to_grid(&self, w: DVec3) -> DVec3 {
        self.axes.inverse() * (w - self.origin)
    }

    /// Checks that the frame is usable: finite origin and axes, and axes
    /// that are not singular or nearly so (see [`VolumeFrame::MIN_CONDITION`]).
    pub fn validate(&self) -> Result<()> {
        let cols = [self.axes.x_axis, self.axes.y_axis, self.axes.z_axis];
        // The columns as a user wrote them, not glam's `Debug`.
        let shown = || cols.map(crate::error::shown).join(", ");
        if !self.origin.is_finite() || cols.iter().any(|c| !c.is_finite()) {
            return Err(VoxkitError::invalid(format!(
                "volume frame is not finite: origin {}, axes {}",
                crate::error::shown(self.origin),
                shown()
            )));
        }
        if let Some(k) = cols.iter().position(|c| *c == DVec3::ZERO) {
            // Named apart: the ratio below would read 0/0 = NaN.
            return Err(VoxkitError::invalid(format!(
                "volume axes {} are singular: the {} axis ({}) has zero length (its \
                 spacing or direction is 0)",
                shown(),
                ["first", "second", "third"][k],
                ["i", "j", "k"][k],
            )));
        }
        let norms: f64 = cols.iter().map(|c| c.length()).product();
        let ratio = self.axes.determinant().abs() / norms;
        // A column too short for its length to square gives 0/0 = NaN,
        // which fails the comparison.
        let well_conditioned = ratio >= Self::MIN_CONDITION; // false for NaN
        if !well_conditioned || !self.axes.inverse().is_finite() {
            return Err(VoxkitError::invalid(format!(
                "volume axes {} are singular or nearly so (|det| / product of \
                 column lengths = {ratio:e})",
                shown()
            )));
        }
        Ok(())
    }
}

/// A dense scalar volume: samples in the file's element type, x fastest,
/// placed in world space by a [`VolumeFrame`].
#[derive(Clone, Debug, PartialEq)]
pub struct ScalarVolume {
    /// Extents `[nx, ny, nz]` in voxels.
    pub dims: Dims,
    /// The samples, `nx * ny * nz` of them, x fastest.
    pub data: VolumeData,
    /// Where the grid sits in world space.
    pub frame: VolumeFrame,
    /// What the world axes mean anatomically, where the file says so
    /// (NRRD `space`; MetaImage files that carry `AnatomicalOrientation`
    /// are in ITK's LPS); `None` for files without an anatomical space.
    pub space: Option<AnatomicalSpace>,
}

/// An anatomical world space: the patient directions the world's `+x`,
/// `+y` and `+z` point to (NRRD's `space` names). Every one of them has
/// `+z` superior, so a head stands upright when `+z` is drawn up; they
/// differ in which side of the world faces the patient's front.
///
/// ```
/// use voxkit::grid::AnatomicalSpace;
/// assert_eq!(AnatomicalSpace::from_nrrd("RAS"), Some(AnatomicalSpace::Ras));
/// assert_eq!(AnatomicalSpace::from_nrrd("left-posterior-superior"), Some(AnatomicalSpace::Lps));
/// assert_eq!(AnatomicalSpace::from_nrrd("scanner-xyz"), None);
/// assert_eq!(AnatomicalSpace::Ras.anterior_y(), 1.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnatomicalSpace {
    /// Right, anterior, superior (`+x` to the patient's right).
    Ras,
    /// Left, anterior, superior.
    Las,
    /// Left, posterior, superior (DICOM's and ITK's patient space).
    Lps,
}

impl AnatomicalSpace {
    /// The space a NRRD `space` field names (any case, long or short
    /// form); `None` for the non-anatomical spaces (`scanner-xyz`,
    /// `3D-right-handed`, `3D-left-handed`) and unknown names.
    pub fn from_nrrd(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "right-anterior-superior" | "ras" => Some(Self::Ras),
            "left-anterior-superior" | "las" => Some(Self::Las),
            "left-posterior-superior" | "lps" => Some(Self::Lps),
            _ => None,
        }
    }

    /// The sign of the world `y` axis pointing to the patient's front:
    /// `+1` where `+y` is anterior (RAS, LAS), `−1` where it is posterior
    /// (LPS).
    pub fn anterior_y(self) -> f64 {
        match self {
            Self::Ras | Self::Las => 1.0,
            Self::Lps => -1.0,
        }
    }
}

impl ScalarVolume {
    /// A volume of `dims` holding `data` (x fastest). Fails with
    /// [`VoxkitError::Invalid`] if a side is zero or too large to index, if
    /// `data` does not hold exactly `nx * ny * nz` samples, or if the frame
    /// is not valid ([`VolumeFrame::validate`]).
    ///
    /// ```
    /// use glam::DVec3;
    /// use voxkit::grid::{ScalarType, ScalarVolume, VolumeData, VolumeFrame};
    /// let frame = VolumeFrame::from_spacing(DVec3::ZERO, DVec3::new(1.0, 1.0, 2.5));
    /// let v = ScalarVolume::new([3, 2, 1], VolumeData::I16(vec![0, 1, 2, 3, 4, -5]), frame).unwrap();
    /// assert_eq!(v.source_type(), ScalarType::I16);
    /// assert_eq!(v.get(2, 1, 0), -5.0); // index 2 + 3 * 1
    /// assert_eq!(v.range(), Some((-5.0, 4.0)));
    /// // Five samples cannot fill 3 x 2 x 1.
    /// assert!(ScalarVolume::new([3, 2, 1], VolumeData::U8(vec![0; 5]), frame).is_err());
    /// ```
    pub fn new(dims: Dims, data: VolumeData, frame: VolumeFrame) -> Result<Self> {
        let n = cell_count(dims)?;
        if data.len() != n {
            return Err(VoxkitError::invalid(format!(
                "volume data has {} samples, dimensions {}x{}x{} need {n}",
                data.len(),
                dims[0],
                dims[1],
                dims[2]
            )));
        }
        frame.validate()?;
        Ok(ScalarVolume {
            dims,
            data,
            frame,
            space: None,
        })
    }

    /// This volume with its world axes' anatomical meaning set.
    pub fn with_space(self, space: Option<AnatomicalSpace>) -> Self {
        ScalarVolume { space, ..self }
    }

    /// The element type the samples are stored in.
    pub fn source_type(&self) -> ScalarType {
        self.data.scalar_type()
    }

    /// Number of samples, `nx * ny * nz`.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Always false: a volume has at least one sample.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Linear index of sample `(x, y, z)`, or `None` outside the grid.
    #[inline]
    pub fn index(&self, x: usize, y: usize, z: usize) -> Option<usize> {
        let [nx, ny, nz] = self.dims;
        (x < nx && y < ny && z < nz).then(|| x + nx * (y + ny * z))
    }

    /// Sample `(x, y, z)` as `f64`.
    ///
    /// # Panics
    /// If `(x, y, z)` lies outside the grid (as slice indexing does); use
    /// [`ScalarVolume::index`] and [`VolumeData::value`] to check instead.
    #[inline]
    pub fn get(&self, x: usize, y: usize, z: usize) -> f64 {
        self.index(x, y, z)
            .and_then(|i| self.data.value(i))
            .unwrap_or_else(|| panic!("sample ({x}, {y}, {z}) outside {:?}", self.dims))
    }

    /// The samples converted to a dense `f32` grid (what a ray caster
    /// samples). Checked against `limit` before allocating; `f64` and 32-bit
    /// integer samples round to the nearest `f32`.
    pub fn to_f32(&self, limit: MemoryLimit) -> Result<DenseGrid<f32>> {
        let [nx, ny, nz] = self.dims;
        limit.check(
            &format!("f32 copy of a {nx}x{ny}x{nz} volume"),
            self.len() as u128,
            4,
        )?;
        let mut out = Vec::new();
        out.try_reserve_exact(self.len())
            .map_err(|_| VoxkitError::Limits {
                what: format!("f32 copy of a {nx}x{ny}x{nz} volume"),
                needed: self.len() as u128 * 4,
                limit: limit.bytes,
            })?;
        with_samples!(&self.data, v => out.extend(v.iter().map(|s| s.to_f64() as f32)));
        DenseGrid::from_vec(self.dims, out)
    }

    /// The smallest and largest finite sample, or `None` if no sample is
    /// finite (NaN and ±∞ are skipped).
    pub fn range(&self) -> Option<(f64, f64)> {
        with_samples!(&self.data, v => finite_range(v))
    }

    /// The `ps` percentiles (each in `0..=100`, clamped; NaN gives NaN) of
    /// the finite samples, **exact**, interpolated between neighbouring
    /// ranks as NumPy's default (`linear`) method does: percentile `p` is
    /// `s[⌊r⌋] + (r - ⌊r⌋)(s[⌊r⌋+1] - s[⌊r⌋])` with `r = p/100 · (n - 1)`
    /// over the sorted finite samples `s`. NaN and ±∞ are skipped; with no
    /// finite sample every entry is NaN.
    ///
    /// Nothing is sorted or copied: the ranks are found by radix selection
    /// on the samples' order-preserving bit patterns, 16 bits per pass, all
    /// ranks in the same passes (one pass for 8/16-bit types, two for
    /// 32-bit, four for `f64`), each pass counting in parallel into
    /// 65 536-entry tables (one per distinct prefix fixed so far).
    pub fn percentiles(&self, ps: &[f64]) -> Vec<f64> {
        with_samples!(&self.data, v => percentiles_of(v, ps))
    }

    /// Whether this is an occupancy grid in disguise: 8-bit samples (`bool`
    /// arrays read as `uint8`) that are all 0 or 1. The renderer then draws
    /// it as voxels rather than as a density.
    pub fn is_binary(&self) -> bool {
        match &self.data {
            VolumeData::U8(v) => v.iter().all(|&s| s <= 1),
            VolumeData::I8(v) => v.iter().all(|&s| s == 0 || s == 1),
            _ => false,
        }
    }

    /// The voxels whose sample is set (nonzero and not NaN), in grid
    /// coordinates.
    pub fn to_brick_grid(&self) -> BrickGrid {
        with_samples!(&self.data, v => occupancy(v, self.dims))
    }
}

fn finite_range<T: Sample>(v: &[T]) -> Option<(f64, f64)> {
    // Min and max by key: the key skips non-finite values and orders the
    // rest exactly, in one pass without float comparisons.
    let (lo, hi) = v
        .iter()
        .filter_map(|s| s.key())
        .fold((u64::MAX, 0u64), |(lo, hi), k| (lo.min(k), hi.max(k)));
    (lo <= hi).then(|| (T::from_key(lo).to_f64(), T::from_key(hi).to_f64()))
}

/// The percentiles `ps` of the samples `v` (see [`ScalarVolume::percentiles`]).
pub(crate) fn percentiles_of<T: Sample>(v: &[T], ps: &[f64]) -> Vec<f64> {
    let width = 1usize << digit_bits::<T>(0);
    let first = par_counts(v, FIRST_DIGIT_WAYS * width, count_first_digit);
    percentiles_by::<T>(ps, sum_ways(first, width), |known, prefixes| {
        let width = 1usize << digit_bits::<T>(known);
        par_counts(v, width * prefixes.len(), |chunk, counts| {
            count_digit(chunk, known, prefixes, counts)
        })
    })
}

/// The percentiles `ps` (NumPy's `linear`; NaN where there is no finite
/// sample or `p` is NaN) of samples of type `T` by radix selection, from
/// the first digit's counts `first` (`2^digit_bits(0)` entries, which also
/// count the finite samples) and `count(known, prefixes)`: the next digit's
/// counts after `known` fixed bits among the samples whose key starts with
/// one of `prefixes` (a table per prefix, concatenated, as
/// [`count_digit`] fills them). Where the samples live is the caller's:
/// a dense vector, or bricks that read only the ones that may match.
pub(crate) fn percentiles_by<T: Sample>(
    ps: &[f64],
    first: Vec<u64>,
    count: impl FnMut(u32, &[u64]) -> Vec<u64>,
) -> Vec<f64> {
    let n: usize = first.iter().map(|&c| c as usize).sum();
    // The ranks each percentile needs: its lower neighbour, and the upper
    // one where it interpolates.
    let mut plan = Vec::with_capacity(ps.len());
    let mut ranks = Vec::new();
    for &p in ps {
        if n == 0 || p.is_nan() {
            plan.push(None);
            continue;
        }
        let r = p.clamp(0.0, 100.0) / 100.0 * (n - 1) as f64;
        let lo = (r.floor() as usize).min(n - 1);
        let frac = r - lo as f64;
        let hi = (frac != 0.0 && lo + 1 < n).then_some(lo + 1);
        ranks.push(lo);
        ranks.extend(hi);
        plan.push(Some((lo, hi, frac)));
    }
    ranks.sort_unstable();
    ranks.dedup();
    let values = if ranks.is_empty() {
        Vec::new()
    } else {
        select_ranks::<T>(&ranks, first, count)
    };
    let at = |r: usize| values[ranks.binary_search(&r).expect("planned rank")];
    plan.into_iter()
        .map(|q| match q {
            None => f64::NAN,
            Some((lo, None, _)) => at(lo),
            Some((lo, Some(hi), frac)) => {
                let (a, b) = (at(lo), at(hi));
                a + frac * (b - a)
            }
        })
        .collect()
}

/// Bits of the digit fixed after `known` bits of a `T` key.
pub(crate) fn digit_bits<T: Sample>(known: u32) -> u32 {
    (T::KEY_BITS - known).min(16)
}

/// Tables of `len` counts that `count` fills from chunks of `v`, in one
/// parallel pass, summed.
fn par_counts<T: Sample>(v: &[T], len: usize, count: impl Fn(&[T], &mut [u64]) + Sync) -> Vec<u64> {
    let table = || vec![0u64; len];
    v.par_chunks(1 << 16)
        .fold(table, |mut counts, chunk| {
            count(chunk, &mut counts);
            counts
        })
        .reduce(table, |mut a, b| {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
            a
        })
}

/// Adds the next digit (after `known > 0` fixed bits) of the keys of the
/// finite samples in `samples` that start with one of `prefixes` to
/// `counts` (a table of `2^digit_bits` per prefix, concatenated).
#[inline]
pub(crate) fn count_digit<T: Sample>(
    samples: &[T],
    known: u32,
    prefixes: &[u64],
    counts: &mut [u64],
) {
    // The first digit has its own counter (`count_first_digit`): with
    // nothing fixed there is no prefix to shift out.
    debug_assert!(known > 0);
    let bits = digit_bits::<T>(known);
    let shift = T::KEY_BITS - known - bits;
    let width = 1usize << bits;
    let mask = (width - 1) as u64;
    for k in samples.iter().filter_map(|s| s.key()) {
        let p = k >> (shift + bits);
        if let Some(j) = prefixes.iter().position(|&q| q == p) {
            counts[j * width + ((k >> shift) & mask) as usize] += 1;
        }
    }
}

/// Tables [`count_first_digit`] counts into.
pub(crate) const FIRST_DIGIT_WAYS: usize = 4;

/// The first digit (`known = 0`) of the keys of the finite samples in
/// `samples`, counted into [`FIRST_DIGIT_WAYS`] tables of
/// `2^digit_bits(0)` (concatenated; sample `i` into table
/// `i % FIRST_DIGIT_WAYS`), which [`sum_ways`] adds up. Why: neighbouring
/// samples of smooth data share a digit, and in one table each increment
/// waits for the one before it through memory (the counting was half of
/// copying a 512³ float32 volume into bricks).
#[inline]
pub(crate) fn count_first_digit<T: Sample>(samples: &[T], counts: &mut [u64]) {
    let bits = digit_bits::<T>(0);
    let shift = T::KEY_BITS - bits;
    let width = 1usize << bits;
    let mask = (width - 1) as u64;
    let counts = &mut counts[..FIRST_DIGIT_WAYS * width];
    let mut quads = samples.chunks_exact(FIRST_DIGIT_WAYS);
    for q in &mut quads {
        for (j, s) in q.iter().enumerate() {
            if let Some(k) = s.key() {
                counts[j * width + ((k >> shift) & mask) as usize] += 1;
            }
        }
    }
    for k in quads.remainder().iter().filter_map(|s| s.key()) {
        counts[((k >> shift) & mask) as usize] += 1;
    }
}

/// The one table of `width` counts from [`count_first_digit`]'s tables.
pub(crate) fn sum_ways(ways: Vec<u64>, width: usize) -> Vec<u64> {
    let mut sum = ways[..width].to_vec();
    for t in ways.chunks_exact(width).skip(1) {
        sum.iter_mut().zip(t).for_each(|(s, x)| *s += x);
    }
    sum
}

/// The finite samples of the sorted, distinct `ranks` (0-based, ascending
/// order of value) by radix selection: the keys' top bits are fixed 16 at
/// a time, each pass (`count`, as in [`percentiles_by`]) counting the next
/// digit among the samples that share a prefix fixed so far, for every
/// rank at once. `first` holds the first digit's counts.
fn select_ranks<T: Sample>(
    ranks: &[usize],
    first: Vec<u64>,
    mut count: impl FnMut(u32, &[u64]) -> Vec<u64>,
) -> Vec<f64> {
    // Per rank: the prefix fixed so far and the rank among its samples.
    let mut state: Vec<(u64, usize)> = ranks.iter().map(|&r| (0, r)).collect();
    let mut known = 0;
    let mut counts = first;
    let mut prefixes = vec![0u64];
    while known < T::KEY_BITS {
        let bits = digit_bits::<T>(known);
        let width = 1usize << bits;
        for (prefix, rank) in &mut state {
            let j = prefixes
                .iter()
                .position(|q| q == prefix)
                .expect("counted prefix");
            let table = &counts[j * width..(j + 1) * width];
            let mut digit = 0;
            while *rank as u64 >= table[digit] {
                *rank -= table[digit] as usize;
                digit += 1;
            }
            *prefix = (*prefix << bits) | digit as u64;
        }
        known += bits;
        if known < T::KEY_BITS {
            prefixes = state.iter().map(|s| s.0).collect();
            prefixes.dedup();
            counts = count(known, &prefixes);
        }
    }
    state.iter().map(|s| T::from_key(s.0).to_f64()).collect()
}

fn occupancy<T: Sample>(v: &[T], dims: Dims) -> BrickGrid {
    let [nx, ny, _] = dims;
    // `ScalarVolume::new` checked that every coordinate fits an i32. Brick
    // by brick, full bricks as tiles.
    BrickGrid::from_x_rows(dims, |p| {
        let i = p.x as usize + nx * (p.y as usize + ny * p.z as usize);
        let row = &v[i..i + (nx - p.x as usize).min(8)];
        row.iter()
            .enumerate()
            .fold(0u8, |r, (k, s)| r | u8::from(s.is_set()) << k)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::IVec3;

    fn vol(dims: Dims, data: VolumeData) -> ScalarVolume {
        ScalarVolume::new(dims, data, VolumeFrame::default()).unwrap()
    }

    /// NumPy's `linear` percentile by sorting: the reference.
    fn sorted_percentile(v: &[f64], p: f64) -> f64 {
        let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        s.sort_by(f64::total_cmp);
        let r = p / 100.0 * (s.len() - 1) as f64;
        let lo = r.floor() as usize;
        let hi = (lo + 1).min(s.len() - 1);
        s[lo] + (r - lo as f64) * (s[hi] - s[lo])
    }

    #[test]
    fn keys_order_like_numbers() {
        let f = [-f64::MAX, -1.5, -0.0, 0.0, 1e-300, 2.0, f64::MAX];
        let k: Vec<u64> = f.iter().map(|x| x.key().unwrap()).collect();
        assert!(k.windows(2).all(|w| w[0] < w[1]));
        for x in f {
            assert_eq!(f64::from_key(x.key().unwrap()).to_bits(), x.to_bits());
        }
        for x in [f32::MIN, -3.25, 0.0, 7.5, f32::MAX] {
            assert_eq!(f32::from_key(x.key().unwrap()), x);
        }
        assert_eq!(f32::NAN.key(), None);
        assert_eq!(f64::INFINITY.key(), None);
        let i = [i32::MIN, -1, 0, 1, i32::MAX];
        let k: Vec<u64> = i.iter().map(|x| x.key().unwrap()).collect();
        assert!(k.windows(2).all(|w| w[0] < w[1]));
        assert!(i.iter().all(|&x| i32::from_key(x.key().unwrap()) == x));
        assert!(
            [-128i8, -1, 0, 127]
                .iter()
                .all(|&x| i8::from_key(x.key().unwrap()) == x)
        );
        assert!(
            [-32768i16, -1, 0, 32767]
                .iter()
                .all(|&x| i16::from_key(x.key().unwrap()) == x)
        );
    }

    #[test]
    fn percentiles_match_sorting_for_every_type() {
        let raw: Vec<f64> = (0..997u32)
            .map(|i| ((i * 7919) % 1000) as f64 - 300.0)
            .collect();
        let ps = [0.0, 1.0, 25.0, 50.0, 99.5, 100.0, 33.3];
        let cases = [
            VolumeData::I16(raw.iter().map(|&x| x as i16).collect()),
            VolumeData::I32(raw.iter().map(|&x| x as i32 * 1000).collect()),
            VolumeData::F32(raw.iter().map(|&x| x as f32 * 0.25).collect()),
            VolumeData::F64(raw.iter().map(|&x| x * 1e-7).collect()),
            VolumeData::U8(
                raw.iter()
                    .map(|&x| (x as i32).rem_euclid(256) as u8)
                    .collect(),
            ),
            VolumeData::U32(raw.iter().map(|&x| (x + 300.0) as u32 * 99_999).collect()),
        ];
        for data in cases {
            let v = vol([997, 1, 1], data);
            let f: Vec<f64> = (0..v.len()).map(|i| v.data.value(i).unwrap()).collect();
            let got = v.percentiles(&ps);
            for (p, g) in ps.iter().zip(got) {
                let want = sorted_percentile(&f, *p);
                assert!(
                    (g - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "{:?} p{p}: {g} vs {want}",
                    v.source_type()
                );
            }
        }
    }

    #[test]
    fn statistics_skip_nan_and_infinity() {
        let v = vol(
            [3, 2, 1],
            VolumeData::F32(vec![
                f32::NAN,
                2.0,
                f32::INFINITY,
                -1.0,
                f32::NEG_INFINITY,
                5.0,
            ]),
        );
        assert_eq!(v.range(), Some((-1.0, 5.0)));
        assert_eq!(v.percentiles(&[0.0, 50.0, 100.0]), vec![-1.0, 2.0, 5.0]);
        assert!(v.percentiles(&[f64::NAN])[0].is_nan());
        // Out-of-range percentiles clamp.
        assert_eq!(v.percentiles(&[-5.0, 250.0]), vec![-1.0, 5.0]);
        let all_nan = vol([2, 1, 1], VolumeData::F64(vec![f64::NAN; 2]));
        assert_eq!(all_nan.range(), None);
        assert!(all_nan.percentiles(&[50.0])[0].is_nan());
        // NaN is not a set voxel; -0.0 is zero.
        let g = vol([3, 1, 1], VolumeData::F64(vec![f64::NAN, -0.0, 0.5])).to_brick_grid();
        assert_eq!(g.iter().collect::<Vec<_>>(), vec![IVec3::new(2, 0, 0)]);
    }

    #[test]
    fn binary_and_occupancy() {
        let dims = [5, 3, 7];
        let n = 105;
        let bits: Vec<u8> = (0..n).map(|i| u8::from(i % 3 == 0)).collect();
        let v = vol(dims, VolumeData::U8(bits.clone()));
        assert!(v.is_binary());
        let g = v.to_brick_grid();
        assert_eq!(g.count(), 35);
        for (i, &b) in bits.iter().enumerate() {
            let p = IVec3::new((i % 5) as i32, ((i / 5) % 3) as i32, (i / 15) as i32);
            assert_eq!(g.contains(p), b == 1);
            assert_eq!(v.get(p.x as usize, p.y as usize, p.z as usize), b as f64);
        }
        assert!(!vol([2, 1, 1], VolumeData::U8(vec![0, 2])).is_binary());
        assert!(!vol([2, 1, 1], VolumeData::I8(vec![0, -1])).is_binary());
        assert!(!vol([2, 1, 1], VolumeData::U16(vec![0, 1])).is_binary());
    }

    #[test]
    fn to_f32_checks_the_limit_first() {
        let v = vol([4, 4, 4], VolumeData::U16((0..64).collect()));
        assert!(matches!(
            v.to_f32(MemoryLimit::new(255)),
            Err(VoxkitError::Limits { .. })
        ));
        let g = v.to_f32(MemoryLimit::new(256)).unwrap();
        assert_eq!(g.dims(), [4, 4, 4]);
        assert_eq!(g.as_slice()[37], 37.0);
    }

    #[test]
    fn constructor_and_frame_checks() {
        let ok = VolumeFrame::default();
        assert!(ScalarVolume::new([0, 1, 1], VolumeData::U8(vec![]), ok).is_err());
        assert!(ScalarVolume::new([2, 2, 1], VolumeData::U8(vec![0; 5]), ok).is_err());
        let bad = [
            VolumeFrame::from_spacing(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0)),
            VolumeFrame::from_spacing(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::ONE),
            VolumeFrame::from_spacing(DVec3::ZERO, DVec3::new(1.0, f64::INFINITY, 1.0)),
            VolumeFrame::from_spacing(DVec3::ZERO, DVec3::splat(1e-200)),
            VolumeFrame::from_spacing(DVec3::ZERO, DVec3::splat(1e300)),
            VolumeFrame {
                origin: DVec3::ZERO,
                // Two columns 1e-12 apart: nearly coplanar.
                axes: DMat3::from_cols(DVec3::X, DVec3::new(1.0, 1e-12, 0.0), DVec3::Z),
            },
        ];
        for f in bad {
            let e = f.validate();
            assert!(matches!(e, Err(VoxkitError::Invalid(_))), "{f:?}");
            // The axes in a user's numbers, not glam's `Debug` dump.
            let msg = e.unwrap_err().to_string();
            assert!(!msg.contains("DVec3") && msg.contains("axes ["), "{msg}");
            // Extreme numbers in exponent form, not hundreds of digits.
            assert!(msg.len() < 300 && !msg.contains("00000000"), "{msg}");
        }
        // A zero axis is named, not reported as a ratio of NaN.
        let msg = VolumeFrame::from_spacing(DVec3::ZERO, DVec3::new(1.0, -0.0, 1.0))
            .validate()
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("singular: the second axis (j) has zero length") && !msg.contains("NaN"),
            "{msg}"
        );
        // Negative spacing is a mirror, not an error.
        let m = VolumeFrame::from_spacing(DVec3::ONE, DVec3::new(-2.0, 1.0, 0.5));
        m.validate().unwrap();
        assert_eq!(m.spacing(), DVec3::new(2.0, 1.0, 0.5));
        assert_eq!(
            m.world_to_grid(DVec3::new(-3.0, 2.0, 1.5)),
            DVec3::new(2.0, 1.0, 1.0)
        );
    }

    #[test]
    fn grid_frame_centres_agree() {
        let gf = GridFrame::new(DVec3::new(1.0, -2.0, 3.0), 0.5, [4, 5, 6]);
        let vf = VolumeFrame::from_grid_frame(&gf);
        for g in [
            DVec3::ZERO,
            DVec3::new(3.0, 4.0, 5.0),
            DVec3::new(-0.5, 0.25, 2.0),
        ] {
            assert!((vf.grid_to_world(g) - gf.grid_to_world(g)).length() < 1e-12);
            let w = gf.grid_to_world(g);
            assert!((vf.world_to_grid(w) - gf.world_to_grid(w)).length() < 1e-12);
        }
    }
}
