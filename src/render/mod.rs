//! The discrete ray caster: one discrete ray per pixel through a sparse voxel
//! grid ([`render_grid`]), headless, on the CPU.
//!
//! Per pixel, the camera's `f64` ray ([`Camera::primary_ray`]) is moved to
//! grid space, clipped to the grid box padded by one voxel, and quantized
//! once to the line engine's fixed point ([`crate::fixed`]): every
//! [`RayKind`] walks that *same* segment, so images differ only by the
//! algorithms.
//!
//! | [`RayKind`] | what | first hit |
//! |---|---|---|
//! | `Six` | tripod 6-line | every voxel the continuous ray passes through: the reference |
//! | `TwentySix` | 26-line | may slip through diagonal gaps |
//! | `Adaptive` | 26 through unflagged voxels, 6 in flagged ones (Cohen-Or & Kaufman) | equals the 6-ray's, always |
//! | `AmanatidesWoo` | floating-point 6-connected traversal (as OpenVDB's DDA) | the 6-ray's up to float ties |
//!
//! Empty space is skipped with a brick-level proximity cloud (see
//! [`OccupancyGrid`]) without changing a pixel; [`RenderOptions::skip`]
//! turns it off. The hit's depth is where the continuous ray enters the hit
//! voxel's cube (world units along the ray, `+∞` for misses); the face
//! normal is that entry face's, the smooth normal that of a plane fitted to
//! the surface voxels within 3 of the hit (Gaussian weights: no staircase
//! moiré). Shading: Lambert from a headlight plus ambient.
//!
//! Scalar volumes ([`render_volume`], module [`volume`]): maximum intensity
//! projection, front-to-back compositing through a transfer function, and
//! iso-surfaces, over the same per-pixel segments and ray kinds, with
//! brick-level skipping that changes no pixel.

pub mod bricks;
mod cast;
pub mod measure;
mod normal;
mod occupancy;
mod opacity;
mod paged;
pub mod shear_warp;
mod tiles;
pub mod volume;
mod walk;

use std::time::Instant;

use glam::{DMat3, DVec3, IVec3};
use rayon::prelude::*;

pub use crate::camera::{Camera, Projection, SceneAxes, ViewPreset};
pub use bricks::{BrickRange, VolumeBricks};
pub use occupancy::{BrickFlags, MAX_RENDER_DIM, OccupancyGrid, RenderBricks};
pub use opacity::{OPACITY_ULPS, corrected_opacity};
pub use paged::{PagedBrick, PagedOccupancy};
pub use volume::{
    EARLY_TERMINATION, RAMP_OPACITY, Sampling, TfPoint, TransferFunction, VolumeMethod, VolumeMode,
    VolumeOptions, VolumeScene, differing_values, render_volume,
};

use crate::error::{Result, VoxkitError};
use crate::grid::{GridFrame, MemoryLimit};
use crate::line::Segment;
use normal::{Fit, FitCache, Moments};

/// Image rows per task of [`render_grid_window`]: the rows of a band share
/// their smooth normals' fits.
const NORMAL_BAND: usize = 8;

/// How a pixel's discrete ray steps (`--ray`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum RayKind {
    /// Tripod 6-connected line: visits every voxel the ray passes through.
    #[value(name = "6")]
    Six,
    /// 26-connected line: the fewest voxels; may slip through diagonal gaps.
    #[value(name = "26")]
    TwentySix,
    /// 26-connected through unflagged voxels, 6-connected in flagged ones.
    Adaptive,
    /// Amanatides–Woo in `f64` (the traversal other voxel renderers use).
    #[value(name = "aw")]
    AmanatidesWoo,
}

impl RayKind {
    /// Every kind, reference first.
    pub const ALL: [RayKind; 4] = [
        RayKind::Six,
        RayKind::TwentySix,
        RayKind::Adaptive,
        RayKind::AmanatidesWoo,
    ];

    /// The command-line name (`6`, `26`, `adaptive`, `aw`).
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Six => "6",
            RayKind::TwentySix => "26",
            RayKind::Adaptive => "adaptive",
            RayKind::AmanatidesWoo => "aw",
        }
    }
}

/// Which normal shades a hit (`--normals`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum NormalMode {
    /// The face of the hit voxel the ray enters through.
    Face,
    /// A plane fitted to the surface voxels within 3 of the hit, with
    /// Gaussian weights: smooth on curved surfaces, without the moiré of a
    /// 3×3×3 gradient.
    Smooth,
}

/// Options of [`render_grid`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Ray kind.
    pub ray: RayKind,
    /// Skip empty space (never changes the image).
    pub skip: bool,
    /// Normals for shading.
    pub normals: NormalMode,
    /// Background colour (linear RGB in `[0, 1]`), for PNG output.
    pub background: [f32; 3],
    /// Surface colour where the grid has no colours.
    pub base_color: [f32; 3],
    /// Ambient share of the lighting, in `[0, 1]`.
    pub ambient: f32,
    /// Cap on the image buffers (checked before allocating).
    pub limit: MemoryLimit,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 1024,
            height: 1024,
            ray: RayKind::Adaptive,
            skip: true,
            normals: NormalMode::Smooth,
            background: [0.07, 0.08, 0.1],
            base_color: [0.85, 0.8, 0.72],
            ambient: 0.25,
            limit: MemoryLimit::DEFAULT,
        }
    }
}

