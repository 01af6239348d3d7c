//! Scalar volumes in the discrete ray caster: maximum intensity projection,
//! front-to-back compositing through a transfer function, and iso-surfaces
//! ([`render_volume`]).
//!
//! Every pixel casts one discrete ray over the *same* fixed-point segment
//! for every [`RayKind`] (the camera ray clipped strictly inside the volume
//! box, exactly as [`super::render_grid`] does), so images differ only by
//! which voxels the kinds visit. A visited voxel contributes its *sample*:
//! the voxel's value ([`Sampling::Nearest`]) or the trilinear value at the
//! midpoint of the ray's stretch in the voxel ([`Sampling::Trilinear`]).
//!
//! # The ray's stretch in a voxel
//! Positions along a ray are world distances `t` from its origin (the eye,
//! or the eye plane for orthographic cameras); `[t0, t1]` is the ray's way
//! through the volume (the hull of the voxel cubes, from `t = 0` on). The
//! stretch of a visited voxel is
//! - for the 6-ray, the adaptive ray and Amanatides–Woo: the chord of the
//!   continuous ray through the voxel's cube (entry to exit, clipped to
//!   `[t0, t1]`). For the 6-ray the chords of the visited voxels tile
//!   `[t0, t1]`;
//! - for the 26-ray, which visits one voxel per column along the major axis
//!   `m`: the ray's stretch through the voxel's *column* (the slab
//!   `|g_m − v_m| ≤ ½`, clipped to `[t0, t1]`), so the visited voxels again
//!   tile the ray; where the 26-line holds two voxels of one column (in its
//!   short prefix or suffix) the second one gets an empty stretch.
//!
//! The trilinear sample point is the stretch's midpoint clamped to the
//! voxel's cube, so a sample lies between the minimum and the maximum of
//! the voxel's 3×3×3 neighbourhood (the bricks' aprons below rely on it).
//!
//! # Modes
//! - [`VolumeMode::Mip`]: the largest sample along the ray. The pixel is
//!   the grey level of that maximum through the window,
//!   `g = clamp((s − lo) / (hi − lo), 0, 1)`, alpha 1 wherever the ray
//!   crosses the volume. `hit` is the first visited voxel holding the
//!   maximum if it exceeds the window's low end (`None` otherwise: nothing
//!   on the ray is visible), `depth` the distance at which the ray enters
//!   that voxel's cube. With the 6-ray this is exactly the maximum over the
//!   voxels the ray passes through.
//! - [`VolumeMode::Composite`]: front-to-back alpha compositing. A visited
//!   voxel with sample `s` and stretch length `ℓ` (world units) has opacity
//!   `α = 1 − (1 − τ(s))^(ℓ / ℓ_ref)`, where `τ` is the transfer function's
//!   opacity, defined as the opacity of a stretch of the *reference length*
//!   `ℓ_ref = ∛|det A|` (`A` the volume's axes: the edge of a cube with the
//!   voxel's volume, i.e. the spacing for cubic voxels), and colour the
//!   transfer function's (or, without colours, the window's grey of `s`).
//!   `C += (1 − A)·α·colour`, `A += (1 − A)·α`, stopping once `A ≥ 0.99`.
//!   The pixel is `(C / A, A)`; `hit`/`depth` are the first voxel with
//!   `α > 0`.
//! - [`VolumeMode::Iso`]`(V)`: the first visited voxel whose sample is
//!   `≥ V`, shaded like [`super::render_grid`]'s hits (Lambert from a
//!   headlight plus ambient): face normals are the entry face's, smooth
//!   normals the negated value gradient by central differences at the voxel
//!   (one-sided at the volume's border).
//!
//! NaN samples are stored as `−∞`: they never hold a maximum, never reach
//! an iso value, and take the transfer function's opacity at its lowest
//! point; a trilinear sample with a positive weight on one is `−∞` too.
//!
//! # Skipping and adaptive flags
//! [`VolumeScene`] keeps per 8³ brick the minimum and maximum of the values
//! over the brick and over the brick grown by one and two voxels (its
//! *aprons*). Per frame each brick is classified, with `r = 0` for nearest
//! and `r = 1` for trilinear samples (whose range in a brick is that of the
//! brick grown by one voxel):
//! - *skippable*: no sample in it can change the pixel — MIP: max over
//!   `r` ≤ window low; iso: max over `r` `< V`; composite: the transfer
//!   function's opacity is 0 on `[min, max]` over `r`;
//! - *flagged* (the adaptive ray's proximity flags, constant per brick): the
//!   same test over `r + 1` fails. Flagged bricks hold the one-voxel
//!   dilation of every voxel whose sample can matter, so the adaptive ray
//!   (26-steps only from unflagged voxels) visits every voxel that matters
//!   on the 6-ray's path, in order, with the same sample: its MIP, iso hit
//!   and composite equal the 6-ray's.
//!
//! A Chebyshev distance transform over the bricks (Cohen & Sheffer's
//! proximity clouds) lets a ray jump, in O(1) (the line core's `jump`,
//! [`AwStepper::jump_past_box`](crate::line::amanatides_woo::AwStepper::jump_past_box)),
//! the whole box of skippable bricks around
//! its brick; the adaptive ray in 26 mode jumps only boxes of unflagged
//! bricks (where stepping would stay in 26 mode). MIP also jumps, from a
//! brick whose maximum does not exceed the running maximum, the largest
//! aligned block of `2^l` bricks per side (`l ≤ 4`) around it that does not
//! either (a max pyramid over the bricks, built per frame). Skipped voxels
//! contribute nothing and every voxel's contribution depends only on the
//! voxel and the ray, so skipping changes no pixel, for every ray kind.
//!
//! # Walking
//! Rays are walked by the one driver of `render::walk`: a ray steps through
//! a brick first, recording voxels and storage indices (moved by per-move
//! offsets, no 3D→1D per voxel), and this module's visitor then reads them
//! as a run: the reads depend neither on each other nor on the stepping.
//! The adaptive ray reads its flags per brick (a brick is flagged when its
//! range with the wider apron can matter); the lean steppers visit the
//! same voxels as the line engine's core (tested); pixels run in bands of
//! rows, column by column, for cache reuse between neighbouring rays.

use std::time::Instant;

use glam::{DVec3, IVec3};
use rayon::prelude::*;

use crate::camera::{Camera, SceneAxes};
use crate::error::{Result, VoxkitError};
use crate::grid::{AnatomicalSpace, MemoryLimit, ScalarVolume};
use crate::line::Segment;
use crate::line::segment::Frame;

use super::bricks::{BRICK, BrickRange, VolumeBricks};
use super::occupancy::chessboard_distance;
use super::opacity::{corrected_opacity_from_log, ln_one_minus};
use super::tiles::TileMask;
use super::walk::{BUF, CastCounters, Run, Visitor, walk_aw, walk_exact};
use super::{
    GridRay, GridTransform, NormalMode, RayKind, RaySetup, RenderImage, RenderOptions, RenderStats,
    camera_check, check_image,
};

/// Compositing stops once the accumulated opacity reaches this.
pub const EARLY_TERMINATION: f32 = 0.99;

/// Opacity at the window's high end of [`TransferFunction::ramp`] (the
/// opacity of one reference length of the brightest material).
pub const RAMP_OPACITY: f32 = 0.1;

/// A scalar volume prepared for [`render_volume`]: its samples in 8³
/// bricks in their own type with per-brick value ranges and aprons
/// ([`VolumeBricks`]), and its placement in the world.
#[derive(Clone, Debug)]
pub struct VolumeScene {
    bricks: VolumeBricks,
    xf: GridTransform,
    /// `∛|det axes|`: the reference length of the opacity correction.
    ref_len: f64,
    /// The world's anatomical meaning, if the file gave one.
    space: Option<AnatomicalSpace>,
}

impl VolumeScene {
    /// Prepares a copy of `volume` (see [`VolumeScene::from_volume`], which
    /// takes the volume and needs no copy); `limit` caps the copy and the
    /// render structures together, checked before allocating.
    ///
    /// ```
    /// use glam::{DVec3, IVec3};
    /// use voxkit::grid::{MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
    /// use voxkit::render::VolumeScene;
    /// let data: Vec<f32> = (0..1000).map(|i| i as f32).collect();
    /// let vol = ScalarVolume::new([10, 10, 10], VolumeData::F32(data), VolumeFrame::default()).unwrap();
    /// let scene = VolumeScene::new(&vol, MemoryLimit::DEFAULT).unwrap();
    /// assert_eq!(scene.value(IVec3::new(1, 2, 3)), Some(321.0));
    /// // Brick (1, 0, 0) holds x = 8..9, y, z = 0..7: values 8 ..= 779.
    /// let r = scene.brick_range(IVec3::new(1, 0, 0)).unwrap();
    /// assert_eq!((r.min[0], r.max[0]), (8.0, 779.0));
    /// // With a one-voxel apron: x = 7..9, y, z = 0..8.
    /// assert_eq!((r.min[1], r.max[1]), (7.0, 889.0));
    /// ```
    pub fn new(volume: &ScalarVolume, limit: MemoryLimit) -> Result<Self> {
        let copy = volume.len() as u128 * volume.source_type().bytes() as u128;
        limit.check(
            "copy of the volume for rendering",
            copy + VolumeBricks::bytes_needed(volume.dims, volume.source_type()),
            1,
        )?;
        Self::from_volume(volume.clone(), limit)
    }

    /// Prepares `volume` for rendering, rearranging its samples into bricks
    /// in place (no second copy of the volume; see [`VolumeBricks`]);
    /// `limit` caps the render structures, checked before anything grows.
    pub fn from_volume(volume: ScalarVolume, limit: MemoryLimit) -> Result<Self> {
        Ok(Self::with_percentiles(volume, limit, &[])?.0)
    }

    /// [`VolumeScene::from_volume`], and the default window
    /// ([`VolumeOptions::default_window`]) found in the same pass over the
    /// samples ([`VolumeBricks::with_percentiles`]): one read of the volume
    /// less than asking for both.
    pub fn with_default_window(
        volume: ScalarVolume,
        limit: MemoryLimit,
    ) -> Result<(Self, (f32, f32))> {
        let (scene, p) = Self::with_percentiles(volume, limit, &DEFAULT_WINDOW_PERCENTILES)?;
        Ok((scene, window_of_percentiles(p[0], p[1])))
    }

