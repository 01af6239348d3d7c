//! A scalar volume's samples stored for rendering: 8³ bricks, brick-major,
//! in the file's own sample type, with per-brick value ranges.
//!
//! # Layout
//! Brick `b = v >> 3` holds its 512 samples contiguously at
//! `512 · (bx + bx_n · (by + by_n · bz))`, x fastest inside the brick
//! (`(x & 7) + 8 (y & 7) + 64 (z & 7)`): a ray crossing a brick touches one
//! 512-sample block (one or a few cache lines per brick row) instead of 64
//! rows spread over the volume, and neighbouring rays reuse it. Bricks at the
//! volume's far faces are padded to 8³; padding is never sampled (rays are
//! clipped inside the volume, trilinear samples clamp at its border).
//!
//! Samples keep their type (`int8`, `uint8`, `int16`, `uint16`, `int32`,
//! `uint32`, `float32`): a `uint8` CT stays one byte a voxel. `float64`
//! narrows to `float32` (round to nearest: a relative error of at most
//! 2⁻²⁴, the precision every mode computes in anyway; finite samples beyond
//! `float32`'s range become `±∞`, counted as they narrow:
//! [`VolumeBricks::narrowed_to_infinity`], which `voxkit render` and the Python
//! `render` report in a warning). A sample is read as
//! `f32` (`Stored::value`): integers convert exactly up to 2²⁴ and round to
//! nearest beyond; NaN is stored as `−∞` (it never holds a maximum, never
//! reaches an iso value).
//!
//! # Building without a second copy
//! [`VolumeBricks::from_volume`] takes the volume's sample vector and
//! rearranges it *in place*, one layer of bricks (8 z-slices) at a time,
//! from the last layer to the first: layer `k` of bricks starts at or after
//! where slab `k` of the dense data starts (a brick layer is at least as
//! long as a dense slab), so writing it only overwrites slabs that were
//! already consumed. The only extra memory is the slab being rearranged and
//! the next one (whose first two slices are the aprons below): peak memory
//! stays within two slabs of the volume itself, where a dense `f32` copy doubled it. The
//! brick ranges are computed in the same pass, from the dense slices.
//!
//! # Brick ranges
//! Per brick, the smallest and largest value over the brick grown by 0, 1
//! and 2 voxels ([`BrickRange`], clipped to the volume): what the renderer's
//! skipping and adaptive flags need for nearest and trilinear samples.

use std::sync::{Mutex, PoisonError};

use glam::IVec3;
use rayon::prelude::*;

use crate::error::{Result, VoxkitError};
use crate::grid::volume::{
    FIRST_DIGIT_WAYS, Sample, count_digit, count_first_digit, digit_bits, percentiles_by,
    percentiles_of, sum_ways,
};
use crate::grid::{MemoryLimit, ScalarType, ScalarVolume, VolumeData};

/// Brick edge in voxels.
pub(crate) const BRICK: i32 = 8;
/// Samples per brick.
const BRICK_LEN: usize = 512;

/// Value ranges of one 8³ brick: `min[r]`, `max[r]` over the brick grown by
/// `r` voxels on every side (clipped to the volume), `r = 0, 1, 2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrickRange {
    /// Smallest value over the brick grown by `r` voxels.
    pub min: [f32; 3],
    /// Largest value over the brick grown by `r` voxels.
    pub max: [f32; 3],
}

impl BrickRange {
    const EMPTY: BrickRange = BrickRange {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };
}

/// A sample type the bricks store, read as the renderer's `f32`.
pub(crate) trait Stored: Sample {
    /// The smallest and the largest value of the type (`±∞` for floats).
    const EXTREMES: (Self, Self);
    /// The value the renderer computes with (see the [module docs](self)).
    fn value(self) -> f32;
}

macro_rules! stored_int {
    ($($t:ty),*) => {$(
        impl Stored for $t {
            const EXTREMES: (Self, Self) = (<$t>::MIN, <$t>::MAX);
            #[inline(always)]
            fn value(self) -> f32 {
                // Round to nearest, as `f64 → f32` of the exact value does.
                self as f32
            }
        }
    )*};
}
stored_int!(i8, u8, i16, u16, i32, u32);

impl Stored for f32 {
    const EXTREMES: (Self, Self) = (f32::NEG_INFINITY, f32::INFINITY);
    #[inline(always)]
    fn value(self) -> f32 {
        // NaN was replaced by −∞ when the bricks were built.
        self
    }
}

/// NaN as `−∞`, every other value unchanged.
#[inline(always)]
fn denan(x: f32) -> f32 {
    if x.is_nan() { f32::NEG_INFINITY } else { x }
}

/// The typed sample vectors the bricks may hold.
#[derive(Clone, Debug)]
enum Store {
    I8(Vec<i8>),
    U8(Vec<u8>),
    I16(Vec<i16>),
    U16(Vec<u16>),
    I32(Vec<i32>),
    U32(Vec<u32>),
    F32(Vec<f32>),
}

/// Runs `$body` with `$v` bound to the typed vector of a [`Store`].
macro_rules! with_store {
    ($store:expr, $v:ident => $body:expr) => {
        match $store {
            Store::I8($v) => $body,
            Store::U8($v) => $body,
            Store::I16($v) => $body,
            Store::U16($v) => $body,
            Store::I32($v) => $body,
            Store::U32($v) => $body,
            Store::F32($v) => $body,
        }
    };
}

/// A scalar volume's samples in 8³ bricks (see the [module docs](self)).
///
/// ```
/// use glam::IVec3;
/// use voxkit::grid::{MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
/// use voxkit::render::VolumeBricks;
/// let data: Vec<i16> = (0..1000).map(|i| i as i16 - 500).collect();
/// let vol = ScalarVolume::new([10, 10, 10], VolumeData::I16(data), VolumeFrame::default()).unwrap();
/// let b = VolumeBricks::from_volume(vol, MemoryLimit::DEFAULT).unwrap();
/// assert_eq!(b.value(IVec3::new(1, 2, 3)), Some(321.0 - 500.0));
/// assert_eq!(b.heap_bytes(), 8 * 512 * 2 + 8 * std::mem::size_of::<voxkit::render::BrickRange>());
/// // Brick (1, 0, 0) holds x = 8..9, y, z = 0..7.
/// let r = b.brick_range(IVec3::new(1, 0, 0)).unwrap();
/// assert_eq!((r.min[0], r.max[0]), (8.0 - 500.0, 779.0 - 500.0));
/// ```
#[derive(Clone, Debug)]
pub struct VolumeBricks {
    dims: [i32; 3],
    bdims: [i32; 3],
    store: Store,
    ranges: Vec<BrickRange>,
    source: ScalarType,
    /// Finite `float64` samples stored as `±∞` (beyond `f32`'s range).
    narrowed_to_infinity: u64,
}

impl VolumeBricks {
    /// Rearranges `volume`'s samples into bricks in place (see the
    /// [module docs](self)) and computes the brick ranges. `limit` caps the
    /// bricks and their ranges together, checked before anything grows.
    pub fn from_volume(volume: ScalarVolume, limit: MemoryLimit) -> Result<Self> {
        Ok(Self::with_percentiles(volume, limit, &[])?.0)
    }