/// The affine map between world space and a grid's space (voxel centres at
/// integers): `world = origin + axes · g`. Anisotropic and sheared voxels
/// are rays transformed, never a resampled volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridTransform {
    /// World position of the centre of voxel `(0, 0, 0)`.
    pub origin: DVec3,
    /// Column `i`: the world displacement of one voxel along grid axis `i`.
    pub axes: DMat3,
    inv: DMat3,
}

impl GridTransform {
    /// The transform with the given origin (centre of voxel 0) and axes;
    /// `Invalid` if they are not finite or the axes are (nearly) singular.
    pub fn new(origin: DVec3, axes: DMat3) -> Result<Self> {
        let norms = [axes.x_axis, axes.y_axis, axes.z_axis].map(|c| c.length());
        let det = axes.determinant();
        if !(origin.is_finite() && axes.is_finite())
            || norms.iter().any(|&n| n <= 0.0)
            || det.abs() < 1e-9 * norms.iter().product::<f64>()
        {
            return Err(VoxkitError::invalid(format!(
                "grid transform: origin {origin} and axes {axes} are not a usable frame"
            )));
        }
        Ok(GridTransform {
            origin,
            axes,
            inv: axes.inverse(),
        })
    }

    /// The transform of a cubic-voxel [`GridFrame`] (origin at the min corner
    /// of voxel 0).
    pub fn from_frame(frame: &GridFrame) -> Result<Self> {
        let h = frame.voxel_size;
        Self::new(
            frame.origin + DVec3::splat(h / 2.0),
            DMat3::from_diagonal(DVec3::splat(h)),
        )
    }

    /// World point → grid point.
    pub fn world_to_grid(&self, w: DVec3) -> DVec3 {
        self.inv * (w - self.origin)
    }

    /// Grid point → world point.
    pub fn grid_to_world(&self, g: DVec3) -> DVec3 {
        self.origin + self.axes * g
    }

    /// World-space box of a grid of `dims` (the voxel cubes' hull).
    pub fn world_bounds(&self, lo: DVec3, hi: DVec3) -> (DVec3, DVec3) {
        let mut a = DVec3::INFINITY;
        let mut b = DVec3::NEG_INFINITY;
        for i in 0..8 {
            let g = DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            let w = self.grid_to_world(g);
            a = a.min(w);
            b = b.max(w);
        }
        (a, b)
    }
}

/// A rendered image: colour, coverage, depth and the hit voxel per pixel,
/// row-major with row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Shaded colour (linear RGB in `[0, 1]`) and coverage `A` (1 hit, 0 miss).
    pub color: Vec<[f32; 4]>,
    /// Distance along the ray in world units to the hit, `+∞` for misses.
    pub depth: Vec<f32>,
    /// The hit voxel per pixel (`None`: miss).
    pub hit: Vec<Option<IVec3>>,
}

/// One band of rows of a [`RenderImage`]: its colours, depths and hits.
pub(crate) type ImageBand<'a> = (&'a mut [[f32; 4]], &'a mut [f32], &'a mut [Option<IVec3>]);

/// Buffers of a frame handed back by [`RenderImage::recycle`], for the next
/// frame of the same size.
static SPARE_FRAME: std::sync::Mutex<Option<RenderImage>> = std::sync::Mutex::new(None);

impl RenderImage {
    /// Hands this image's buffers to the next frame rendered at the same
    /// size (one frame is kept; a later call replaces it). A renderer
    /// drawing frame after frame (turntables, repeated timings) then
    /// writes into memory it already holds: a fresh frame of 1024² pixels
    /// is 36 MiB whose first touch, on virtual machines that hand freed
    /// memory back to their host, cost 7–90 ms a frame.
    ///
    /// ```
    /// use glam::{DVec3, IVec3};
    /// use voxkit::camera::Camera;
    /// use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
    /// use voxkit::render::{render_grid, GridTransform, OccupancyGrid, RenderOptions};
    /// let grid: BrickGrid = [IVec3::new(4, 4, 4)].into_iter().collect();
    /// let occ = OccupancyGrid::new(&grid, [9, 9, 9], MemoryLimit::DEFAULT).unwrap();
    /// let xf = GridTransform::from_frame(&GridFrame::new(DVec3::ZERO, 1.0, [9, 9, 9])).unwrap();
    /// let cam = Camera::perspective(DVec3::new(4.5, 4.5, 30.0), DVec3::splat(4.5), DVec3::Y, 20.0);
    /// let opts = RenderOptions { width: 31, height: 17, ..RenderOptions::default() };
    /// let (first, _) = render_grid(&occ, &xf, &cam, &opts).unwrap();
    /// // A used frame of that size, every pixel a hit somewhere else.
    /// let mut used = first.clone();
    /// used.color.fill([1.0; 4]);
    /// used.depth.fill(0.0);
    /// used.hit.fill(Some(IVec3::ZERO));
    /// let buffer = used.color.as_ptr();
    /// used.recycle();
    /// // The next frame of that size writes into those buffers, from a clean start.
    /// let (next, _) = render_grid(&occ, &xf, &cam, &opts).unwrap();
    /// assert_eq!(next.color.as_ptr(), buffer);
    /// assert_eq!(next, first);
    /// ```
    pub fn recycle(self) {
        if let Ok(mut spare) = SPARE_FRAME.lock() {
            *spare = Some(self);
        }
    }

