//! Shear-warp rendering of scalar volumes (Lacroute & Levoy 1994): the
//! object-order alternative to one discrete ray per pixel, for
//! [`VolumeMethod::ShearWarp`](super::VolumeMethod).
//!
//! # What it computes
//! The volume is cut into slices across its *principal axis* `c` (the grid
//! axis most nearly along the view: for perspective cameras, the axis whose
//! slab the eye lies outside of, chosen so the steepest ray to a corner of
//! the volume is the least oblique). Slice `k` is the plane `g_c = k`
//! through its voxels' centres. Every slice maps onto the *base plane* (the
//! slice nearest the eye) by the projection along the view: a translation
//! for orthographic cameras (the shear), a scale about the eye's foot for
//! perspective ones. The *intermediate image* has one pixel per voxel of
//! the base plane; its pixel `(i, j)` stands for the ray through base-plane
//! point `(U₀ + i, V₀ + j)`, and takes, front to back, one sample per slice:
//! the bilinear value of the slice's voxel centres at the ray's crossing
//! (clamped at the volume's border; no sample where the crossing lies
//! outside the slice's voxel squares). The *warp* then gives each pixel of
//! the image the bilinear value of the intermediate image where its own ray
//! meets the base plane; pixels whose rays miss the volume's box are
//! misses, as with rays.
//!
//! - MIP: the largest sample along the intermediate ray, through the
//!   window; `hit`/`depth` are those of the sample that holds it (of the
//!   nearest intermediate pixel), if it exceeds the window's low end.
//! - Compositing: the samples composited front to back as the rays do,
//!   with the stretch between two slices (`ℓ = 1/|d_c|` world units for a
//!   ray of unit world speed `d`) as each sample's length; the transfer
//!   function read from a table of [`TF_TABLE`] entries over its span
//!   (nearest entry). A table without colours (grey, as the default
//!   ramp's) is blended in one colour channel, the same sums.
//!
//! # Error
//! Every ray reads the same samples (trilinear on the slice planes), not
//! the voxels its discrete 6-ray passes through, and the warp resamples an
//! image of the base plane's resolution: the image is *not* the 6-ray's.
//! `voxkit render --method shear-warp --measure` reports the difference,
//! and `scripts/compare_render.py` reports it beside the time.
//!
//! Samples that cannot change a pixel are not taken. The 8³ bricks (with
//! their aprons) that no intermediate pixel of a band of rows can take
//! from a layer of 8 slices are found before the layer is read (so they
//! are not read either): for MIP, those whose maximum cannot exceed the
//! running maximum of any pixel that reads them; for compositing, those
//! whose values the transfer function makes fully transparent. Compositing
//! also passes over a pair of slice rows that is transparent throughout,
//! and pixels stop once their opacity reaches [`EARLY_TERMINATION`]. Rows of the intermediate image run in parallel
//! bands; every pixel's samples are taken in the same order whatever the
//! thread count, so images are identical for any number of threads.
//!
//! Iso-surfaces, and perspective views whose eye lies inside the volume's
//! box, have no factorization here: its `render` returns `None` and the
//! caller casts rays.

use std::cmp::Ordering;
use std::time::Instant;

use glam::{DVec3, IVec3};
use rayon::prelude::*;

use super::bricks::BRICK;
use super::opacity::{corrected_opacity_from_log, ln_one_minus};
use super::volume::{EARLY_TERMINATION, grey, sample_color};
use super::{
    GridRay, ImageBand, RaySetup, RenderImage, RenderOptions, RenderStats, RowRays,
    TransferFunction, VolumeMode, VolumeOptions, VolumeScene, clip_hits,
};
use crate::camera::Camera;
use crate::error::Result;

/// Entries of the transfer function's table for compositing.
pub const TF_TABLE: usize = 4096;

/// Rows of the intermediate image per parallel task: 32 rather than 16
/// reads a tenth fewer slab rows twice (the rows two bands share), for a
/// frame about 7% faster (docs/performance-notes.md).
const BAND: usize = 32;
// A band's rows are bits of a `u32` (`Layer::rows`).
const _: () = assert!(BAND <= 32);

/// The factorization of the view into a shear (per slice) and a warp.
#[derive(Clone, Copy, Debug)]
struct Factor {
    /// Principal axis, then the in-plane axes (`a` the one stored with the
    /// smaller stride).
    c: usize,
    a: usize,
    b: usize,
    /// Slices in depth order: `front + q·step` for `q < n`.
    front: i32,
    step: i32,
    n: i32,
    /// Orthographic: the ray direction in grid space; perspective: the eye.
    dir: Option<DVec3>,
    eye: DVec3,
    /// The intermediate image: pixel `(i, j)` is base-plane point
    /// `(u0 + i, v0 + j)`.
    u0: f64,
    v0: f64,
    w: usize,
    h: usize,
    dims: [i32; 3],
}

impl Factor {
    /// The factorization for `camera` over a volume of `dims`, `None` where
    /// it does not exist (a perspective eye inside the volume's box).
    fn new(setup: &RaySetup, dims: [i32; 3]) -> Option<Factor> {
        let lo = DVec3::splat(-0.5);
        let hi = DVec3::from_array(dims.map(|d| d as f64 - 0.5));
        let (c, dir, eye) = if setup.ortho {
            let d = setup.f;
            let c = (0..3).max_by(|&i, &j| d[i].abs().total_cmp(&d[j].abs()))?;
            (c, Some(d), DVec3::ZERO)
        } else {
            let e = setup.o;
            let corners: Vec<DVec3> = (0..8)
                .map(|m| {
                    DVec3::new(
                        if m & 1 == 0 { lo.x } else { hi.x },
                        if m & 2 == 0 { lo.y } else { hi.y },
                        if m & 4 == 0 { lo.z } else { hi.z },
                    )
                })
                .collect();
            let c = (0..3)
                .filter(|&k| e[k] < lo[k] || e[k] > hi[k])
                .map(|k| {
                    let worst = corners
                        .iter()
                        .map(|p| (p[k] - e[k]).abs() / (*p - e).length())
                        .fold(f64::INFINITY, f64::min);
                    (k, worst)
                })
                .max_by(|x, y| x.1.total_cmp(&y.1))?
                .0;
            (c, None, e)
        };
        let (a, b) = match c {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let n = dims[c];
        let forward = match dir {
            Some(d) => d[c] > 0.0,
            None => eye[c] < 0.0,
        };
        let (front, step) = if forward { (0, 1) } else { (n - 1, -1) };
        let mut f = Factor {
            c,
            a,
            b,
            front,
            step,
            n,
            dir,
            eye,
            u0: 0.0,
            v0: 0.0,
            w: 0,
            h: 0,
            dims,
        };
        // The intermediate image spans every slice's footprint (the
        // footprints' edges move monotonically with the slice).
        let (mut umin, mut umax, mut vmin, mut vmax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for k in [front, front + step * (n - 1)] {
            let (s, ta, tb) = f.slice(k);
            for (lo_x, hi_x, t, mn, mx) in [
                (lo[a], hi[a], ta, &mut umin, &mut umax),
                (lo[b], hi[b], tb, &mut vmin, &mut vmax),
            ] {
                for p in [lo_x, hi_x] {
                    *mn = mn.min(s * p + t);
                    *mx = mx.max(s * p + t);
                }
            }
        }
        f.u0 = umin.floor();
        f.v0 = vmin.floor();
        f.w = (umax.ceil() - f.u0) as usize + 1;
        f.h = (vmax.ceil() - f.v0) as usize + 1;
        Some(f)
    }

    /// Slice `k` onto the base plane: `(u, v) = s·(a, b) + (ta, tb)`.
    #[inline]
    fn slice(&self, k: i32) -> (f64, f64, f64) {
        let (k0, k) = (self.front as f64, k as f64);
        match self.dir {
            Some(d) => {
                let r = (k0 - k) / d[self.c];
                (1.0, d[self.a] * r, d[self.b] * r)
            }
            None => {
                let e = self.eye;
                let s = (k0 - e[self.c]) / (k - e[self.c]);
                (s, e[self.a] * (1.0 - s), e[self.b] * (1.0 - s))
            }
        }
    }

    /// The row coordinate `b` where intermediate row `j` crosses the slice
    /// of offset `tb` and scale `1/inv` ([`Factor::slice`]), if it crosses
    /// the slice's voxel squares: the one test of whether a row takes a
    /// sample from a slice (the shear and the MIP's brick skip both ask).
    #[inline(always)]
    fn slice_row(&self, j: usize, tb: f64, inv: f64) -> Option<f64> {
        let b = (self.v0 + j as f64 - tb) * inv;
        (b >= -0.5 && b <= self.dims[self.b] as f64 - 0.5).then_some(b)
    }

    /// The grid point of slice `k` on the intermediate ray of pixel
    /// `(i, j)` (its base-plane point moved along the view).
    fn point(&self, i: f64, j: f64, k: i32) -> DVec3 {
        let (s, ta, tb) = self.slice(k);
        let mut p = DVec3::ZERO;
        p[self.c] = k as f64;
        p[self.a] = (self.u0 + i - ta) / s;
        p[self.b] = (self.v0 + j - tb) / s;
        p
    }
}

/// The transfer function as a table: opacity, `ln(1 − τ)` and colour per
/// entry, over `[lo, lo + (TF_TABLE − 1)/scale]`.
struct TfTable {
    lo: f32,
    scale: f32,
    /// Per entry `[ln(1 − τ), r, g, b]`, with `ln(1 − τ) = −∞` where
    /// `τ ≥ 1` (the only use of `τ` itself, [`CompositeBand::blend`]'s
    /// test for a full opacity, reads it back from that): one 16-byte
    /// entry a sample.
    entries: Vec<[f32; 4]>,
    /// Per entry `e`, the entries before it with `τ > 0`
    /// (`TF_TABLE + 1` counts): entries `e0..=e1` are all transparent
    /// where the counts at `e0` and `e1 + 1` agree.
    opaque_before: Vec<u32>,
    /// Whether every entry's colour is a grey (`r = g = b`, bit for bit),
    /// as a transfer function without colours gives: compositing then
    /// blends one colour channel and copies it to the others, the same
    /// sums with a third of the colour work.
    grey: bool,
    /// Where grey, per entry `[ln(1 − τ), grey]`: the half of each entry
    /// the grey blend reads, 32 KiB, which stays in the first-level cache
    /// where the full entries (64 KiB) did not; empty otherwise.
    pairs: Vec<[f32; 2]>,
    /// `Some(y)`: every pixel's stretch is `y` (an orthographic view), and
    /// the first value of each entry (and pair) holds the corrected opacity
    /// `α` for it ([`TfTable::for_stretch`]) instead of `ln(1 − τ)`.
    stretch: Option<f32>,
}

impl TfTable {
    fn new(tf: &TransferFunction, window: (f32, f32)) -> TfTable {
        let p = tf.points();
        let lo = p[0].value.min(window.0);
        let hi = p[p.len() - 1].value.max(window.1);
        let span = if hi > lo { hi - lo } else { 1.0 };
        let scale = (TF_TABLE - 1) as f32 / span;
        let value = |e: usize| lo + e as f32 / scale;
        let tau: Vec<f32> = (0..TF_TABLE).map(|e| tf.opacity(value(e))).collect();
        let entries: Vec<[f32; 4]> = tau
            .iter()
            .enumerate()
            .map(|(e, &t)| {
                let ln = if t < 1.0 {
                    ln_one_minus(t)
                } else {
                    f32::NEG_INFINITY
                };
                let [r, g, b] = sample_color(tf, window, value(e));
                [ln, r, g, b]
            })
            .collect();
        let opaque_before = std::iter::once(0)
            .chain(tau.iter().scan(0, |n, &t| {
                *n += u32::from(t > 0.0);
                Some(*n)
            }))
            .collect();
        let grey = entries
            .iter()
            .all(|&[_, r, g, b]| r.to_bits() == g.to_bits() && r.to_bits() == b.to_bits());
        let pairs = if grey {
            entries.iter().map(|&[ln, c, _, _]| [ln, c]).collect()
        } else {
            Vec::new()
        };
        TfTable {
            lo,
            scale,
            entries,
            opaque_before,
            grey,
            pairs,
            stretch: None,
        }
    }

    /// The table for a view whose every pixel has the stretch `y`: each
    /// entry's `α` ([`entry_alpha`]) found once, by the operations
    /// [`CompositeBand::blend`] would apply to every sample taking the
    /// entry, so the same bits, and the exponential leaves the blend.
    fn for_stretch(mut self, y: f32) -> TfTable {
        for e in &mut self.entries {
            e[0] = entry_alpha(e[0], y);
        }
        for p in &mut self.pairs {
            p[0] = entry_alpha(p[0], y);
        }
        self.stretch = Some(y);
        self
    }

    #[inline(always)]
    fn entry(&self, s: f32) -> usize {
        // Saturating casts: −∞ and NaN take entry 0.
        (((s - self.lo) * self.scale + 0.5) as usize).min(TF_TABLE - 1)
    }

    /// Whether every sample in `[min, max]` is transparent (none is where
    /// `min > max`): [`TfTable::entry`] never falls as its sample rises
    /// (each of its roundings is monotone), so such samples read only
    /// entries `entry(min)..=entry(max)`, and those have `τ = 0`, which
    /// adds exactly nothing to a pixel. Exact, not conservative: it asks
    /// the same operations the look-up makes (`clear_is_the_lookup`).
    #[inline]
    fn clear(&self, min: f32, max: f32) -> bool {
        let (e0, e1) = (self.entry(min), self.entry(max));
        e1 < e0 || self.opaque_before[e1 + 1] == self.opaque_before[e0]
    }
}

/// The corrected opacity for stretch `y` of a table entry holding
/// `ln(1 − τ)`: `τ ≥ 1` exactly where that is `−∞`, and any `τ < 1` serves
/// the others (the test is the only use of `τ`). One rule for the blend
/// and for [`TfTable::for_stretch`], so their bits agree.
#[inline(always)]
fn entry_alpha(ln_tau: f32, y: f32) -> f32 {
    let tau = if ln_tau == f32::NEG_INFINITY {
        1.0
    } else {
        0.0
    };
    corrected_opacity_from_log(tau, ln_tau, y)
}

/// One slice row of the volume resampled along `a` for one slice: the
/// bilinear's first step.
struct Row {
    /// The row's `b` coordinate, `−1` if none is held.
    b: i32,
    vals: Vec<f32>,
    min: f32,
    max: f32,
}

/// The per-slice geometry along `a`: for intermediate columns `lo..hi`,
/// the voxel column `a0` and the weight of `a0 + 1` (indexed from `lo`).
struct Columns {
    lo: usize,
    hi: usize,
    a0: Vec<u32>,
    fa: Vec<f32>,
    /// The longest stretch `run.0..run.1` (indexed from `lo`) over which
    /// `a0` rises by one a column and `fa` is the same bit for bit: an
    /// orthographic slice's interior, where the shear is a translation.
    /// There the resampling reads contiguous samples with one weight.
    run: (usize, usize),
    /// Per brick along `a` (voxels `8·t..8·t + 8`), the first column
    /// (indexed from `lo`) whose `a0` lies in it or beyond: brick `t`'s
    /// columns are `starts[t]..starts[t + 1]` (`a0` never falls).
    starts: Vec<u32>,
}

impl Columns {
    /// Slice `q`'s columns: `a = (u0 + i − ta)/s` within its voxel squares
    /// (`−½ ≤ a ≤ n_a − ½`), clamped to the voxel centres.
    fn of(f: &Factor, q: i32) -> Columns {
        let (s, ta, _) = f.slice(f.front + q * f.step);
        let inv = 1.0 / s;
        let na = f.dims[f.a];
        let (mut a0, mut fa) = (Vec::new(), Vec::new());
        let (mut lo, mut hi) = (f.w, 0);
        for i in 0..f.w {
            let a = (f.u0 + i as f64 - ta) * inv;
            if a >= -0.5 && a <= na as f64 - 0.5 {
                // `ac ≥ 0`: truncation is the floor.
                let ac = a.clamp(0.0, (na - 1) as f64);
                let i0 = ac as u32;
                if lo > i {
                    lo = i;
                }
                hi = i + 1;
                a0.push(i0);
                fa.push((ac - i0 as f64) as f32);
            }
        }
        let run = affine_run(&a0, &fa);
        let bricks = (na as u32).div_ceil(BRICK as u32);
        let starts = (0..=bricks)
            .map(|t| a0.partition_point(|&x| x < t * BRICK as u32) as u32)
            .collect();
        Columns {
            lo,
            hi,
            a0,
            fa,
            run,
            starts,
        }
    }
}

/// The longest stretch `i0..i1` with `a0[i] = a0[i0] + (i − i0)` and
/// `fa[i] = fa[i0]` (bit for bit); `(0, 0)` if none is longer than one.
fn affine_run(a0: &[u32], fa: &[f32]) -> (usize, usize) {
    let (mut best, mut start) = ((0, 0), 0);
    for i in 1..=a0.len() {
        let extends =
            i < a0.len() && a0[i] == a0[i - 1] + 1 && fa[i].to_bits() == fa[start].to_bits();
        if !extends {
            if i - start > (best.1 - best.0).max(1) {
                best = (start, i);
            }
            start = i;
        }
    }
    best
}

/// What the intermediate image holds per pixel.
trait Accumulate: Send {
    /// Adds slice `q`'s samples at columns `lo..lo + v0.len()` of
    /// intermediate row `row`: `v0 + fb·(v1 − v0)`, the bilinear's second
    /// step between two resampled slice rows (taken here, so no sample
    /// is stored on its way); returns the samples taken.
    fn add(&mut self, row: usize, lo: usize, v: [&[f32]; 2], fb: f32, q: u16) -> u64;
    /// Whether a sample at columns `lo..hi` of row `row` may still change
    /// a pixel.
    fn live(&self, _row: usize, _lo: usize, _hi: usize) -> bool {
        true
    }
    /// Notes that columns `lo..hi` of intermediate row `row` cross slice
    /// squares (sampled or passed over as transparent).
    fn cover(&mut self, row: usize, lo: usize, hi: usize);
    /// Where samples no larger than a floor change no pixel (MIP): fills
    /// `out` (one per column) with the smallest running value over the
    /// band's rows in the mask `rows` (bit `r` for row `r`; `+∞` if none)
    /// and returns `true`; `false` (and `out` untouched) for accumulators
    /// that every sample may change.
    fn floor(&self, _rows: u32, _out: &mut [f32]) -> bool {
        false
    }
    /// Whether every pixel at columns `cols` of the band's rows in the
    /// mask `rows` (bit `r` for row `r`) is past any change (compositing:
    /// past [`EARLY_TERMINATION`]); `false` for accumulators whose pixels
    /// never are.
    fn finished(&self, _rows: u32, _cols: std::ops::Range<usize>) -> bool {
        false
    }
}

/// MIP: the running maximum (`−∞` before any sample) and the slice that
/// first holds it.
struct MipBand {
    w: usize,
    m: Vec<f32>,
    q: Vec<u16>,
}

impl Accumulate for MipBand {
    #[inline(always)]
    fn add(&mut self, row: usize, lo: usize, [v0, v1]: [&[f32]; 2], fb: f32, q: u16) -> u64 {
        let (o, n) = (row * self.w + lo, v0.len());
        let (m, qs) = (&mut self.m[o..o + n], &mut self.q[o..o + n]);
        for (((m, qq), &x0), &x1) in m.iter_mut().zip(qs.iter_mut()).zip(v0).zip(&v1[..n]) {
            let v = x0 + fb * (x1 - x0);
            let up = v > *m;
            *m = if up { v } else { *m };
            *qq = if up { q } else { *qq };
        }
        n as u64
    }

    /// A MIP pixel is covered once it holds a sample (`m > −∞`; a pixel
    /// whose samples are all `−∞` shows the window's low end either way).
    fn cover(&mut self, _: usize, _: usize, _: usize) {}

    /// A sample changes a pixel only where it exceeds the running maximum
    /// (`v > m`): the column minima of `m` over the band's rows.
    fn floor(&self, rows: u32, out: &mut [f32]) -> bool {
        out.fill(f32::INFINITY);
        for (r, row) in self.m.chunks_exact(self.w).enumerate() {
            if rows >> r & 1 == 1 {
                for (o, &x) in out.iter_mut().zip(row) {
                    *o = if x < *o { x } else { *o };
                }
            }
        }
        true
    }
}

/// Compositing: premultiplied colour and opacity, the first slice with
/// `α > 0`, and the stretch (in reference lengths) per pixel.
struct CompositeBand<'a> {
    w: usize,
    /// Red, green, blue (premultiplied) and opacity; green and blue empty
    /// where the table is grey (red stands for all three).
    rgba: [Vec<f32>; 4],
    q: Vec<u16>,
    y: Vec<f32>,
    /// Pixels whose ray crosses the volume.
    seen: Vec<bool>,
    /// Per row, its chunks of [`CHUNK`] pixels all past
    /// [`EARLY_TERMINATION`].
    done: Vec<bool>,
    table: &'a TfTable,
    /// Look the table up in AVX2 registers ([`lookup_avx2`]; detected).
    avx2: bool,
}

/// Pixels per chunk of a compositing row: a chunk whose pixels have all
/// reached [`EARLY_TERMINATION`] is passed over.
const CHUNK: usize = 32;

/// The most pixels one [`CompositeBand::blend`] takes: up to four
/// neighbouring chunks still live, so that the call's fixed cost (the
/// look-up's set-up, the loops' ends) is spread over more samples while
/// termination keeps the chunk's finer grain. Measured on the translucent
/// 512³ shell: blends of 64 and 128 pixels ~10% faster than of 32; chunks
/// of 128 would have passed over fewer pixels (twice the samples under an
/// opaque table, and slower).
const RUN: usize = 4 * CHUNK;

impl CompositeBand<'_> {
    /// Front-to-back over the pixels `o..o + vals.len()` (at most a
    /// [`RUN`]; lane by lane: every pixel's chain is its own; a pixel past
    /// [`EARLY_TERMINATION`] takes `α = 0`, which adds exactly nothing).
    /// `GREY`: the table is grey ([`TfTable::grey`]), and only red and
    /// opacity are kept. `ALPHA`: the table holds each entry's `α` for
    /// every pixel's stretch ([`TfTable::for_stretch`]).
    #[inline(always)]
    fn blend<const GREY: bool, const ALPHA: bool>(&mut self, o: usize, vals: &[f32], q: u16) {
        let n = vals.len().min(RUN);
        let t = self.table;
        // The table's entries first (loads by index), then the arithmetic
        // over contiguous lanes, which vectorises.
        let (mut ln_tau, mut col) = ([0f32; RUN], [[0f32; RUN]; 3]);
        #[cfg(target_arch = "x86_64")]
        let looked_up = self.avx2 && {
            // SAFETY: `avx2` is set only where the CPU has AVX2.
            unsafe {
                if GREY {
                    lookup_grey_avx2(t, &vals[..n], &mut ln_tau, &mut col[0]);
                } else {
                    lookup_avx2(t, &vals[..n], &mut ln_tau, &mut col);
                }
            }
            true
        };
        #[cfg(not(target_arch = "x86_64"))]
        let looked_up = false;
        if !looked_up {
            for (k, &s) in vals[..n].iter().enumerate() {
                if GREY {
                    [ln_tau[k], col[0][k]] = t.pairs[t.entry(s)];
                } else {
                    [ln_tau[k], col[0][k], col[1][k], col[2][k]] = t.entries[t.entry(s)];
                }
            }
        }
        let [r, g, b, a] = &mut self.rgba;
        let (r, a) = (&mut r[o..o + n], &mut a[o..o + n]);
        // Grey: green and blue are empty, and never touched.
        let (g, b) = if GREY {
            (&mut [][..], &mut [][..])
        } else {
            (&mut g[o..o + n], &mut b[o..o + n])
        };
        let (qs, ys) = (&mut self.q[o..o + n], &self.y[o..o + n]);
        for k in 0..n {
            let alpha = if ALPHA {
                ln_tau[k]
            } else {
                entry_alpha(ln_tau[k], ys[k])
            };
            let alpha = if a[k] < EARLY_TERMINATION { alpha } else { 0.0 };
            let wgt = (1.0 - a[k]) * alpha;
            r[k] += wgt * col[0][k];
            if !GREY {
                g[k] += wgt * col[1][k];
                b[k] += wgt * col[2][k];
            }
            a[k] += wgt;
            qs[k] = if qs[k] == u16::MAX && alpha > 0.0 {
                q
            } else {
                qs[k]
            };
        }
    }
}