    /// [`VolumeBricks::from_volume`], and the percentiles `ps` of the
    /// finite samples (as [`ScalarVolume::percentiles`] gives them) read in
    /// the same pass: the rearrangement counts the keys' first radix digit
    /// as it goes, and the further digits (32-bit types) count only the
    /// bricks whose range may hold the ranks sought. `float64` samples are
    /// ranked before they narrow.
    ///
    /// ```
    /// use voxkit::grid::{MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
    /// use voxkit::render::VolumeBricks;
    /// let data: Vec<f32> = (0..1000).map(|i| i as f32 * 0.5).collect();
    /// let vol = ScalarVolume::new([10, 10, 10], VolumeData::F32(data), VolumeFrame::default()).unwrap();
    /// let want = vol.percentiles(&[1.0, 99.5]);
    /// let (_, got) = VolumeBricks::with_percentiles(vol, MemoryLimit::DEFAULT, &[1.0, 99.5]).unwrap();
    /// assert_eq!(got, want);
    /// ```
    pub fn with_percentiles(
        volume: ScalarVolume,
        limit: MemoryLimit,
        ps: &[f64],
    ) -> Result<(Self, Vec<f64>)> {
        let dims = volume.dims;
        let bdims = dims.map(|d| d.div_ceil(BRICK as usize));
        let nb: usize = bdims.iter().product();
        limit.check(
            "volume bricks",
            Self::bytes_needed(dims, volume.data.scalar_type()),
            1,
        )?;
        let source = volume.data.scalar_type();
        let mut ranges = Vec::new();
        ranges
            .try_reserve_exact(nb)
            .map_err(|_| too_big(nb * std::mem::size_of::<BrickRange>(), limit))?;
        ranges.resize(nb, BrickRange::EMPTY);
        let count = !ps.is_empty();
        let mut first = None;
        // Rearranges one typed vector in place, counting as asked.
        macro_rules! in_place {
            ($v:expr, $fix:expr) => {
                in_place($v, dims, &mut ranges, $fix, count, &mut first, limit)?
            };
        }
        let (mut dense, mut narrowed_to_infinity) = (Vec::new(), 0);
        let store = match volume.data {
            VolumeData::I8(v) => Store::I8(in_place!(v, |x| x)),
            VolumeData::U8(v) => Store::U8(in_place!(v, |x| x)),
            VolumeData::I16(v) => Store::I16(in_place!(v, |x| x)),
            VolumeData::U16(v) => Store::U16(in_place!(v, |x| x)),
            VolumeData::I32(v) => Store::I32(in_place!(v, |x| x)),
            VolumeData::U32(v) => Store::U32(in_place!(v, |x| x)),
            VolumeData::F32(v) => Store::F32(in_place!(v, denan)),
            VolumeData::F64(v) => {
                // Ranked as they are: narrowing could merge distinct values.
                if count {
                    dense = percentiles_of(&v, ps);
                }
                let (store, beyond) = narrowed(&v, dims, &mut ranges, limit)?;
                narrowed_to_infinity = beyond;
                Store::F32(store)
            }
        };
        let bricks = VolumeBricks {
            dims: dims.map(|d| d as i32),
            bdims: bdims.map(|d| d as i32),
            store,
            ranges,
            source,
            narrowed_to_infinity,
        };
        let p = match first {
            Some(first) => with_store!(&bricks.store, v => bricks.percentiles_of(v, ps, first)),
            None => dense,
        };
        Ok((bricks, p))
    }

    /// The percentiles `ps` of the stored samples `v` (this store's vector)
    /// from the first digit's counts `first`: the further digits are counted
    /// over the bricks whose range meets a prefix sought, their padding
    /// left out.
    fn percentiles_of<T: Stored>(&self, v: &[T], ps: &[f64], first: Vec<u64>) -> Vec<f64> {
        percentiles_by::<T>(ps, first, |known, prefixes| {
            // Each prefix's keys span a closed interval of values (key order
            // is numeric order; key patterns beyond the finite values, NaN
            // for floats, widen to the type's extremes: the stored samples
            // hold no NaN). Samples are screened by value, which vectorises,
            // and only screened runs are counted by key (which also tells
            // −0 from +0).
            let free = T::KEY_BITS - known;
            let spans: Vec<(T, T)> = prefixes
                .iter()
                .map(|&p| {
                    let (lo, hi) = (
                        T::from_key(p << free),
                        T::from_key((p << free) | ((1u64 << free) - 1)),
                    );
                    #[allow(clippy::eq_op)] // NaN test for a generic sample
                    let (lo, hi) = (
                        if lo == lo { lo } else { T::EXTREMES.0 },
                        if hi == hi { hi } else { T::EXTREMES.1 },
                    );
                    (lo, hi)
                })
                .collect();
            let may_hold = |run: &[T]| {
                spans.iter().any(|&(lo, hi)| {
                    run.iter()
                        .fold(false, |hit, &s| hit | ((s >= lo) & (s <= hi)))
                })
            };
            // The same screen on a brick's range (`f32`, rounded to nearest:
            // monotone, so a brick holding a matching sample has a range
            // that meets the rounded interval).
            let brick_spans: Vec<(f32, f32)> = spans
                .iter()
                .map(|&(lo, hi)| (lo.value(), hi.value()))
                .collect();
            let counts = ThreadTables::new((1usize << digit_bits::<T>(known)) * prefixes.len());
            let [nx, ny, nz] = self.dims.map(|d| d as usize);
            let [bx_n, by_n, _] = self.bdims.map(|d| d as usize);
            self.ranges
                .par_iter()
                .enumerate()
                .with_min_len(1 << 8)
                .for_each(|(bi, r)| {
                    if !brick_spans
                        .iter()
                        .any(|&(lo, hi)| r.max[0] >= lo && r.min[0] <= hi)
                    {
                        return;
                    }
                    let (bx, by, bz) = (bi % bx_n, bi / bx_n % by_n, bi / (bx_n * by_n));
                    let b = BRICK as usize;
                    let w = (nx - bx * b).min(b);
                    let h = (ny - by * b).min(b);
                    let d = (nz - bz * b).min(b);
                    let brick = &v[bi * BRICK_LEN..][..BRICK_LEN];
                    if w == b && h == b {
                        for run in brick[..d * 64].chunks_exact(64) {
                            if may_hold(run) {
                                counts.with(|t| count_digit(run, known, prefixes, t));
                            }
                        }
                    } else {
                        counts.with(|t| {
                            for lz in 0..d {
                                for ly in 0..h {
                                    let row = &brick[lz * 64 + ly * 8..][..w];
                                    count_digit(row, known, prefixes, t);
                                }
                            }
                        });
                    }
                });
            counts.total()
        })
    }

    /// Bytes the bricks and their ranges take for a volume of `dims`
    /// samples of type `ty` (padding included; `float64` held as `float32`).
    pub fn bytes_needed(dims: [usize; 3], ty: ScalarType) -> u128 {
        let nb: u128 = dims
            .iter()
            .map(|&d| d.div_ceil(BRICK as usize) as u128)
            .product();
        let elem = match ty {
            ScalarType::F64 => 4,
            t => t.bytes() as u128,
        };
        nb * (BRICK_LEN as u128 * elem + std::mem::size_of::<BrickRange>() as u128)
    }

    /// Extents in voxels.
    pub fn dims(&self) -> [i32; 3] {
        self.dims
    }

    /// Bricks per axis.
    pub fn brick_dims(&self) -> [i32; 3] {
        self.bdims
    }

    /// The sample type of the volume the bricks were built from (the bricks
    /// hold it, but `float64`, which they hold as `float32`).
    pub fn source_type(&self) -> ScalarType {
        self.source
    }