    /// A `width × height` image of misses: no colour, `depth` everywhere, no hit.
    pub(crate) fn blank(width: u32, height: u32, depth: f32) -> Self {
        let n = width as usize * height as usize;
        let spare = SPARE_FRAME.lock().ok().and_then(|mut s| s.take());
        if let Some(mut img) = spare
            && img.width == width
            && [img.color.len(), img.depth.len(), img.hit.len()] == [n; 3]
        {
            img.height = height;
            img.par_bands(64).for_each(|(_, (color, d, hit))| {
                color.fill([0.0; 4]);
                d.fill(depth);
                hit.fill(None);
            });
            return img;
        }
        // Filled rather than asked zeroed: a zeroed request of this size
        // gets lazily mapped 4 KiB pages (crate::alloc), whose first
        // touches in the render cost more than writing the zeros into
        // huge pages here, after all threads have mapped them in.
        fn filled<T: Clone + Default + Send>(n: usize, value: T) -> Vec<T> {
            let mut v = Vec::with_capacity(n);
            crate::alloc::prefault_spare(&mut v);
            v.resize(n, value);
            v
        }
        RenderImage {
            width,
            height,
            color: filled(n, [0.0; 4]),
            depth: filled(n, depth),
            hit: filled(n, None),
        }
    }

    /// The image in bands of `rows` rows (the last may be shorter), in
    /// parallel, each with its index: renderers write pixels straight into
    /// the frame's buffers, with no per-band vectors to gather afterwards.
    pub(crate) fn par_bands(
        &mut self,
        rows: usize,
    ) -> impl IndexedParallelIterator<Item = (usize, ImageBand<'_>)> {
        let len = rows * self.width as usize;
        self.color
            .par_chunks_mut(len)
            .zip(self.depth.par_chunks_mut(len))
            .zip(self.hit.par_chunks_mut(len))
            .map(|((c, d), h)| (c, d, h))
            .enumerate()
    }

    /// RGBA8 composited over `background` (for PNG and GIF).
    pub fn to_rgba8(&self, background: [f32; 3]) -> Vec<u8> {
        let q = |x: f32| (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        self.color
            .iter()
            .flat_map(|c| {
                let a = c[3];
                let mix = |k: usize| q(c[k] * a + background[k] * (1.0 - a));
                [mix(0), mix(1), mix(2), 255]
            })
            .collect()
    }

    /// Pixels whose first hit (voxel, hence depth) differs from `other`'s.
    pub fn differing_hits(&self, other: &RenderImage) -> u64 {
        self.hit
            .iter()
            .zip(&other.hit)
            .filter(|(a, b)| a != b)
            .count() as u64
    }
}

/// Counters and timings of a render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Rays cast (pixels).
    pub rays: u64,
    /// Rays that hit.
    pub hits: u64,
    /// Voxels whose flags the rays read.
    pub voxels_visited: u64,
    /// Jumps over empty boxes of bricks (each leaves at least one empty
    /// brick); for shear-warp, the bricks of each band's slice layers that
    /// skipping passed over (transparent, below the MIP's running maxima,
    /// or read only by terminated pixels).
    pub bricks_skipped: u64,
    /// Rays not cast: their pixel's tile of 8 × 8 meets no brick that can
    /// change a pixel (found by one coarse pass before the rays; skipping only).
    pub rays_culled: u64,
    /// Wall time of the frame.
    pub render_ms: f64,
    /// Whether the frame was rendered by shear-warp
    /// ([`VolumeMethod::ShearWarp`]; `false` where it was asked for and the
    /// view has no factorization, so rays were cast).
    pub shear_warp: bool,
}

/// How far inside the clip box a pixel's segment starts and ends, in voxels:
/// far above `f64` rounding and far below the fixed point's 2^-20, so both
/// end points lie in voxels of the box and the walks need no discrete clip.
const CLIP_INSET: f64 = 1.0 / 4096.0;

/// A pixel's ray in grid space: `g(t) = o + t·d` (`t` in world units).
#[derive(Clone, Copy, Debug)]
pub(crate) struct GridRay {
    pub o: DVec3,
    pub d: DVec3,
}

/// The rays of one image row ([`RaySetup::row_rays`]), one array per
/// coordinate of origin and direction (so that a row's arithmetic runs
/// in vector lanes).
#[derive(Default)]
pub(crate) struct RowRays {
    pub o: [Vec<f64>; 3],
    pub d: [Vec<f64>; 3],
}