/// The table's entries for `vals` (at most a [`RUN`]) as the scalar
/// loop of [`CompositeBand::blend`] reads them, eight lanes at a time
/// without gathers: the entry index as the scalar's ([`entries_avx2`]),
/// then each entry's 16 bytes by one load, two entries to a register
/// (lanes `i + k` and `i + k + 4`), and a 4×4 transpose within each
/// 128-bit half puts
/// `ln(1 − τ)`, `r`, `g`, `b` of the eight samples in order. Lanes from
/// `vals.len()` to the next multiple of eight are overwritten as scratch.
/// Called only where the CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn lookup_avx2(t: &TfTable, vals: &[f32], ln_tau: &mut [f32; RUN], col: &mut [[f32; RUN]; 3]) {
    use std::arch::x86_64::*;
    let n = vals.len().min(RUN);
    let mut padded = [0f32; RUN];
    padded[..n].copy_from_slice(&vals[..n]);
    let mut idx = [0u32; RUN];
    assert!(t.entries.len() == TF_TABLE);
    let entries = t.entries.as_ptr().cast::<f32>();
    let [rs, gs, bs] = col;
    for i in (0..n).step_by(8) {
        // SAFETY: `i` is a multiple of 8 below `n ≤ RUN` (a multiple of
        // 8), so `i + 8 ≤ RUN` and every load and store stays in the arrays;
        // each index is in `0..TF_TABLE` ([`entries_avx2`]), so each
        // entry's 16 bytes lie in the table (asserted length).
        unsafe {
            let at = entries_avx2(t, _mm256_loadu_ps(padded.as_ptr().add(i)));
            _mm256_storeu_si256(idx.as_mut_ptr().add(i).cast(), at);
            let entry = |k: usize| _mm_loadu_ps(entries.add(4 * idx[i + k] as usize));
            let pair = |k: usize| _mm256_set_m128(entry(k + 4), entry(k));
            let (a, b, c, d) = (pair(0), pair(1), pair(2), pair(3));
            let (ab_lo, ab_hi) = (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
            let (cd_lo, cd_hi) = (_mm256_unpacklo_ps(c, d), _mm256_unpackhi_ps(c, d));
            let part = |x: __m256, y: __m256, hi: bool| {
                let (x, y) = (_mm256_castps_pd(x), _mm256_castps_pd(y));
                _mm256_castpd_ps(if hi {
                    _mm256_unpackhi_pd(x, y)
                } else {
                    _mm256_unpacklo_pd(x, y)
                })
            };
            _mm256_storeu_ps(ln_tau.as_mut_ptr().add(i), part(ab_lo, cd_lo, false));
            _mm256_storeu_ps(rs.as_mut_ptr().add(i), part(ab_lo, cd_lo, true));
            _mm256_storeu_ps(gs.as_mut_ptr().add(i), part(ab_hi, cd_hi, false));
            _mm256_storeu_ps(bs.as_mut_ptr().add(i), part(ab_hi, cd_hi, true));
        }
    }
}

/// [`TfTable::entry`] of eight samples by the same `f32` operations,
/// clamped as its saturating cast and `min` clamp it: NaN and negatives to
/// entry 0, all beyond the table to its last. Every lane is in
/// `0..TF_TABLE`. Called only where the CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn entries_avx2(t: &TfTable, s: std::arch::x86_64::__m256) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    let (lo, scale, half) = (
        _mm256_set1_ps(t.lo),
        _mm256_set1_ps(t.scale),
        _mm256_set1_ps(0.5),
    );
    let (zero, last) = (_mm256_setzero_ps(), _mm256_set1_ps((TF_TABLE - 1) as f32));
    let x = _mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(s, lo), scale), half);
    // `max` yields its second operand for a NaN: entry 0.
    let x = _mm256_min_ps(_mm256_max_ps(x, zero), last);
    _mm256_cvttps_epi32(x)
}

/// [`lookup_avx2`] for a grey table ([`TfTable::grey`]): `ln(1 − τ)` and
/// the one colour of each entry from the table's
/// [`pairs`](TfTable::pairs), one eight-byte load an entry, two entries
/// to a 128-bit half, and one shuffle each for the two values (lanes in
/// order: the halves hold entries `i..i + 4` and `i + 4..i + 8`). Faster
/// than two gathers of eight lanes on the Emerald Rapids VM. Lanes from
/// `vals.len()` to the next multiple of eight are overwritten as scratch.
/// Called only where the CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn lookup_grey_avx2(t: &TfTable, vals: &[f32], ln_tau: &mut [f32; RUN], grey: &mut [f32; RUN]) {
    use std::arch::x86_64::*;
    let n = vals.len().min(RUN);
    let mut padded = [0f32; RUN];
    padded[..n].copy_from_slice(&vals[..n]);
    assert!(t.pairs.len() == TF_TABLE);
    let pairs = t.pairs.as_ptr().cast::<f32>();
    let mut idx = [0u32; RUN];
    for i in (0..n).step_by(8) {
        // SAFETY: `i` is a multiple of 8 below `n ≤ RUN` (a multiple of
        // 8), so `i + 8 ≤ RUN` and every load and store stays in the arrays;
        // each index is in `0..TF_TABLE` ([`entries_avx2`]), so the eight
        // bytes at float `2·index` lie in the pairs (asserted length).
        unsafe {
            let at = entries_avx2(t, _mm256_loadu_ps(padded.as_ptr().add(i)));
            _mm256_storeu_si256(idx.as_mut_ptr().add(i).cast(), at);
            // Entries k and k + 1 in one 128-bit register.
            let two = |k: usize| {
                let lo = _mm_load_sd(pairs.add(2 * idx[i + k] as usize).cast());
                _mm_castpd_ps(_mm_loadh_pd(
                    lo,
                    pairs.add(2 * idx[i + k + 1] as usize).cast(),
                ))
            };
            let (x, y) = (
                _mm256_set_m128(two(4), two(0)),
                _mm256_set_m128(two(6), two(2)),
            );
            let ln = _mm256_shuffle_ps::<0b10_00_10_00>(x, y);
            let c = _mm256_shuffle_ps::<0b11_01_11_01>(x, y);
            _mm256_storeu_ps(ln_tau.as_mut_ptr().add(i), ln);
            _mm256_storeu_ps(grey.as_mut_ptr().add(i), c);
        }
    }
}

impl CompositeBand<'_> {
    /// [`Accumulate::add`], each sample's `α` computed from its stretch
    /// or, with `ALPHA`, looked up ([`TfTable::for_stretch`]).
    #[inline(always)]
    fn add_runs<const ALPHA: bool>(
        &mut self,
        row: usize,
        lo: usize,
        [v0, v1]: [&[f32]; 2],
        fb: f32,
        q: u16,
    ) -> u64 {
        debug_assert_eq!(ALPHA, self.table.stretch.is_some());
        let chunks = self.w.div_ceil(CHUNK);
        let (hi, mut n) = (lo + v0.len(), 0);
        let row_done = row * chunks;
        let mut vals = [0f32; RUN];
        let (mut c, c_end) = (lo / CHUNK, hi.div_ceil(CHUNK));
        while c < c_end {
            if self.done[row_done + c] {
                c += 1;
                continue;
            }
            // A run of live chunks, blended in one call.
            let first = c;
            while c < c_end && c - first < RUN / CHUNK && !self.done[row_done + c] {
                c += 1;
            }
            let (x0, x1) = ((first * CHUNK).max(lo), (c * CHUNK).min(hi));
            let vals = &mut vals[..x1 - x0];
            for ((v, &a), &b) in vals.iter_mut().zip(&v0[x0 - lo..]).zip(&v1[x0 - lo..]) {
                *v = a + fb * (b - a);
            }
            if self.table.grey {
                self.blend::<true, ALPHA>(row * self.w + x0, vals, q);
            } else {
                self.blend::<false, ALPHA>(row * self.w + x0, vals, q);
            }
            n += (x1 - x0) as u64;
            let alpha = &self.rgba[3][row * self.w..(row + 1) * self.w];
            for k in first..c {
                let pixels = &alpha[k * CHUNK..((k + 1) * CHUNK).min(self.w)];
                self.done[row_done + k] = pixels.iter().all(|&a| a >= EARLY_TERMINATION);
            }
        }
        n
    }
}

impl Accumulate for CompositeBand<'_> {
    #[inline(always)]
    fn add(&mut self, row: usize, lo: usize, v: [&[f32]; 2], fb: f32, q: u16) -> u64 {
        self.add_runs::<false>(row, lo, v, fb, q)
    }

    fn live(&self, row: usize, lo: usize, hi: usize) -> bool {
        let chunks = self.w.div_ceil(CHUNK);
        (lo / CHUNK..hi.div_ceil(CHUNK)).any(|c| !self.done[row * chunks + c])
    }

    fn cover(&mut self, row: usize, lo: usize, hi: usize) {
        let o = row * self.w;
        self.seen[o + lo..o + hi].fill(true);
    }

    /// Done chunks take no sample ([`CompositeBand::add_runs`] passes
    /// them over), and a chunk once done stays done.
    fn finished(&self, rows: u32, cols: std::ops::Range<usize>) -> bool {
        // (`checked_div`: a band of no columns has no rows to test.)
        (0..self.q.len().checked_div(self.w).unwrap_or(0))
            .filter(|r| rows >> r & 1 == 1)
            .all(|r| !self.live(r, cols.start, cols.end))
    }
}

/// A compositing band whose table holds each entry's `α` for every
/// pixel's one stretch ([`TfTable::for_stretch`]). A type of its own, so
/// that the shear compiled for it and the one for per-sample opacities
/// each hold only their own blends (one shear holding both ran the
/// perspective frame ~15% slower).
struct LookedUpAlpha<'b, 'a>(&'b mut CompositeBand<'a>);

impl Accumulate for LookedUpAlpha<'_, '_> {
    #[inline(always)]
    fn add(&mut self, row: usize, lo: usize, v: [&[f32]; 2], fb: f32, q: u16) -> u64 {
        self.0.add_runs::<true>(row, lo, v, fb, q)
    }