    /// How many finite samples of a `float64` volume lie beyond `f32`'s
    /// range (`|x| > f32::MAX` after rounding) and are held as `±∞`:
    /// counted as they narrow, `0` for every other sample type.
    ///
    /// ```
    /// use voxkit::grid::{MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
    /// use voxkit::render::VolumeBricks;
    /// let data = VolumeData::F64(vec![1.0, -1e300, 3e38, 1e39, f64::INFINITY, f64::NAN]);
    /// let vol = ScalarVolume::new([6, 1, 1], data, VolumeFrame::default()).unwrap();
    /// let b = VolumeBricks::from_volume(vol, MemoryLimit::DEFAULT).unwrap();
    /// assert_eq!(b.narrowed_to_infinity(), 2);
    /// ```
    pub fn narrowed_to_infinity(&self) -> u64 {
        self.narrowed_to_infinity
    }

    /// The smallest and largest sample of a volume of 8- or 16-bit
    /// integers (every sample is then one of at most 65,536 values, exact
    /// in `f32`); `None` for other types.
    pub(crate) fn small_integer_range(&self) -> Option<(i32, i32)> {
        if !matches!(
            self.store,
            Store::I8(_) | Store::U8(_) | Store::I16(_) | Store::U16(_)
        ) {
            return None;
        }
        let (lo, hi) = self
            .ranges
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), r| {
                (lo.min(r.min[0]), hi.max(r.max[0]))
            });
        (lo <= hi).then_some((lo as i32, hi as i32))
    }

    /// Bytes held: the bricks (padding included) and the brick ranges.
    pub fn heap_bytes(&self) -> usize {
        let samples = with_store!(&self.store, v => std::mem::size_of_val(&v[..]));
        samples + self.ranges.len() * std::mem::size_of::<BrickRange>()
    }

    /// The largest stored sample (padding included), in one parallel pass
    /// over every byte of the bricks: what a MIP that reads every voxel
    /// once cannot beat. Benchmarks time it beside each frame as the
    /// memory floor (see `benches/render.rs`).
    pub fn max_pass(&self) -> f32 {
        with_store!(&self.store, v => v
            .par_chunks(1 << 16)
            .map(|c| c.iter().fold(f32::NEG_INFINITY, |m, s| m.max(s.value())))
            .reduce(|| f32::NEG_INFINITY, f32::max))
    }

    /// The value of voxel `v` as the renderer reads it, `None` outside the
    /// volume.
    pub fn value(&self, v: IVec3) -> Option<f32> {
        self.contains(v).then(|| self.value_at(self.index(v)))
    }

    /// The value ranges of brick `b` (brick coordinates: voxel `>> 3`),
    /// `None` outside the volume.
    pub fn brick_range(&self, b: IVec3) -> Option<BrickRange> {
        ((0..3).all(|k| b[k] >= 0 && b[k] < self.bdims[k]))
            .then(|| self.ranges[self.brick_index(b)])
    }

    /// All brick ranges, brick index order (x fastest).
    pub(crate) fn ranges(&self) -> &[BrickRange] {
        &self.ranges
    }

    /// Whether voxel `v` lies in the volume.
    #[inline(always)]
    pub(crate) fn contains(&self, v: IVec3) -> bool {
        v.cmpge(IVec3::ZERO).all() && v.cmplt(IVec3::from_array(self.dims)).all()
    }

    /// The index of brick `b` (inside the volume).
    #[inline(always)]
    pub(crate) fn brick_index(&self, b: IVec3) -> usize {
        (b.x + self.bdims[0] * (b.y + self.bdims[1] * b.z)) as usize
    }

    /// The storage index of voxel `v` (inside the volume).
    #[inline(always)]
    pub(crate) fn index(&self, v: IVec3) -> usize {
        (self.brick_index(v >> 3) << 9) | super::occupancy::local_index(v)
    }

    /// Index steps of a move along x, y, z that stays inside one brick.
    pub(crate) const STRIDES: [isize; 3] = [1, 8, 64];

    /// Asks the CPU to fetch brick `bi`'s samples into its caches: a ray
    /// entering a brick reads a few of its cache lines one after another,
    /// and the rays of the neighbouring pixels most of the others, so the
    /// whole brick's lines are requested at once. A hint: nothing is read.
    #[inline(always)]
    pub(crate) fn prefetch(&self, bi: usize) {
        #[cfg(target_arch = "x86_64")]
        self.prefetch_to::<{ std::arch::x86_64::_MM_HINT_T0 }>(bi);
        #[cfg(not(target_arch = "x86_64"))]
        let _ = bi;
    }

    /// [`VolumeBricks::prefetch`] into the cache level `HINT` names
    /// (`_MM_HINT_T0` for every level, `_MM_HINT_T1` from the second on):
    /// shear-warp fetches the next layer's bricks into the second level
    /// while it works on the current one, which the first holds.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn prefetch_to<const HINT: i32>(&self, bi: usize) {
        with_store!(&self.store, v => {
            use std::arch::x86_64::_mm_prefetch;
            let start = v.as_ptr().wrapping_add(bi << 9).cast::<i8>();
            // One brick's bytes in the store's sample type (none for a
            // store without samples).
            let bytes = std::mem::size_of_val(&v[..BRICK_LEN.min(v.len())]);
            for off in (0..bytes).step_by(64) {
                // SAFETY: SSE is part of the x86-64 baseline, and a
                // prefetch never faults (any address is allowed).
                unsafe { _mm_prefetch::<HINT>(start.wrapping_add(off)) };
            }
        });
    }

    /// The sample at storage index `i`.
    #[inline(always)]
    pub(crate) fn value_at(&self, i: usize) -> f32 {
        // `float32` ahead of the match: a predictable branch where the
        // jump table's indirect one cost an exact MIP frame 3–4% (the
        // 6-ray's brick loop reads a sample every step).
        if let Store::F32(v) = &self.store {
            return v[i];
        }
        with_store!(&self.store, v => v[i].value())
    }

    /// The samples of the voxels `start + i·e_axis` for `i < out.len()`
    /// (all inside the volume), as the renderer reads them: one row of a
    /// slice, brick by brick.
    pub(crate) fn read_row(&self, axis: usize, start: IVec3, out: &mut [f32]) {
        let local = Self::STRIDES[axis] as usize;
        with_store!(&self.store, v => {
            // Brick by brick: up to 8 samples `local` apart from one base.
            let (mut pos, mut o) = (start, 0);
            while o < out.len() {
                let take = (8 - (pos[axis] & 7) as usize).min(out.len() - o);
                let base = self.index(pos);
                let src = &v[base..=base + (take - 1) * local];
                for (t, x) in out[o..o + take].iter_mut().enumerate() {
                    *x = src[t * local].value();
                }
                o += take;
                pos[axis] += take as i32;
            }
        })
    }

    /// The samples of the voxels `v` in the box `lo..=hi` (inside the
    /// volume) into `out[Σₖ (v[k] − lo[k])·stride[k]]`, read brick by
    /// brick in storage order: each brick's samples are one contiguous
    /// run, so the block streams from memory where rows of it would not.
    ///
    /// # Panics
    /// If an index lies outside `out`.
    pub(crate) fn read_block(&self, lo: IVec3, hi: IVec3, stride: [usize; 3], out: &mut [f32]) {
        debug_assert!(self.contains(lo) && self.contains(hi) && lo.cmple(hi).all());
        let (blo, bhi): (IVec3, IVec3) = (lo >> 3, hi >> 3);
        // Per axis and brick coordinate: the local range and the output
        // offset of its first voxel.
        let span = |k: usize, bk: i32| {
            let first = (bk * 8).max(lo[k]);
            let last = (bk * 8 + 7).min(hi[k]);
            (
                (first - bk * 8) as usize,
                (last - bk * 8) as usize,
                (first - lo[k]) as usize * stride[k],
            )
        };
        with_store!(&self.store, v => {
            for bz in blo.z..=bhi.z {
                let (z0, z1, oz) = span(2, bz);
                for by in blo.y..=bhi.y {
                    let (y0, y1, oy) = span(1, by);
                    for bx in blo.x..=bhi.x {
                        let (x0, x1, ox) = span(0, bx);
                        let brick = &v[self.brick_index(IVec3::new(bx, by, bz)) << 9..][..512];
                        for z in z0..=z1 {
                            for y in y0..=y1 {
                                let src = &brick[64 * z + 8 * y..][x0..=x1];
                                let d = oz + (z - z0) * stride[2] + oy + (y - y0) * stride[1] + ox;
                                if stride[0] == 1 && src.len() == 8 {
                                    // A whole brick row: a fixed-size copy the
                                    // compiler keeps inline (a `memcpy` call
                                    // per 8 samples costs more than the copy).
                                    let row: [f32; 8] = std::array::from_fn(|t| src[t].value());
                                    out[d..d + 8].copy_from_slice(&row);
                                } else if stride[0] == 1 {
                                    for (o, x) in out[d..d + src.len()].iter_mut().zip(src) {
                                        *o = x.value();
                                    }
                                } else {
                                    for (t, x) in src.iter().enumerate() {
                                        out[d + t * stride[0]] = x.value();
                                    }
                                }
                            }
                        }
                    }
                }
            }
        })
    }

    /// The samples at the storage indices `buf[..].1`, into `out` (as long
    /// as `buf`): one type dispatch for a run of voxels.
    #[inline(always)]
    pub(crate) fn gather(&self, buf: &[(IVec3, usize)], out: &mut [f32]) {
        with_store!(&self.store, v => {
            for (o, &(_, i)) in out.iter_mut().zip(buf) {
                *o = v[i].value();
            }
        })
    }

    /// Trilinear value at grid point `p` (inside voxel `v`'s cube, `v` at
    /// storage index `idx`) from the 8 voxel centres around it, clamped at
    /// the volume's border (a corner past the border gets weight 0 and is
    /// the corner before it).
    #[inline(always)]
    pub(crate) fn trilinear(&self, v: IVec3, idx: usize, p: [f64; 3]) -> f32 {
        // The cell's low corner `c` and, per axis, whether it has a second
        // corner and the weight of that one.
        let mut c = v;
        let mut step = [0i32; 3];
        let mut w = [0f32; 3];
        for k in 0..3 {
            let dk = p[k] - v[k] as f64;
            if dk >= 0.0 {
                if v[k] + 1 < self.dims[k] {
                    step[k] = 1;
                    w[k] = dk as f32;
                }
            } else if v[k] > 0 {
                c[k] -= 1;
                step[k] = 1;
                w[k] = (1.0 + dk) as f32;
            }
        }
        // Inside one brick the corners are fixed offsets from `c`'s index;
        // across a brick face each corner finds its own brick.
        let one_brick = (0..3).all(|k| (c[k] & 7) + step[k] <= 7);
        let corners: [usize; 8] = if one_brick {
            let base = if c == v { idx } else { self.index(c) };
            let s = [0, 1, 2].map(|k| step[k] as usize * Self::STRIDES[k] as usize);
            [
                base,
                base + s[0],
                base + s[1],
                base + s[1] + s[0],
                base + s[2],
                base + s[2] + s[0],
                base + s[2] + s[1],
                base + s[2] + s[1] + s[0],
            ]
        } else {
            std::array::from_fn(|j| {
                let o = IVec3::new(
                    step[0] * (j as i32 & 1),
                    step[1] * (j as i32 >> 1 & 1),
                    step[2] * (j as i32 >> 2 & 1),
                );
                self.index(c + o)
            })
        };
        let at = with_store!(&self.store, s => corners.map(|i| s[i].value()));
        let x00 = lerp(at[0], at[1], w[0]);
        let x10 = lerp(at[2], at[3], w[0]);
        let x01 = lerp(at[4], at[5], w[0]);
        let x11 = lerp(at[6], at[7], w[0]);
        lerp(lerp(x00, x10, w[1]), lerp(x01, x11, w[1]), w[2])
    }
}