impl RowRays {
    /// Column `x`'s ray.
    #[inline(always)]
    pub(crate) fn ray(&self, x: usize) -> GridRay {
        let [ox, oy, oz] = &self.o;
        let [dx, dy, dz] = &self.d;
        GridRay {
            o: DVec3::new(ox[x], oy[x], oz[x]),
            d: DVec3::new(dx[x], dy[x], dz[x]),
        }
    }
}

/// Whether the ray `o + t·d` meets the box `[lo, hi]` for some `t ≥ 0`:
/// what [`GridRay::clip`] says (`is_some`) for every input, a zero
/// direction component included, computed with selects instead of
/// branches (a row of rays runs without mispredictions).
#[inline(always)]
pub(crate) fn clip_hits(o: [f64; 3], d: [f64; 3], lo: DVec3, hi: DVec3) -> bool {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        let (o, d) = (o[k], d[k]);
        let (a, b) = ((lo[k] - o) / d, (hi[k] - o) / d);
        // Along an axis the ray does not move on, `clip` skips the axis
        // if `o` lies in the slab and misses otherwise: `−∞..∞` or an
        // empty `∞..∞` here.
        let flat = d == 0.0;
        let outside = (o < lo[k]) | (o > hi[k]);
        let near = if flat {
            if outside {
                f64::INFINITY
            } else {
                f64::NEG_INFINITY
            }
        } else {
            a.min(b)
        };
        let far = if flat { f64::INFINITY } else { a.max(b) };
        t0 = t0.max(near);
        t1 = t1.min(far);
    }
    t0 < t1
}

impl GridRay {
    /// The `t` interval (from 0 on) inside the box `[lo, hi]`, if any.
    #[inline]
    fn clip(&self, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for k in 0..3 {
            let (o, d) = (self.o[k], self.d[k]);
            if d == 0.0 {
                if o < lo[k] || o > hi[k] {
                    return None;
                }
                continue;
            }
            let (a, b) = ((lo[k] - o) / d, (hi[k] - o) / d);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 < t1).then_some((t0, t1))
    }

    /// Entry distance into voxel `v`'s cube and the axis of the entry face
    /// (`None`: the ray starts inside the cube).
    pub(crate) fn entry(&self, v: IVec3) -> (f64, Option<usize>) {
        let mut t = f64::NEG_INFINITY;
        let mut axis = None;
        for k in 0..3 {
            if self.d[k] == 0.0 {
                continue;
            }
            let c = v[k] as f64;
            let (a, b) = (
                (c - 0.5 - self.o[k]) / self.d[k],
                (c + 0.5 - self.o[k]) / self.d[k],
            );
            let near = a.min(b);
            if near > t {
                t = near;
                axis = Some(k);
            }
        }
        if t <= 0.0 { (0.0, None) } else { (t, axis) }
    }
}

/// Fixed point of a grid coordinate known to be far inside the supported
/// range: round half away from zero as [`crate::fixed::to_fixed`] does, by a
/// truncating conversion (exact: `|x·2^20| < 2^51`), without a libm call.
#[inline(always)]
fn to_fixed_in_range(x: f64) -> i64 {
    let v = x * crate::fixed::ONE as f64;
    (v + 0.5f64.copysign(v)) as i64
}

/// Sets up pixel rays for a camera and grid once per frame: the camera basis
/// moved to grid space, and the clip box.
pub(crate) struct RaySetup {
    xf: GridTransform,
    /// Grid-space origin of perspective rays / of the image-plane centre.
    o: DVec3,
    /// Grid-space images of the world forward, right·tan_h and up·tan_v
    /// (perspective) or right·half_w and up·half_h (orthographic).
    f: DVec3,
    r: DVec3,
    u: DVec3,
    ortho: bool,
    lo: DVec3,
    hi: DVec3,
    width: u32,
    height: u32,
}

impl RaySetup {
    /// `bounds`: the inclusive voxel box that can hold anything (the occupied
    /// voxels' bounds; rays are clipped to it), `None` for an empty scene.
    pub(crate) fn new(
        camera: &Camera,
        xf: &GridTransform,
        bounds: Option<(IVec3, IVec3)>,
        width: u32,
        height: u32,
    ) -> Self {
        let (r, u, f) = camera.basis();
        let aspect = width as f64 / height as f64;
        let (ortho, sr, su) = match camera.projection {
            crate::camera::Projection::Perspective { fov_y_deg } => {
                let t = (fov_y_deg.to_radians() * 0.5).tan();
                (false, t * aspect, t)
            }
            crate::camera::Projection::Orthographic { height } => {
                (true, height * 0.5 * aspect, height * 0.5)
            }
        };
        let (lo, hi) = match bounds {
            Some((a, b)) => (
                a.as_dvec3() - 0.5 + CLIP_INSET,
                b.as_dvec3() + 0.5 - CLIP_INSET,
            ),
            None => (DVec3::ONE, DVec3::ZERO),
        };
        RaySetup {
            xf: *xf,
            o: xf.world_to_grid(camera.eye),
            f: xf.inv * f,
            r: xf.inv * (r * sr),
            u: xf.inv * (u * su),
            ortho,
            lo,
            hi,
            width,
            height,
        }
    }