    fn with_percentiles(
        volume: ScalarVolume,
        limit: MemoryLimit,
        ps: &[f64],
    ) -> Result<(Self, Vec<f64>)> {
        let xf = GridTransform::new(volume.frame.origin, volume.frame.axes)?;
        let ref_len = volume.frame.axes.determinant().abs().cbrt();
        let space = volume.space;
        let (bricks, p) = VolumeBricks::with_percentiles(volume, limit, ps)?;
        let scene = VolumeScene {
            bricks,
            xf,
            ref_len,
            space,
        };
        Ok((scene, p))
    }

    /// The axes the default views refer to: Z up, the front where the
    /// volume's anatomical space has the patient's front
    /// ([`SceneAxes::for_volume`]).
    pub fn scene_axes(&self) -> SceneAxes {
        SceneAxes::for_volume(self.space)
    }

    /// Extents in voxels.
    pub fn dims(&self) -> [usize; 3] {
        self.bricks.dims().map(|d| d as usize)
    }

    /// The samples in bricks, with their value ranges.
    pub fn bricks(&self) -> &VolumeBricks {
        &self.bricks
    }

    /// What preparing the volume changed in its values, one line each, for
    /// a user to see (`voxkit render` prints them and lists them in
    /// `--json` `warnings`; the Python `render` issues them as
    /// `UserWarning`s): today, the `float64` samples beyond `f32`'s range
    /// that render as `±∞` ([`VolumeBricks::narrowed_to_infinity`]).
    ///
    /// ```
    /// use voxkit::grid::{MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
    /// use voxkit::render::VolumeScene;
    /// let data = VolumeData::F64(vec![0.5, -1e300, 2.0, 1e39]);
    /// let vol = ScalarVolume::new([4, 1, 1], data, VolumeFrame::default()).unwrap();
    /// let scene = VolumeScene::from_volume(vol, MemoryLimit::DEFAULT).unwrap();
    /// assert!(scene.warnings()[0].starts_with("2 float64 samples lie beyond float32's range"));
    /// ```
    pub fn warnings(&self) -> Vec<String> {
        let beyond = self.bricks.narrowed_to_infinity();
        (beyond > 0)
            .then(|| {
                format!(
                    "{beyond} float64 samples lie beyond float32's range (±3.4e38) and render as ±infinity"
                )
            })
            .into_iter()
            .collect()
    }

    /// The value of voxel `v` as the renderer reads it (`f32`, NaN as
    /// `−∞`), `None` outside the volume.
    pub fn value(&self, v: IVec3) -> Option<f32> {
        self.bricks.value(v)
    }

    /// Where the volume sits in the world.
    pub fn transform(&self) -> &GridTransform {
        &self.xf
    }

    /// The reference length of the opacity correction in world units:
    /// `∛|det axes|` (see the [module docs](self)).
    pub fn reference_length(&self) -> f64 {
        self.ref_len
    }

    /// The value ranges of brick `b` (brick coordinates: voxel `>> 3`),
    /// `None` outside the volume.
    pub fn brick_range(&self, b: IVec3) -> Option<BrickRange> {
        self.bricks.brick_range(b)
    }

    /// Bytes held: the bricks and their value ranges.
    pub fn heap_bytes(&self) -> usize {
        self.bricks.heap_bytes()
    }

    #[inline(always)]
    fn brick_index(&self, b: IVec3) -> usize {
        self.bricks.brick_index(b)
    }

    #[inline(always)]
    fn index(&self, v: IVec3) -> usize {
        self.bricks.index(v)
    }
}

/// What a volume render shows (`--volume`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VolumeMode {
    /// Maximum intensity projection.
    Mip,
    /// Front-to-back compositing through the transfer function.
    Composite,
    /// The iso-surface at this value: the first sample `≥` it, shaded.
    Iso(f32),
}

/// How a visited voxel is sampled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Sampling {
    /// The voxel's value.
    Nearest,
    /// Trilinear from the 8 voxel centres around the midpoint of the ray's
    /// stretch in the voxel (clamped at the volume's border).
    Trilinear,
}

/// How a volume frame is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum VolumeMethod {
    /// One discrete ray per pixel of the frame's [`RayKind`]: exact (the
    /// [module docs](self) define every pixel).
    #[default]
    #[value(help = "One exact discrete ray per pixel, of the --ray kind")]
    Rays,
    /// Shear-warp (object order, see [`super::shear_warp`]): every slice
    /// resampled once onto an intermediate image, then warped to the
    /// frame. Faster, not exact: its error against the 6-ray is measured.
    /// MIP and compositing; iso-surfaces and perspective eyes inside the
    /// volume's box cast rays.
    #[value(
        help = "Shear-warp (object order): every slice resampled once onto an intermediate image, then warped to the frame. Faster, not exact (--measure gives its difference from the 6-ray image). MIP and compositing; iso-surfaces and perspective eyes inside the volume's box cast rays"
    )]
    ShearWarp,
}

/// One point of a [`TransferFunction`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfPoint {
    /// Sample value.
    pub value: f32,
    /// Opacity of one reference length at this value, in `[0, 1]`.
    pub opacity: f32,
    /// Linear RGB in `[0, 1]`, if given.
    pub color: Option<[f32; 3]>,
}

/// A piecewise linear map from sample values to opacity (and optionally
/// colour), constant beyond its first and last points. Colours interpolate
/// between the points that have one; without any, compositing uses the
/// window's grey.
///
/// ```
/// use voxkit::render::TransferFunction;
/// let tf = TransferFunction::parse("0:0, 100:0.5:#ff0000, 200:1:#0000ff").unwrap();
/// assert_eq!(tf.opacity(50.0), 0.25);
/// assert_eq!(tf.opacity(-7.0), 0.0);
/// assert_eq!(tf.opacity(1e9), 1.0);
/// assert_eq!(tf.color(150.0), Some([0.5, 0.0, 0.5]));
/// assert_eq!(tf.max_opacity(-5.0, 20.0), 0.1);
/// assert!(TransferFunction::parse("5:0.1,1:0.2").is_err()); // not sorted
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    points: Vec<TfPoint>,
    /// The points that have a colour: `(value, rgb)`.
    colored: Vec<(f32, [f32; 3])>,
}

impl TransferFunction {
    /// A transfer function from points sorted by value (equal values make a
    /// step); `Invalid` if there are none, a value is not finite, an
    /// opacity or colour component is outside `[0, 1]`, or the values
    /// decrease.
    pub fn new(points: Vec<TfPoint>) -> Result<Self> {
        if points.is_empty() {
            return Err(VoxkitError::invalid("transfer function: no points"));
        }
        for (i, p) in points.iter().enumerate() {
            let unit = |x: f32| (0.0..=1.0).contains(&x);
            if !p.value.is_finite()
                || !unit(p.opacity)
                || p.color.is_some_and(|c| !c.iter().all(|&x| unit(x)))
            {
                return Err(VoxkitError::invalid(format!(
                    "transfer function point {i}: value must be finite, opacity and colour in [0, 1] (got {p:?})"
                )));
            }
            if i > 0 && p.value < points[i - 1].value {
                return Err(VoxkitError::invalid(format!(
                    "transfer function: values must not decrease ({} after {})",
                    p.value,
                    points[i - 1].value
                )));
            }
        }
        let colored = points
            .iter()
            .filter_map(|p| p.color.map(|c| (p.value, c)))
            .collect();
        Ok(TransferFunction { points, colored })
    }

    /// Parses `v:o[:#rrggbb],...` (value, opacity, optional hex colour per
    /// point; whitespace around items is ignored).
    pub fn parse(s: &str) -> Result<Self> {
        let bad = |item: &str, why: &str| {
            VoxkitError::invalid(format!(
                "transfer function item '{item}': {why} (expected value:opacity[:#rrggbb])"
            ))
        };
        let mut points = Vec::new();
        for item in s.split(',') {
            let item = item.trim();
            let parts: Vec<&str> = item.split(':').map(str::trim).collect();
            if !(2..=3).contains(&parts.len()) {
                return Err(bad(item, "wrong number of fields"));
            }
            let value: f32 = parts[0].parse().map_err(|_| bad(item, "bad value"))?;
            let opacity: f32 = parts[1].parse().map_err(|_| bad(item, "bad opacity"))?;
            let color = match parts.get(2) {
                None => None,
                Some(c) => {
                    let hex = c
                        .strip_prefix('#')
                        .filter(|h| h.len() == 6 && h.chars().all(|ch| ch.is_ascii_hexdigit()))
                        .ok_or_else(|| bad(item, "colour must be #rrggbb"))?;
                    let byte = |i: usize| {
                        u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap() as f32 / 255.0
                    };
                    Some([byte(0), byte(1), byte(2)])
                }
            };
            points.push(TfPoint {
                value,
                opacity,
                color,
            });
        }
        Self::new(points)
    }

    /// The default: opacity rising linearly from 0 at `window.0` to
    /// [`RAMP_OPACITY`] at `window.1`, no colours (grey through the window).
    pub fn ramp(window: (f32, f32)) -> Self {
        let p = |value, opacity| TfPoint {
            value,
            opacity,
            color: None,
        };
        TransferFunction {
            points: vec![p(window.0, 0.0), p(window.1.max(window.0), RAMP_OPACITY)],
            colored: Vec::new(),
        }
    }

    /// The points.
    pub fn points(&self) -> &[TfPoint] {
        &self.points
    }

    /// Opacity at sample `s` (the first point's below it, the last's above;
    /// `−∞` takes the first point's).
    #[inline]
    pub fn opacity(&self, s: f32) -> f32 {
        let p = &self.points;
        let j = p.partition_point(|q| q.value <= s);
        if j == 0 {
            return p[0].opacity;
        }
        if j == p.len() {
            return p[j - 1].opacity;
        }
        let (a, b) = (&p[j - 1], &p[j]);
        let t = (s - a.value) / (b.value - a.value);
        a.opacity + t * (b.opacity - a.opacity)
    }

    /// [`TransferFunction::opacity`] at eight samples, bit for bit, by
    /// selects over the segments (its loops vectorise): `j`, the number
    /// of points at or below the sample, picks the end value or the
    /// segment `(p[j−1], p[j])`, whose interpolation is the same
    /// arithmetic as `opacity`'s.
    #[inline(always)]
    fn opacity_lanes(&self, s: &[f32; 8], out: &mut [f32; 8]) {
        let p = &self.points;
        let mut j = [0u32; 8];
        for q in p {
            for k in 0..8 {
                j[k] += u32::from(q.value <= s[k]);
            }
        }
        let (first, last) = (p[0].opacity, p[p.len() - 1].opacity);
        for k in 0..8 {
            out[k] = if j[k] == 0 { first } else { last };
        }
        for (i, w) in p.windows(2).enumerate() {
            let (a, b) = (&w[0], &w[1]);
            let seg = i as u32 + 1;
            for k in 0..8 {
                let t = (s[k] - a.value) / (b.value - a.value);
                let v = a.opacity + t * (b.opacity - a.opacity);
                out[k] = if j[k] == seg { v } else { out[k] };
            }
        }
    }