/// Linear interpolation in which a corner of weight 0 does not count (a
/// `−∞` there does not poison the value) and any other non-finite mix is
/// `−∞`.
#[inline(always)]
pub(crate) fn lerp(a: f32, b: f32, t: f32) -> f32 {
    let r = a * (1.0 - t) + b * t;
    if r.is_nan() {
        if t <= 0.0 {
            a
        } else if t >= 1.0 {
            b
        } else {
            f32::NEG_INFINITY
        }
    } else {
        r
    }
}

fn too_big(bytes: usize, limit: MemoryLimit) -> VoxkitError {
    VoxkitError::Limits {
        what: "volume bricks".into(),
        needed: bytes as u128,
        limit: limit.bytes,
    }
}

/// Rearranges the dense samples `v` (x fastest, `dims`) into bricks in
/// place, applying `fix` to every sample, and fills `ranges`; with `count`,
/// also the first radix digit's counts of the fixed samples' keys into
/// `first` (see [`VolumeBricks::with_percentiles`]).
fn in_place<T: Stored>(
    mut v: Vec<T>,
    dims: [usize; 3],
    ranges: &mut [BrickRange],
    fix: impl Fn(T) -> T + Sync,
    count: bool,
    first: &mut Option<Vec<u64>>,
    limit: MemoryLimit,
) -> Result<Vec<T>> {
    let [nx, ny, nz] = dims;
    let bd = dims.map(|d| d.div_ceil(BRICK as usize));
    let slice = nx * ny;
    let layer = bd[0] * bd[1] * BRICK_LEN;
    let total = layer * bd[2];
    debug_assert!(total >= v.len() && v.len() == slice * nz);
    let size = std::mem::size_of::<T>();
    v.try_reserve_exact(total - v.len())
        .map_err(|_| too_big(total * size, limit))?;
    v.resize(total, T::default());
    // The dense slab being rearranged, and the one after it (already
    // overwritten in `v`), both with `fix` applied; the buffers swap roles
    // from slab to slab, so each slab is copied once, in parallel, fused
    // with `fix` and the counting (a serial copy per slab was ~5% of a
    // 512³ float32 render command).
    let mut cur: Vec<T> = Vec::new();
    let mut next: Vec<T> = Vec::new();
    let width = 1 << digit_bits::<T>(0);
    let tables = count.then(|| ThreadTables::new(FIRST_DIGIT_WAYS * width));
    const CHUNK: usize = 1 << 16;
    let mut layers = LayerRanges::new(dims);
    for k in (0..bd[2]).rev() {
        let z0 = k * BRICK as usize;
        let z1 = (z0 + BRICK as usize).min(nz);
        let len = (z1 - z0) * slice;
        if cur.len() != len {
            // At most thrice: the last slab may be short, the first two
            // buffers start empty.
            cur.clear();
            cur.resize(len, T::default());
        }
        cur.par_chunks_mut(CHUNK)
            .zip(v[z0 * slice..z1 * slice].par_chunks(CHUNK))
            .for_each(|(c, src)| {
                c.iter_mut().zip(src).for_each(|(x, &s)| *x = fix(s));
                if let Some(t) = &tables {
                    t.with(|t| count_first_digit(c, t));
                }
            });
        {
            // Rows of the dense volume around this slab: slices before it
            // are still dense in `v` (the layers written so far start at or
            // after slab `k + 1`'s start), slices after it are in `next`.
            let before = &v[z0.saturating_sub(2) * slice..z0 * slice];
            let first_before = z0.saturating_sub(2);
            let row = |z: usize, y: usize| {
                let (buf, z): (&[T], usize) = if z < z0 {
                    (before, z - first_before)
                } else if z < z1 {
                    (&cur[..], z - z0)
                } else {
                    (&next[..], z - z1)
                };
                &buf[(z * ny + y) * nx..][..nx]
            };
            let rlayer = &mut ranges[k * bd[0] * bd[1]..(k + 1) * bd[0] * bd[1]];
            layers.layer(rlayer, k, &row, &fix);
        }
        let out = &mut v[k * layer..(k + 1) * layer];
        let cur_ref = &cur;
        out.par_chunks_mut(BRICK_LEN)
            .enumerate()
            .for_each(|(i, brick)| {
                let (bx, by) = (i % bd[0], i / bd[0]);
                fill_brick(brick, bx, by, z1 - z0, [nx, ny], |z, y| {
                    &cur_ref[(z * ny + y) * nx..][..nx]
                });
            });
        std::mem::swap(&mut cur, &mut next);
    }
    *first = tables.map(|t| sum_ways(t.total(), width));
    Ok(v)
}