    /// The grid-space ray of pixel `(x, y)` (unit world speed) and its
    /// segment inside the clip box (`None`: the ray misses it).
    #[inline]
    pub(crate) fn pixel(&self, x: u32, y: u32) -> (GridRay, Option<Segment>) {
        let ray = self.ray(x, y);
        let seg = ray.clip(self.lo, self.hi).and_then(|(t0, t1)| {
            let q = |t: f64| {
                let p = (ray.o + ray.d * t).clamp(self.lo, self.hi);
                [p.x, p.y, p.z].map(to_fixed_in_range)
            };
            Segment::from_fixed(q(t0), q(t1)).ok()
        });
        (ray, seg)
    }

    /// The grid-space ray of pixel `(x, y)` (unit world speed).
    #[inline]
    pub(crate) fn ray(&self, x: u32, y: u32) -> GridRay {
        self.ray_at(self.column(x), self.row(y))
    }

    /// Pixel column `x`'s position across the image, `−1..1` left to right.
    #[inline(always)]
    fn column(&self, x: u32) -> f64 {
        2.0 * (x as f64 + 0.5) / self.width as f64 - 1.0
    }

    /// Pixel row `y`'s position up the image, `1..−1` top to bottom.
    #[inline(always)]
    fn row(&self, y: u32) -> f64 {
        1.0 - 2.0 * (y as f64 + 0.5) / self.height as f64
    }

    /// The rays of image row `y` into `out` (one per column): the values
    /// [`RaySetup::ray`] gives, bit for bit, computed column after column
    /// with no branch, so that they run in vector lanes.
    #[inline(always)]
    pub(crate) fn row_rays(&self, y: u32, out: &mut RowRays) {
        let ny = self.row(y);
        let n = self.width as usize;
        let RowRays { o, d } = out;
        for v in o.iter_mut().chain(d.iter_mut()) {
            v.resize(n, 0.0);
        }
        let [ox, oy, oz] = o.each_mut().map(|v| &mut v[..n]);
        let [dx, dy, dz] = d.each_mut().map(|v| &mut v[..n]);
        // One loop per projection (the test hoisted), each the same
        // expressions as `ray_at`'s.
        if self.ortho {
            for x in 0..n {
                let ray = self.ortho_ray(self.column(x as u32), ny);
                (ox[x], oy[x], oz[x]) = (ray.o.x, ray.o.y, ray.o.z);
                (dx[x], dy[x], dz[x]) = (ray.d.x, ray.d.y, ray.d.z);
            }
        } else {
            for x in 0..n {
                let ray = self.perspective_ray(self.column(x as u32), ny);
                (ox[x], oy[x], oz[x]) = (ray.o.x, ray.o.y, ray.o.z);
                (dx[x], dy[x], dz[x]) = (ray.d.x, ray.d.y, ray.d.z);
            }
        }
    }

    /// The clip box of [`RaySetup::pixel`].
    pub(crate) fn clip_box(&self) -> (DVec3, DVec3) {
        (self.lo, self.hi)
    }

    /// The ray at image position `(nx, ny)` (unit world speed).
    #[inline(always)]
    fn ray_at(&self, nx: f64, ny: f64) -> GridRay {
        if self.ortho {
            self.ortho_ray(nx, ny)
        } else {
            self.perspective_ray(nx, ny)
        }
    }

    /// [`RaySetup::ray_at`] for an orthographic camera.
    #[inline(always)]
    fn ortho_ray(&self, nx: f64, ny: f64) -> GridRay {
        GridRay {
            o: self.o + self.r * nx + self.u * ny,
            d: self.f,
        }
    }

    /// [`RaySetup::ray_at`] for a perspective camera.
    #[inline(always)]
    fn perspective_ray(&self, nx: f64, ny: f64) -> GridRay {
        // World direction f + r·a + u·b has length sqrt(1 + a² + b²)
        // (orthonormal basis): divide it out for unit world speed.
        let d = self.f + self.r * nx + self.u * ny;
        let world_len = self.xf.axes.mul_vec3(d).length();
        GridRay {
            o: self.o,
            d: d / world_len,
        }
    }

    /// World normal of grid-space direction `n` (a normal transforms with
    /// the inverse transpose).
    fn world_normal(&self, n: DVec3) -> DVec3 {
        (self.xf.inv.transpose() * n).normalize_or_zero()
    }
}

/// Checks a frame's size against `limit` (colour, depth and hit buffers).
pub(crate) fn check_image(width: u32, height: u32, limit: MemoryLimit) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(VoxkitError::invalid(format!(
            "image size {width}x{height}: both sides must be positive"
        )));
    }
    limit.check(
        "render image buffers",
        width as u128 * height as u128,
        16 + 4 + 16,
    )
}