    /// Colour at sample `s`, interpolated between the points that have one;
    /// `None` if none has.
    #[inline]
    pub fn color(&self, s: f32) -> Option<[f32; 3]> {
        let c = &self.colored;
        if c.is_empty() {
            return None;
        }
        let j = c.partition_point(|q| q.0 <= s);
        if j == 0 {
            return Some(c[0].1);
        }
        if j == c.len() {
            return Some(c[j - 1].1);
        }
        let ((va, ca), (vb, cb)) = (c[j - 1], c[j]);
        let t = (s - va) / (vb - va);
        Some(std::array::from_fn(|k| ca[k] + t * (cb[k] - ca[k])))
    }

    /// The largest opacity over the samples in `[lo, hi]` (`lo ≤ hi`): at
    /// the ends or at a point between them.
    pub fn max_opacity(&self, lo: f32, hi: f32) -> f32 {
        self.points
            .iter()
            .filter(|p| p.value > lo && p.value < hi)
            .map(|p| p.opacity)
            .fold(self.opacity(lo).max(self.opacity(hi)), f32::max)
    }
}

/// Options of [`render_volume`] (the rest is in [`RenderOptions`]).
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeOptions {
    /// What to show.
    pub mode: VolumeMode,
    /// Values mapped to black and white (MIP grey, compositing's grey
    /// colours), `lo < hi`; MIP shows nothing at or below `lo`.
    pub window: (f32, f32),
    /// Opacity and colour for compositing (iso takes its colour, if it has
    /// one, at the iso value).
    pub transfer: TransferFunction,
    /// How visited voxels are sampled.
    pub sampling: Sampling,
    /// Rays or shear-warp.
    pub method: VolumeMethod,
}

impl VolumeOptions {
    /// `mode` with the default window ([`VolumeOptions::default_window`]),
    /// the default ramp over it ([`TransferFunction::ramp`]) and nearest
    /// sampling.
    pub fn new(volume: &ScalarVolume, mode: VolumeMode) -> Self {
        Self::with_window(mode, Self::default_window(volume))
    }

    /// `mode` with `window`, the default ramp over it and nearest
    /// sampling: [`VolumeOptions::new`] without reading the samples.
    pub fn with_window(mode: VolumeMode, window: (f32, f32)) -> Self {
        VolumeOptions {
            mode,
            window,
            transfer: TransferFunction::ramp(window),
            sampling: Sampling::Nearest,
            method: VolumeMethod::Rays,
        }
    }

    /// The 1% and 99.5% percentiles of the finite samples; if they are
    /// equal in `f32` (`v`), `(v − d, v + d)` with `d = max(½, 4ε|v|)`
    /// (at least four units in the last place of `v`, so that the window
    /// is not empty where `v ± ½` rounds back to `v`: a uniform `u32` mask
    /// of `2³² − 1`), kept finite at `±f32::MAX`; without finite samples
    /// `(0, 1)`.
    ///
    /// ```
    /// use voxkit::grid::{ScalarVolume, VolumeData, VolumeFrame};
    /// use voxkit::render::VolumeOptions;
    /// let data: Vec<u16> = (0..=1000).collect();
    /// let vol = ScalarVolume::new([1001, 1, 1], VolumeData::U16(data), VolumeFrame::default()).unwrap();
    /// assert_eq!(VolumeOptions::default_window(&vol), (10.0, 995.0));
    /// ```
    pub fn default_window(volume: &ScalarVolume) -> (f32, f32) {
        let p = volume.percentiles(&DEFAULT_WINDOW_PERCENTILES);
        window_of_percentiles(p[0], p[1])
    }

    /// The iso value `--volume iso` takes by default: the middle of the
    /// window, `(lo + hi) / 2` rounded once, and finite for every finite
    /// window (the halves are summed, so ends near `±f32::MAX` do not
    /// overflow).
    ///
    /// ```
    /// use voxkit::render::{VolumeMode, VolumeOptions};
    /// let o = VolumeOptions::with_window(VolumeMode::Mip, (f32::MAX / 2.0, f32::MAX));
    /// assert_eq!(o.middle_of_window(), 0.75 * f32::MAX);
    /// ```
    pub fn middle_of_window(&self) -> f32 {
        let (lo, hi) = self.window;
        lo * 0.5 + hi * 0.5
    }

    fn validate(&self) -> Result<()> {
        let (lo, hi) = self.window;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(VoxkitError::invalid(format!(
                "volume window {lo},{hi}: need finite low < high"
            )));
        }
        if let VolumeMode::Iso(v) = self.mode
            && !v.is_finite()
        {
            return Err(VoxkitError::invalid(format!("iso value {v} is not finite")));
        }
        Ok(())
    }
}

/// The percentiles the default window spans.
const DEFAULT_WINDOW_PERCENTILES: [f64; 2] = [1.0, 99.5];

/// The default window from its percentiles (see
/// [`VolumeOptions::default_window`]).
fn window_of_percentiles(lo: f64, hi: f64) -> (f32, f32) {
    let (lo, hi) = (lo as f32, hi as f32);
    if !(lo.is_finite() && hi.is_finite()) {
        (0.0, 1.0)
    } else if lo < hi {
        (lo, hi)
    } else {
        // Half a unit, or at least four ulps where half a unit would
        // round away (`lo ± ½ == lo` from 2²³ on).
        let d = (lo.abs() * (4.0 * f32::EPSILON)).max(0.5);
        let (below, above) = (lo - d, lo + d);
        (
            if below.is_finite() { below } else { lo },
            if above.is_finite() { above } else { lo },
        )
    }
}

/// Pixels whose colour (RGBA, bit for bit) differs between two images of
/// the same size: e.g. the MIP pixels of a ray kind that differ from the
/// 6-ray's.
pub fn differing_values(a: &RenderImage, b: &RenderImage) -> u64 {
    a.color
        .iter()
        .zip(&b.color)
        .filter(|(x, y)| x.map(f32::to_bits) != y.map(f32::to_bits))
        .count() as u64
}

/// Per brick, per frame: proximity-cloud distances (in bricks) to the
/// nearest brick that is not skippable (`skip`) and to the nearest flagged
/// brick (`flag`; 0: this brick is flagged), and the brick's largest sample
/// as the frame samples (`max`, which the MIP's running maximum is held
/// against: in the cache line the ray reads on entering the brick, not one
/// more of the ranges'). Without skipping both distances are only 0 or 1.
#[derive(Clone, Copy, Debug, Default)]
struct BrickClass {
    skip: u8,
    flag: u8,
    max: f32,
}

/// Everything a frame's rays share.
struct FrameCtx<'a> {
    scene: &'a VolumeScene,
    vopts: &'a VolumeOptions,
    opts: &'a RenderOptions,
    setup: RaySetup,
    class: Vec<BrickClass>,
    dims: [i32; 3],
    /// MIP with skipping: per level `l ≥ 1`, the blocks' extents (in
    /// blocks) and the largest sample over each block of `2^l` bricks per
    /// side.
    pyramid: Vec<([i32; 3], Vec<f32>)>,
    /// With skipping, the tiles whose rays may meet a brick that is not
    /// skippable (the others' pixels are known without a walk).
    tiles: TileMask,
    /// Compositing nearest samples of a volume of 8- or 16-bit integers:
    /// the per-value table.
    table: Option<ValueTable>,
}

impl<'a> FrameCtx<'a> {
    fn new(
        scene: &'a VolumeScene,
        camera: &Camera,
        opts: &'a RenderOptions,
        vopts: &'a VolumeOptions,
    ) -> Self {
        let dims = scene.dims().map(|d| d as i32);
        let setup = RaySetup::new(
            camera,
            &scene.xf,
            Some((IVec3::ZERO, IVec3::from_array(dims) - 1)),
            opts.width,
            opts.height,
        );
        let r = usize::from(vopts.sampling == Sampling::Trilinear);
        // Whether no sample over the bricks' range `r` can matter.
        let quiet = |b: &BrickRange, r: usize| -> bool {
            match vopts.mode {
                VolumeMode::Mip => b.max[r] <= vopts.window.0,
                VolumeMode::Iso(v) => b.max[r] < v,
                VolumeMode::Composite => vopts.transfer.max_opacity(b.min[r], b.max[r]) == 0.0,
            }
        };
        let bricks = scene.bricks.ranges();
        let class: Vec<BrickClass> = if opts.skip {
            let skip = chessboard_distance(scene.bricks.brick_dims(), |i| !quiet(&bricks[i], r));
            let flag = if opts.ray == RayKind::Adaptive {
                chessboard_distance(scene.bricks.brick_dims(), |i| !quiet(&bricks[i], r + 1))
            } else {
                vec![0; bricks.len()]
            };
            skip.into_iter()
                .zip(flag)
                .zip(bricks)
                .map(|((skip, flag), b)| BrickClass {
                    skip,
                    flag,
                    max: b.max[r],
                })
                .collect()
        } else {
            bricks
                .par_iter()
                .map(|b| BrickClass {
                    skip: 0,
                    flag: u8::from(quiet(b, r + 1)),
                    max: b.max[r],
                })
                .collect()
        };
        let pyramid = if opts.skip && vopts.mode == VolumeMode::Mip {
            max_pyramid(
                scene.bricks.brick_dims(),
                bricks.iter().map(|b| b.max[r]).collect(),
            )
        } else {
            Vec::new()
        };
        let tiles = if opts.skip {
            TileMask::new(&setup, scene.bricks.brick_dims(), |i| class[i].skip == 0)
        } else {
            TileMask::all()
        };
        let table = (vopts.mode == VolumeMode::Composite && vopts.sampling == Sampling::Nearest)
            .then(|| scene.bricks.small_integer_range())
            .flatten()
            .map(|range| ValueTable::new(&vopts.transfer, vopts.window, range));
        FrameCtx {
            scene,
            vopts,
            opts,
            setup,
            class,
            dims,
            pyramid,
            tiles,
            table,
        }
    }
}