/// Tables of counts, one per worker thread (each filled under its own,
/// uncontended lock), summed at the end: a parallel pass counts into them
/// without a table per task.
struct ThreadTables {
    tables: Vec<Mutex<Vec<u64>>>,
}

impl ThreadTables {
    fn new(width: usize) -> Self {
        // One table per pool thread, and one for callers outside the pool.
        let n = rayon::current_num_threads() + 1;
        ThreadTables {
            tables: (0..n).map(|_| Mutex::new(vec![0; width])).collect(),
        }
    }

    /// Runs `f` on the calling thread's table.
    #[inline]
    fn with(&self, f: impl FnOnce(&mut [u64])) {
        let last = self.tables.len() - 1;
        let i = rayon::current_thread_index().map_or(last, |i| i.min(last));
        f(&mut self.tables[i]
            .lock()
            .unwrap_or_else(PoisonError::into_inner));
    }

    fn total(self) -> Vec<u64> {
        let mut tables = self
            .tables
            .into_iter()
            .map(|m| m.into_inner().unwrap_or_else(PoisonError::into_inner));
        let mut sum = tables.next().unwrap_or_default();
        for t in tables {
            sum.iter_mut().zip(t).for_each(|(s, x)| *s += x);
        }
        sum
    }
}

/// Bricks of `f32` from dense `f64` samples (a new vector: the types differ
/// in size), and the ranges; returns the bricks and the finite samples that
/// narrowed to `±∞` (each counted once, in the slab of its own layer).
fn narrowed(
    v: &[f64],
    dims: [usize; 3],
    ranges: &mut [BrickRange],
    limit: MemoryLimit,
) -> Result<(Vec<f32>, u64)> {
    let [nx, ny, nz] = dims;
    let bd = dims.map(|d| d.div_ceil(BRICK as usize));
    let slice = nx * ny;
    let layer = bd[0] * bd[1] * BRICK_LEN;
    let total = layer * bd[2];
    let mut out: Vec<f32> = Vec::new();
    out.try_reserve_exact(total)
        .map_err(|_| too_big(total * 4, limit))?;
    crate::alloc::prefault_spare(&mut out);
    out.resize(total, 0.0);
    let conv = |x: f64| denan(x as f32);
    let mut slab: Vec<f32> = Vec::new();
    let mut layers = LayerRanges::new(dims);
    let mut beyond = 0u64;
    for k in 0..bd[2] {
        let z0 = k * BRICK as usize;
        let lo = z0.saturating_sub(2);
        let hi = (z0 + BRICK as usize + 2).min(nz);
        let z1 = (z0 + BRICK as usize).min(nz);
        slab.clear();
        // The layer's own slices count what narrows to ±∞ as they convert
        // (the aprons are counted in their own layers).
        slab.extend(v[lo * slice..z0 * slice].iter().map(|&x| conv(x)));
        slab.extend(v[z0 * slice..z1 * slice].iter().map(|&x| {
            let y = conv(x);
            beyond += u64::from(y.is_infinite() && x.is_finite());
            y
        }));
        slab.extend(v[z1 * slice..hi * slice].iter().map(|&x| conv(x)));
        let slab_rows = &slab;
        let row = |z: usize, y: usize| &slab_rows[((z - lo) * ny + y) * nx..][..nx];
        let rlayer = &mut ranges[k * bd[0] * bd[1]..(k + 1) * bd[0] * bd[1]];
        layers.layer(rlayer, k, &row, &|x| x);
        let slab_ref = &slab;
        out[k * layer..(k + 1) * layer]
            .par_chunks_mut(BRICK_LEN)
            .enumerate()
            .for_each(|(i, brick)| {
                let (bx, by) = (i % bd[0], i / bd[0]);
                fill_brick(brick, bx, by, z1 - z0, [nx, ny], |z, y| {
                    &slab_ref[((z + z0 - lo) * ny + y) * nx..][..nx]
                });
            });
    }
    Ok((out, beyond))
}

/// Writes brick `(bx, by)` of a layer of `depth` slices (padding with the
/// default value) from the layer's dense rows `row(z, y)` (z from the
/// layer's first slice).
#[inline]
fn fill_brick<'a, T: Copy + Default + 'a>(
    brick: &mut [T],
    bx: usize,
    by: usize,
    depth: usize,
    [nx, ny]: [usize; 2],
    row: impl Fn(usize, usize) -> &'a [T],
) {
    let x0 = bx * BRICK as usize;
    let w = (nx - x0).min(BRICK as usize);
    for lz in 0..BRICK as usize {
        for ly in 0..BRICK as usize {
            let y = by * BRICK as usize + ly;
            let dst = &mut brick[lz * 64 + ly * 8..][..8];
            if lz < depth && y < ny {
                let src = &row(lz, y)[x0..x0 + w];
                if let (Ok(d), Ok(s)) =
                    (<&mut [T; 8]>::try_from(&mut *dst), <&[T; 8]>::try_from(src))
                {
                    // A whole brick row: a fixed-size copy the compiler
                    // keeps inline (a `memcpy` call per 8 samples costs
                    // more than the copy).
                    *d = *s;
                } else {
                    dst[..w].copy_from_slice(src);
                    dst[w..].fill(T::default());
                }
            } else {
                dst.fill(T::default());
            }
        }
    }
}

/// The brick ranges of one layer of bricks at a time, from per-slice
/// ranges computed once per slice.
///
/// Separable: a row pass ([`row_pass`]) finds, for each dense row and brick
/// column, the ranges over the row's x-extents `[8bx − r, 8bx + 7 + r]`; a
/// slice's rows fold into per-brick *slice ranges* (over the rows within
/// `r` of the brick's rows, [`slice_ranges`]); a layer's bricks fold the
/// slice ranges of the slices within `r` of theirs. A slice within 2 of a
/// layer boundary is read by two layers: its slice ranges are kept for the
/// second. Every row of ranges is level-major ([`Lanes`]), so the folds are
/// element-wise over brick columns and vectorise.
struct LayerRanges {
    /// Slice ranges by slice (per brick row, a row of [`Lanes`]), kept for
    /// the slices of the last layer's window.
    slices: Vec<Option<Vec<f32>>>,
    dims: [usize; 3],
    bd: [usize; 3],
}

/// Ranges of a row of `n` bricks at the three levels, level-major: `6n`
/// floats, the minima of level `r` at `2rn..(2r + 1)n`, its maxima after.
type Lanes = [f32];

/// A row of `n` empty ranges.
fn empty_lanes(n: usize, out: &mut Vec<f32>) {
    out.clear();
    for _ in 0..3 {
        out.extend(std::iter::repeat_n(f32::INFINITY, n));
        out.extend(std::iter::repeat_n(f32::NEG_INFINITY, n));
    }
}