    fn live(&self, row: usize, lo: usize, hi: usize) -> bool {
        self.0.live(row, lo, hi)
    }

    fn finished(&self, rows: u32, cols: std::ops::Range<usize>) -> bool {
        self.0.finished(rows, cols)
    }

    fn cover(&mut self, row: usize, lo: usize, hi: usize) {
        self.0.cover(row, lo, hi);
    }
}

/// Renders `scene` by shear-warp (see the [module docs](self)); `None` if
/// the view has no factorization or the mode is an iso-surface, an error
/// if its buffers would exceed `opts.limit`.
pub(crate) fn render(
    scene: &VolumeScene,
    camera: &Camera,
    opts: &RenderOptions,
    vopts: &VolumeOptions,
) -> Result<Option<(RenderImage, RenderStats)>> {
    let tuning = Tuning {
        slab_cap: SLAB_CAP,
        skip: true,
        grey: true,
        alpha_table: true,
        #[cfg(target_arch = "x86_64")]
        avx2: std::arch::is_x86_feature_detected!("avx2"),
        #[cfg(target_arch = "x86_64")]
        avx512: std::arch::is_x86_feature_detected!("avx512f"),
    };
    render_with(scene, camera, opts, vopts, tuning)
}

/// How the shear runs (never what it computes): the slab cap in floats,
/// and whether the CPU's AVX2 and AVX-512 registers may be used.
#[derive(Clone, Copy, Debug)]
struct Tuning {
    slab_cap: usize,
    /// Pass over the bricks no pixel of a band can take: for MIP, those
    /// below every running maximum that reads them; for compositing,
    /// those the transfer function makes transparent.
    skip: bool,
    /// Blend one colour channel where the table is grey
    /// ([`TfTable::grey`]).
    grey: bool,
    /// Look each sample's `α` up where every pixel's stretch is the same
    /// (orthographic views; [`TfTable::for_stretch`]).
    alpha_table: bool,
    #[cfg(target_arch = "x86_64")]
    avx2: bool,
    /// The shear compiled for AVX-512 (with `avx2`) and its perspective
    /// resampling by permutes ([`lerp_gathered_avx512`]).
    #[cfg(target_arch = "x86_64")]
    avx512: bool,
}

/// The bytes shear-warp holds beside the volume and the image: the
/// intermediate image (and its copy for the warp), the per-slice column tables (and brick starts) and
/// each thread's rows, column floors and slab.
fn working_bytes(f: &Factor, table: Option<&TfTable>, threads: usize, slab_cap: usize) -> u128 {
    let (w, h, n) = (f.w as u128, f.h as u128, f.n as u128);
    let composite = table.is_some();
    // MIP: maximum and slice; compositing: colour (one channel if grey)
    // and opacity, slice, stretch, seen (and a flag per chunk).
    let per_pixel = match table {
        None => 6,
        Some(t) if t.grey => 16,
        Some(_) => 24,
    };
    let row = f.dims[f.a] as u128 + 1;
    let slab = (slab_cap as u128).min(8 * f.dims[f.b] as u128 * row);
    let per_thread = 4 * (3 * w + 2 * row + slab);
    let starts = 4 * (row / 8 + 2);
    // The warp's source: channels and coverage, and the hit slice.
    let pad = 2 * PAD as u128;
    let source = (w + pad) * (h + pad) * if composite { 22 } else { 10 };
    w * h * per_pixel + source + n * (w * 8 + starts) + threads as u128 * per_thread
}

/// [`render`] as `tuning` says.
fn render_with(
    scene: &VolumeScene,
    camera: &Camera,
    opts: &RenderOptions,
    vopts: &VolumeOptions,
    tuning: Tuning,
) -> Result<Option<(RenderImage, RenderStats)>> {
    let slab_cap = tuning.slab_cap;
    if matches!(vopts.mode, VolumeMode::Iso(_)) {
        return Ok(None);
    }
    let start = Instant::now();
    let dims = scene.dims().map(|d| d as i32);
    let hi = IVec3::from_array(dims) - 1;
    let setup = RaySetup::new(
        camera,
        scene.transform(),
        Some((IVec3::ZERO, hi)),
        opts.width,
        opts.height,
    );
    let Some(f) = Factor::new(&setup, dims) else {
        return Ok(None);
    };
    if f.n > u16::MAX as i32 - 1 {
        return Ok(None);
    }
    let composite = vopts.mode == VolumeMode::Composite;
    let threads = rayon::current_num_threads();
    // Every pixel's stretch between slices, in an orthographic view.
    let y_ortho = f
        .dir
        .map(|d| (1.0 / (d[f.c].abs() * scene.reference_length())) as f32);
    let table = composite.then(|| {
        let mut t = TfTable::new(&vopts.transfer, vopts.window);
        t.grey &= tuning.grey;
        match y_ortho {
            Some(y) if tuning.alpha_table => t.for_stretch(y),
            _ => t,
        }
    });
    opts.limit.check(
        "shear-warp intermediate image",
        working_bytes(&f, table.as_ref(), threads, slab_cap),
        1,
    )?;
    let columns: Vec<Columns> = (0..f.n)
        .into_par_iter()
        .map(|q| Columns::of(&f, q))
        .collect();
    #[cfg(target_arch = "x86_64")]
    let gather = if tuning.avx512 {
        Gather::Avx512
    } else if tuning.avx2 {
        Gather::Avx2
    } else {
        Gather::Scalar
    };
    #[cfg(not(target_arch = "x86_64"))]
    let gather = Gather::Scalar;
    let shear_job = |table| Shear {
        scene,
        f: &f,
        columns: &columns,
        table,
        slab_cap,
        skip: tuning.skip,
        gather,
    };
    #[cfg(target_arch = "x86_64")]
    let avx2 = tuning.avx2;
    #[cfg(not(target_arch = "x86_64"))]
    let avx2 = false;
    let mut image = Intermediate::new(&f, table.as_ref(), avx2);
    let sheared: Sheared = match &mut image {
        Intermediate::Mip(m) => m
            .par_iter_mut()
            .enumerate()
            .map(|(band, acc)| shear_as(tuning, &shear_job(None), band * BAND, acc))
            .sum(),
        Intermediate::Composite(c) => c
            .par_iter_mut()
            .enumerate()
            .map(|(band, acc)| {
                fill_stretches(scene, &f, band * BAND, y_ortho, acc);
                let job = shear_job(table.as_ref());
                if acc.table.stretch.is_some() {
                    shear_as(tuning, &job, band * BAND, &mut LookedUpAlpha(acc))
                } else {
                    shear_as(tuning, &job, band * BAND, acc)
                }
            })
            .sum(),
    };
    let (img, hits) = warp(tuning, &setup, &f, &image, opts, vopts);
    let stats = RenderStats {
        rays: opts.width as u64 * opts.height as u64,
        hits,
        voxels_visited: sheared.samples,
        bricks_skipped: sheared.passed,
        render_ms: start.elapsed().as_secs_f64() * 1e3,
        shear_warp: true,
        ..RenderStats::default()
    };
    Ok(Some((img, stats)))
}

/// The intermediate image in bands of [`BAND`] rows.
enum Intermediate<'a> {
    Mip(Vec<MipBand>),
    Composite(Vec<CompositeBand<'a>>),
}

impl<'a> Intermediate<'a> {
    fn new(f: &Factor, table: Option<&'a TfTable>, avx2: bool) -> Self {
        let bands = f.h.div_ceil(BAND);
        let len = |band: usize| f.w * BAND.min(f.h - band * BAND);
        match table {
            None => Intermediate::Mip(
                (0..bands)
                    .map(|band| MipBand {
                        w: f.w,
                        m: vec![f32::NEG_INFINITY; len(band)],
                        q: vec![u16::MAX; len(band)],
                    })
                    .collect(),
            ),
            Some(table) => Intermediate::Composite(
                (0..bands)
                    .map(|band| CompositeBand {
                        w: f.w,
                        rgba: std::array::from_fn(|c| {
                            let kept = !(table.grey && (c == 1 || c == 2));
                            vec![0.0; if kept { len(band) } else { 0 }]
                        }),
                        q: vec![u16::MAX; len(band)],
                        y: vec![0.0; len(band)],
                        seen: vec![false; len(band)],
                        done: vec![false; len(band) / f.w * f.w.div_ceil(CHUNK)],
                        table,
                        avx2,
                    })
                    .collect(),
            ),
        }
    }
}

/// The stretch between slices, in reference lengths, for each pixel of a
/// compositing band: constant for orthographic views (`y_ortho`), per
/// intermediate ray for perspective ones.
fn fill_stretches(
    scene: &VolumeScene,
    f: &Factor,
    j0: usize,
    y_ortho: Option<f32>,
    band: &mut CompositeBand,
) {
    if let Some(y) = y_ortho {
        band.y.fill(y);
        return;
    }
    let axes = scene.transform().axes;
    let inv_ref = 1.0 / scene.reference_length();
    for (r, row) in band.y.chunks_mut(f.w).enumerate() {
        for (i, y) in row.iter_mut().enumerate() {
            let g = f.point(i as f64, (j0 + r) as f64, f.front) - f.eye;
            *y = ((axes * g).length() / g[f.c].abs() * inv_ref) as f32;
        }
    }
}

/// What the shear of every band reads: the volume, the factorization,
/// each slice's columns, the compositing table (none for MIP), the slab's
/// cap in floats and whether bricks no pixel can take are passed over.
#[derive(Clone, Copy)]
struct Shear<'a> {
    scene: &'a VolumeScene,
    f: &'a Factor,
    columns: &'a [Columns],
    table: Option<&'a TfTable>,
    slab_cap: usize,
    skip: bool,
    /// How [`resample`] gathers a perspective slice's columns.
    gather: Gather,
}

/// How [`resample`] reads columns that are not one affine run: one by
/// one, or eight or sixteen at a time by permutes of the samples they
/// span ([`lerp_gathered_avx2`], [`lerp_gathered_avx512`]; the CPU's,
/// detected). The values are the same bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Gather {
    Scalar,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

/// Takes every slice's samples for the intermediate rows `j0..` of `acc`,
/// front to back; returns the samples taken and the bricks passed over.
fn shear_as<A: Accumulate>(tuning: Tuning, job: &Shear, j0: usize, acc: &mut A) -> Sheared {
    #[cfg(target_arch = "x86_64")]
    if tuning.avx2 && tuning.avx512 {
        // SAFETY: both are set only where detected.
        return unsafe { shear_avx512(job, j0, acc) };
    }
    #[cfg(target_arch = "x86_64")]
    if tuning.avx2 {
        // SAFETY: the CPU runs AVX2 (`Tuning::avx2` is set only where
        // detected); the code is the portable `shear`, in wider registers.
        return unsafe { shear_avx2(job, j0, acc) };
    }
    shear(job, j0, acc)
}

/// [`shear`] compiled for AVX-512 (and AVX2): as [`shear_avx2`], in
/// 16 lanes, with the AVX-512 kernels inlined.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f")]
fn shear_avx512<A: Accumulate>(job: &Shear, j0: usize, acc: &mut A) -> Sheared {
    shear(job, j0, acc)
}

/// [`shear`] compiled for AVX2: the same operations in the same order, so
/// the same samples bit for bit (no fused multiply-adds: Rust never
/// contracts `a·b + c`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn shear_avx2<A: Accumulate>(job: &Shear, j0: usize, acc: &mut A) -> Sheared {
    shear(job, j0, acc)
}

/// The body of [`shear_as`], inlined into each of its compilations.
#[inline(always)]
fn shear<A: Accumulate>(job: &Shear, j0: usize, acc: &mut A) -> Sheared {
    let Shear {
        scene,
        f,
        columns,
        table,
        slab_cap,
        skip,
        gather,
    } = *job;
    let rows = BAND.min(f.h - j0);
    let (na, nb) = (f.dims[f.a], f.dims[f.b]);
    // A slice row: its `na` samples and a copy of the last, so the column
    // after `a0` is always there.
    let row_len = na as usize + 1;
    let mut raw = vec![0f32; row_len];
    let mut slab = Slab {
        layer: -1,
        vals: SLAB_BUFFER.take(),
        k_lo: 0,
        k_hi: -1,
        b_lo: 0,
        b_hi: -1,
        row_len: 0,
    };
    let mut held = [
        Row {
            b: -1,
            vals: vec![0.0; f.w],
            min: 0.0,
            max: 0.0,
        },
        Row {
            b: -1,
            vals: vec![0.0; f.w],
            min: 0.0,
            max: 0.0,
        },
    ];
    // The layer's bricks along `a` that a pixel of the band may take, in
    // runs; each slice's columns reading them (indexed from its `lo`).
    let bricks_a = (na as u32).div_ceil(BRICK as u32) as usize;
    let (mut live, mut runs, mut spans) = (vec![true; bricks_a], Vec::new(), Vec::new());
    // Compositing: per brick row of the layer (`b >> 3`), the range of
    // its bricks' values along `a`, found when first needed.
    let mut brick_rows = vec![
        None;
        if table.is_some() {
            (nb as usize).div_ceil(8)
        } else {
            0
        }
    ];
    let mut floor = vec![0f32; if skip { f.w } else { 0 }];
    // The next layer (its extent and its live bricks, found ahead and
    // taken as they are when it comes), its bricks fetched into the
    // second-level cache a share per slice row while this layer blends, so
    // the next fill reads from cache rather than memory. The fetch is a
    // hint: no value depends on it.
    let mut next: Option<Layer> = None;
    let mut live_next = live.clone();
    let (mut ahead, mut ahead_at, mut ahead_per_row) = (Vec::new(), 0, 0);
    let (mut samples, mut passed, mut passed_next) = (0, 0, 0);
    for q in 0..f.n {
        let k = f.front + q * f.step;
        let (s, _, tb) = f.slice(k);
        let inv = 1.0 / s;
        let cols = &columns[q as usize];
        if cols.lo >= cols.hi {
            continue;
        }
        if k >> 3 != slab.layer {
            let (extent, ahead_known) = match next.take() {
                Some(l) if l.k_lo == k & !7 => (l, true),
                _ => (Layer::of(f, j0, rows, k), false),
            };
            if ahead_known {
                // Compositing: the live bricks found for the prefetch (by
                // the layer, the table and the pixels terminated then).
                live.copy_from_slice(&live_next);
                passed += passed_next;
            } else if skip {
                passed += mark_live(job, acc, &extent, &mut live, &mut floor);
            }
            brick_rows.fill(None);
            runs.clear();
            let mut t = 0;
            while t < bricks_a {
                let first = t;
                while t < bricks_a && live[t] {
                    t += 1;
                }
                if t > first {
                    runs.push((first, t));
                }
                t += 1;
            }
            slab.fill(scene, f, &extent, &runs, slab_cap);
            let k_next = if f.step > 0 {
                (k | 7) + 1
            } else {
                (k & !7) - 1
            };
            ahead.clear();
            ahead_at = 0;
            // Compositing only: the MIP's light blend leaves too little
            // time to hide the fetch behind (tried: no gain).
            if table.is_some() && (0..f.dims[f.c]).contains(&k_next) {
                let l = Layer::of(f, j0, rows, k_next);
                live_next.fill(true);
                passed_next = 0;
                if skip {
                    // (`floor` is scratch here.)
                    passed_next = mark_live(job, acc, &l, &mut live_next, &mut floor);
                }
                bricks_ahead(scene, f, &l, &live_next, &mut ahead);
                next = Some(l);
            }
            let row_visits = (extent.k_hi - extent.k_lo + 1) as usize * rows;
            ahead_per_row = ahead.len().div_ceil(row_visits);
        }
        spans.clear();
        spans.extend(
            runs.iter()
                .map(|&(t0, t1)| (cols.starts[t0] as usize, cols.starts[t1] as usize))
                .filter(|(c0, c1)| c0 < c1),
        );
        held[0].b = -1;
        held[1].b = -1;
        for r in 0..rows {
            let share = ahead_per_row.min(ahead.len() - ahead_at);
            #[cfg(target_arch = "x86_64")]
            for &bi in &ahead[ahead_at..ahead_at + share] {
                use std::arch::x86_64::_MM_HINT_T1;
                scene.bricks().prefetch_to::<_MM_HINT_T1>(bi);
            }
            ahead_at += share;
            let Some(b) = f.slice_row(j0 + r, tb, inv) else {
                continue;
            };
            acc.cover(r, cols.lo, cols.hi);
            if spans.is_empty() || !acc.live(r, cols.lo, cols.hi) {
                continue;
            }
            // `bc ≥ 0`: truncation is the floor.
            let bc = b.clamp(0.0, (nb - 1) as f64);
            let b0 = bc as i32;
            let fb = (bc - b0 as f64) as f32;
            let b1 = (b0 + 1).min(nb - 1);
            // The two slice rows, resampled along `a` (kept while the next
            // intermediate row still needs them).
            if held[1].b == b0 {
                held.swap(0, 1);
            }
            for (slot, want) in [(0, b0), (1, b1)] {
                if held[slot].b != want {
                    let src: &[f32] = match slab.row(k, want) {
                        Some(src) => src,
                        None => {
                            let mut p = IVec3::ZERO;
                            p[f.c] = k;
                            p[f.b] = want;
                            scene.bricks().read_row(f.a, p, &mut raw[..na as usize]);
                            raw[na as usize] = raw[na as usize - 1];
                            &raw
                        }
                    };
                    let row = &mut held[slot];
                    // The row's values lie in its bricks' range (wider
                    // than the row's own, so a row pair is passed over as
                    // transparent no more often than by its values).
                    let (mn, mx) = match table {
                        Some(_) => *brick_rows[(want >> 3) as usize]
                            .get_or_insert_with(|| brick_row_range(scene, f, k, want)),
                        None => (f32::INFINITY, f32::NEG_INFINITY),
                    };
                    (row.min, row.max, row.b) = (mn, mx, want);
                    for &(c0, c1) in &spans {
                        let out = &mut row.vals[cols.lo + c0..cols.lo + c1];
                        resample(src, cols, c0..c1, out, gather);
                    }
                }
            }
            if let Some(t) = table
                && t.clear(held[0].min.min(held[1].min), held[0].max.max(held[1].max))
            {
                continue;
            }
            let (h0, h1) = (&held[0].vals, &held[1].vals);
            for &(c0, c1) in &spans {
                let (c0, c1) = (cols.lo + c0, cols.lo + c1);
                samples += acc.add(r, c0, [&h0[c0..c1], &h1[c0..c1]], fb, q as u16);
            }
        }
    }
    SLAB_BUFFER.set(slab.vals);
    Sheared { samples, passed }
}