/// Levels `1..=`[`PYRAMID_LEVELS`] of a max pyramid over per-brick maxima
/// (`bdims` bricks): each level's extents and maxima over blocks of `2^l`
/// bricks per side.
fn max_pyramid(bdims: [i32; 3], mut below: Vec<f32>) -> Vec<([i32; 3], Vec<f32>)> {
    let mut out = Vec::new();
    let mut d = bdims;
    while out.len() < PYRAMID_LEVELS && d.iter().any(|&x| x > 1) {
        let up = d.map(|x| (x + 1) / 2);
        let mut level = vec![f32::NEG_INFINITY; (up[0] * up[1] * up[2]) as usize];
        for z in 0..d[2] {
            for y in 0..d[1] {
                for x in 0..d[0] {
                    let i = (x / 2 + up[0] * (y / 2 + up[1] * (z / 2))) as usize;
                    level[i] = level[i].max(below[(x + d[0] * (y + d[1] * z)) as usize]);
                }
            }
        }
        out.push((up, level.clone()));
        below = level;
        d = up;
    }
    out
}

/// Levels of the MIP max pyramid: blocks of up to 16 bricks (128 voxels,
/// the longest O(1) jump) per side.
const PYRAMID_LEVELS: usize = 4;

/// A pixel ray's continuous geometry, for stretches and sample points.
#[derive(Clone, Copy)]
struct RayGeom {
    o: [f64; 3],
    d: [f64; 3],
    /// `1 / d` (0 where `d` is 0: those axes do not bound a stretch).
    inv: [f64; 3],
    t0: f64,
    t1: f64,
}

impl RayGeom {
    /// The geometry of `ray`, clipped to the volume's box of `dims` voxels
    /// (the cubes' hull, not the walks' inset box: the 6-ray's chords tile
    /// the ray's whole way through the volume).
    fn new(ray: &GridRay, dims: [i32; 3]) -> Self {
        let hi = IVec3::from_array(dims).as_dvec3() - 0.5;
        let (t0, t1) = ray.clip(DVec3::splat(-0.5), hi).unwrap_or((0.0, 0.0));
        let d = ray.d.to_array();
        RayGeom {
            o: ray.o.to_array(),
            d,
            // 0 also where `1 / x` overflows: such an axis bounds no
            // stretch either, and every slab bound stays finite (no NaN
            // reaches `lt_min`/`gt_max`).
            inv: d.map(|x| {
                let i = 1.0 / x;
                if x == 0.0 || !i.is_finite() { 0.0 } else { i }
            }),
            t0,
            t1,
        }
    }

    /// The `t` interval where coordinate `k` lies in `[c − ½, c + ½]`
    /// (everything if the ray is parallel to that slab).
    #[inline(always)]
    fn slab(&self, k: usize, c: i32) -> (f64, f64) {
        if self.inv[k] == 0.0 {
            return (f64::NEG_INFINITY, f64::INFINITY);
        }
        let a = (c as f64 - 0.5 - self.o[k]) * self.inv[k];
        let b = (c as f64 + 0.5 - self.o[k]) * self.inv[k];
        if self.inv[k] > 0.0 { (a, b) } else { (b, a) }
    }

    /// The chord through voxel `v`'s cube, clipped to `[t0, t1]` (possibly
    /// empty: `t_in > t_out`).
    #[inline(always)]
    fn chord(&self, v: IVec3) -> (f64, f64) {
        let (mut a, mut b) = (self.t0, self.t1);
        for k in 0..3 {
            let (p, q) = self.slab(k, v[k]);
            a = gt_max(a, p);
            b = lt_min(b, q);
        }
        (a, b)
    }

    /// The stretch through the slab of column `c` of axis `k`, clipped.
    #[inline(always)]
    fn column(&self, k: usize, c: i32) -> (f64, f64) {
        let (p, q) = self.slab(k, c);
        (gt_max(self.t0, p), lt_min(self.t1, q))
    }

    /// The stretch's midpoint, clamped to voxel `v`'s cube.
    #[inline(always)]
    fn sample_point(&self, v: IVec3, (a, b): (f64, f64)) -> [f64; 3] {
        let t = 0.5 * (a + b);
        std::array::from_fn(|k| {
            let c = v[k] as f64;
            (self.o[k] + self.d[k] * t).clamp(c - 0.5, c + 0.5)
        })
    }
}

/// The larger of two numbers that are not NaN, as `f64::max` gives it up
/// to the sign of a zero (which no stretch length or sample point keeps):
/// one comparison, where `f64::max` also handles NaN (a blend per call on
/// the baseline target, 12 a composite visit).
#[inline(always)]
fn gt_max(a: f64, b: f64) -> f64 {
    if b > a { b } else { a }
}

/// The smaller of two numbers that are not NaN (see [`gt_max`]).
#[inline(always)]
fn lt_min(a: f64, b: f64) -> f64 {
    if b < a { b } else { a }
}

/// What a mode does with the visited voxels of one ray.
trait Accum {
    /// Whether `visit` needs the stretch length.
    const LEN: bool;
    /// Whether a ray usually reads on through a brick it enters (MIP,
    /// compositing), so the brick's cache lines are worth asking for at
    /// once (`VolumeBricks::prefetch`); an iso ray stops at its first
    /// crossing.
    const READS_ON: bool = true;
    /// Takes a visited voxel's sample and stretch length (world units);
    /// `true` ends the ray.
    fn visit(&mut self, v: IVec3, s: f32, len: f64) -> bool;
    /// [`Accum::visit`] of a sample without a stretch, its voxel found by
    /// `v` only where the accumulator keeps it.
    #[inline(always)]
    fn visit_nearest(&mut self, v: impl FnOnce() -> IVec3, s: f32) -> bool {
        self.visit(v(), s, 0.0)
    }
    /// Visits a run of voxels in order (`buf`'s world voxels, their
    /// samples and stretch lengths, zeros past `buf.len()`); `Some(i)` when
    /// voxel `i` ends the ray. Accumulators whose per-voxel arithmetic
    /// vectorises over the run (compositing) override it.
    #[inline(always)]
    fn visit_run(
        &mut self,
        buf: &[(IVec3, usize)],
        s: &[f32; BUF],
        len: &[f64; BUF],
    ) -> Option<usize> {
        (0..buf.len().min(BUF)).find(|&i| self.visit(buf[i].0, s[i], len[i]))
    }
    /// Takes a run's samples (`n` of them; zeros past `n`) before their
    /// stretch lengths are computed; `false` when no voxel of the run can
    /// change the result, and the run is then not visited (compositing:
    /// every opacity is 0, which no stretch length makes visible).
    #[inline(always)]
    fn prepare(&mut self, _s: &[f32; BUF], _n: usize) -> bool {
        true
    }
    /// A value such that boxes whose samples all lie at or below it can be
    /// jumped now, beyond the frame's static classification (MIP: the
    /// running maximum).
    #[inline(always)]
    fn threshold(&self) -> Option<f32> {
        None
    }
}

/// MIP: the running maximum (starting at the window's low end) and the
/// first voxel holding it.
struct Mip {
    m: f32,
    hit: Option<IVec3>,
}

impl Accum for Mip {
    const LEN: bool = false;
    #[inline(always)]
    fn visit(&mut self, v: IVec3, s: f32, _len: f64) -> bool {
        self.visit_nearest(|| v, s)
    }
    #[inline(always)]
    fn visit_nearest(&mut self, v: impl FnOnce() -> IVec3, s: f32) -> bool {
        if s > self.m {
            self.m = s;
            self.hit = Some(v());
        }
        false
    }
    #[inline(always)]
    fn threshold(&self) -> Option<f32> {
        Some(self.m)
    }
}

/// Iso: the first voxel with a sample `≥ v`.
struct Iso {
    v: f32,
    hit: Option<IVec3>,
}

impl Accum for Iso {
    const READS_ON: bool = false;
    const LEN: bool = false;
    #[inline(always)]
    fn visit(&mut self, v: IVec3, s: f32, _len: f64) -> bool {
        self.visit_nearest(|| v, s)
    }
    #[inline(always)]
    fn visit_nearest(&mut self, v: impl FnOnce() -> IVec3, s: f32) -> bool {
        if s >= self.v {
            self.hit = Some(v());
            return true;
        }
        false
    }
}

/// Compositing's per-sample work on a volume of 8- or 16-bit integers,
/// done once per value of its range rather than per visited voxel: the
/// transfer function's opacity `τ`, `ln(1 − τ)` and (for a coloured
/// function) the colour, each the same arithmetic on the same `f32` value
/// as the per-voxel path, so bit for bit what it gives.
struct ValueTable {
    lo: i32,
    /// `(τ, ln(1 − τ))` of value `lo + i`.
    opacity: Vec<[f32; 2]>,
    /// Colour of value `lo + i`; empty where the transfer function has no
    /// colours, whose grey level ([`grey`]) is computed per sample instead:
    /// the same operations on the same value, and one table (up to
    /// 768 KiB for an int16 range) fewer for the cache.
    color: Vec<[f32; 3]>,
}

impl ValueTable {
    /// The table over the values `lo..=hi` (at most 65,536 of them).
    fn new(tf: &TransferFunction, window: (f32, f32), (lo, hi): (i32, i32)) -> Self {
        let values = || (lo..=hi).map(|v| v as f32);
        ValueTable {
            lo,
            opacity: values()
                .map(|s| {
                    let tau = tf.opacity(s);
                    [tau, ln_one_minus(tau)]
                })
                .collect(),
            color: if tf.colored.is_empty() {
                Vec::new()
            } else {
                values().map(|s| sample_color(tf, window, s)).collect()
            },
        }
    }

    /// The entry of sample `s` (a value of the range; padding lanes may
    /// hold others, clamped: their entries are not used).
    #[inline(always)]
    fn index(&self, s: f32) -> usize {
        ((s as i32).saturating_sub(self.lo).max(0) as usize).min(self.opacity.len() - 1)
    }
}

/// The colour compositing gives sample `s`: the transfer function's, or
/// the window's grey level where its points carry none.
#[inline(always)]
pub(super) fn sample_color(tf: &TransferFunction, window: (f32, f32), s: f32) -> [f32; 3] {
    tf.color(s).unwrap_or_else(|| [grey(s, window); 3])
}

/// Compositing: premultiplied colour, opacity, first contributing voxel.
struct Composite<'a> {
    tf: &'a TransferFunction,
    window: (f32, f32),
    table: Option<&'a ValueTable>,
    inv_ref: f64,
    c: [f32; 3],
    a: f32,
    hit: Option<IVec3>,
    /// The transfer function's opacities of the run being visited (from
    /// [`Accum::prepare`]) and their `ln(1 − τ)` (from the table, or
    /// computed where the run is not all transparent).
    tau: [f32; BUF],
    ln_tau: [f32; BUF],
}