/// Folds the row of ranges `from` into `into` (both of `n` bricks) at
/// levels `ring..3`. Plain comparisons: no NaN reaches the ranges (see
/// [`row_pass`]), and `f32::min`'s NaN handling costs a blend per value.
#[inline]
fn fold_lanes(into: &mut Lanes, from: &Lanes, n: usize, ring: usize) {
    let (into, from) = (&mut into[2 * ring * n..6 * n], &from[2 * ring * n..6 * n]);
    for (k, (i, f)) in into
        .chunks_exact_mut(n)
        .zip(from.chunks_exact(n))
        .enumerate()
    {
        if k % 2 == 0 {
            i.iter_mut()
                .zip(f)
                .for_each(|(i, &f)| *i = if f < *i { f } else { *i });
        } else {
            i.iter_mut()
                .zip(f)
                .for_each(|(i, &f)| *i = if f > *i { f } else { *i });
        }
    }
}

impl LayerRanges {
    fn new(dims: [usize; 3]) -> Self {
        LayerRanges {
            slices: (0..dims[2]).map(|_| None).collect(),
            dims,
            bd: dims.map(|d| d.div_ceil(BRICK as usize)),
        }
    }

    /// The ranges of layer `k`'s bricks into `out` (x fastest), reading the
    /// dense rows `row(z, y)` through `fix`: only those of slices
    /// `8k − 2 ..= 8k + 9` (clipped to the volume) whose slice ranges are
    /// not kept from the layer before. Any order of the layers gives the
    /// same ranges; in order (up or down) each slice is passed once.
    fn layer<'a, T: Stored + 'a>(
        &mut self,
        out: &mut [BrickRange],
        k: usize,
        row: &(impl Fn(usize, usize) -> &'a [T] + Sync),
        fix: &(impl Fn(T) -> T + Sync),
    ) {
        let b = BRICK as usize;
        let [nx, ny, nz] = self.dims;
        let n = self.bd[0];
        let (z0, z1) = (k * b, (k * b + b - 1).min(nz - 1));
        let (lo, hi) = (z0.saturating_sub(2), (z1 + 2).min(nz - 1));
        // Layers come in order (either way): a slice outside this layer's
        // window is not read again.
        for (z, s) in self.slices.iter_mut().enumerate() {
            if s.is_some() && !(lo..=hi).contains(&z) {
                *s = None;
            }
        }
        let missing: Vec<usize> = (lo..=hi).filter(|&z| self.slices[z].is_none()).collect();
        let bd = self.bd;
        let computed: Vec<(usize, Vec<f32>)> = missing
            .par_iter()
            .map_init(
                || (Vec::with_capacity(nx), Vec::new()),
                |(buf, line), &z| {
                    let r = slice_ranges(|y| row(z, y), [nx, ny], bd, fix, buf, line);
                    (z, r)
                },
            )
            .collect();
        for (z, r) in computed {
            self.slices[z] = Some(r);
        }
        let slices = &self.slices;
        out.par_chunks_mut(n)
            .enumerate()
            .for_each_init(Vec::new, |acc, (by, brow)| {
                empty_lanes(n, acc);
                for (z, s) in slices.iter().enumerate().take(hi + 1).skip(lo) {
                    let rz = z0.saturating_sub(z).max(z.saturating_sub(z1));
                    let s = s.as_deref().expect("computed above");
                    fold_lanes(acc, &s[by * 6 * n..][..6 * n], n, rz);
                }
                for (bx, o) in brow.iter_mut().enumerate() {
                    for r in 0..3 {
                        o.min[r] = acc[2 * r * n + bx];
                        o.max[r] = acc[(2 * r + 1) * n + bx];
                    }
                }
            });
    }
}

/// The slice ranges of one slice (dense rows `row(y)`, read through `fix`):
/// per brick `(bx, by)` of a layer and level `r`, the range over the rows
/// within `r` of brick row `by`'s (clipped), each over its x-extent grown
/// by `r`; brick row by brick row, each a row of [`Lanes`]. `buf` and
/// `line` are scratch.
fn slice_ranges<'a, T: Stored + 'a>(
    row: impl Fn(usize) -> &'a [T],
    [nx, ny]: [usize; 2],
    bd: [usize; 3],
    fix: &impl Fn(T) -> T,
    buf: &mut Vec<f32>,
    line: &mut Vec<f32>,
) -> Vec<f32> {
    let b = BRICK as usize;
    let n = bd[0];
    let mut out = Vec::with_capacity(6 * n * bd[1]);
    let mut empty = Vec::new();
    empty_lanes(n, &mut empty);
    for _ in 0..bd[1] {
        out.extend_from_slice(&empty);
    }
    line.clear();
    line.resize(6 * n, 0.0);
    for y in 0..ny {
        row_pass(row(y), nx, line, fix, buf);
        // The brick rows whose rows grown by 2 hold row `y`.
        for by in (y / b).saturating_sub(1)..=(y / b + 1).min(bd[1] - 1) {
            let (y0, y1) = (by * b, (by * b + b - 1).min(ny - 1));
            let ring = y0.saturating_sub(y).max(y.saturating_sub(y1));
            if ring < 3 {
                fold_lanes(&mut out[by * 6 * n..][..6 * n], line, n, ring);
            }
        }
    }
    out
}

/// Per brick column `bx` of one dense row (`nx` samples, read through
/// `fix` into `buf`): the min and max over `[8bx − r, 8bx + 7 + r]`
/// (clipped), `r = 0, 1, 2`, into the row of [`Lanes`] `out`.
#[inline]
fn row_pass<T: Stored>(
    row: &[T],
    nx: usize,
    out: &mut Lanes,
    fix: &impl Fn(T) -> T,
    buf: &mut Vec<f32>,
) {
    buf.clear();
    buf.extend(row[..nx].iter().map(|&s| fix(s).value()));
    let n = out.len() / 6;
    debug_assert!(nx >= 1 && n == nx.div_ceil(BRICK as usize));
    let (level0, wider) = out.split_at_mut(2 * n);
    let (min0, max0) = level0.split_at_mut(n);
    // No NaN reaches here (`fix` and the narrowing map it to −∞), so plain
    // comparisons are `f32::min`/`max`, and they compile to `minss`/`maxss`
    // rather than to branches on the data (which mispredicted on noisy
    // rows: the apron's four comparisons a brick were a third of the
    // pass).
    let min = |a: f32, b: f32| if b < a { b } else { a };
    let max = |a: f32, b: f32| if b > a { b } else { a };
    let fold = |c: &[f32]| {
        c.iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(mn, mx), &v| {
                (min(mn, v), max(mx, v))
            })
    };
    // Level 0: whole chunks have a fixed length, and their reductions
    // vectorize; a short last chunk folds apart.
    let whole = nx / BRICK as usize;
    for (bx, c) in buf.chunks_exact(BRICK as usize).enumerate() {
        let c: &[f32; BRICK as usize] = c.try_into().expect("exact chunks");
        (min0[bx], max0[bx]) = fold(c);
    }
    if whole < n {
        (min0[whole], max0[whole]) = fold(&buf[whole * BRICK as usize..]);
    }
    // Levels 1 and 2 grow level 0 by the samples `r` before and after the
    // chunk; where the row has none, a sample of the chunk itself stands
    // in (it is already in the range), so every brick takes the same
    // branch-free steps.
    let (level1, level2) = wider.split_at_mut(2 * n);
    let (min1, max1) = level1.split_at_mut(n);
    let (min2, max2) = level2.split_at_mut(n);
    for bx in 0..n {
        let lo = bx * BRICK as usize;
        let hi = (lo + BRICK as usize - 1).min(nx - 1);
        let at = |x: Option<usize>| buf[x.filter(|&x| x < nx).unwrap_or(lo)];
        let [before1, after1, before2, after2] = [
            lo.checked_sub(1),
            Some(hi + 1),
            lo.checked_sub(2),
            Some(hi + 2),
        ]
        .map(at);
        min1[bx] = min(min(min0[bx], before1), after1);
        max1[bx] = max(max(max0[bx], before1), after1);
        min2[bx] = min(min(min1[bx], before2), after2);
        max2[bx] = max(max(max1[bx], before2), after2);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::VolumeFrame;

    /// Volume shapes that are and are not multiples of the brick: whole
    /// bricks, padding on every axis, one voxel, thin, padding in z only.
    const SHAPES: [[usize; 3]; 5] = [[8, 8, 8], [19, 9, 17], [1, 1, 1], [3, 20, 2], [16, 16, 9]];

    fn bricks(dims: [usize; 3], data: VolumeData) -> VolumeBricks {
        let vol = ScalarVolume::new(dims, data, VolumeFrame::default()).unwrap();
        VolumeBricks::from_volume(vol, MemoryLimit::DEFAULT).unwrap()
    }

    /// The float64 samples that narrow to ±∞ are counted once each, over
    /// many brick layers with their overlapping aprons, against a direct
    /// count; NaN, ±∞ and in-range extremes are not counted.
    #[test]
    fn narrowed_to_infinity_counts_each_sample_once() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(21);
        let specials = [
            1e300,
            -1e39,
            3.4e38,
            f64::INFINITY,
            f64::NAN,
            -f64::MAX,
            1e-300,
        ];
        for dims in [[3, 2, 30], [9, 5, 17], [1, 1, 8], [4, 3, 1]] {
            let n: usize = dims.iter().product();
            let v: Vec<f64> = (0..n)
                .map(|_| {
                    if rng.random_bool(0.3) {
                        specials[rng.random_range(0..specials.len())]
                    } else {
                        rng.random_range(-1e3..1e3)
                    }
                })
                .collect();
            let want = v
                .iter()
                .filter(|x| x.is_finite() && (**x as f32).is_infinite())
                .count();
            let b = bricks(dims, VolumeData::F64(v));
            assert_eq!(b.narrowed_to_infinity(), want as u64, "{dims:?}");
        }
    }