/// Renders `occ` (placed in the world by `xf`) with `camera`.
///
/// ```
/// use glam::{DVec3, IVec3};
/// use voxkit::camera::Camera;
/// use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
/// use voxkit::render::{render_grid, GridTransform, OccupancyGrid, RayKind, RenderOptions};
/// let grid: BrickGrid = [IVec3::new(4, 4, 4)].into_iter().collect();
/// let occ = OccupancyGrid::new(&grid, [9, 9, 9], MemoryLimit::DEFAULT).unwrap();
/// let xf = GridTransform::from_frame(&GridFrame::new(DVec3::ZERO, 1.0, [9, 9, 9])).unwrap();
/// let cam = Camera::perspective(DVec3::new(4.5, 4.5, 30.0), DVec3::splat(4.5), DVec3::Y, 20.0);
/// let opts = RenderOptions { width: 32, height: 32, ..RenderOptions::default() };
/// let (img, stats) = render_grid(&occ, &xf, &cam, &opts).unwrap();
/// assert_eq!(img.hit[16 * 32 + 16], Some(IVec3::new(4, 4, 4)));
/// assert!(img.depth[16 * 32 + 16] > 24.9 && img.depth[16 * 32 + 16] < 25.1);
/// // The adaptive ray sees exactly what the 6-ray sees.
/// let six = RenderOptions { ray: RayKind::Six, ..opts };
/// assert_eq!(render_grid(&occ, &xf, &cam, &six).unwrap().0.hit, img.hit);
/// ```
pub fn render_grid<G: RenderBricks>(
    occ: &G,
    xf: &GridTransform,
    camera: &Camera,
    opts: &RenderOptions,
) -> Result<(RenderImage, RenderStats)> {
    render_grid_window(occ, xf, camera, opts, PixelWindow::full(opts))
}

/// A rectangle of pixels of an `opts.width × opts.height` frame: columns
/// `x..x + width`, rows `y..y + height` (row 0 at the top).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelWindow {
    /// First column.
    pub x: u32,
    /// First row.
    pub y: u32,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

impl PixelWindow {
    /// The whole frame of `opts`.
    pub fn full(opts: &RenderOptions) -> PixelWindow {
        PixelWindow {
            x: 0,
            y: 0,
            width: opts.width,
            height: opts.height,
        }
    }
}

/// Renders the pixels of `window` of the frame [`render_grid`] renders:
/// every pixel is the frame's pixel, bit for bit (each ray depends on its
/// pixel alone), so windows rendered apart (by different processes or
/// machines: `voxkit.distributed.render_tiled`) stitch into the frame.
///
/// ```
/// use glam::{DVec3, IVec3};
/// use voxkit::camera::Camera;
/// use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
/// use voxkit::render::{render_grid, render_grid_window, GridTransform, OccupancyGrid, PixelWindow, RenderOptions};
/// let grid: BrickGrid = (0..6).map(|i| IVec3::new(i, 2 * i % 7, 3)).collect();
/// let occ = OccupancyGrid::new(&grid, [8, 8, 8], MemoryLimit::DEFAULT).unwrap();
/// let xf = GridTransform::from_frame(&GridFrame::new(DVec3::ZERO, 1.0, [8, 8, 8])).unwrap();
/// let cam = Camera::perspective(DVec3::new(4.0, 9.0, 25.0), DVec3::splat(3.5), DVec3::Y, 25.0);
/// let opts = RenderOptions { width: 40, height: 30, ..RenderOptions::default() };
/// let (frame, _) = render_grid(&occ, &xf, &cam, &opts).unwrap();
/// let win = PixelWindow { x: 13, y: 7, width: 20, height: 16 };
/// let (part, _) = render_grid_window(&occ, &xf, &cam, &opts, win).unwrap();
/// assert!(frame.hit.iter().any(|h| h.is_some()));
/// for r in 0..16 {
///     let row = (7 + r) * 40 + 13;
///     assert_eq!(&part.color[r * 20..(r + 1) * 20], &frame.color[row..row + 20]);
///     assert_eq!(&part.hit[r * 20..(r + 1) * 20], &frame.hit[row..row + 20]);
/// }
/// ```
pub fn render_grid_window<G: RenderBricks>(
    occ: &G,
    xf: &GridTransform,
    camera: &Camera,
    opts: &RenderOptions,
    window: PixelWindow,
) -> Result<(RenderImage, RenderStats)> {
    camera_check(camera)?;
    let PixelWindow {
        x: x0,
        y: y0,
        width: w,
        height: h,
    } = window;
    // Only the window's buffers are allocated; the frame need only exist.
    if w == 0 || h == 0 || x0.saturating_add(w) > opts.width || y0.saturating_add(h) > opts.height {
        return Err(VoxkitError::invalid(format!(
            "pixel window {w}x{h} at ({x0}, {y0}) is not inside the {}x{} frame",
            opts.width, opts.height
        )));
    }
    check_image(w, h, opts.limit)?;
    let start = Instant::now();
    let setup = RaySetup::new(camera, xf, occ.occupied_bounds(), opts.width, opts.height);
    // Tiles whose rays meet no brick holding an occupied voxel miss: no
    // ray is cast there.
    let tiles = match occ.resident_clouds() {
        Some(cloud) if opts.skip => {
            let bdims = occ.grid_dims().map(|d| (d + 7) >> 3);
            tiles::TileMask::new(&setup, bdims, |i| cloud[i] == 0)
        }
        _ => tiles::TileMask::all(),
    };
    // Rows write straight into the frame's buffers (no per-row vectors to
    // gather afterwards); only the counters are reduced.
    let n = (w as usize) * (h as usize);
    let mut img = RenderImage::blank(w, h, f32::INFINITY);
    // Bands of rows: a band's rows run in order, so a hit voxel's fit for
    // its smooth normal is shared with the pixels right of and below it.
    let (counters, hits) = img
        .par_bands(NORMAL_BAND)
        .map(|(b, (color, depth, hit))| {
            let mut c = walk::CastCounters::default();
            let mut hits = 0u64;
            let mut fits = (opts.normals == NormalMode::Smooth).then(|| FitCache::new(w as usize));
            // Rows, then columns (no division per pixel to find them).
            for (row, start) in (0..color.len()).step_by(w as usize).enumerate() {
                let y = b * NORMAL_BAND + row;
                for x in 0..w as usize {
                    let i = start + x;
                    if !tiles.may_see(x0 + x as u32, y0 + y as u32) {
                        c.culled += 1;
                        continue;
                    }
                    let (ray, seg) = setup.pixel(x0 + x as u32, y0 + y as u32);
                    let v = seg.and_then(|s| cast::first_hit(occ, &s, opts.ray, opts.skip, &mut c));
                    if let Some(v) = v {
                        hits += 1;
                        let (t, axis) = ray.entry(v);
                        let fit = fits
                            .as_mut()
                            .map(|f| f.fit(x, v, || Moments::around(v, |b| occ.occupancy_mask(b))));
                        color[i] = shade(occ, &setup, &ray, v, axis, fit.as_ref(), opts);
                        depth[i] = t as f32;
                        hit[i] = Some(v);
                    }
                }
            }
            (c, hits)
        })
        .reduce(
            || (walk::CastCounters::default(), 0),
            |(a, ha), (b, hb)| {
                (
                    walk::CastCounters {
                        visited: a.visited + b.visited,
                        jumps: a.jumps + b.jumps,
                        culled: a.culled + b.culled,
                    },
                    ha + hb,
                )
            },
        );
    occ.health()?;
    let mut stats = RenderStats {
        rays: n as u64,
        hits,
        voxels_visited: counters.visited,
        bricks_skipped: counters.jumps,
        rays_culled: counters.culled,
        ..RenderStats::default()
    };
    stats.render_ms = start.elapsed().as_secs_f64() * 1e3;
    Ok((img, stats))
}