impl<'a> Composite<'a> {
    fn new(
        tf: &'a TransferFunction,
        window: (f32, f32),
        table: Option<&'a ValueTable>,
        ref_len: f64,
    ) -> Self {
        Composite {
            tf,
            window,
            table,
            inv_ref: 1.0 / ref_len,
            c: [0.0; 3],
            a: 0.0,
            hit: None,
            tau: [0.0; BUF],
            ln_tau: [0.0; BUF],
        }
    }
}

impl Accum for Composite<'_> {
    const LEN: bool = true;
    #[inline(always)]
    fn visit(&mut self, v: IVec3, s: f32, len: f64) -> bool {
        let (mut run_s, mut run_len) = ([0.0; BUF], [0.0; BUF]);
        (run_s[0], run_len[0]) = (s, len);
        self.prepare(&run_s, 1) && self.visit_run(&[(v, 0)], &run_s, &run_len).is_some()
    }

    /// The run's opacities, in lanes of 8 (whole lanes: a loop with a
    /// remainder would take short runs, the common case, through scalar
    /// code; the padding's values are computed and not used). A run of
    /// transparent voxels (`τ = 0` gives `α = 0` exactly, whatever the
    /// stretch) adds nothing.
    #[inline(always)]
    fn prepare(&mut self, s: &[f32; BUF], n: usize) -> bool {
        let lanes = n.min(BUF).div_ceil(8) * 8;
        let mut any = false;
        if let Some(table) = self.table {
            for ((t, l), &s) in self.tau[..lanes]
                .iter_mut()
                .zip(&mut self.ln_tau[..lanes])
                .zip(&s[..lanes])
            {
                [*t, *l] = table.opacity[table.index(s)];
                any |= *t > 0.0;
            }
            return any;
        }
        for (t, s) in self.tau[..lanes]
            .chunks_exact_mut(8)
            .zip(s[..lanes].chunks_exact(8))
        {
            let t: &mut [f32; 8] = t.try_into().unwrap();
            self.tf.opacity_lanes(s.try_into().unwrap(), t);
            any |= t.iter().fold(false, |a, &x| a | (x > 0.0));
        }
        if any {
            // What the table holds per value, here per voxel (only for
            // runs that are not all transparent).
            for (l, t) in self.ln_tau[..lanes]
                .chunks_exact_mut(8)
                .zip(self.tau[..lanes].chunks_exact(8))
            {
                for k in 0..8 {
                    l[k] = ln_one_minus(t[k]);
                }
            }
        }
        any
    }

    /// The corrected opacities first (in lanes of 8 across the run's
    /// voxels, from [`Accum::prepare`]'s), then front-to-back accumulation
    /// in order.
    #[inline(always)]
    fn visit_run(
        &mut self,
        buf: &[(IVec3, usize)],
        s: &[f32; BUF],
        len: &[f64; BUF],
    ) -> Option<usize> {
        let n = buf.len().min(BUF);
        let lanes = n.div_ceil(8) * 8;
        let tau = &self.tau;
        let mut y = [0f32; BUF];
        for (y, &l) in y[..lanes].iter_mut().zip(&len[..lanes]) {
            *y = (l * self.inv_ref) as f32;
        }
        let mut alpha = [0f32; BUF];
        for (((a, t), l), y) in alpha[..lanes]
            .chunks_exact_mut(8)
            .zip(tau[..lanes].chunks_exact(8))
            .zip(self.ln_tau[..lanes].chunks_exact(8))
            .zip(y[..lanes].chunks_exact(8))
        {
            for k in 0..8 {
                a[k] = corrected_opacity_from_log(t[k], l[k], y[k]);
            }
        }
        for i in 0..n {
            // τ = 0 gives α = 0 exactly.
            let alpha = alpha[i];
            if alpha <= 0.0 {
                continue;
            }
            if self.hit.is_none() {
                self.hit = Some(buf[i].0);
            }
            let col = match self.table {
                Some(table) if table.color.is_empty() => [grey(s[i], self.window); 3],
                Some(table) => table.color[table.index(s[i])],
                None => sample_color(self.tf, self.window, s[i]),
            };
            let w = (1.0 - self.a) * alpha;
            for (ck, k) in self.c.iter_mut().zip(col) {
                *ck += w * k;
            }
            self.a += w;
            if self.a >= EARLY_TERMINATION {
                return Some(i);
            }
        }
        None
    }
}

/// The window's grey level of `s`.
#[inline]
pub(super) fn grey(s: f32, (lo, hi): (f32, f32)) -> f32 {
    ((s - lo) / (hi - lo)).clamp(0.0, 1.0)
}

/// Reads the voxels `buf` (world voxel, storage index) that a ray stepped
/// through, in order, into `acc`; `Some(i)` when voxel `i` ends the ray.
/// Stretches are chords, or with `column = (major axis, previous column)`
/// (the 26-ray) the ray's stretch through each voxel's column.
#[inline(always)]
fn consume<A: Accum, const TRI: bool>(
    ctx: &FrameCtx,
    g: &RayGeom,
    buf: &[(IVec3, usize)],
    mut column: Option<(usize, &mut i32)>,
    acc: &mut A,
) -> Option<usize> {
    let bricks = &ctx.scene.bricks;
    let mut samples = [0f32; BUF];
    let mut lens = [0f64; BUF];
    if !TRI {
        bricks.gather(buf, &mut samples[..buf.len()]);
        if !acc.prepare(&samples, buf.len()) {
            // No stretch is needed; the 26-ray's column bookkeeping
            // still moves to the run's last voxel.
            if let (Some((major, prev)), Some(&(v, _))) = (column, buf.last()) {
                *prev = v[major];
            }
            return None;
        }
    }
    if TRI || A::LEN {
        for (i, &(v, idx)) in buf.iter().enumerate() {
            let st = if let Some((major, prev)) = column.as_mut()
                && g.inv[*major] != 0.0
            {
                let c = v[*major];
                let (a, z) = g.column(*major, c);
                let repeated = c == **prev;
                **prev = c;
                if repeated { (a, a) } else { (a, z) }
            } else {
                g.chord(v)
            };
            if TRI {
                samples[i] = bricks.trilinear(v, idx, g.sample_point(v, st));
            }
            lens[i] = gt_max(st.1 - st.0, 0.0);
        }
    }
    if TRI && !acc.prepare(&samples, buf.len()) {
        return None;
    }
    acc.visit_run(buf, &samples, &lens)
}

/// The box of world voxels (inclusive) a ray in brick `b` may jump, if
/// any: the bricks within `k − 1` of it (`k`: the brick's proximity-cloud
/// value), or, where `dynamic` and the accumulator has a threshold (MIP)
/// that the brick's samples (at most `max`) do not exceed, the largest
/// aligned block of `2^l` bricks per side around it whose samples do not
/// exceed it either (the frame's max pyramid).
#[inline(always)]
fn skip_box<A: Accum>(
    ctx: &FrameCtx,
    acc: &A,
    b: IVec3,
    max: f32,
    k: u8,
    dynamic: bool,
) -> Option<(IVec3, IVec3)> {
    let cloud = |k: u8| {
        let r = i32::from(k) - 1;
        ((b - r) * BRICK, (b + r + 1) * BRICK - 1)
    };
    if k >= 2 {
        return Some(cloud(k));
    }
    if dynamic
        && let Some(m) = acc.threshold()
        && max <= m
    {
        let mut l = 0;
        while let Some((dims, maxima)) = ctx.pyramid.get(l) {
            let p = b >> (l as i32 + 1);
            if maxima[(p.x + dims[0] * (p.y + dims[1] * p.z)) as usize] > m {
                break;
            }
            l += 1;
        }
        let base = (b >> l as i32) << l as i32;
        return Some((base * BRICK, (base + (1 << l)) * BRICK - 1));
    }
    (k == 1).then(|| cloud(1))
}

/// The volume visitor of the [`walk`](super::walk) driver: per brick its
/// class (static skip and flag distances) and storage base, jump boxes from
/// [`skip_box`] (a 26 stretch of the adaptive ray only over flag-free
/// bricks, and without the MIP's dynamic threshold, which a 6 stretch
/// takes), per run the samples into the accumulator.
struct VolumeVisit<'c, 'a, A: Accum, const TRI: bool> {
    ctx: &'c FrameCtx<'a>,
    g: &'c RayGeom,
    acc: &'c mut A,
    /// The 26-ray's major axis and previous column (a repeated column gets
    /// no stretch); `None` for the other kinds.
    column: Option<(usize, i32)>,
}

impl<A: Accum, const TRI: bool> Visitor for VolumeVisit<'_, '_, A, TRI> {
    /// Brick index and class.
    type Brick = (usize, BrickClass);

    #[inline(always)]
    fn enter(&mut self, b: IVec3) -> Self::Brick {
        let bi = self.ctx.scene.brick_index(b);
        (bi, self.ctx.class[bi])
    }

    #[inline(always)]
    fn base(&self, (bi, _): Self::Brick) -> usize {
        bi << 9
    }

    #[inline(always)]
    fn jump_box(
        &mut self,
        (_, class): Self::Brick,
        b: IVec3,
        _: IVec3,
        in26: bool,
    ) -> Option<(IVec3, IVec3)> {
        if !self.ctx.opts.skip {
            return None;
        }
        let k = if in26 { class.flag } else { class.skip };
        skip_box(self.ctx, self.acc, b, class.max, k, !in26)
    }

    /// Every brick not jumped is read; where rays read on through it,
    /// its cache lines are asked for at once: a MIP frame ~7% faster
    /// (docs/performance-notes.md), an iso frame slower.
    #[inline(always)]
    fn reads(&self, (bi, _): Self::Brick) -> bool {
        if A::READS_ON {
            self.ctx.scene.bricks.prefetch(bi);
        }
        true
    }

    #[inline(always)]
    fn flagged(&self, (_, class): Self::Brick, _: usize) -> bool {
        class.flag == 0
    }

    #[inline(always)]
    fn recheck_on_mode_change(&self, _: Self::Brick) -> bool {
        self.ctx.opts.skip
    }

    /// Nearest samples without stretches (MIP, iso) are taken voxel by
    /// voxel: a run would store each voxel and read it back for nothing.
    const PER_VOXEL: bool = !TRI && !A::LEN;

    #[inline(always)]
    fn voxel(&mut self, _: Self::Brick, i: usize, v: impl FnOnce() -> IVec3) -> bool {
        self.acc.visit_nearest(v, self.ctx.scene.bricks.value_at(i))
    }

    #[inline(always)]
    fn all_flagged(&self, (_, class): Self::Brick) -> bool {
        class.flag == 0
    }