    /// A sample's expected value by its dense index.
    type Expected = Box<dyn Fn(usize) -> f32>;

    /// Every sample type reads back the file's values exactly (NaN as
    /// −∞, f64 rounded to f32), at sizes that are and are not multiples of
    /// the brick, through `value`, `gather` and `value_at`.
    #[test]
    fn every_type_reads_back_its_values() {
        for dims in SHAPES {
            let n: usize = dims.iter().product();
            let raw: Vec<i64> = (0..n as i64)
                .map(|i| (i * 7919 + 13) % 1009 - 500)
                .collect();
            let cases: Vec<(VolumeData, Expected)> = vec![
                (
                    VolumeData::I8(raw.iter().map(|&x| (x % 128) as i8).collect()),
                    {
                        let r = raw.clone();
                        Box::new(move |i| (r[i] % 128) as f32)
                    },
                ),
                (
                    VolumeData::U8(raw.iter().map(|&x| (x + 500) as u8).collect()),
                    {
                        let r = raw.clone();
                        Box::new(move |i| ((r[i] + 500) as u8) as f32)
                    },
                ),
                (
                    VolumeData::I16(raw.iter().map(|&x| (x * 60) as i16).collect()),
                    {
                        let r = raw.clone();
                        Box::new(move |i| (r[i] * 60) as f32)
                    },
                ),
                (
                    VolumeData::U16(raw.iter().map(|&x| (x + 500) as u16 * 60).collect()),
                    {
                        let r = raw.clone();
                        Box::new(move |i| ((r[i] + 500) * 60) as f32)
                    },
                ),
                (
                    VolumeData::I32(raw.iter().map(|&x| x as i32 * 4_000_037).collect()),
                    {
                        let r = raw.clone();
                        Box::new(move |i| ((r[i] * 4_000_037) as f64) as f32)
                    },
                ),
                (
                    VolumeData::U32(raw.iter().map(|&x| (x + 500) as u32 * 4_000_037).collect()),
                    {
                        let r = raw.clone();
                        Box::new(move |i| (((r[i] + 500) * 4_000_037) as f64) as f32)
                    },
                ),
                (
                    VolumeData::F32(
                        raw.iter()
                            .map(|&x| {
                                if x % 97 == 0 {
                                    f32::NAN
                                } else {
                                    x as f32 / 3.0
                                }
                            })
                            .collect(),
                    ),
                    {
                        let r = raw.clone();
                        Box::new(move |i| {
                            if r[i] % 97 == 0 {
                                f32::NEG_INFINITY
                            } else {
                                r[i] as f32 / 3.0
                            }
                        })
                    },
                ),
                (
                    VolumeData::F64(
                        raw.iter()
                            .map(|&x| {
                                if x % 89 == 0 {
                                    f64::NAN
                                } else {
                                    x as f64 / 7.0
                                }
                            })
                            .collect(),
                    ),
                    {
                        let r = raw.clone();
                        Box::new(move |i| {
                            if r[i] % 89 == 0 {
                                f32::NEG_INFINITY
                            } else {
                                (r[i] as f64 / 7.0) as f32
                            }
                        })
                    },
                ),
            ];
            for (data, want) in cases {
                let t = data.scalar_type();
                let b = bricks(dims, data);
                assert_eq!(b.source_type(), t);
                let mut buf = Vec::new();
                for z in 0..dims[2] {
                    for y in 0..dims[1] {
                        for x in 0..dims[0] {
                            let v = IVec3::new(x as i32, y as i32, z as i32);
                            let i = x + dims[0] * (y + dims[1] * z);
                            assert_eq!(b.value(v), Some(want(i)), "{t} {dims:?} {v}");
                            buf.push((v, b.index(v)));
                        }
                    }
                }
                let mut out = vec![0.0; buf.len()];
                b.gather(&buf, &mut out);
                for (k, &(v, _)) in buf.iter().enumerate() {
                    assert_eq!(out[k], b.value(v).unwrap());
                }
                assert_eq!(b.value(IVec3::new(-1, 0, 0)), None);
                assert_eq!(b.value(IVec3::from_array(dims.map(|d| d as i32))), None);
            }
        }
    }