/// The default camera for a grid: the three-quarter view
/// ([`ViewPreset::Iso`](crate::camera::ViewPreset)) of the occupied voxels'
/// world box (the whole grid if empty), perspective with a 35° vertical field
/// of view, framed for a `width × height` image.
pub fn default_camera<G: RenderBricks>(
    occ: &G,
    xf: &GridTransform,
    axes: &crate::camera::SceneAxes,
    width: u32,
    height: u32,
) -> Result<Camera> {
    let (lo, hi) = occupied_world_box(occ, xf);
    let (dir, up) = axes.view(crate::camera::ViewPreset::Iso);
    Camera::framing(lo, hi, dir, up, Some(35.0), width, height)
}

/// World box of the occupied voxels' cubes (the whole grid if none).
pub fn occupied_world_box<G: RenderBricks>(occ: &G, xf: &GridTransform) -> (DVec3, DVec3) {
    match occ.occupied_bounds() {
        Some((a, b)) => xf.world_bounds(a.as_dvec3() - 0.5, b.as_dvec3() + 0.5),
        None => xf.world_bounds(
            DVec3::splat(-0.5),
            DVec3::from_array(occ.grid_dims().map(f64::from)) - 0.5,
        ),
    }
}

/// The first occupied voxel along a grid-space segment for a ray kind (the
/// per-pixel kernel of [`render_grid`]); the segment must lie inside the
/// grid (both end voxels in `0..dims`), else `None`.
pub fn first_hit<G: RenderBricks>(
    occ: &G,
    seg: &Segment,
    kind: RayKind,
    skip: bool,
) -> Option<IVec3> {
    if !(occ.contains_voxel(seg.start_voxel()) && occ.contains_voxel(seg.end_voxel())) {
        return None;
    }
    cast::first_hit(occ, seg, kind, skip, &mut walk::CastCounters::default())
}