/// What the shear of a band counts.
#[derive(Clone, Copy, Default)]
struct Sheared {
    /// Samples taken.
    samples: u64,
    /// Bricks along `a` of the band's layers that some column reads but
    /// skipping passed over (their samples could change no pixel).
    passed: u64,
}

impl std::iter::Sum for Sheared {
    fn sum<I: Iterator<Item = Sheared>>(iter: I) -> Sheared {
        iter.fold(Sheared::default(), |a, b| Sheared {
            samples: a.samples + b.samples,
            passed: a.passed + b.passed,
        })
    }
}

/// Marks the bricks along `a` of `layer` that a pixel of the band may
/// take: brick `t` is live where `keep(lo, hi, cols)` says so, given
/// bounds `lo ≤ s ≤ hi` of every sample it weighs and the intermediate
/// columns `cols` that read it on the layer's slices (a brick no column
/// reads is passed over). A sample is a lerp of two lerps of voxels of the
/// brick grown by one (`BrickRange::min[1]`, `max[1]`), so it lies in that
/// range [`widened`] by the lerps' rounding. Returns the bricks some
/// column reads that `keep` passed over.
fn live_bricks(
    scene: &VolumeScene,
    f: &Factor,
    columns: &[Columns],
    layer: &Layer,
    live: &mut [bool],
    keep: impl Fn(f32, f32, std::ops::Range<usize>) -> bool,
) -> u64 {
    let bricks = scene.bricks();
    let ranges = bricks.ranges();
    let mut passed = 0;
    let mut at = IVec3::ZERO;
    at[f.c] = layer.k_lo >> 3;
    for (t, live) in live.iter_mut().enumerate() {
        // The intermediate columns whose `a0` lies in the brick, over the
        // layer's slices.
        let (mut c0, mut c1) = (usize::MAX, 0);
        for k in layer.k_lo..=layer.k_hi {
            let cols = &columns[((k - f.front) * f.step) as usize];
            let (s0, s1) = (cols.starts[t] as usize, cols.starts[t + 1] as usize);
            if s0 < s1 {
                c0 = c0.min(cols.lo + s0);
                c1 = c1.max(cols.lo + s1);
            }
        }
        if c0 >= c1 || layer.b_lo > layer.b_hi {
            *live = false;
            continue;
        }
        at[f.a] = t as i32;
        let (mut bottom, mut top, mut mag) = (f32::INFINITY, f32::NEG_INFINITY, 0f32);
        for tb in layer.b_lo >> 3..=layer.b_hi >> 3 {
            at[f.b] = tb;
            let r = &ranges[bricks.brick_index(at)];
            bottom = bottom.min(r.min[1]);
            top = top.max(r.max[1]);
            mag = mag.max(r.max[1].abs()).max(r.min[1].abs());
        }
        let (lo, hi) = widened(bottom, top, mag);
        *live = keep(lo, hi, c0..c1);
        passed += u64::from(!*live);
    }
    passed
}

/// Marks `layer`'s live bricks along `a` in `live` (and leaves it alone
/// for an accumulator every sample may change), with `floor` as scratch;
/// returns the bricks some column reads that are passed over.
fn mark_live<A: Accumulate>(
    job: &Shear,
    acc: &A,
    layer: &Layer,
    live: &mut [bool],
    floor: &mut [f32],
) -> u64 {
    let (scene, f, columns) = (job.scene, job.f, job.columns);
    if let Some(t) = job.table {
        // Compositing: a brick whose samples the table makes transparent
        // adds exactly nothing (`α = 0`), nor does one whose every reading
        // pixel has terminated (so far: the set only grows, and a brick
        // found live here may turn out not to be).
        live_bricks(scene, f, columns, layer, live, |lo, hi, cols| {
            !t.clear(lo, hi) && !acc.finished(layer.rows, cols)
        })
    } else if acc.floor(layer.rows, floor) {
        // MIP: live unless the bound is at most the floor (a NaN bound,
        // from infinite samples, keeps the brick).
        live_bricks(scene, f, columns, layer, live, |_, hi, cols| {
            let low = floor[cols].iter().fold(f32::INFINITY, |m, &x| m.min(x));
            !matches!(hi.partial_cmp(&low), Some(Ordering::Less | Ordering::Equal))
        })
    } else {
        0
    }
}

/// Appends to `out` the storage indices of `layer`'s bricks along `a`
/// marked in `live`, over its rows' bricks along `b`.
fn bricks_ahead(
    scene: &VolumeScene,
    f: &Factor,
    layer: &Layer,
    live: &[bool],
    out: &mut Vec<usize>,
) {
    if layer.b_lo > layer.b_hi {
        return;
    }
    let bricks = scene.bricks();
    let mut at = IVec3::ZERO;
    at[f.c] = layer.k_lo >> 3;
    for tb in layer.b_lo >> 3..=layer.b_hi >> 3 {
        at[f.b] = tb;
        for (ta, _) in live.iter().enumerate().filter(|(_, l)| **l) {
            at[f.a] = ta as i32;
            out.push(bricks.brick_index(at));
        }
    }
}

/// Slice row `src` (with its last sample repeated) resampled at `cols`'
/// columns `span` (indexed from `cols.lo`) into `out` (as long):
/// `x0 + fa·(x1 − x0)` per column. Over the affine run the same operations
/// read contiguous samples with one weight, so they vectorise without
/// gathers.
///
/// Elsewhere (a perspective view's every slice) the columns gather, as
/// `gather` says.
#[inline(always)]
fn resample(
    src: &[f32],
    cols: &Columns,
    span: std::ops::Range<usize>,
    out: &mut [f32],
    gather: Gather,
) {
    let gathered = |out: &mut [f32], a0: &[u32], fa: &[f32]| match gather {
        Gather::Scalar => lerp_gathered(src, a0, fa, out),
        // SAFETY: `Gather::Avx2` is chosen only where the CPU has AVX2.
        #[cfg(target_arch = "x86_64")]
        Gather::Avx2 => unsafe { lerp_gathered_avx2(src, a0, fa, out) },
        // SAFETY: `Gather::Avx512` is chosen only where it has AVX-512F.
        #[cfg(target_arch = "x86_64")]
        Gather::Avx512 => unsafe { lerp_gathered_avx512(src, a0, fa, out) },
    };
    let (s0, s1) = (span.start, span.end);
    let (r0, r1) = (cols.run.0.clamp(s0, s1), cols.run.1.clamp(s0, s1));
    gathered(&mut out[..r0 - s0], &cols.a0[s0..r0], &cols.fa[s0..r0]);
    if r1 > r0 {
        let (base, fa) = (cols.a0[r0] as usize, cols.fa[r0]);
        let xs = &src[base..=base + (r1 - r0)];
        for ((v, &x0), &x1) in out[r0 - s0..r1 - s0].iter_mut().zip(xs).zip(&xs[1..]) {
            *v = x0 + fa * (x1 - x0);
        }
    }
    gathered(&mut out[r1 - s0..], &cols.a0[r1..s1], &cols.fa[r1..s1]);
}

/// `out[i] = x0 + fa[i]·(x1 − x0)` for `x0, x1 = src[a0[i]], src[a0[i] + 1]`:
/// the resampling of columns that are not one affine run.
#[inline(always)]
fn lerp_gathered(src: &[f32], a0: &[u32], fa: &[f32], out: &mut [f32]) {
    for ((v, &a0), &fa) in out.iter_mut().zip(a0).zip(fa) {
        let a0 = a0 as usize;
        let (x0, x1) = (src[a0], src[a0 + 1]);
        *v = x0 + fa * (x1 - x0);
    }
}

/// [`lerp_gathered`] 8 columns at a time, for `a0` that never falls (as
/// [`Columns`]' do): where the 8 columns read from fewer than 16
/// consecutive samples (a perspective slice's columns step by about one
/// sample), two loads hold them all, and a permute of each register
/// (`vpermps`, which reads an index's low three bits) and a blend on the
/// index's fourth bit put each column's `x0` and `x1` in its lane, with no
/// gather. The arithmetic is the scalar one, operation for operation (no
/// fused multiply-add), so the values are the same bit for bit; other
/// chunks and the tail take the scalar loop. AVX2 has no two-register
/// permute: this is [`lerp_gathered_avx512`]'s scheme for CPUs without
/// AVX-512, where the scalar loop was a fifth of a perspective
/// compositing frame.
///
/// Called only where the CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn lerp_gathered_avx2(src: &[f32], a0: &[u32], fa: &[f32], out: &mut [f32]) {
    use std::arch::x86_64::*;
    let n = out.len().min(a0.len()).min(fa.len());
    let mut i = 0;
    while i + 8 <= n {
        let (first, last) = (a0[i] as usize, a0[i + 7] as usize);
        // Lanes read `first..=last + 1`: within two registers' 16 samples,
        // all inside `src`. Both bounds are checked here, so every load
        // below is in bounds.
        if last >= first && last + 1 - first < 16 && first + 16 <= src.len() {
            // SAFETY: `i + 8 ≤ n` bounds the loads of `a0`, `fa` and the
            // store to `out`; `first + 16 ≤ src.len()` bounds the two loads
            // of `src`; the indices `a0 − first` and `a0 + 1 − first` lie
            // in `0..16` because `a0` rises from `first` to `last` and
            // `last + 1 − first < 16`, so the low three bits pick the
            // sample within a register and bit 3 picks the register.
            unsafe {
                let lo = _mm256_loadu_ps(src.as_ptr().add(first));
                let hi = _mm256_loadu_ps(src.as_ptr().add(first + 8));
                let pick = |idx: __m256i| {
                    let upper = _mm256_castsi256_ps(_mm256_cmpgt_epi32(idx, _mm256_set1_epi32(7)));
                    _mm256_blendv_ps(
                        _mm256_permutevar8x32_ps(lo, idx),
                        _mm256_permutevar8x32_ps(hi, idx),
                        upper,
                    )
                };
                let idx = _mm256_sub_epi32(
                    _mm256_loadu_si256(a0.as_ptr().add(i).cast()),
                    _mm256_set1_epi32(first as i32),
                );
                let x0 = pick(idx);
                let x1 = pick(_mm256_add_epi32(idx, _mm256_set1_epi32(1)));
                let w = _mm256_loadu_ps(fa.as_ptr().add(i));
                let v = _mm256_add_ps(x0, _mm256_mul_ps(w, _mm256_sub_ps(x1, x0)));
                _mm256_storeu_ps(out.as_mut_ptr().add(i), v);
            }
        } else {
            lerp_gathered(src, &a0[i..i + 8], &fa[i..i + 8], &mut out[i..i + 8]);
        }
        i += 8;
    }
    lerp_gathered(src, &a0[i..n], &fa[i..n], &mut out[i..n]);
}

/// [`lerp_gathered`] 16 columns at a time, for `a0` that never falls (as
/// [`Columns`]' do): where the 16 columns read from fewer than 32
/// consecutive samples, two loads hold them all and AVX-512's
/// two-register permute (`vpermt2ps`) puts each column's `x0` and `x1` in
/// its lane, with no gather. The arithmetic is the scalar one, operation
/// for operation (no fused multiply-add), so the values are the same bit
/// for bit; other chunks and the tail take the scalar loop.
///
/// Called only where the CPU has AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn lerp_gathered_avx512(src: &[f32], a0: &[u32], fa: &[f32], out: &mut [f32]) {
    use std::arch::x86_64::*;
    let n = out.len().min(a0.len()).min(fa.len());
    let mut i = 0;
    while i + 16 <= n {
        let (first, last) = (a0[i] as usize, a0[i + 15] as usize);
        // Lanes read `first..=last + 1`: within two registers' 32 samples,
        // all inside `src`. Both bounds are checked here, so every load
        // below is in bounds.
        if last >= first && last + 1 - first < 32 && first + 32 <= src.len() {
            // SAFETY: `i + 16 ≤ n` bounds the loads of `a0`, `fa` and the
            // store to `out`; `first + 32 ≤ src.len()` bounds the two
            // loads of `src`; the permute's indices `a0 − first` and
            // `a0 + 1 − first` lie in `0..32` because `a0` rises from
            // `first` to `last` and `last + 1 − first < 32`.
            unsafe {
                let lo = _mm512_loadu_ps(src.as_ptr().add(first));
                let hi = _mm512_loadu_ps(src.as_ptr().add(first + 16));
                let idx = _mm512_sub_epi32(
                    _mm512_loadu_si512(a0.as_ptr().add(i).cast()),
                    _mm512_set1_epi32(first as i32),
                );
                let x0 = _mm512_permutex2var_ps(lo, idx, hi);
                let idx1 = _mm512_add_epi32(idx, _mm512_set1_epi32(1));
                let x1 = _mm512_permutex2var_ps(lo, idx1, hi);
                let w = _mm512_loadu_ps(fa.as_ptr().add(i));
                let v = _mm512_add_ps(x0, _mm512_mul_ps(w, _mm512_sub_ps(x1, x0)));
                _mm512_storeu_ps(out.as_mut_ptr().add(i), v);
            }
        } else {
            lerp_gathered(src, &a0[i..i + 16], &fa[i..i + 16], &mut out[i..i + 16]);
        }
        i += 16;
    }
    lerp_gathered(src, &a0[i..n], &fa[i..n], &mut out[i..n]);
}

/// The smallest and largest value of the bricks along `a` that hold row
/// `b` of slice `k` (`(+∞, −∞)` for none), [`widened`] by the lerps'
/// rounding: a range holding every sample taken between two such rows,
/// from the bricks' stored ranges rather than a pass over the row.
fn brick_row_range(scene: &VolumeScene, f: &Factor, k: i32, b: i32) -> (f32, f32) {
    let bricks = scene.bricks();
    let ranges = bricks.ranges();
    let mut at = IVec3::ZERO;
    (at[f.b], at[f.c]) = (b >> 3, k >> 3);
    let (lo, hi) =
        (0..bricks.brick_dims()[f.a]).fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), t| {
            at[f.a] = t;
            let r = &ranges[bricks.brick_index(at)];
            (lo.min(r.min[0]), hi.max(r.max[0]))
        });
    widened(lo, hi, lo.abs().max(hi.abs()))
}

/// `[lo, hi]`, the range of some voxels whose largest magnitude is `mag`,
/// widened to hold every sample shear-warp takes from them: a lerp of two
/// lerps, each within `14u·mag` of the range (`u = 2⁻²⁴`), so `2⁻¹⁹·mag`
/// on each side (and `2⁻¹⁴⁶` for subnormal roundings; nothing where every
/// value is 0, whose lerps are exact). An empty range (`lo > hi`) stays
/// empty; an infinite one stays infinite.
fn widened(lo: f32, hi: f32, mag: f32) -> (f32, f32) {
    if lo > hi {
        return (lo, hi);
    }
    let tiny = if mag > 0.0 { f32::from_bits(8) } else { 0.0 };
    let slack = mag * (1.0 / (1 << 19) as f32) + tiny;
    (lo - slack, hi + slack)
}

/// Floats a band's [`Slab`] may hold (4 MiB); a layer needing more is read
/// row by row.
const SLAB_CAP: usize = 1 << 20;

thread_local! {
    /// A thread's [`Slab`] buffer, kept from band to band and frame to
    /// frame (at most [`SLAB_CAP`] floats a thread). A slab is over the
    /// allocator's huge-page threshold, so a fresh one per band was a
    /// fresh 2 MiB mapping per band: its page fault, the kernel clearing
    /// it and its unmapping cost ~7% of a 512³ MIP frame on an Intel VM
    /// (within the noise on Zen 4; docs/performance-notes.md).
    static SLAB_BUFFER: std::cell::Cell<Vec<f32>> = const { std::cell::Cell::new(Vec::new()) };
}

/// The slice rows a band needs from one layer of bricks (8 slices): read
/// brick by brick, so each brick streams from memory once, where reading
/// row by row would touch every brick along `a` once per row.
struct Slab {
    /// The layer (`k >> 3`) read, `−1` before the first.
    layer: i32,
    /// Slices `k_lo..=k_hi`, rows `b_lo..=b_hi`, each row `row_len` long
    /// (the last sample repeated at the end); empty if the layer is read
    /// row by row.
    vals: Vec<f32>,
    k_lo: i32,
    k_hi: i32,
    b_lo: i32,
    b_hi: i32,
    row_len: usize,
}