    /// The percentiles read while the bricks are built (first digit fused
    /// into the rearrangement, further digits over screened bricks) are the
    /// dense radix selection's, bit for bit: every stored type, padded
    /// shapes, values that share their keys' top 16 bits (so the second
    /// pass decides), negatives, ±0, NaN and ±∞, and no finite sample.
    #[test]
    fn percentiles_in_the_bricks_pass_equal_the_dense_ones() {
        let ps = [0.0, 1.0, 12.5, 25.0, 33.3, 50.0, 70.0, 99.5, 100.0];
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            seed >> 33
        };
        for dims in SHAPES {
            let n: usize = dims.iter().product();
            let r: Vec<u64> = (0..n).map(|_| next()).collect();
            // Clustered: one top-16-bit bucket of each 32-bit type holds most
            // samples, a few lie far out.
            let f32s: Vec<f32> = r
                .iter()
                .enumerate()
                .map(|(i, &x)| match i % 17 {
                    0 => f32::NAN,
                    1 => -0.0,
                    2 => 0.0,
                    3 if n > 40 => f32::INFINITY,
                    4 if n > 40 => f32::NEG_INFINITY,
                    5 => -1.0e30 * (x % 7) as f32,
                    // Denormals: the bucket of +0, where a padding zero
                    // counted by mistake would move a rank.
                    6..=8 => f32::from_bits((x % 5000) as u32),
                    _ => 1.0 + (x % 4096) as f32 * f32::EPSILON,
                })
                .collect();
            let cases = vec![
                VolumeData::I8(r.iter().map(|&x| x as i8).collect()),
                VolumeData::U8(r.iter().map(|&x| (x % 3) as u8).collect()),
                VolumeData::I16(r.iter().map(|&x| x as i16).collect()),
                VolumeData::U16(r.iter().map(|&x| (x % 50) as u16 * 1000).collect()),
                VolumeData::I32(r.iter().map(|&x| -70_000 + (x % 300) as i32).collect()),
                VolumeData::I32(r.iter().map(|&x| (x % 600) as i32 - 300).collect()),
                VolumeData::U32(r.iter().map(|&x| (x as u32) | 0xfff0_0000).collect()),
                VolumeData::U32(r.iter().map(|&x| (x % 1000) as u32).collect()),
                VolumeData::F32(f32s.clone()),
                VolumeData::F32(r.iter().map(|&x| f32::from_bits(x as u32)).collect()),
                VolumeData::F32(vec![f32::NAN; n]),
                VolumeData::F64(f32s.iter().map(|&x| f64::from(x) * (1.0 + 1e-12)).collect()),
            ];
            for data in cases {
                let ty = data.scalar_type();
                let vol = ScalarVolume::new(dims, data, VolumeFrame::default()).unwrap();
                let want = vol.percentiles(&ps);
                let (b, got) =
                    VolumeBricks::with_percentiles(vol.clone(), MemoryLimit::DEFAULT, &ps).unwrap();
                for (g, w) in got.iter().zip(&want) {
                    assert!(
                        g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                        "{ty:?} {dims:?}: {got:?} vs {want:?}"
                    );
                }
                // The bricks are those `from_volume` builds.
                let plain = VolumeBricks::from_volume(vol, MemoryLimit::DEFAULT).unwrap();
                assert_eq!(b.ranges(), plain.ranges());
            }
        }
    }

    /// Brick ranges equal brute force over the grown boxes, at odd sizes
    /// and with −∞ (NaN) samples, built in place (float32, int16) and
    /// narrowed (float64, whose layers come in the other order).
    #[test]
    fn brick_ranges_match_brute_force() {
        let shapes = [
            [19usize, 9, 17],
            [8, 8, 8],
            [5, 30, 26],
            [2, 3, 10],
            [1, 1, 20],
            [9, 1, 1],
            [12, 20, 41],
        ];
        for (dims, ty) in shapes.into_iter().flat_map(|d| [(d, 0), (d, 1), (d, 2)]) {
            let n = dims.iter().product::<usize>();
            let value = |i: usize| ((i * 7919 + 13) % 1009) as f32 - 500.0;
            let nan = |i: usize| i % 211 == 5;
            let data = match ty {
                0 => VolumeData::F32(
                    (0..n)
                        .map(|i| if nan(i) { f32::NAN } else { value(i) })
                        .collect(),
                ),
                1 => VolumeData::F64(
                    (0..n)
                        .map(|i| {
                            if nan(i) {
                                f64::NAN
                            } else {
                                f64::from(value(i))
                            }
                        })
                        .collect(),
                ),
                _ => VolumeData::I16((0..n).map(|i| value(i) as i16).collect()),
            };
            let s = bricks(dims, data);
            let bd = s.brick_dims();
            for bz in 0..bd[2] {
                for by in 0..bd[1] {
                    for bx in 0..bd[0] {
                        let b = IVec3::new(bx, by, bz);
                        let got = s.brick_range(b).unwrap();
                        for r in 0..3 {
                            let (mut mn, mut mx) = (f32::INFINITY, f32::NEG_INFINITY);
                            let lo = b * 8 - r;
                            let hi = b * 8 + 7 + r;
                            for z in lo.z..=hi.z {
                                for y in lo.y..=hi.y {
                                    for x in lo.x..=hi.x {
                                        if let Some(v) = s.value(IVec3::new(x, y, z)) {
                                            mn = mn.min(v);
                                            mx = mx.max(v);
                                        }
                                    }
                                }
                            }
                            assert_eq!(
                                (got.min[r as usize], got.max[r as usize]),
                                (mn, mx),
                                "{dims:?} type {ty} brick {b} r {r}"
                            );
                        }
                    }
                }
            }
        }
    }

    /// Trilinear samples equal the dense formula at every corner
    /// configuration, across brick faces and at the volume's border.
    #[test]
    fn trilinear_across_bricks_equals_dense() {
        let dims = [19usize, 10, 17];
        let n: usize = dims.iter().product();
        let dense: Vec<f32> = (0..n).map(|i| ((i * 31 + 7) % 113) as f32 * 0.5).collect();
        let b = bricks(dims, VolumeData::F32(dense.clone()));
        let at = |v: IVec3| {
            let c = v.clamp(IVec3::ZERO, IVec3::from_array(dims.map(|d| d as i32)) - 1);
            dense[c.x as usize + dims[0] * (c.y as usize + dims[1] * c.z as usize)]
        };
        for z in 0..dims[2] as i32 {
            for y in 0..dims[1] as i32 {
                for x in 0..dims[0] as i32 {
                    let v = IVec3::new(x, y, z);
                    for (dx, dy, dz) in [(0.3, -0.2, 0.45), (-0.5, 0.5, -0.1), (0.0, 0.0, 0.0)] {
                        let p = [x as f64 + dx, y as f64 + dy, z as f64 + dz];
                        let got = b.trilinear(v, b.index(v), p);
                        // The clamped trilinear formula on the dense array.
                        let f = p.map(|c| c.floor() as i32);
                        let w = [0, 1, 2].map(|k| (p[k] - f[k] as f64) as f32);
                        let c = IVec3::from_array(f);
                        let g = |o: IVec3| at(c + o);
                        let x00 = lerp(g(IVec3::new(0, 0, 0)), g(IVec3::new(1, 0, 0)), w[0]);
                        let x10 = lerp(g(IVec3::new(0, 1, 0)), g(IVec3::new(1, 1, 0)), w[0]);
                        let x01 = lerp(g(IVec3::new(0, 0, 1)), g(IVec3::new(1, 0, 1)), w[0]);
                        let x11 = lerp(g(IVec3::new(0, 1, 1)), g(IVec3::new(1, 1, 1)), w[0]);
                        let want = lerp(lerp(x00, x10, w[1]), lerp(x01, x11, w[1]), w[2]);
                        assert!(
                            (got - want).abs() <= 1e-4 * want.abs().max(1.0),
                            "{v} {p:?}: {got} {want}"
                        );
                    }
                }
            }
        }
    }

    /// The bricks take no more than the limit allows, checked first.
    #[test]
    fn the_limit_is_checked_first() {
        let vol = ScalarVolume::new(
            [9, 9, 9],
            VolumeData::U8(vec![1; 729]),
            VolumeFrame::default(),
        )
        .unwrap();
        let need = 8 * 512 + 8 * std::mem::size_of::<BrickRange>();
        assert!(matches!(
            VolumeBricks::from_volume(vol.clone(), MemoryLimit::new(need as u64 - 1)),
            Err(VoxkitError::Limits { .. })
        ));
        assert_eq!(
            VolumeBricks::from_volume(vol, MemoryLimit::new(need as u64))
                .unwrap()
                .heap_bytes(),
            need
        );
    }
}