/// The fixed-point segment that every ray kind of [`render_grid`] walks for
/// pixel `(x, y)` of a `width × height` image (the pixel's ray clipped
/// 2^-12 voxel inside the occupied box, then quantized), or `None` where the
/// ray misses that box. For oracles that judge a rendered image pixel by
/// pixel.
///
/// ```
/// use glam::{DVec3, IVec3};
/// use voxkit::camera::Camera;
/// use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
/// use voxkit::render::{pixel_segment, GridTransform, OccupancyGrid};
/// let grid: BrickGrid = [IVec3::new(4, 4, 4)].into_iter().collect();
/// let occ = OccupancyGrid::new(&grid, [9, 9, 9], MemoryLimit::DEFAULT).unwrap();
/// let xf = GridTransform::from_frame(&GridFrame::new(DVec3::ZERO, 1.0, [9, 9, 9])).unwrap();
/// let cam = Camera::perspective(DVec3::new(4.5, 4.5, 30.0), DVec3::splat(4.5), DVec3::Y, 20.0);
/// let s = pixel_segment(&occ, &xf, &cam, 32, 32, 16, 16).unwrap();
/// assert_eq!((s.start_voxel(), s.end_voxel()), (IVec3::splat(4), IVec3::splat(4)));
/// assert!(pixel_segment(&occ, &xf, &cam, 32, 32, 0, 0).is_none());
/// ```
pub fn pixel_segment<G: RenderBricks>(
    occ: &G,
    xf: &GridTransform,
    camera: &Camera,
    width: u32,
    height: u32,
    x: u32,
    y: u32,
) -> Option<Segment> {
    RaySetup::new(camera, xf, occ.occupied_bounds(), width, height)
        .pixel(x, y)
        .1
}

/// The camera checks a render needs (the rasterizer's clip distances do not
/// matter to rays).
pub(crate) fn camera_check(camera: &Camera) -> Result<()> {
    let mut c = *camera;
    c.near = 1.0;
    c.far = 2.0;
    c.validate()
}

/// Lambert from a headlight plus ambient, on the hit voxel's colour; `fit`:
/// the plane fitted around the hit, for smooth normals.
fn shade<G: RenderBricks>(
    occ: &G,
    setup: &RaySetup,
    ray: &GridRay,
    v: IVec3,
    axis: Option<usize>,
    fit: Option<&Fit>,
    opts: &RenderOptions,
) -> [f32; 4] {
    let face = match axis {
        Some(k) => {
            let mut n = DVec3::ZERO;
            n[k] = -ray.d[k].signum();
            n
        }
        None => -ray.d,
    };
    let n_grid = match (opts.normals, fit) {
        (NormalMode::Smooth, Some(fit)) => fit.normal(-ray.d),
        _ => face,
    };
    let n = setup.world_normal(n_grid);
    let view = (setup.xf.axes * ray.d).normalize_or_zero();
    let lambert = n.dot(-view).abs() as f32;
    let base = occ.voxel_color(v).map_or(opts.base_color, |c| {
        [c[0], c[1], c[2]].map(|x| x as f32 / 255.0)
    });
    let a = opts.ambient.clamp(0.0, 1.0);
    let l = a + (1.0 - a) * lambert;
    [base[0] * l, base[1] * l, base[2] * l, 1.0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A coordinate that is often exactly on the box's faces or zero, so
    /// that flat rays along a face and rays from a face are common.
    fn coordinate() -> impl Strategy<Value = f64> {
        prop_oneof![
            Just(0.0),
            Just(-0.0),
            Just(-0.5),
            Just(7.5),
            Just(f64::INFINITY),
            -20.0..20.0f64,
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]

        /// The branch-free test says what the clip says, for every ray.
        #[test]
        fn clip_hits_is_the_clip(
            o in proptest::array::uniform3(coordinate()),
            d in proptest::array::uniform3(coordinate()),
        ) {
            let (lo, hi) = (DVec3::splat(-0.5), DVec3::new(7.5, 7.5, 3.0));
            let ray = GridRay { o: DVec3::from_array(o), d: DVec3::from_array(d) };
            prop_assert_eq!(clip_hits(o, d, lo, hi), ray.clip(lo, hi).is_some());
        }
    }

    /// A row's rays are the pixels' rays, bit for bit, perspective and
    /// orthographic.
    #[test]
    fn row_rays_are_the_pixel_rays() {
        use crate::camera::Camera;
        // Oblique axes of unequal lengths (as a volume's header may give).
        let axes = DMat3::from_cols(
            DVec3::new(0.37, 0.02, 0.0),
            DVec3::new(-0.05, 0.41, 0.03),
            DVec3::new(0.0, 0.01, 1.2),
        );
        let xf = GridTransform::new(DVec3::new(-3.0, 1.0, 2.0), axes).unwrap();
        let eye = DVec3::new(30.0, -20.0, 14.0);
        let target = DVec3::new(1.0, 4.0, 5.0);
        for cam in [
            Camera::perspective(eye, target, DVec3::Z, 41.0),
            Camera::orthographic(eye, target, DVec3::Z, 17.0),
        ] {
            let setup = RaySetup::new(&cam, &xf, Some((IVec3::ZERO, IVec3::splat(40))), 37, 23);
            let mut rays = RowRays::default();
            for y in 0..23 {
                setup.row_rays(y, &mut rays);
                for x in 0..37 {
                    let (a, b) = (rays.ray(x as usize), setup.ray(x, y));
                    assert_eq!(
                        a.o.to_array().map(f64::to_bits),
                        b.o.to_array().map(f64::to_bits)
                    );
                    assert_eq!(
                        a.d.to_array().map(f64::to_bits),
                        b.d.to_array().map(f64::to_bits)
                    );
                }
            }
        }
    }
}