    #[inline(always)]
    fn run(&mut self, _: Self::Brick, run: &Run) -> Option<usize> {
        let column = self.column.as_mut().map(|(major, prev)| (*major, prev));
        consume::<A, TRI>(self.ctx, self.g, run, column, self.acc)
    }

    #[inline(always)]
    fn jumped(&mut self) {
        if let Some((_, prev)) = &mut self.column {
            *prev = i32::MIN;
        }
    }
}

/// Casts one ray of the frame's kind into `acc`.
#[inline]
fn cast<A: Accum, const TRI: bool>(
    ctx: &FrameCtx,
    g: &RayGeom,
    seg: &Segment,
    acc: &mut A,
    n: &mut CastCounters,
) {
    let kind = ctx.opts.ray;
    let column = (kind == RayKind::TwentySix).then(|| (Frame::new(seg).perm[0], i32::MIN));
    let mut vis = VolumeVisit::<A, TRI> {
        ctx,
        g,
        acc,
        column,
    };
    match kind {
        RayKind::AmanatidesWoo => walk_aw(seg, &mut vis, n),
        _ => walk_exact(seg, kind, &mut vis, n),
    }
}

/// One pixel: colour, depth, hit.
type Pixel = ([f32; 4], f32, Option<IVec3>);

const MISS: Pixel = ([0.0; 4], f32::INFINITY, None);