/// The slices of a layer and the slice rows a band takes from them.
struct Layer {
    k_lo: i32,
    k_hi: i32,
    /// Rows `b_lo..=b_hi` (`b_lo > b_hi` if none).
    b_lo: i32,
    b_hi: i32,
    /// The band's rows that take a sample from a slice of the layer (bit
    /// `r` for row `r`, by the test [`shear`] makes).
    rows: u32,
}

impl Layer {
    /// The rows `b0`, `b0 + 1` that intermediate rows `j0..j0 + rows` take
    /// from the slices of slice `k`'s layer (`b` rises with `j`).
    fn of(f: &Factor, j0: usize, rows: usize, k: i32) -> Layer {
        let (nb, nc) = (f.dims[f.b], f.dims[f.c]);
        let (k_lo, k_hi) = (k & !7, (k | 7).min(nc - 1));
        let floor_b = |j: usize, k: i32| {
            let (s, _, tb) = f.slice(k);
            ((f.v0 + j as f64 - tb) / s).clamp(0.0, (nb - 1) as f64) as i32
        };
        let (mut b_lo, mut b_hi, mut mask) = (nb - 1, 0, 0u32);
        for kk in k_lo..=k_hi {
            b_lo = b_lo.min(floor_b(j0, kk));
            b_hi = b_hi.max((floor_b(j0 + rows - 1, kk) + 1).min(nb - 1));
            let (s, _, tb) = f.slice(kk);
            let inv = 1.0 / s;
            for r in 0..rows {
                if f.slice_row(j0 + r, tb, inv).is_some() {
                    mask |= 1 << r;
                }
            }
        }
        Layer {
            k_lo,
            k_hi,
            b_lo,
            b_hi,
            rows: mask,
        }
    }
}

impl Slab {
    /// Reads `layer`'s rows of the bricks along `a` in `runs` (brick
    /// ranges `t0..t1`, each with the first column after it, which the
    /// last columns' lerps read), unless they exceed `cap` floats. Columns
    /// of other bricks keep what they held.
    fn fill(
        &mut self,
        scene: &VolumeScene,
        f: &Factor,
        layer: &Layer,
        runs: &[(usize, usize)],
        cap: usize,
    ) {
        let na = f.dims[f.a];
        let &Layer {
            k_lo,
            k_hi,
            b_lo,
            b_hi,
            ..
        } = layer;
        self.layer = k_lo >> 3;
        self.row_len = na as usize + 1;
        let len = (k_hi - k_lo + 1) as usize * (b_hi - b_lo + 1).max(0) as usize * self.row_len;
        (self.k_lo, self.k_hi) = (0, -1);
        if b_lo > b_hi || len > cap {
            return;
        }
        self.vals.resize(len, 0.0);
        (self.k_lo, self.k_hi, self.b_lo, self.b_hi) = (k_lo, k_hi, b_lo, b_hi);
        let (mut lo, mut hi, mut stride) = (IVec3::ZERO, IVec3::ZERO, [0; 3]);
        (lo[f.b], lo[f.c]) = (b_lo, k_lo);
        (hi[f.b], hi[f.c]) = (b_hi, k_hi);
        stride[f.a] = 1;
        stride[f.b] = self.row_len;
        stride[f.c] = self.row_len * (b_hi - b_lo + 1) as usize;
        for &(t0, t1) in runs {
            lo[f.a] = t0 as i32 * BRICK;
            hi[f.a] = (t1 as i32 * BRICK).min(na - 1);
            let out = &mut self.vals[lo[f.a] as usize..];
            scene.bricks().read_block(lo, hi, stride, out);
        }
        for row in self.vals.chunks_exact_mut(self.row_len) {
            row[na as usize] = row[na as usize - 1];
        }
    }

    /// Row `b` of slice `k`, if held.
    #[inline]
    fn row(&self, k: i32, b: i32) -> Option<&[f32]> {
        if k < self.k_lo || k > self.k_hi || b < self.b_lo || b > self.b_hi {
            return None;
        }
        let rows = (self.b_hi - self.b_lo + 1) as usize;
        let i = (k - self.k_lo) as usize * rows + (b - self.b_lo) as usize;
        Some(&self.vals[i * self.row_len..][..self.row_len])
    }
}

/// The image from the intermediate one: each pixel's ray meets the base
/// plane, and takes the bilinear value of the intermediate pixels there.
fn warp(
    tuning: Tuning,
    setup: &RaySetup,
    f: &Factor,
    image: &Intermediate,
    opts: &RenderOptions,
    vopts: &VolumeOptions,
) -> (RenderImage, u64) {
    let (w, h) = (opts.width, opts.height);
    let mut img = RenderImage::blank(w, h, f32::INFINITY);
    let hits = match image {
        Intermediate::Mip(bands) => {
            let source = mip_source(bands, (f.w, f.h), vopts.window.0);
            warp_bands(tuning, setup, f, &source, vopts, &mut img)
        }
        Intermediate::Composite(bands) => {
            let source = composite_source(bands, (f.w, f.h));
            warp_bands(tuning, setup, f, &source, vopts, &mut img)
        }
    };
    (img, hits)
}

/// A MIP's warp source: `[m, cov]`, the pixel covered where it holds a
/// sample (`m > −∞`), and a hit where its maximum exceeds `low` (the
/// window's low end).
fn mip_source(bands: &[MipBand], dims: (usize, usize), low: f32) -> WarpSource<2> {
    WarpSource::of(dims, |bd, r, i| {
        let (b, o) = (&bands[bd], r * dims.0 + i);
        let (m, q) = (b.m[o], b.q[o]);
        let covered = m > f32::NEG_INFINITY;
        let hit = if m > low { q } else { u16::MAX };
        ([if covered { m } else { 0.0 }, f32::from(covered)], hit)
    })
}

/// A composite's warp source: `[r, g, b, a, cov]`, the pixel covered
/// where its ray crosses the volume, and a hit at its first slice with
/// `α > 0`.
fn composite_source(bands: &[CompositeBand], dims: (usize, usize)) -> WarpSource<5> {
    WarpSource::of(dims, |bd, r, i| {
        let (b, o) = (&bands[bd], r * dims.0 + i);
        let seen = b.seen[o];
        // A grey table kept red alone.
        let grey = b.table.grey;
        let ch = |k: usize| {
            let k = if grey && k < 3 { 0 } else { k };
            if seen { b.rgba[k][o] } else { 0.0 }
        };
        ([ch(0), ch(1), ch(2), ch(3), f32::from(seen)], b.q[o])
    })
}

/// The warp of every band of `img` from `source`: returns the hits.
fn warp_bands<const N: usize>(
    tuning: Tuning,
    setup: &RaySetup,
    f: &Factor,
    source: &WarpSource<N>,
    vopts: &VolumeOptions,
    img: &mut RenderImage,
) -> u64 {
    let job = Warp {
        setup,
        f,
        source,
        vopts,
        w: img.width,
    };
    img.par_bands(WARP_ROWS)
        .map(|(band, pixels)| {
            #[cfg(target_arch = "x86_64")]
            if tuning.avx2 {
                // SAFETY: the CPU runs AVX2 (`Tuning::avx2` is set only
                // where detected); the code is the portable `warp_band`.
                return unsafe { warp_band_avx2(&job, band, pixels) };
            }
            warp_band(&job, band, pixels)
        })
        .sum()
}

/// Image rows per parallel task of the warp.
const WARP_ROWS: usize = 16;

/// Uncovered pixels around [`WarpSource`]'s image: enough that every
/// corner of a crossing clamped to `-PAD..=w` (and `-PAD..=h`) is in the
/// array and a corner outside the image reads an uncovered pixel.
const PAD: usize = 2;

/// The intermediate image as the warp reads it: one row-major array with
/// [`PAD`] uncovered pixels on every side (the bands' rows joined), each
/// pixel's `N − 1` channels beside one another (MIP: the maximum;
/// compositing: premultiplied colour and opacity), zero where the pixel
/// is not covered, then its coverage (1 or 0), and the slice of its hit
/// (`u16::MAX` for none). Products with a zero weight or a zero channel
/// add `+0.0`, which leaves every sum as the covered corners alone make
/// it (a sum that starts at `+0.0` never holds `−0.0`), so the warp's
/// pixels are those of the corner-by-corner tests it replaces.
struct WarpSource<const N: usize> {
    stride: usize,
    w: i64,
    h: i64,
    /// Channels and coverage: `[m, cov]` (MIP) or `[r, g, b, a, cov]`.
    px: Vec<[f32; N]>,
    q: Vec<u16>,
}

impl<const N: usize> WarpSource<N> {
    /// The source of a `w × h` intermediate image in bands of [`BAND`]
    /// rows, whose pixel `i` of row `r` of band `bd` is `pixel(bd, r, i)`.
    fn of(
        (w, h): (usize, usize),
        pixel: impl Fn(usize, usize, usize) -> ([f32; N], u16) + Sync,
    ) -> Self {
        let stride = w + 2 * PAD;
        let len = stride * (h + 2 * PAD);
        let (mut px, mut q) = (vec![[0f32; N]; len], vec![u16::MAX; len]);
        let rows = px[PAD * stride..]
            .par_chunks_mut(stride * BAND)
            .zip(q[PAD * stride..].par_chunks_mut(stride * BAND))
            .take(h.div_ceil(BAND))
            .enumerate();
        rows.for_each(|(bd, (px, qs))| {
            let pixels = px
                .chunks_mut(stride)
                .zip(qs.chunks_mut(stride))
                .take(BAND.min(h - bd * BAND));
            for (r, (px, qs)) in pixels.enumerate() {
                let (px, qs) = (&mut px[PAD..PAD + w], &mut qs[PAD..PAD + w]);
                for (i, (p, q)) in px.iter_mut().zip(qs).enumerate() {
                    (*p, *q) = pixel(bd, r, i);
                }
            }
        });
        WarpSource {
            stride,
            w: w as i64,
            h: h as i64,
            px,
            q,
        }
    }

    /// The array index of pixel `(i, j)`, which must lie within the border.
    #[inline(always)]
    fn index(&self, i: i64, j: i64) -> usize {
        (j + PAD as i64) as usize * self.stride + (i + PAD as i64) as usize
    }

    /// At crossing `(fi, fj)` (intermediate pixel units): the sums over
    /// the four pixels around it of bilinear weight × channel and of the
    /// weights of the covered ones (last), and the hit slice of the
    /// nearest pixel (`u16::MAX` for none or outside).
    #[inline(always)]
    fn sample(&self, fi: f64, fj: f64) -> ([f32; N], u16) {
        let (i0, j0) = (fi.floor(), fj.floor());
        let (wi, wj) = ((fi - i0) as f32, (fj - j0) as f32);
        // A corner beyond the border reads the border: uncovered either way.
        let pad = PAD as i64;
        let (i0, j0) = (
            (i0 as i64).clamp(-pad, self.w),
            (j0 as i64).clamp(-pad, self.h),
        );
        let base = self.index(i0, j0);
        let corners = [
            (base, (1.0 - wi) * (1.0 - wj)),
            (base + 1, wi * (1.0 - wj)),
            (base + self.stride, (1.0 - wi) * wj),
            (base + self.stride + 1, wi * wj),
        ];
        let mut acc = [0f32; N];
        for (o, wt) in corners {
            for (a, &v) in acc.iter_mut().zip(&self.px[o]) {
                *a += wt * v;
            }
        }
        let (ni, nj) = (
            (fi.round() as i64).clamp(-1, self.w),
            (fj.round() as i64).clamp(-1, self.h),
        );
        (acc, self.q[self.index(ni, nj)])
    }
}

/// What the warp of every band reads.
struct Warp<'a, const N: usize> {
    setup: &'a RaySetup,
    f: &'a Factor,
    source: &'a WarpSource<N>,
    vopts: &'a VolumeOptions,
    w: u32,
}

/// [`warp_band`] compiled for AVX2: the same operations (SSE4.1's rounding
/// instructions instead of libm's `floor` and `round` calls, which the
/// baseline target needs: a fifth of the warp's time), so the same pixels.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn warp_band_avx2<const N: usize>(job: &Warp<N>, band: usize, pixels: ImageBand) -> u64 {
    warp_band(job, band, pixels)
}

/// The depth and voxel where `ray` crosses slice `q` (a function, not a
/// closure, so that it is compiled with [`warp_band_avx2`]'s features).
#[inline(always)]
fn hit_at(f: &Factor, ray: &GridRay, q: u16) -> (f32, Option<IVec3>) {
    let k = f.front + q as i32 * f.step;
    let tk = (k as f64 - ray.o[f.c]) / ray.d[f.c];
    let p = ray.o + ray.d * tk;
    let v = IVec3::new(
        (p.x.round() as i32).clamp(0, f.dims[0] - 1),
        (p.y.round() as i32).clamp(0, f.dims[1] - 1),
        (p.z.round() as i32).clamp(0, f.dims[2] - 1),
    );
    (tk as f32, Some(v))
}

/// The warp of the image's rows `band·WARP_ROWS..`: returns the hits.
#[inline(always)]
fn warp_band<const N: usize>(job: &Warp<N>, band: usize, (color, depth, hit): ImageBand) -> u64 {
    let Warp { setup, f, w, .. } = *job;
    let w = w as usize;
    let (lo, hi) = setup.clip_box();
    let mut rays = RowRays::default();
    let (mut fis, mut fjs, mut meets) = (vec![0f64; w], vec![0f64; w], vec![false; w]);
    let mut hits = 0u64;
    let rows = color
        .chunks_mut(w)
        .zip(depth.chunks_mut(w))
        .zip(hit.chunks_mut(w));
    for (row, ((color, depth), hit)) in rows.enumerate() {
        setup.row_rays((band * WARP_ROWS + row) as u32, &mut rays);
        // The row's geometry first, column after column without a branch
        // (the rays themselves in vector lanes): whether each ray meets
        // the box and the base plane, and where it meets the plane.
        let [o, d] = [&rays.o, &rays.d].map(|v| v.each_ref().map(|v| &v[..w]));
        let (meets, fis, fjs) = (&mut meets[..w], &mut fis[..w], &mut fjs[..w]);
        let (oc, dc, oa, da, ob, db) = (o[f.c], d[f.c], o[f.a], d[f.a], o[f.b], d[f.b]);
        let front = f.front as f64;
        for x in 0..w {
            let (oo, dd) = ([o[0][x], o[1][x], o[2][x]], [d[0][x], d[1][x], d[2][x]]);
            meets[x] = clip_hits(oo, dd, lo, hi) & (dc[x] != 0.0);
            let t = (front - oc[x]) / dc[x];
            fis[x] = oa[x] + da[x] * t - f.u0;
            fjs[x] = ob[x] + db[x] * t - f.v0;
        }
        hits += warp_row(job, &rays, (fis, fjs, meets), (color, depth, hit));
    }
    hits
}