/// A lower bound on the MIP of the ray over `seg` (whose continuous
/// geometry is `g`) that some voxel it visits attains, from the voxels
/// where neighbouring pixels found their maxima (`hints`); `−∞` if none
/// applies.
///
/// For each hint `h` the segment's point `p` nearest to `h` lies in the
/// cube of `u = round(p)`. If `p` is inside that cube by a margin (so no
/// tie between cubes is near), the segment passes through `u`'s open cube,
/// and the 6-ray visits `u` (its voxels' closed cubes cover the segment,
/// and only `u`'s contains points of its open cube); so does
/// Amanatides–Woo. `u`'s sample (its value, or the trilinear sample at its
/// chord's midpoint, exactly as the walk reads it) is then at most the
/// ray's maximum. The adaptive ray's maximum is the 6-ray's, so the bound
/// holds for it too; the 26-ray visits one voxel per column, not `u`
/// necessarily, and gets no bound.
fn mip_hint_floor<const TRI: bool>(
    ctx: &FrameCtx,
    g: &RayGeom,
    seg: &Segment,
    hints: &[Option<IVec3>],
) -> f32 {
    /// Distance a point must keep from its voxel cube's faces: far above
    /// the f64 error of the projection (grid coordinates stay below 2^30,
    /// where f64 rounds by ~1e-7), far below a voxel.
    const MARGIN: f64 = 1e-3;
    if ctx.opts.ray == RayKind::TwentySix {
        return f32::NEG_INFINITY;
    }
    let [a, b] = [seg.a(), seg.b()].map(|p| DVec3::from_array(p.map(crate::fixed::to_f64)));
    let d = b - a;
    let dd = d.length_squared();
    let mut best = f32::NEG_INFINITY;
    for h in hints.iter().flatten() {
        let t = if dd > 0.0 {
            ((h.as_dvec3() - a).dot(d) / dd).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let p = a + d * t;
        let u = p.round();
        if (p - u).abs().max_element() > 0.5 - MARGIN {
            continue;
        }
        let u = u.as_ivec3();
        if !ctx.scene.bricks.contains(u) {
            continue;
        }
        let s = if TRI {
            ctx.scene
                .bricks
                .trilinear(u, ctx.scene.index(u), g.sample_point(u, g.chord(u)))
        } else {
            ctx.scene.bricks.value_at(ctx.scene.index(u))
        };
        best = best.max(s);
    }
    best
}

/// Renders one pixel of the frame; `hints` are voxels where neighbouring
/// pixels found their MIP maxima (they only speed the MIP up).
fn render_pixel<const TRI: bool>(
    ctx: &FrameCtx,
    x: u32,
    y: u32,
    hints: &[Option<IVec3>],
    n: &mut CastCounters,
) -> Pixel {
    let vo = ctx.vopts;
    // A culled tile's rays meet only skippable bricks: nothing to hit or
    // accumulate, so they end as a walk would leave them (a MIP ray inside
    // the volume still shows the window's low end, which its running
    // maximum starts at).
    let seen = ctx.tiles.may_see(x, y);
    n.culled += u64::from(!seen);
    if !seen && vo.mode != VolumeMode::Mip {
        return MISS;
    }
    let (ray, seg) = ctx.setup.pixel(x, y);
    let Some(seg) = seg else { return MISS };
    if !seen {
        let gl = grey(vo.window.0, vo.window);
        return ([gl, gl, gl, 1.0], f32::INFINITY, None);
    }
    let g = RayGeom::new(&ray, ctx.dims);
    let depth = |v: IVec3| ray.entry(v).0 as f32;
    match vo.mode {
        VolumeMode::Mip => {
            // Start the running maximum just below a sample the ray is
            // known to reach: bricks that cannot reach it are skipped from
            // the start, and the first voxel holding the maximum still
            // raises the running maximum, so the pixel, its hit and its
            // depth are those of the walk from the window's low end.
            let floor = if ctx.opts.skip {
                mip_hint_floor::<TRI>(ctx, &g, &seg, hints)
            } else {
                f32::NEG_INFINITY
            };
            let mut acc = Mip {
                m: if floor > vo.window.0 {
                    floor.next_down().max(vo.window.0)
                } else {
                    vo.window.0
                },
                hit: None,
            };
            cast::<_, TRI>(ctx, &g, &seg, &mut acc, n);
            let gl = grey(acc.m, vo.window);
            let d = acc.hit.map_or(f32::INFINITY, depth);
            ([gl, gl, gl, 1.0], d, acc.hit)
        }
        VolumeMode::Iso(iso) => {
            let mut acc = Iso { v: iso, hit: None };
            cast::<_, TRI>(ctx, &g, &seg, &mut acc, n);
            match acc.hit {
                Some(v) => (shade_iso(ctx, &ray, v, iso), depth(v), Some(v)),
                None => MISS,
            }
        }
        VolumeMode::Composite => {
            let mut acc = Composite::new(
                &vo.transfer,
                vo.window,
                ctx.table.as_ref(),
                ctx.scene.ref_len,
            );
            cast::<_, TRI>(ctx, &g, &seg, &mut acc, n);
            match acc.hit {
                Some(v) if acc.a > 0.0 => {
                    let [r, gr, b] = acc.c.map(|c| (c / acc.a).clamp(0.0, 1.0));
                    ([r, gr, b, acc.a.min(1.0)], depth(v), Some(v))
                }
                _ => MISS,
            }
        }
    }
}

/// Lambert from a headlight plus ambient at iso hit `v`.
fn shade_iso(ctx: &FrameCtx, ray: &GridRay, v: IVec3, iso: f32) -> [f32; 4] {
    let (_, axis) = ray.entry(v);
    let face = match axis {
        Some(k) => {
            let mut n = DVec3::ZERO;
            n[k] = -ray.d[k].signum();
            n
        }
        None => -ray.d,
    };
    let n_grid = match ctx.opts.normals {
        NormalMode::Face => face,
        NormalMode::Smooth => {
            let grad = value_gradient(ctx.scene, v);
            if grad.is_finite() && grad.length_squared() > 0.0 {
                -grad
            } else {
                face
            }
        }
    };
    let setup = &ctx.setup;
    let n = setup.world_normal(n_grid);
    let view = (setup.xf.axes * ray.d).normalize_or_zero();
    let lambert = n.dot(-view).abs() as f32;
    let base = ctx.vopts.transfer.color(iso).unwrap_or(ctx.opts.base_color);
    let a = ctx.opts.ambient.clamp(0.0, 1.0);
    let l = a + (1.0 - a) * lambert;
    [base[0] * l, base[1] * l, base[2] * l, 1.0]
}

/// Central differences of the values at voxel `v` (grid units; one-sided
/// at the border, 0 along an axis of extent 1).
fn value_gradient(scene: &VolumeScene, v: IVec3) -> DVec3 {
    let dims = scene.dims().map(|d| d as i32);
    let at = |p: IVec3| scene.bricks.value_at(scene.index(p)) as f64;
    let mut g = DVec3::ZERO;
    for k in 0..3 {
        let (mut lo, mut hi) = (v, v);
        lo[k] = (v[k] - 1).max(0);
        hi[k] = (v[k] + 1).min(dims[k] - 1);
        let span = hi[k] - lo[k];
        if span > 0 {
            g[k] = (at(hi) - at(lo)) / span as f64;
        }
    }
    g
}

/// Rows per band: a band's pixels run column by column, so consecutive rays
/// are vertical neighbours and a ray's horizontal neighbour was cast
/// `BAND` rays before, while the voxels they share are still in cache (a
/// ray through a large volume touches a cache line per voxel; row by row,
/// the row above is a thousand rays back). Measured on a 1024² MIP of a
/// 512³ volume (6-ray, no skipping): rows 1630 ms, bands of 4 rows 1350,
/// 8: 1150, 16: 1130–1220, 32: 1140–1155, 64: 1190.
const BAND: u32 = 16;

/// Renders a scalar volume: one discrete ray per pixel of `opts.ray`'s kind
/// (`opts.skip`: jump bricks that cannot change the pixel, which changes no
/// pixel), in `vopts.mode` (see the [module docs](self) for exactly what
/// each mode computes). Bands of rows run in parallel.
///
/// ```
/// use glam::{DVec3, IVec3};
/// use voxkit::camera::Camera;
/// use voxkit::grid::{MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
/// use voxkit::render::{
///     differing_values, render_volume, RayKind, RenderOptions, VolumeMode, VolumeOptions, VolumeScene,
/// };
/// // A 16³ volume, 0 everywhere but a bright voxel at (8, 8, 8).
/// let mut data = vec![0.0f32; 16 * 16 * 16];
/// data[8 + 16 * (8 + 16 * 8)] = 100.0;
/// let vol = ScalarVolume::new([16; 3], VolumeData::F32(data), VolumeFrame::default()).unwrap();
/// let scene = VolumeScene::new(&vol, MemoryLimit::DEFAULT).unwrap();
/// // Orthographic, down the z axis: pixel (x, y) looks along column (x, 15 − y).
/// let cam = Camera::orthographic(DVec3::new(7.5, 7.5, 40.0), DVec3::new(7.5, 7.5, 0.0), DVec3::Y, 16.0);
/// let opts = RenderOptions { width: 16, height: 16, ray: RayKind::Six, ..RenderOptions::default() };
/// let vopts = VolumeOptions { window: (0.0, 100.0), ..VolumeOptions::new(&vol, VolumeMode::Mip) };
/// let (img, stats) = render_volume(&scene, &cam, &opts, &vopts).unwrap();
/// let p = 8 + 16 * 7;
/// assert_eq!(img.color[p], [1.0, 1.0, 1.0, 1.0]);
/// assert_eq!(img.hit[p], Some(IVec3::new(8, 8, 8)));
/// assert_eq!(img.depth[p], 40.0 - 8.5); // entering the voxel's cube
/// assert_eq!(stats.hits, 1);
/// // The adaptive ray's MIP is the 6-ray's.
/// let ad = RenderOptions { ray: RayKind::Adaptive, ..opts };
/// assert_eq!(differing_values(&render_volume(&scene, &cam, &ad, &vopts).unwrap().0, &img), 0);
/// ```
pub fn render_volume(
    scene: &VolumeScene,
    camera: &Camera,
    opts: &RenderOptions,
    vopts: &VolumeOptions,
) -> Result<(RenderImage, RenderStats)> {
    camera_check(camera)?;
    let (w, h) = (opts.width, opts.height);
    check_image(w, h, opts.limit)?;
    vopts.validate()?;
    if vopts.method == VolumeMethod::ShearWarp
        && let Some(frame) = super::shear_warp::render(scene, camera, opts, vopts)?
    {
        return Ok(frame);
    }
    let start = Instant::now();
    let ctx = FrameCtx::new(scene, camera, opts, vopts);
    let tri = vopts.sampling == Sampling::Trilinear;
    // The image's buffers, written band by band in place (collecting bands
    // and then concatenating them held the image twice: 36 MiB more at
    // 1024², 14% of an int16 512³ volume).
    let n = (w as usize) * (h as usize);
    let mut img = RenderImage::blank(w, h, 0.0);
    let counts: Vec<(CastCounters, u64)> = img
        .par_bands(BAND as usize)
        .map(|(band, (color, depth, hit))| {
            let (y0, y1) = (band as u32 * BAND, (band as u32 * BAND + BAND).min(h));
            let mut counters = CastCounters::default();
            let mut hits = 0u64;
            // The hits of the pixel above and of the one to the left (the
            // previous column of the band): the MIP's hints.
            let mut left = [None; BAND as usize];
            for x in 0..w {
                let mut above = None;
                for y in y0..y1 {
                    let hints = [above, left[(y - y0) as usize]];
                    let (c, d, v) = if tri {
                        render_pixel::<true>(&ctx, x, y, &hints, &mut counters)
                    } else {
                        render_pixel::<false>(&ctx, x, y, &hints, &mut counters)
                    };
                    above = v;
                    left[(y - y0) as usize] = v;
                    let i = ((y - y0) * w + x) as usize;
                    color[i] = c;
                    depth[i] = d;
                    hit[i] = v;
                    hits += u64::from(v.is_some());
                }
            }
            (counters, hits)
        })
        .collect();
    let mut stats = RenderStats {
        rays: n as u64,
        ..RenderStats::default()
    };
    for (cn, hits) in counts {
        stats.voxels_visited += cn.visited;
        stats.bricks_skipped += cn.jumps;
        stats.rays_culled += cn.culled;
        stats.hits += hits;
    }
    stats.render_ms = start.elapsed().as_secs_f64() * 1e3;
    Ok((img, stats))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{VolumeData, VolumeFrame};

    /// A uniform volume's window holds its value strictly inside, finite,
    /// at every magnitude (a `u32` mask of `2³² − 1` and `±f32::MAX`
    /// included), and is `v ± ½` where that is exact; the default iso
    /// value is finite and inside it.
    #[test]
    fn uniform_windows_are_proper_at_every_magnitude() {
        let mut values = vec![0.0, -0.0, 7.0, -3.25, 1e6, 1048575.0, f64::from(u32::MAX)];
        values.extend([i32::MIN, i32::MAX].map(f64::from));
        values.extend([f32::MAX, -f32::MAX, f32::MIN_POSITIVE, 1e-42, 3e38].map(f64::from));
        values.extend((0..60).map(|e| 1.7f64.powi(e)));
        values.extend((0..60).map(|e| -(2f64.powi(e) + 1.0)));
        for v in values {
            let (lo, hi) = window_of_percentiles(v, v);
            let x = v as f32;
            assert!(lo.is_finite() && hi.is_finite(), "{v}: {lo}, {hi}");
            assert!(lo < hi && lo <= x && x <= hi, "{v}: {lo}, {hi}");
            assert!(lo < x || hi > x, "{v}");
            if x.abs() < 1048576.0 {
                assert_eq!((lo, hi), (x - 0.5, x + 0.5), "{v}");
            }
            let o = VolumeOptions::with_window(VolumeMode::Mip, (lo, hi));
            let m = o.middle_of_window();
            assert!(m.is_finite() && lo <= m && m <= hi, "{v}: {m}");
        }
        let wide = VolumeOptions::with_window(VolumeMode::Mip, (-f32::MAX, f32::MAX));
        assert_eq!(wide.middle_of_window(), 0.0);
        let o = VolumeOptions::with_window(VolumeMode::Mip, (0.2, 0.9));
        assert_eq!(o.middle_of_window(), (0.2f32 + 0.9) * 0.5);
    }

    /// Each pyramid level holds the maxima over its blocks of bricks.
    #[test]
    fn max_pyramid_matches_brute_force() {
        let bdims = [7, 3, 5];
        let n = 7 * 3 * 5;
        let maxima: Vec<f32> = (0..n).map(|i| ((i * 37) % 101) as f32).collect();
        let pyr = max_pyramid(bdims, maxima.clone());
        assert_eq!(pyr.len(), 3); // 4×2×3, 2×1×2, 1×1×1 blocks
        for (l, (dims, level)) in pyr.iter().enumerate() {
            let s = 1 << (l + 1);
            for (i, &got) in level.iter().enumerate() {
                let i = i as i32;
                let p = IVec3::new(
                    i % dims[0],
                    (i / dims[0]) % dims[1],
                    i / (dims[0] * dims[1]),
                );
                let want = (0..n)
                    .filter(|&j| {
                        let j = j as i32;
                        let b = IVec3::new(j % 7, (j / 7) % 3, j / 21);
                        b / s == p
                    })
                    .map(|j| maxima[j])
                    .fold(f32::NEG_INFINITY, f32::max);
                assert_eq!(got, want, "level {} block {p}", l + 1);
            }
        }
    }

    /// Trilinear reproduces a linear function inside the volume, clamps at
    /// the border, and ignores `−∞` corners of weight 0.
    #[test]
    fn trilinear_is_exact_on_linear_functions() {
        let dims = [5usize, 4, 3];
        let f = |x: f64, y: f64, z: f64| (1.5 * x - 2.0 * y + 0.25 * z + 3.0) as f32;
        let mut data = Vec::new();
        for z in 0..3 {
            for y in 0..4 {
                for x in 0..5 {
                    data.push(f(x as f64, y as f64, z as f64));
                }
            }
        }
        let vol = ScalarVolume::new(dims, VolumeData::F32(data), VolumeFrame::default()).unwrap();
        let scene = VolumeScene::new(&vol, MemoryLimit::DEFAULT).unwrap();
        for (v, p) in [
            (IVec3::new(2, 1, 1), [2.3, 0.6, 1.5]),
            (IVec3::new(0, 0, 0), [0.2, 0.4, -0.1]),
            (IVec3::new(4, 3, 2), [3.6, 3.2, 2.4]),
        ] {
            let got = scene.bricks.trilinear(v, scene.index(v), p);
            let clamped = p.map(|x| x.max(0.0));
            let c = [
                clamped[0].min(4.0),
                clamped[1].min(3.0),
                clamped[2].min(2.0),
            ];
            assert!((got - f(c[0], c[1], c[2])).abs() < 1e-5, "{v} {p:?}: {got}");
        }
        assert_eq!(
            super::super::bricks::lerp(f32::NEG_INFINITY, 2.0, 0.0),
            f32::NEG_INFINITY
        );
        assert_eq!(super::super::bricks::lerp(3.0, f32::NEG_INFINITY, 0.0), 3.0);
        assert_eq!(
            super::super::bricks::lerp(3.0, f32::NEG_INFINITY, 0.5),
            f32::NEG_INFINITY
        );
        assert_eq!(
            super::super::bricks::lerp(f32::INFINITY, f32::NEG_INFINITY, 0.5),
            f32::NEG_INFINITY
        );
    }

    /// Records the visited voxels and the samples read there.
    struct Record(Vec<(IVec3, f32)>);

    impl Accum for Record {
        const LEN: bool = false;
        fn visit(&mut self, v: IVec3, s: f32, _len: f64) -> bool {
            self.0.push((v, s));
            false
        }
    }

    /// Chords and column stretches with plain comparisons equal those of
    /// `f64::min`/`max` (up to the sign of a zero), and are never NaN, on
    /// rays whose direction has zero, subnormal (`1/d` overflows), tiny and
    /// ordinary components, starting on and off voxel faces.
    #[test]
    fn chords_equal_the_nan_aware_reference() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        let dims = [9, 7, 8];
        for _ in 0..20_000 {
            let o = DVec3::from_array(std::array::from_fn(|k| {
                let x = rng.random_range(-0.5..dims[k] as f64 - 0.5);
                if rng.random_bool(0.2) {
                    x.round() + 0.5
                } else {
                    x
                }
            }));
            let d = DVec3::from_array(std::array::from_fn(|_| {
                let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                sign * match rng.random_range(0..5) {
                    0 => 0.0,
                    1 => 1e-310,
                    2 => 1e-200,
                    _ => rng.random_range(0.01..1.0),
                }
            }));
            let g = RayGeom::new(&GridRay { o, d }, dims);
            // The reference: `1/d` where it is finite, parallel elsewhere,
            // bounds ordered and clipped by `f64::min`/`max`.
            let slab = |k: usize, c: i32| {
                let inv = 1.0 / d[k];
                if d[k] == 0.0 || !inv.is_finite() {
                    return (f64::NEG_INFINITY, f64::INFINITY);
                }
                let a = (c as f64 - 0.5 - o[k]) * inv;
                let b = (c as f64 + 0.5 - o[k]) * inv;
                (a.min(b), a.max(b))
            };
            let v = IVec3::from_array(std::array::from_fn(|k| rng.random_range(0..dims[k])));
            let (mut a, mut b) = (g.t0, g.t1);
            for k in 0..3 {
                let (p, q) = slab(k, v[k]);
                (a, b) = (a.max(p), b.min(q));
            }
            let got = g.chord(v);
            assert!(!got.0.is_nan() && !got.1.is_nan(), "{o} {d} {v}");
            assert_eq!(got, (a, b), "chord of {v}, ray {o} + t {d}");
            assert_eq!(gt_max(got.1 - got.0, 0.0), (b - a).max(0.0));
            for k in 0..3 {
                let (p, q) = slab(k, v[k]);
                assert_eq!(g.column(k, v[k]), (g.t0.max(p), g.t1.min(q)));
            }
        }
    }

    /// A random segment inside a volume of `dims` (a fifth of its
    /// coordinates on voxel centres, so it runs along faces and edges), and
    /// its continuous ray's geometry.
    fn random_segment(
        rng: &mut rand_chacha::ChaCha8Rng,
        dims: [usize; 3],
    ) -> ([f64; 3], [f64; 3], Segment, RayGeom) {
        use rand::Rng;
        let mut p = || -> [f64; 3] {
            std::array::from_fn(|k| {
                let x = rng.random_range(-0.49..dims[k] as f64 - 0.51);
                if rng.random_bool(0.2) { x.round() } else { x }
            })
        };
        let (a, b) = (p(), p());
        let seg = Segment::from_f64(a, b).unwrap();
        let ray = GridRay {
            o: DVec3::from_array(a),
            d: (DVec3::from_array(b) - DVec3::from_array(a)).normalize_or(DVec3::X),
        };
        (a, b, seg, RayGeom::new(&ray, dims.map(|d| d as i32)))
    }

    /// The lean steppers of the walk driver visit exactly the voxels of the
    /// line engine's core, in order, for the 6-ray, the 26-ray and the
    /// adaptive ray (brick flags per brick: runs of flagged and unflagged
    /// voxels), on volumes with flagged and unflagged bricks and random
    /// segments inside them.
    #[test]
    fn lean_walks_equal_the_core() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let mut mixed = 0;
        for _ in 0..12 {
            let dims = [
                rng.random_range(1..50),
                rng.random_range(1..50),
                rng.random_range(1..50),
            ];
            let n = dims.iter().product::<usize>();
            let hot: Vec<usize> = (0..3).map(|_| rng.random_range(0..n)).collect();
            let data: Vec<f32> = (0..n)
                .map(|i| if hot.contains(&i) { 10.0 } else { 0.0 })
                .collect();
            let vol =
                ScalarVolume::new(dims, VolumeData::F32(data), VolumeFrame::default()).unwrap();
            let scene = VolumeScene::new(&vol, MemoryLimit::DEFAULT).unwrap();
            let cam = Camera::orthographic(DVec3::new(0.0, 0.0, 99.0), DVec3::ZERO, DVec3::Y, 4.0);
            let opts = RenderOptions {
                ray: RayKind::Adaptive,
                skip: false,
                ..RenderOptions::default()
            };
            let vopts = VolumeOptions {
                window: (5.0, 10.0),
                ..VolumeOptions::new(&vol, VolumeMode::Mip)
            };
            let ctx = FrameCtx::new(&scene, &cam, &opts, &vopts);
            for _ in 0..300 {
                let (_, _, seg, g) = random_segment(&mut rng, dims);
                let walk = |core: bool, kind: RayKind| {
                    let mut r = Record(Vec::new());
                    let mut vis = VolumeVisit::<Record, false> {
                        ctx: &ctx,
                        g: &g,
                        acc: &mut r,
                        column: None,
                    };
                    let n = &mut CastCounters::default();
                    if core {
                        super::super::walk::walk_core(&seg, kind, &mut vis, n);
                    } else {
                        walk_exact(&seg, kind, &mut vis, n);
                    }
                    r.0
                };
                for kind in [RayKind::Six, RayKind::TwentySix] {
                    assert_eq!(walk(false, kind), walk(true, kind), "{kind:?} {seg:?}");
                }
                let ad = walk(false, RayKind::Adaptive);
                assert_eq!(ad, walk(true, RayKind::Adaptive), "{seg:?}");
                let flagged = ad
                    .iter()
                    .filter(|(v, _)| ctx.class[scene.brick_index(*v >> 3)].flag == 0)
                    .count();
                mixed += usize::from(flagged > 0 && flagged < ad.len());
            }
        }
        assert!(mixed > 300, "{mixed}");
    }

    /// The MIP's floor from neighbours' hits is a sample the ray reads: for
    /// the 6-ray and Amanatides–Woo one of their own visited samples
    /// (voxel and value), for the adaptive ray at most its maximum (the
    /// 6-ray's). Hints near the ray, on it, far from it; segments with
    /// endpoints on faces and edges; nearest and trilinear samples.
    #[test]
    fn mip_hint_floor_is_a_visited_sample() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        let mut bounded = 0;
        let mut tried = 0;
        for round in 0..16 {
            let dims: [usize; 3] = std::array::from_fn(|_| rng.random_range(1..40));
            let n = dims.iter().product::<usize>();
            let data: Vec<f32> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
            let vol =
                ScalarVolume::new(dims, VolumeData::F32(data), VolumeFrame::default()).unwrap();
            let scene = VolumeScene::new(&vol, MemoryLimit::DEFAULT).unwrap();
            let cam = Camera::orthographic(DVec3::new(0.0, 0.0, 99.0), DVec3::ZERO, DVec3::Y, 4.0);
            let vopts = VolumeOptions {
                window: (0.0, 1.0),
                sampling: if round % 2 == 0 {
                    Sampling::Nearest
                } else {
                    Sampling::Trilinear
                },
                ..VolumeOptions::new(&vol, VolumeMode::Mip)
            };
            for ray in [RayKind::Six, RayKind::AmanatidesWoo, RayKind::Adaptive] {
                let opts = RenderOptions {
                    ray,
                    skip: false,
                    ..RenderOptions::default()
                };
                let ctx = FrameCtx::new(&scene, &cam, &opts, &vopts);
                for _ in 0..200 {
                    let (a, b, seg, g) = random_segment(&mut rng, dims);
                    // Hints around a point of the segment, up to two voxels off.
                    let t: f64 = rng.random_range(0.0..1.0);
                    let on = DVec3::from_array(a).lerp(DVec3::from_array(b), t).round();
                    let hints: Vec<Option<IVec3>> = (0..2)
                        .map(|_| {
                            let off = IVec3::new(
                                rng.random_range(-2..=2),
                                rng.random_range(-2..=2),
                                rng.random_range(-2..=2),
                            );
                            rng.random_bool(0.9).then(|| on.as_ivec3() + off)
                        })
                        .collect();
                    let floor = if round % 2 == 0 {
                        mip_hint_floor::<false>(&ctx, &g, &seg, &hints)
                    } else {
                        mip_hint_floor::<true>(&ctx, &g, &seg, &hints)
                    };
                    let read = |kind: RayKind| {
                        let mut r = Record(Vec::new());
                        let mut n = CastCounters::default();
                        let o = RenderOptions { ray: kind, ..opts };
                        let c = FrameCtx::new(&scene, &cam, &o, &vopts);
                        if round % 2 == 0 {
                            cast::<_, false>(&c, &g, &seg, &mut r, &mut n);
                        } else {
                            cast::<_, true>(&c, &g, &seg, &mut r, &mut n);
                        }
                        r.0
                    };
                    tried += 1;
                    if floor == f32::NEG_INFINITY {
                        continue;
                    }
                    bounded += 1;
                    let own = read(ray);
                    if ray == RayKind::Adaptive {
                        let six = read(RayKind::Six);
                        let max = six.iter().map(|x| x.1).fold(f32::NEG_INFINITY, f32::max);
                        assert!(floor <= max, "{seg:?} {hints:?}: {floor} > {max}");
                    } else {
                        assert!(
                            own.iter().any(|x| x.1 == floor),
                            "{ray:?} {seg:?} {hints:?}: {floor} not read"
                        );
                    }
                }
            }
        }
        // Most hints near the ray give a floor: the test is not vacuous.
        assert!(bounded * 2 > tried, "{bounded} of {tried}");
    }

    #[test]
    fn opacity_lanes_equal_opacity_bit_for_bit() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        let tfs = [
            TransferFunction::ramp((0.1, 0.9)),
            TransferFunction::ramp((3.0, 3.0)),
            TransferFunction::parse("5:0.3").unwrap(),
            // A step (equal values), a flat stretch, decreasing opacity.
            TransferFunction::parse("-2:0,0:0.5,0:0.9,1:0.9,4:0.05,4.5:1").unwrap(),
        ];
        for tf in &tfs {
            let mut specials: Vec<f32> = tf.points().iter().map(|p| p.value).collect();
            specials.extend([f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0]);
            for round in 0..2000 {
                let s: [f32; 8] = std::array::from_fn(|k| {
                    if round % 4 == 0 {
                        specials[(round / 4 + k) % specials.len()]
                    } else {
                        rng.random_range(-4.0f32..6.0)
                    }
                });
                let mut got = [0.0; 8];
                tf.opacity_lanes(&s, &mut got);
                for k in 0..8 {
                    assert_eq!(
                        got[k].to_bits(),
                        tf.opacity(s[k]).to_bits(),
                        "{tf:?} at {}",
                        s[k]
                    );
                }
            }
        }
    }

    #[test]
    fn transfer_function_parsing_and_errors() {
        let tf = TransferFunction::parse(" -1000:0 , 0:0.2:#808080,0:0.5 ,300:1:#FFFFFF").unwrap();
        assert_eq!(tf.points().len(), 4);
        // A step at 0: below it the ramp, at and above the second point.
        assert!((tf.opacity(-500.0) - 0.1).abs() < 1e-6);
        assert_eq!(tf.opacity(0.0), 0.5);
        assert_eq!(tf.opacity(f32::NEG_INFINITY), 0.0);
        assert_eq!(tf.max_opacity(-2000.0, -1000.0), 0.0);
        assert!(tf.max_opacity(-2000.0, -999.0) > 0.0);
        assert_eq!(tf.max_opacity(-10.0, 10.0), 0.5 + 10.0 / 300.0 * 0.5);
        for bad in [
            "",
            "1",
            "1:2",
            "a:0.5",
            "1:0.5:#12345",
            "1:0.5:123456",
            "1:0.5:#gg0000",
            "nan:0.5",
            "2:0.5,1:0.5",
            "1:0.5:#ffffff:3",
        ] {
            assert!(TransferFunction::parse(bad).is_err(), "{bad}");
        }
    }
}