/// The pixels of one image row from its rays' crossings `(fi, fj)` of
/// the base plane (intermediate pixel units), for the rays that `meet`
/// the box and the plane; returns the hits. Each pixel is the bilinear
/// blend of the covered corners among the four around its crossing,
/// their weights rescaled (the volume's silhouette is not darkened by
/// the pixels beyond it), and its hit the slice of the nearest pixel's.
#[inline(always)]
fn warp_row<const N: usize>(
    job: &Warp<N>,
    rays: &RowRays,
    (fis, fjs, meets): (&[f64], &[f64], &[bool]),
    (color, depth, hit): ImageBand,
) -> u64 {
    let Warp {
        f, source, vopts, ..
    } = *job;
    let mut hits = 0u64;
    for (x, ((c, d), hv)) in color.iter_mut().zip(depth).zip(hit).enumerate() {
        if !meets[x] {
            continue;
        }
        let (acc, q) = source.sample(fis[x], fjs[x]);
        let wsum = acc[N - 1];
        if N == 2 {
            let m = if wsum > 0.0 {
                acc[0] / wsum
            } else {
                vopts.window.0
            };
            let g = grey(m, vopts.window);
            *c = [g, g, g, 1.0];
            if q != u16::MAX {
                (*d, *hv) = hit_at(f, &rays.ray(x), q);
                hits += 1;
            }
        } else {
            let acc = if wsum > 0.0 {
                [0, 1, 2, 3].map(|k| acc[k] / wsum)
            } else {
                [0, 1, 2, 3].map(|k| acc[k])
            };
            let a = acc[3];
            if a > 0.0 {
                let rgb = [0, 1, 2].map(|k| (acc[k] / a).clamp(0.0, 1.0));
                *c = [rgb[0], rgb[1], rgb[2], a.min(1.0)];
                if q != u16::MAX {
                    (*d, *hv) = hit_at(f, &rays.ray(x), q);
                }
                hits += 1;
            }
        }
    }
    hits
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
    use crate::render::{RayKind, VolumeMethod, render_volume};
    use rand::{Rng, SeedableRng, rngs::StdRng};

    fn scene(dims: [usize; 3], f: impl Fn(usize, usize, usize) -> f32) -> VolumeScene {
        let mut data = Vec::with_capacity(dims.iter().product());
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    data.push(f(x, y, z));
                }
            }
        }
        let vol = ScalarVolume::new(dims, VolumeData::F32(data), VolumeFrame::default()).unwrap();
        VolumeScene::new(&vol, MemoryLimit::DEFAULT).unwrap()
    }

    fn opts(method: VolumeMethod, mode: VolumeMode, window: (f32, f32)) -> VolumeOptions {
        VolumeOptions {
            method,
            ..VolumeOptions::with_window(mode, window)
        }
    }

    fn both(
        s: &VolumeScene,
        cam: &Camera,
        ro: &RenderOptions,
        mode: VolumeMode,
        window: (f32, f32),
    ) -> (RenderImage, RenderImage, RenderStats) {
        let six = RenderOptions {
            ray: RayKind::Six,
            ..*ro
        };
        let exact = render_volume(s, cam, &six, &opts(VolumeMethod::Rays, mode, window)).unwrap();
        let sw = render_volume(s, cam, ro, &opts(VolumeMethod::ShearWarp, mode, window)).unwrap();
        (sw.0, exact.0, sw.1)
    }

    /// A camera looking at `c` from a random direction at a random
    /// distance: orthographic (`height`) or perspective (`fov`).
    fn random_camera(
        rng: &mut StdRng,
        c: DVec3,
        dist: std::ops::Range<f64>,
        ortho: bool,
        height: f64,
        fov: f64,
    ) -> Camera {
        let dir = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize();
        let eye = c + dir * rng.random_range(dist);
        let up = if dir.z.abs() > 0.9 {
            DVec3::X
        } else {
            DVec3::Z
        };
        if ortho {
            Camera::orthographic(eye, c, up, height)
        } else {
            Camera::perspective(eye, c, up, fov)
        }
    }

    fn largest_difference(a: &RenderImage, b: &RenderImage) -> f32 {
        a.color
            .iter()
            .zip(&b.color)
            .flat_map(|(p, q)| (0..4).map(move |k| (p[k] - q[k]).abs()))
            .fold(0.0, f32::max)
    }

    /// Slices whose rows a slice row reads: every axis, every start, the
    /// value the renderer reads.
    #[test]
    fn slice_rows_read_the_voxels() {
        let dims = [19, 11, 17];
        let s = scene(dims, |x, y, z| (x * 1000 + y * 31 + z * 7) as f32);
        let b = s.bricks();
        let mut rng = StdRng::seed_from_u64(3);
        for _ in 0..300 {
            let axis = rng.random_range(0..3);
            let mut p = IVec3::new(
                rng.random_range(0..19),
                rng.random_range(0..11),
                rng.random_range(0..17),
            );
            p[axis] = rng.random_range(0..dims[axis] as i32);
            let len = rng.random_range(0..=dims[axis] - p[axis] as usize);
            let mut out = vec![0.0; len];
            b.read_row(axis, p, &mut out);
            for (i, &v) in out.iter().enumerate() {
                let mut q = p;
                q[axis] += i as i32;
                assert_eq!(Some(v), b.value(q), "axis {axis} from {p} at {i}");
            }
        }
    }

    /// Blocks read brick by brick land where their strides say, for every
    /// permutation of axes (as the slabs of every principal axis use them)
    /// and boxes cut anywhere across bricks.
    #[test]
    fn blocks_read_the_voxels() {
        let dims = [19, 11, 17];
        let s = scene(dims, |x, y, z| (x * 1000 + y * 31 + z * 7) as f32);
        let b = s.bricks();
        let mut rng = StdRng::seed_from_u64(5);
        for _ in 0..200 {
            let (mut lo, mut hi) = (IVec3::ZERO, IVec3::ZERO);
            for k in 0..3 {
                let (p, q) = (
                    rng.random_range(0..dims[k] as i32),
                    rng.random_range(0..dims[k] as i32),
                );
                (lo[k], hi[k]) = (p.min(q), p.max(q));
            }
            let ext = (hi - lo + 1).to_array().map(|e| e as usize);
            // Axes in a random order of strides, rows padded by one.
            let mut order = [0usize, 1, 2];
            order.swap(0, rng.random_range(0..3));
            order.swap(1, rng.random_range(1..3));
            let mut stride = [0; 3];
            let mut n = 1;
            for (i, &k) in order.iter().enumerate() {
                stride[k] = n;
                n *= ext[k] + usize::from(i == 0);
            }
            let mut out = vec![f32::NAN; n];
            b.read_block(lo, hi, stride, &mut out);
            for z in lo.z..=hi.z {
                for y in lo.y..=hi.y {
                    for x in lo.x..=hi.x {
                        let v = IVec3::new(x, y, z);
                        let d = v - lo;
                        let i = (0..3).map(|k| d[k] as usize * stride[k]).sum::<usize>();
                        assert_eq!(Some(out[i]), b.value(v), "{lo}..={hi} {stride:?} at {v}");
                    }
                }
            }
        }
    }

    /// Reading a layer's rows brick by brick (slabs) or row by row, in
    /// portable, AVX2 or AVX-512 registers, and compositing a grey table
    /// in one colour channel or in three, gives the same image, bit for
    /// bit, whatever fits under the cap: every principal axis, both
    /// directions, near and far eyes, grey and coloured tables.
    #[test]
    fn tunings_give_the_same_image() {
        #[cfg(target_arch = "x86_64")]
        let (wide, wider) = (
            std::arch::is_x86_feature_detected!("avx2"),
            std::arch::is_x86_feature_detected!("avx512f"),
        );
        let tuning = |slab_cap: usize, _avx2: bool| Tuning {
            slab_cap,
            skip: slab_cap > 0 || _avx2,
            grey: slab_cap > 0 || _avx2,
            alpha_table: slab_cap > 0 || _avx2,
            #[cfg(target_arch = "x86_64")]
            avx2: _avx2 && wide,
            #[cfg(target_arch = "x86_64")]
            avx512: _avx2 && slab_cap > 0 && wider,
        };
        let dims = [37usize, 29, 45];
        let mut rng = StdRng::seed_from_u64(17);
        let vals: Vec<f32> = (0..37 * 29 * 45)
            .map(|_| rng.random_range(0.0..1.0))
            .collect();
        let s = scene(dims, |x, y, z| vals[x + 37 * (y + 29 * z)]);
        let c = DVec3::new(18.0, 14.0, 22.0);
        let ro = RenderOptions {
            width: 64,
            height: 56,
            ..RenderOptions::default()
        };
        let (mut slabbed, mut ortho_composites) = (0, 0);
        let coloured = TransferFunction::parse("0.2:0,0.5:0.3:#2040ff,0.9:0.8:#ff8000").unwrap();
        let modes = [
            opts(VolumeMethod::ShearWarp, VolumeMode::Mip, (0.2, 0.9)),
            opts(VolumeMethod::ShearWarp, VolumeMode::Composite, (0.2, 0.9)),
            VolumeOptions {
                transfer: coloured,
                ..opts(VolumeMethod::ShearWarp, VolumeMode::Composite, (0.2, 0.9))
            },
        ];
        for t in 0..24 {
            let cam = random_camera(&mut rng, c, 45.0..160.0, t % 2 == 0, 70.0, 50.0);
            for o in &modes {
                let mode = o.mode;
                let Some((rows, _)) = render_with(&s, &cam, &ro, o, tuning(0, false)).unwrap()
                else {
                    continue;
                };
                for (cap, avx2) in [
                    (3_000, false),
                    (SLAB_CAP, false),
                    (0, true),
                    (SLAB_CAP, true),
                ] {
                    let t = tuning(cap, avx2);
                    let (img, _) = render_with(&s, &cam, &ro, o, t).unwrap().unwrap();
                    assert_eq!(img, rows, "{cam:?} {mode:?} {t:?}");
                }
                slabbed += 1;
                // The first tuning computes every `α`; the others look
                // orthographic views' up (`alpha_table`).
                ortho_composites += usize::from(t % 2 == 0 && mode == VolumeMode::Composite);
            }
        }
        assert!(slabbed >= 30, "{slabbed} views factorized");
        assert!(
            ortho_composites >= 10,
            "{ortho_composites} orthographic composites"
        );
    }

    /// The packed table's `ln(1 − τ)` (`−∞` where `τ ≥ 1`) gives, through
    /// the blend's test, the opacity `corrected_opacity` gives for the
    /// entry's `τ`, bit for bit: every entry of a function with clear,
    /// partial and fully opaque stretches, over stretches from tiny to
    /// long.
    #[test]
    fn packed_entries_give_the_opacities() {
        let tf = TransferFunction::parse("0:0,1:0.3,2:1,3:1,4:0.5:#ff8000,5:0").unwrap();
        let t = TfTable::new(&tf, (0.0, 5.0));
        let mut opaque = 0;
        for (e, entry) in t.entries.iter().enumerate() {
            let tau = tf.opacity(t.lo + e as f32 / t.scale);
            opaque += usize::from(tau >= 1.0);
            let ln = entry[0];
            assert_eq!(ln == f32::NEG_INFINITY, tau >= 1.0, "entry {e}");
            for y in [1e-6f32, 0.37, 1.0, 1.7320508, 40.0] {
                let full = if ln == f32::NEG_INFINITY { 1.0 } else { 0.0 };
                let got = corrected_opacity_from_log(full, ln, y);
                let want = crate::render::corrected_opacity(tau, y);
                assert_eq!(got.to_bits(), want.to_bits(), "entry {e}, y {y}");
            }
        }
        assert!(opaque > 500, "{opaque} opaque entries");
        // The table for one stretch holds those opacities, in its entries
        // and (for a grey function) its pairs; colours and the clear
        // ranges' counts are kept.
        let grey = TransferFunction::parse("0:0,1:0.3,2:1,3:1,4:0.5,5:0").unwrap();
        for tf in [&tf, &grey] {
            let t = TfTable::new(tf, (0.0, 5.0));
            for y in [1e-6f32, 0.37, 1.0, 1.7320508, 40.0] {
                let a = TfTable::new(tf, (0.0, 5.0)).for_stretch(y);
                assert_eq!((a.stretch, a.grey), (Some(y), t.grey));
                assert_eq!(a.opaque_before, t.opaque_before);
                assert_eq!(a.pairs.len(), t.pairs.len());
                for (e, (entry, alpha)) in t.entries.iter().zip(&a.entries).enumerate() {
                    let tau = tf.opacity(t.lo + e as f32 / t.scale);
                    let want = crate::render::corrected_opacity(tau, y);
                    assert_eq!(alpha[0].to_bits(), want.to_bits(), "entry {e}, y {y}");
                    assert_eq!(alpha[1..], entry[1..]);
                    if let Some(p) = a.pairs.get(e) {
                        assert_eq!(
                            [p[0].to_bits(), p[1].to_bits()],
                            [want.to_bits(), entry[1].to_bits()]
                        );
                    }
                }
            }
        }
    }

    /// A range the table calls clear holds no sample whose entry has
    /// `τ > 0`: random functions with clear stretches between opaque ones,
    /// over windows from tiny to huge and far from zero, and random ranges
    /// probed at their ends, at random inside, and on both sides of every
    /// entry boundary they cross. Clear ranges are found, and not all are
    /// (the test is not vacuous).
    #[test]
    fn clear_is_the_lookup() {
        let mut rng = StdRng::seed_from_u64(43);
        let (mut clear, mut tried) = (0, 0);
        for round in 0..300 {
            let (centre, span) = (
                [0.0f32, 1e3, -3e4, 7.5e6][round % 4],
                [1e-3f32, 1.0, 700.0, 3e5][round / 4 % 4],
            );
            let mut v = centre - span;
            let mut points = Vec::new();
            for i in 0..rng.random_range(2..9) {
                v += rng.random_range(0.05..0.6) * span;
                let o = if i % 2 == 0 {
                    0.0
                } else {
                    rng.random_range(0.0..1.0)
                };
                points.push(format!("{v}:{o}"));
            }
            let Ok(tf) = TransferFunction::parse(&points.join(",")) else {
                continue;
            };
            let t = TfTable::new(&tf, (centre - span, centre + span));
            let tau = |s: f32| tf.opacity(t.lo + t.entry(s) as f32 / t.scale);
            for _ in 0..40 {
                let a = centre + rng.random_range(-1.5f32..1.5) * span;
                let b = a + rng.random_range(0.0f32..0.3) * span;
                tried += 1;
                if !t.clear(a, b) {
                    continue;
                }
                clear += 1;
                let mut probes = vec![a, b, a.next_up(), b.next_down()];
                probes.extend((0..32).map(|_| rng.random_range(a..=b)));
                // Both sides of each entry boundary inside the range.
                let (e0, e1) = (t.entry(a), t.entry(b));
                for e in e0..=e1.min(e0 + 64) {
                    let x = t.lo + (e as f32 - 0.5) / t.scale;
                    probes.extend([x.next_down(), x, x.next_up()]);
                }
                for x in probes.into_iter().filter(|x| (a..=b).contains(x)) {
                    assert_eq!(tau(x), 0.0, "round {round}: {x} in clear [{a}, {b}]");
                }
            }
        }
        assert!(
            clear * 10 > tried && clear < tried,
            "{clear} of {tried} clear"
        );
    }

    /// The table look-ups in AVX2 registers (full, and grey from the
    /// pairs) read the entries the scalar one reads, for every length up
    /// to a chunk and samples of every kind: inside the table, on its
    /// ends, beyond them, ±∞, NaN, ±0, subnormal.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_lookup_is_the_scalar() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 here: the vector look-up is not run");
            return;
        }
        let mut rng = StdRng::seed_from_u64(37);
        let window = (-2.0, 5.0);
        // Clear, partial and opaque (`ln(1 − τ) = −∞`) entries, coloured.
        let tf = TransferFunction::parse("-2:0,0:0.4:#2040ff,2:1,3:1:#ff0000,5:0.2").unwrap();
        let t = TfTable::new(&tf, window);
        // The same without colours: grey.
        let grey_tf = TransferFunction::parse("-2:0,0:0.4,2:1,3:1,5:0.2").unwrap();
        let gt = TfTable::new(&grey_tf, window);
        assert!(gt.grey && !t.grey);
        let special = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            1e-42,
            -2.0,
            5.0,
            3e38,
            -3e38,
            t.lo,
            t.lo + (TF_TABLE - 1) as f32 / t.scale,
        ];
        let mut ends = 0;
        for _ in 0..2_000 {
            let n = rng.random_range(0..=RUN);
            let vals: Vec<f32> = (0..n)
                .map(|_| match rng.random_range(0..3) {
                    0 => special[rng.random_range(0..special.len())],
                    _ => rng.random_range(-4.0..7.0),
                })
                .collect();
            let mut want = ([0f32; RUN], [[0f32; RUN]; 3]);
            let mut want_grey = ([0f32; RUN], [0f32; RUN]);
            for (k, &s) in vals.iter().enumerate() {
                let e = t.entry(s);
                ends += usize::from(e == 0 || e == TF_TABLE - 1);
                [want.0[k], want.1[0][k], want.1[1][k], want.1[2][k]] = t.entries[e];
                let e = gt.entry(s);
                [want_grey.0[k], want_grey.1[k]] = [gt.entries[e][0], gt.entries[e][1]];
            }
            let mut got = ([0f32; RUN], [[0f32; RUN]; 3]);
            let mut grey = ([0f32; RUN], [0f32; RUN]);
            // SAFETY: AVX2 is detected above.
            unsafe {
                lookup_avx2(&t, &vals, &mut got.0, &mut got.1);
                lookup_grey_avx2(&gt, &vals, &mut grey.0, &mut grey.1);
            }
            // Lanes past `n` are scratch (the blend reads `..n`).
            let bits = |v: &[f32]| v[..n].iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got.0), bits(&want.0), "{vals:?}");
            for c in 0..3 {
                assert_eq!(bits(&got.1[c]), bits(&want.1[c]), "{vals:?}");
            }
            // The grey look-up: the grey table's `ln(1 − τ)` and grey.
            assert_eq!(bits(&grey.0), bits(&want_grey.0), "{vals:?}");
            assert_eq!(bits(&grey.1), bits(&want_grey.1), "{vals:?}");
        }
        assert!(ends > 1_000, "{ends} samples at the table's ends");
    }

    /// Compositing a span of a row (runs of up to [`RUN`] pixels across
    /// live chunks, chunks past [`EARLY_TERMINATION`] passed over) gives
    /// every pixel what the blend of that one pixel alone gives, bit for
    /// bit, and counts the samples of the live chunks: rows wider than a
    /// run, spans starting and ending inside chunks, pixels terminating on
    /// the way, grey and coloured tables, portable and AVX2 look-ups.
    #[test]
    fn runs_of_chunks_blend_as_single_pixels() {
        let mut rng = StdRng::seed_from_u64(71);
        let window = (0.0, 1.0);
        let coloured = TransferFunction::parse("0:0,0.3:0.6:#2040ff,1:1:#ff8000").unwrap();
        let grey = TransferFunction::parse("0:0,0.3:0.6,1:1").unwrap();
        #[cfg(target_arch = "x86_64")]
        let wide = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let wide = false;
        let (w, rows) = (5 * RUN + 17, 3);
        let mut live_runs = 0;
        for tf in [&coloured, &grey] {
            let table = TfTable::new(tf, window);
            for avx2 in [false, wide] {
                let n = w * rows;
                let mut band = CompositeBand {
                    w,
                    rgba: std::array::from_fn(|c| {
                        vec![
                            0.0;
                            if table.grey && (c == 1 || c == 2) {
                                0
                            } else {
                                n
                            }
                        ]
                    }),
                    q: vec![u16::MAX; n],
                    y: (0..n).map(|_| rng.random_range(0.3..3.0)).collect(),
                    seen: vec![true; n],
                    done: vec![false; rows * w.div_ceil(CHUNK)],
                    table: &table,
                    avx2,
                };
                // Each pixel's own state: `[r, g, b, a]` and its slice.
                let mut want = vec![([0f32; 4], u16::MAX); n];
                for q in 0..300u16 {
                    let row = rng.random_range(0..rows);
                    let lo = rng.random_range(0..w);
                    let hi = rng.random_range(lo + 1..=w);
                    let v0: Vec<f32> = (lo..hi).map(|_| rng.random_range(-0.1..1.1)).collect();
                    let v1: Vec<f32> = (lo..hi).map(|_| rng.random_range(-0.1..1.1)).collect();
                    let fb = rng.random_range(0.0..1.0);
                    let chunks = w.div_ceil(CHUNK);
                    let live = (lo / CHUNK..hi.div_ceil(CHUNK))
                        .filter(|&c| !band.done[row * chunks + c])
                        .map(|c| ((c + 1) * CHUNK).min(hi) - (c * CHUNK).max(lo))
                        .sum::<usize>();
                    live_runs += usize::from(live > RUN);
                    let got = band.add(row, lo, [&v0, &v1], fb, q);
                    assert_eq!(got, live as u64);
                    for x in lo..hi {
                        let (px, slice) = &mut want[row * w + x];
                        let s = v0[x - lo] + fb * (v1[x - lo] - v0[x - lo]);
                        let [ln, r, g, b] = table.entries[table.entry(s)];
                        let tau = if ln == f32::NEG_INFINITY { 1.0 } else { 0.0 };
                        let alpha = corrected_opacity_from_log(tau, ln, band.y[row * w + x]);
                        let alpha = if px[3] < EARLY_TERMINATION {
                            alpha
                        } else {
                            0.0
                        };
                        let wgt = (1.0 - px[3]) * alpha;
                        px[0] += wgt * r;
                        px[1] += wgt * g;
                        px[2] += wgt * b;
                        px[3] += wgt;
                        if *slice == u16::MAX && alpha > 0.0 {
                            *slice = q;
                        }
                    }
                }
                let mut terminated = 0;
                for (o, (px, slice)) in want.iter().enumerate() {
                    let ch = |c: usize| band.rgba[if table.grey && c < 3 { 0 } else { c }][o];
                    let got = [ch(0), ch(1), ch(2), ch(3)].map(f32::to_bits);
                    assert_eq!(got, px.map(f32::to_bits), "pixel {o}, grey {}", table.grey);
                    assert_eq!(band.q[o], *slice, "pixel {o}");
                    terminated += usize::from(px[3] >= EARLY_TERMINATION);
                }
                assert!(terminated > n / 4, "{terminated} of {n} pixels terminated");
                assert!(band.done.iter().any(|&d| d), "no chunk was passed over");
            }
        }
        assert!(live_runs > 20, "{live_runs} spans longer than a run");
    }

    /// The permuted resampling (AVX2, 8 columns from 16 samples; AVX-512,
    /// 16 from 32) equals the scalar one bit for bit on columns that rise
    /// by 0, 1, 2 or a jump (chunks that span more samples, which fall back
    /// to the scalar loop), up to the row's end, with weights and samples
    /// of every kind (0, −0, subnormal, huge).
    #[cfg(target_arch = "x86_64")]
    /// The warp's source sums every corner (zero where uncovered) where
    /// the warp used to test each corner and skip the uncovered ones: the
    /// same sums, bit for bit (NaN as NaN), and the same nearest hit, on intermediate
    /// images with uncovered pixels, `±0`, NaN and infinite samples, at
    /// crossings inside, on the border, just outside and far outside.
    #[test]
    fn warp_sources_sum_the_covered_corners() {
        let mut rng = StdRng::seed_from_u64(5);
        let special = [
            0.0,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e-40,
            -2.5,
        ];
        let (mut mixed, mut outside) = (0, 0);
        for _ in 0..300 {
            let (w, h) = (rng.random_range(1..40usize), rng.random_range(1..80usize));
            let bands = h.div_ceil(BAND);
            let rows = |bd: usize| BAND.min(h - bd * BAND);
            let value = |rng: &mut StdRng| match rng.random_range(0..6) {
                0 => special[rng.random_range(0..special.len())],
                1 => f32::NEG_INFINITY,
                _ => rng.random_range(-1.0..2.0),
            };
            let low = [f32::NEG_INFINITY, 0.0, 0.5][rng.random_range(0..3)];
            let mip: Vec<MipBand> = (0..bands)
                .map(|bd| MipBand {
                    w,
                    m: (0..w * rows(bd)).map(|_| value(&mut rng)).collect(),
                    q: (0..w * rows(bd)).map(|_| rng.random_range(0..9)).collect(),
                })
                .collect();
            let tf = TransferFunction::ramp((0.0, 1.0));
            // Three colour channels of their own (a grey table's band keeps
            // one; `tunings_give_the_same_image` checks that).
            let mut table = TfTable::new(&tf, (0.0, 1.0));
            table.grey = false;
            let comp: Vec<CompositeBand> = (0..bands)
                .map(|bd| {
                    let n = w * rows(bd);
                    CompositeBand {
                        w,
                        rgba: std::array::from_fn(|_| (0..n).map(|_| value(&mut rng)).collect()),
                        q: (0..n)
                            .map(|_| [u16::MAX, 3][rng.random_range(0..2)])
                            .collect(),
                        y: vec![1.0; n],
                        seen: (0..n).map(|_| rng.random_range(0..3) > 0).collect(),
                        done: vec![false; rows(bd) * w.div_ceil(CHUNK)],
                        table: &table,
                        avx2: false,
                    }
                })
                .collect();
            let (ms, cs) = (
                mip_source(&mip, (w, h), low),
                composite_source(&comp, (w, h)),
            );
            // The corners as the warp used to take them.
            let at = |i: i64, j: i64| {
                ((0..w as i64).contains(&i) && (0..h as i64).contains(&j)).then(|| {
                    let (i, j) = (i as usize, j as usize);
                    (j / BAND, (j % BAND) * w + i)
                })
            };
            for _ in 0..200 {
                let coord = |rng: &mut StdRng, n: usize| match rng.random_range(0..5) {
                    0 => rng.random_range(-3..n as i64 + 3) as f64,
                    1 => rng.random_range(-3..n as i64 + 3) as f64 + 0.5,
                    2 => rng.random_range(-1e6..1e6),
                    _ => rng.random_range(-2.5..n as f64 + 2.5),
                };
                let (fi, fj) = (coord(&mut rng, w), coord(&mut rng, h));
                let (i0, j0) = (fi.floor(), fj.floor());
                let (wi, wj) = ((fi - i0) as f32, (fj - j0) as f32);
                let (i0, j0) = (i0 as i64, j0 as i64);
                let corners = [
                    (i0, j0, (1.0 - wi) * (1.0 - wj)),
                    (i0 + 1, j0, wi * (1.0 - wj)),
                    (i0, j0 + 1, (1.0 - wi) * wj),
                    (i0 + 1, j0 + 1, wi * wj),
                ];
                let inside = corners.iter().filter(|c| at(c.0, c.1).is_some()).count();
                mixed += usize::from(inside > 0 && inside < 4);
                outside += usize::from(inside == 0);
                let nearest = at(fi.round() as i64, fj.round() as i64);
                let (mut m, mut mw) = (0f32, 0f32);
                let (mut acc, mut cw) = ([0f32; 4], 0f32);
                for &(i, j, wt) in &corners {
                    if let Some((bd, o)) = at(i, j) {
                        if mip[bd].m[o] > f32::NEG_INFINITY {
                            m += wt * mip[bd].m[o];
                            mw += wt;
                        }
                        if comp[bd].seen[o] {
                            for (x, ch) in acc.iter_mut().zip(&comp[bd].rgba) {
                                *x += wt * ch[o];
                            }
                            cw += wt;
                        }
                    }
                }
                let mip_hit = nearest
                    .filter(|&(bd, o)| mip[bd].m[o] > low)
                    .map_or(u16::MAX, |(bd, o)| mip[bd].q[o]);
                let comp_hit = nearest.map_or(u16::MAX, |(bd, o)| comp[bd].q[o]);
                // Bits, every NaN as one (Rust leaves a NaN's sign and
                // payload to the code generator, which may swap an
                // addition's operands).
                let bits = |v: &[f32]| {
                    v.iter()
                        .map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() })
                        .collect::<Vec<_>>()
                };
                let (got, q) = ms.sample(fi, fj);
                assert_eq!(bits(&got), bits(&[m, mw]), "MIP at ({fi}, {fj}), {w}×{h}");
                assert_eq!(q, mip_hit, "MIP hit at ({fi}, {fj})");
                let (got, q) = cs.sample(fi, fj);
                let want = [acc[0], acc[1], acc[2], acc[3], cw];
                assert_eq!(
                    bits(&got),
                    bits(&want),
                    "composite at ({fi}, {fj}), {w}×{h}"
                );
                assert_eq!(q, comp_hit, "composite hit at ({fi}, {fj})");
            }
        }
        assert!(
            mixed > 3_000 && outside > 3_000,
            "{mixed} on the border, {outside} outside"
        );
    }

    #[test]
    fn permuted_resampling_is_the_scalar() {
        let avx512 = std::arch::is_x86_feature_detected!("avx512f");
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 here: the permuted resampling is not run");
            return;
        }
        if !avx512 {
            eprintln!("no AVX-512F here: only the AVX2 permutes are run");
        }
        let (mut permuted8, mut fallback8) = (0, 0);
        let mut rng = StdRng::seed_from_u64(31);
        let special = [0.0, -0.0, 1e-40, -3e-39, 3e38, -3e38, 1.0, 0.5];
        let (mut permuted, mut fallback) = (0, 0);
        for _ in 0..3_000 {
            let na = rng.random_range(1..200usize);
            let src: Vec<f32> = (0..=na)
                .map(|_| match rng.random_range(0..4) {
                    0 => special[rng.random_range(0..special.len())],
                    _ => rng.random_range(-10.0..10.0),
                })
                .collect();
            let n = rng.random_range(0..120usize);
            // Columns that rise from a random start by steps of mostly
            // 0..=2 (a perspective slice's), with the odd jump.
            let mut a = rng.random_range(0..na);
            let a0: Vec<u32> = (0..n)
                .map(|_| {
                    let step = match rng.random_range(0..40) {
                        0 => rng.random_range(3..40),
                        k => k % 3,
                    };
                    a = (a + step).min(na - 1);
                    a as u32
                })
                .collect();
            let fa: Vec<f32> = (0..n)
                .map(|_| match rng.random_range(0..6) {
                    0 => 0.0,
                    1 => f32::from_bits(1),
                    _ => rng.random_range(0.0..1.0),
                })
                .collect();
            let (mut scalar, mut wide) = (vec![0f32; n], vec![1f32; n]);
            lerp_gathered(&src, &a0, &fa, &mut scalar);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let mut eight = vec![1f32; n];
            // SAFETY: AVX2 is detected above.
            unsafe { lerp_gathered_avx2(&src, &a0, &fa, &mut eight) };
            assert_eq!(bits(&eight), bits(&scalar), "a0 {a0:?}");
            for c in a0.chunks_exact(8) {
                let fits = (c[7] - c[0]) < 15 && c[0] as usize + 16 <= src.len();
                if fits { permuted8 += 1 } else { fallback8 += 1 }
            }
            if !avx512 {
                continue;
            }
            // SAFETY: AVX-512F is detected above.
            unsafe { lerp_gathered_avx512(&src, &a0, &fa, &mut wide) };
            assert_eq!(bits(&wide), bits(&scalar), "a0 {a0:?}");
            for c in a0.chunks_exact(16) {
                let fits = (c[15] - c[0]) < 31 && c[0] as usize + 32 <= src.len();
                if fits { permuted += 1 } else { fallback += 1 }
            }
        }
        assert!(
            permuted8 > 1_000 && fallback8 > 100,
            "{permuted8} {fallback8}"
        );
        assert!(
            !avx512 || (permuted > 1_000 && fallback > 100),
            "{permuted} {fallback}"
        );
    }

    /// The resampling over a slice's affine run (contiguous samples, one
    /// weight) gives the gathered resampling's values bit for bit, over all
    /// columns or any span of them, and an orthographic slice is one run
    /// but for its clamped ends.
    #[test]
    fn affine_runs_resample_as_gathering_does() {
        let mut rng = StdRng::seed_from_u64(23);
        let dims = [41i32, 33, 27];
        let s = scene(dims.map(|d| d as usize), |_, _, _| 0.0);
        let c = DVec3::new(20.0, 16.0, 13.0);
        let (mut ortho_slices, mut runs) = (0, 0);
        for t in 0..40 {
            let ortho = t % 2 == 0;
            let cam = random_camera(&mut rng, c, 45.0..160.0, ortho, 60.0, 50.0);
            let hi = IVec3::from_array(dims) - 1;
            let setup = RaySetup::new(&cam, s.transform(), Some((IVec3::ZERO, hi)), 48, 40);
            let Some(f) = Factor::new(&setup, dims) else {
                continue;
            };
            let na = dims[f.a] as usize;
            let src: Vec<f32> = (0..=na).map(|_| rng.random_range(-1.0..1.0)).collect();
            for q in 0..f.n {
                let cols = Columns::of(&f, q);
                let n = cols.hi.saturating_sub(cols.lo);
                let (mut fast, mut slow) = (vec![0f32; n], vec![0f32; n]);
                resample(&src, &cols, 0..n, &mut fast, Gather::Scalar);
                // A span of the columns (as skipped bricks leave them),
                // cut anywhere across the run.
                let s0 = rng.random_range(0..=n);
                let s1 = rng.random_range(s0..=n);
                let mut part = vec![0f32; s1 - s0];
                resample(&src, &cols, s0..s1, &mut part, Gather::Scalar);
                let (r0, r1) = cols.run;
                let gathered = Columns {
                    run: (0, 0),
                    ..cols
                };
                resample(&src, &gathered, 0..n, &mut slow, Gather::Scalar);
                // Bits, every NaN as one (Rust leaves a NaN's sign and
                // payload to the code generator, which may swap an
                // addition's operands).
                let bits = |v: &[f32]| {
                    v.iter()
                        .map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() })
                        .collect::<Vec<_>>()
                };
                assert_eq!(bits(&fast), bits(&slow), "{cam:?} slice {q}");
                #[cfg(target_arch = "x86_64")]
                for (gather, feature) in [
                    (Gather::Avx2, std::arch::is_x86_feature_detected!("avx2")),
                    (
                        Gather::Avx512,
                        std::arch::is_x86_feature_detected!("avx512f"),
                    ),
                ] {
                    if feature {
                        let mut wide = vec![0f32; n];
                        resample(&src, &gathered, 0..n, &mut wide, gather);
                        assert_eq!(bits(&wide), bits(&slow), "{cam:?} slice {q} {gather:?}");
                    }
                }
                assert_eq!(bits(&part), bits(&slow[s0..s1]), "{cam:?} slice {q}");
                assert!(r0 <= r1 && r1 <= n);
                if r1 > r0 {
                    runs += 1;
                    let (a, fa) = (gathered.a0[r0], gathered.fa[r0]);
                    for i in r0..r1 {
                        assert_eq!(gathered.a0[i], a + (i - r0) as u32);
                        assert_eq!(gathered.fa[i].to_bits(), fa.to_bits());
                    }
                }
                if ortho && n > 4 {
                    ortho_slices += 1;
                    assert!(
                        r0 <= 2 && r1 + 2 >= n,
                        "{cam:?} slice {q}: run {r0}..{r1} of {n}"
                    );
                }
            }
        }
        assert!(
            ortho_slices > 200 && runs >= ortho_slices,
            "{ortho_slices} {runs}"
        );
    }

    /// Along a grid axis, with one pixel per voxel column centred on it,
    /// every slice sample is a voxel's value and the warp lands on
    /// intermediate pixel centres: shear-warp is the exact image (MIP, and
    /// compositing with a table whose entries fall on the volume's values).
    #[test]
    fn axis_views_on_the_voxel_grid_are_exact() {
        let dims = [72usize, 66, 28];
        let mut rng = StdRng::seed_from_u64(11);
        let vals: Vec<f32> = (0..72 * 66 * 28)
            .map(|_| rng.random_range(0..4096) as f32)
            .collect();
        let s = scene(dims, |x, y, z| vals[x + 72 * (y + 66 * z)]);
        let window = (0.0, (TF_TABLE - 1) as f32);
        let c = DVec3::new(35.5, 32.5, 13.5);
        for (axis, sign) in [
            (0, 1.0),
            (0, -1.0),
            (1, 1.0),
            (1, -1.0),
            (2, 1.0),
            (2, -1.0),
        ] {
            let mut eye = c;
            eye[axis] += sign * 100.0;
            let up = if axis == 1 { DVec3::Z } else { DVec3::Y };
            let (w, h) = match axis {
                0 => (28, 66),
                1 => (72, 28),
                _ => (72, 66),
            };
            let cam = Camera::orthographic(eye, c, up, h as f64);
            let ro = RenderOptions {
                width: w,
                height: h,
                ..RenderOptions::default()
            };
            for mode in [VolumeMode::Mip, VolumeMode::Composite] {
                let (sw, exact, st) = both(&s, &cam, &ro, mode, window);
                assert!(st.shear_warp);
                let d = largest_difference(&sw, &exact);
                assert!(d < 1e-5, "axis {axis}{sign} {mode:?}: off by {d}");
                // Opaque enough that most pixels stop early (the passed-over
                // chunks of the intermediate rows).
                let steep = VolumeOptions {
                    transfer: TransferFunction::parse("0:0,1000:0.6,4095:0.95").unwrap(),
                    ..opts(VolumeMethod::ShearWarp, VolumeMode::Composite, window)
                };
                let sw = render_volume(&s, &cam, &ro, &steep).unwrap().0;
                let six = RenderOptions {
                    ray: RayKind::Six,
                    ..ro
                };
                let rays = VolumeOptions {
                    method: VolumeMethod::Rays,
                    ..steep.clone()
                };
                let exact = render_volume(&s, &cam, &six, &rays).unwrap().0;
                assert!(
                    exact
                        .color
                        .iter()
                        .filter(|c| c[3] >= EARLY_TERMINATION)
                        .count()
                        > w as usize * h as usize / 2
                );
                let d = largest_difference(&sw, &exact);
                assert!(d < 1e-5, "axis {axis}{sign} steep: off by {d}");
                assert_eq!(
                    sw.hit.iter().filter(|h| h.is_some()).count(),
                    exact.hit.iter().filter(|h| h.is_some()).count()
                );
            }
        }
    }

    /// The MIP of the module docs' definition, computed directly: per
    /// pixel, the four intermediate rays around its base-plane point, each
    /// slice's bilinear sample from the voxels' values, the covered
    /// corners' weights rescaled.
    fn mip_by_definition(
        s: &VolumeScene,
        cam: &Camera,
        ro: &RenderOptions,
        window: (f32, f32),
    ) -> Vec<Option<f32>> {
        let dims = s.dims().map(|d| d as i32);
        let setup = RaySetup::new(
            cam,
            s.transform(),
            Some((IVec3::ZERO, IVec3::from_array(dims) - 1)),
            ro.width,
            ro.height,
        );
        let f = Factor::new(&setup, dims).unwrap();
        let value = |p: IVec3| s.value(p).unwrap();
        let sample = |i: f64, j: f64, k: i32| -> Option<f32> {
            let p = f.point(i, j, k);
            let (na, nb) = (dims[f.a] as f64, dims[f.b] as f64);
            if !(p[f.a] >= -0.5 && p[f.a] <= na - 0.5 && p[f.b] >= -0.5 && p[f.b] <= nb - 0.5) {
                return None;
            }
            let (a, b) = (p[f.a].clamp(0.0, na - 1.0), p[f.b].clamp(0.0, nb - 1.0));
            let (a0, b0) = (a.floor(), b.floor());
            let (fa, fb) = ((a - a0) as f32, (b - b0) as f32);
            let at = |da: i32, db: i32| {
                let mut v = IVec3::ZERO;
                v[f.c] = k;
                v[f.a] = (a0 as i32 + da).min(dims[f.a] - 1);
                v[f.b] = (b0 as i32 + db).min(dims[f.b] - 1);
                value(v)
            };
            let r0 = at(0, 0) + fa * (at(1, 0) - at(0, 0));
            let r1 = at(0, 1) + fa * (at(1, 1) - at(0, 1));
            Some(r0 + fb * (r1 - r0))
        };
        let mut out = Vec::new();
        for y in 0..ro.height {
            for x in 0..ro.width {
                let ray = setup.ray(x, y);
                if ray.clip(setup.lo, setup.hi).is_none() {
                    out.push(None);
                    continue;
                }
                let t = (f.front as f64 - ray.o[f.c]) / ray.d[f.c];
                let fi = ray.o[f.a] + ray.d[f.a] * t - f.u0;
                let fj = ray.o[f.b] + ray.d[f.b] * t - f.v0;
                let (i0, j0) = (fi.floor(), fj.floor());
                let (wi, wj) = ((fi - i0) as f32, (fj - j0) as f32);
                let (mut m, mut wsum) = (0.0, 0.0);
                for (i, j, w) in [
                    (i0, j0, (1.0 - wi) * (1.0 - wj)),
                    (i0 + 1.0, j0, wi * (1.0 - wj)),
                    (i0, j0 + 1.0, (1.0 - wi) * wj),
                    (i0 + 1.0, j0 + 1.0, wi * wj),
                ] {
                    let best = (0..f.n)
                        .filter_map(|q| sample(i, j, f.front + q * f.step))
                        .fold(f32::NEG_INFINITY, f32::max);
                    if best > f32::NEG_INFINITY {
                        m += w * best;
                        wsum += w;
                    }
                }
                out.push(Some(grey(
                    if wsum > 0.0 { m / wsum } else { window.0 },
                    window,
                )));
            }
        }
        out
    }

    /// Random oblique views, orthographic and perspective, of a random
    /// anisotropic volume: the fast path (slice rows, column tables, bands)
    /// gives the definition's MIP.
    #[test]
    fn mip_follows_its_definition() {
        let dims = [21usize, 26, 17];
        let mut rng = StdRng::seed_from_u64(5);
        let vals: Vec<f32> = (0..21 * 26 * 17)
            .map(|_| rng.random_range(0.0..10.0))
            .collect();
        let s = scene(dims, |x, y, z| vals[x + 21 * (y + 26 * z)]);
        let window = (1.0, 9.5);
        let c = DVec3::new(10.0, 12.5, 8.0);
        for round in 0..24 {
            let cam = random_camera(&mut rng, c, 40.0..90.0, round % 2 == 0, 45.0, 40.0);
            let ro = RenderOptions {
                width: 48,
                height: 40,
                ..RenderOptions::default()
            };
            let (sw, _, st) = both(&s, &cam, &ro, VolumeMode::Mip, window);
            assert!(st.shear_warp);
            let want = mip_by_definition(&s, &cam, &ro, window);
            let mut inside = 0;
            for (px, (p, w)) in sw.color.iter().zip(&want).enumerate() {
                match w {
                    None => assert_eq!(p[3], 0.0, "round {round} pixel {px}"),
                    Some(g) => {
                        inside += 1;
                        assert!(
                            (p[0] - g).abs() < 1e-4,
                            "round {round} pixel {px}: {} against {g}",
                            p[0]
                        );
                    }
                }
            }
            assert!(inside > 200, "round {round}: {inside}");
        }
    }

    /// Oblique views of a smooth bump `R² − |p − c|²`: where a ray passes
    /// near the centre, shear-warp's MIP is the 6-ray's within the bump's
    /// change over a voxel (bilinear slices of a quadratic, slice spacing).
    #[test]
    fn oblique_views_of_a_bump_match_the_rays_near_its_top() {
        let dims = [32usize, 28, 30];
        let c = DVec3::new(15.5, 13.5, 14.5);
        let s = scene(dims, |x, y, z| {
            (200.0 - (DVec3::new(x as f64, y as f64, z as f64) - c).length_squared()) as f32
        });
        let window = (0.0, 200.0);
        let mut rng = StdRng::seed_from_u64(8);
        for round in 0..16 {
            let cam = random_camera(&mut rng, c, 60.0..120.0, round % 2 == 0, 48.0, 35.0);
            let ro = RenderOptions {
                width: 64,
                height: 64,
                ..RenderOptions::default()
            };
            let (sw, exact, _) = both(&s, &cam, &ro, VolumeMode::Mip, window);
            let mut compared = 0;
            for (p, q) in sw.color.iter().zip(&exact.color) {
                // Rays within ~4 voxels of the centre: 200 − d² ≥ 184.
                if q[0] * 200.0 >= 184.0 {
                    compared += 1;
                    // A voxel centre within 0.87 of the ray: d² off by at
                    // most 2·4·0.87 + 0.75 ≈ 7.7; slices and bilinear < 1.
                    assert!(
                        (p[0] - q[0]).abs() * 200.0 <= 9.0,
                        "round {round}: {} against {}",
                        p[0] * 200.0,
                        q[0] * 200.0
                    );
                }
            }
            assert!(compared > 20, "round {round}: {compared}");
        }
    }

    /// A MIP or compositing that passes over the bricks no pixel of a band
    /// can take gives the image of one that reads them all, bit for bit, in
    /// slabs and row by row, from every side: bright walls of uneven brightness hide
    /// dimmer blobs inside (whole bricks go; some blobs reach through the
    /// walls), and bright sheets one voxel thick lie on the first voxels
    /// of bricks, which the lerps of the last columns of the bricks before
    /// them read (a bound without the bricks' aprons fails here).
    #[test]
    fn skipped_bricks_change_no_pixel() {
        let dims = [101usize, 83, 92];
        let c = DVec3::new(50.0, 41.0, 46.0);
        let mut rng = StdRng::seed_from_u64(31);
        let blobs: Vec<(DVec3, f64, f64)> = (0..40)
            .map(|_| {
                let p = DVec3::new(
                    rng.random_range(0.0..101.0),
                    rng.random_range(0.0..83.0),
                    rng.random_range(0.0..92.0),
                );
                (p, rng.random_range(2.0..8.0), rng.random_range(0.1..0.6))
            })
            .collect();
        let s = scene(dims, |x, y, z| {
            let p = DVec3::new(x as f64, y as f64, z as f64);
            let d = p - c;
            let face = (0..3)
                .map(|k| [x, y, z][k].min(dims[k] - 1 - [x, y, z][k]))
                .min()
                .unwrap();
            let wall = if face < 2 {
                0.7 + 0.3 * (d.x * 0.3).sin() * (d.z * 0.2 + d.y * 0.1).cos()
            } else if (x == 48 || y == 40 || z == 56) && d.length() < 30.0 {
                1.0
            } else {
                0.0
            };
            let v: f64 = blobs
                .iter()
                .map(|&(q, r, h)| h * (-(p - q).length_squared() / (r * r)).exp())
                .fold(wall, f64::max);
            // Steps of 1/64, so that neighbouring samples tie too.
            ((v * 64.0).round() / 64.0) as f32
        });
        let ro = RenderOptions {
            width: 72,
            height: 60,
            ..RenderOptions::default()
        };
        let window = (0.05, 1.2);
        // Compositing with the default ramp (clear below 0.05: the empty
        // inside, the blobs' tails) and with a gap: values from 0.25 to
        // 0.5 are clear too, so bricks of middling values go as well.
        let gap = TransferFunction::parse("0.05:0,0.2:0.3,0.25:0,0.5:0,0.55:0.6,1.2:0.9").unwrap();
        // Nothing clear and every sample nearly opaque: rays terminate
        // within a few slices, and bricks only terminated pixels read go.
        let opaque = TransferFunction::parse("-1:0.95,2:1").unwrap();
        let modes = [
            opts(VolumeMethod::ShearWarp, VolumeMode::Mip, window),
            opts(VolumeMethod::ShearWarp, VolumeMode::Composite, window),
            VolumeOptions {
                transfer: gap,
                ..opts(VolumeMethod::ShearWarp, VolumeMode::Composite, window)
            },
            VolumeOptions {
                transfer: opaque,
                ..opts(VolumeMethod::ShearWarp, VolumeMode::Composite, window)
            },
        ];
        for (m, o) in modes.iter().enumerate() {
            let (mut all, mut taken, mut passed) = (0u64, 0u64, 0u64);
            for t in 0..24 {
                let cam = random_camera(&mut rng, c, 130.0..260.0, t % 2 == 0, 140.0, 50.0);
                let tuning = |skip: bool, slab_cap: usize| Tuning {
                    slab_cap,
                    skip,
                    grey: true,
                    alpha_table: true,
                    #[cfg(target_arch = "x86_64")]
                    avx2: false,
                    #[cfg(target_arch = "x86_64")]
                    avx512: false,
                };
                let Some((every, st)) =
                    render_with(&s, &cam, &ro, o, tuning(false, SLAB_CAP)).unwrap()
                else {
                    continue;
                };
                assert_eq!(st.bricks_skipped, 0);
                for cap in [SLAB_CAP, 0] {
                    let (img, sk) = render_with(&s, &cam, &ro, o, tuning(true, cap))
                        .unwrap()
                        .unwrap();
                    assert_eq!(img, every, "mode {m} {cam:?} cap {cap}");
                    (all, taken) = (all + st.voxels_visited, taken + sk.voxels_visited);
                    passed += sk.bricks_skipped;
                }
            }
            if m == 3 {
                // Terminated pixels take no sample either way: the samples
                // are the same, and the bricks passed over are the ones
                // only such pixels read (none is clear).
                assert_eq!(taken, all, "mode {m}");
                assert!(passed > 100, "mode {m}: {passed} bricks passed over");
                continue;
            }
            // The test sees skipping at work. MIP: a twelfth of the samples
            // or more go (a band's floor is the lowest of its 32 rows', and
            // this intermediate image is ~100 rows tall: 11% go today).
            // Compositing: a fiftieth or more (3.3% and 4.0% today: a
            // brick goes only where all the band's rows there are clear,
            // and the walls and blobs leave few such).
            let share = if m == 0 { 12 } else { 50 };
            assert!(
                taken * share < all * (share - 1),
                "mode {m}: {taken} of {all} samples taken"
            );
        }
    }

    /// One thread or several: the same image.
    #[test]
    fn threads_give_the_same_image() {
        let dims = [40usize, 36, 44];
        let mut rng = StdRng::seed_from_u64(9);
        let vals: Vec<f32> = (0..40 * 36 * 44)
            .map(|_| rng.random_range(0.0..1.0))
            .collect();
        let s = scene(dims, |x, y, z| vals[x + 40 * (y + 36 * z)]);
        let cam = Camera::perspective(
            DVec3::new(90.0, -70.0, 60.0),
            DVec3::new(20.0, 18.0, 22.0),
            DVec3::Z,
            35.0,
        );
        let ro = RenderOptions {
            width: 96,
            height: 80,
            ..RenderOptions::default()
        };
        for mode in [VolumeMode::Mip, VolumeMode::Composite] {
            let o = opts(VolumeMethod::ShearWarp, mode, (0.2, 0.9));
            let run = |t: usize| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .unwrap()
                    .install(|| render_volume(&s, &cam, &ro, &o).unwrap().0)
            };
            let one = run(1);
            assert_eq!(one, run(3), "{mode:?}");
        }
    }

    /// The intermediate image, column tables and slabs are charged to the
    /// memory limit before they are allocated: a limit the image's own
    /// buffers fit under, but not shear-warp's, is one clear error.
    #[test]
    fn working_buffers_are_capped() {
        let s = scene([120, 110, 8], |x, y, z| ((x * 7 + y * 3 + z) % 11) as f32);
        let cam = Camera::orthographic(
            DVec3::new(60.0, 55.0, 100.0),
            DVec3::new(60.0, 55.0, 4.0),
            DVec3::Y,
            130.0,
        );
        let small = RenderOptions {
            width: 64,
            height: 64,
            limit: MemoryLimit::new(200_000),
            ..RenderOptions::default()
        };
        for mode in [VolumeMode::Mip, VolumeMode::Composite] {
            let rays = render_volume(
                &s,
                &cam,
                &small,
                &opts(VolumeMethod::Rays, mode, (0.0, 10.0)),
            );
            assert!(rays.is_ok(), "{mode:?}: the image alone fits");
            let sw = opts(VolumeMethod::ShearWarp, mode, (0.0, 10.0));
            let err = render_volume(&s, &cam, &small, &sw)
                .unwrap_err()
                .to_string();
            assert!(err.contains("shear-warp"), "{mode:?}: {err}");
            let roomy = RenderOptions {
                limit: MemoryLimit::new(4_000_000),
                ..small
            };
            assert!(
                render_volume(&s, &cam, &roomy, &sw).unwrap().1.shear_warp,
                "{mode:?}"
            );
        }
    }

    /// An eye inside the volume, or an iso-surface: rays, the exact image.
    #[test]
    fn no_factorization_casts_rays() {
        let s = scene([16, 16, 16], |x, y, z| ((x * y + z) % 7) as f32);
        let inside = Camera::perspective(
            DVec3::new(7.0, 8.0, 9.0),
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::Z,
            60.0,
        );
        let outside = Camera::perspective(
            DVec3::new(40.0, 30.0, 50.0),
            DVec3::splat(7.5),
            DVec3::Z,
            40.0,
        );
        let ro = RenderOptions {
            width: 40,
            height: 32,
            ..RenderOptions::default()
        };
        for (cam, mode) in [(inside, VolumeMode::Mip), (outside, VolumeMode::Iso(3.0))] {
            let six = RenderOptions {
                ray: RayKind::Six,
                ..ro
            };
            let sw = render_volume(
                &s,
                &cam,
                &six,
                &opts(VolumeMethod::ShearWarp, mode, (0.0, 6.0)),
            )
            .unwrap();
            let exact =
                render_volume(&s, &cam, &six, &opts(VolumeMethod::Rays, mode, (0.0, 6.0))).unwrap();
            assert!(!sw.1.shear_warp);
            assert_eq!(sw.0, exact.0);
        }
    }
}
