//! Tiles of pixels whose rays can see nothing, found before any ray is
//! cast: a coarse pass over the bricks instead of a walk per ray.
//!
//! Every voxel a pixel's walk visits (6, 26, adaptive or Amanatides–Woo)
//! has its closed cube meeting the pixel's segment, so its centre lies
//! within ½ (per axis) of the continuous ray. A brick that may change a
//! pixel (the grid: one holding an occupied voxel; a volume: one whose
//! samples, with the aprons the sampling reads, are not all quiet for the
//! mode) can therefore only matter to pixels whose rays pass through its
//! box of centres grown by [`REACH`]. Each such box is projected through the
//! frame's camera; the bounding rectangle of its corners' images (the image
//! of a convex box is the hull of its corners' images) marks the
//! [`TILE`]-pixel tiles it may reach. A pixel in an unmarked tile sees only
//! skippable bricks, and its ray's result is known without casting it: no
//! hit, nothing accumulated. So culling changes no pixel: it is part of
//! skipping, on with [`RenderOptions::skip`](super::RenderOptions::skip).
//!
//! When many bricks may matter, blocks of `2^l` bricks per side are
//! projected instead (a block matters if any of its bricks does), so the
//! pass stays a few milliseconds; where a box reaches behind the eye or
//! covers a large part of the frame, every tile is marked.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::{DMat3, DVec3, IVec3};
use rayon::prelude::*;

use super::RaySetup;

/// Pixels per tile side.
pub(crate) const TILE: u32 = 8;

/// How far beyond a visited voxel's centre, per axis, its ray may pass:
/// the cube's ½ and a whole voxel of slack (fixed-point segments, float
/// traversal; the walks stay within ½).
const REACH: f64 = 1.5;

/// A box covering more than this share of the frame's tiles marks them all.
const WIDE: usize = 8;

/// Slack on the projected rectangle, in pixels (the projection's rounding
/// is ~1e-12 of the frame).
const PIXEL_SLACK: f64 = 1e-3;

/// The tiles of one frame that some ray may see something through.
pub(crate) struct TileMask {
    cols: usize,
    /// One bit per tile, row-major; `None`: every tile.
    bits: Option<Vec<u64>>,
}

impl TileMask {
    /// Every tile may see.
    pub(crate) fn all() -> TileMask {
        TileMask {
            cols: 0,
            bits: None,
        }
    }

    /// The tiles of `setup`'s frame whose rays may meet a brick (of
    /// `bdims` bricks, x fastest) for which `matters(index)` holds.
    pub(crate) fn new(
        setup: &RaySetup,
        bdims: [i32; 3],
        matters: impl Fn(usize) -> bool + Sync,
    ) -> TileMask {
        let (w, h) = (setup.width as usize, setup.height as usize);
        let cols = w.div_ceil(TILE as usize);
        let tiles = cols * h.div_ceil(TILE as usize);
        let n: usize = bdims.iter().map(|&d| d as usize).product();
        let mut flags: Vec<bool> = (0..n).into_par_iter().map(&matters).collect();
        let mut count = flags.iter().filter(|&&f| f).count();
        // One box per tile at most: beyond, blocks of 2^l bricks.
        let (mut dims, mut level) = (bdims, 0);
        while count > tiles.max(64) && dims.iter().any(|&d| d > 1) {
            (dims, flags) = coarsen(dims, &flags);
            count = flags.iter().filter(|&&f| f).count();
            level += 1;
        }
        let Some(proj) = Projection::new(setup) else {
            return TileMask::all();
        };
        let words: Vec<AtomicU64> = (0..tiles.div_ceil(64)).map(|_| AtomicU64::new(0)).collect();
        let every = AtomicBool::new(false);
        let side = super::bricks::BRICK << level;
        flags.par_iter().enumerate().for_each(|(i, &f)| {
            if !f || every.load(Ordering::Relaxed) {
                return;
            }
            let (x, y, z) = (
                i as i32 % dims[0],
                i as i32 / dims[0] % dims[1],
                i as i32 / (dims[0] * dims[1]),
            );
            let lo = IVec3::new(x, y, z) * side;
            let lo = lo.as_dvec3() - REACH;
            let hi = lo + (side - 1) as f64 + 2.0 * REACH;
            match proj.rect(lo, hi) {
                Reach::Nothing => {}
                Reach::Everything => every.store(true, Ordering::Relaxed),
                Reach::Pixels([x0, y0, x1, y1]) => {
                    let t = TILE as usize;
                    let (tx0, tx1, ty0, ty1) = (x0 / t, x1 / t, y0 / t, y1 / t);
                    if (tx1 - tx0 + 1) * (ty1 - ty0 + 1) * WIDE > tiles {
                        every.store(true, Ordering::Relaxed);
                        return;
                    }
                    for ty in ty0..=ty1 {
                        for tx in tx0..=tx1 {
                            let k = ty * cols + tx;
                            words[k / 64].fetch_or(1 << (k % 64), Ordering::Relaxed);
                        }
                    }
                }
            }
        });
        if every.into_inner() {
            return TileMask::all();
        }
        let bits: Vec<u64> = words.into_iter().map(AtomicU64::into_inner).collect();
        let marked: u32 = bits.iter().map(|b| b.count_ones()).sum();
        TileMask {
            cols,
            bits: (marked as usize != tiles).then_some(bits),
        }
    }

    /// Whether pixel `(x, y)`'s ray may see anything.
    #[inline(always)]
    pub(crate) fn may_see(&self, x: u32, y: u32) -> bool {
        match &self.bits {
            None => true,
            Some(bits) => {
                let k = (y / TILE) as usize * self.cols + (x / TILE) as usize;
                bits[k / 64] >> (k % 64) & 1 == 1
            }
        }
    }

    /// Tiles that no ray sees through (for tests and counters).
    #[cfg(test)]
    pub(crate) fn culled(&self) -> usize {
        self.bits
            .as_ref()
            .map_or(0, |b| b.iter().map(|w| w.count_zeros() as usize).sum())
    }
}

/// Blocks of 2 × 2 × 2 cells, each set where any of its cells is.
fn coarsen(dims: [i32; 3], flags: &[bool]) -> ([i32; 3], Vec<bool>) {
    let up = dims.map(|d| (d + 1) / 2);
    let mut out = vec![false; up.iter().map(|&d| d as usize).product()];
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                if flags[(x + dims[0] * (y + dims[1] * z)) as usize] {
                    out[(x / 2 + up[0] * (y / 2 + up[1] * (z / 2))) as usize] = true;
                }
            }
        }
    }
    (up, out)
}

/// What a box's image covers.
enum Reach {
    /// No pixel's ray reaches the box (it lies behind the eye).
    Nothing,
    /// Possibly every pixel (the box reaches the eye's plane).
    Everything,
    /// Pixels `x0..=x1`, `y0..=y1` at most.
    Pixels([usize; 4]),
}

/// The camera's map from grid points to image coordinates: the inverse of
/// [`RaySetup::pixel`]'s ray construction.
struct Projection {
    o: DVec3,
    /// Grid point − origin ↦ (depth, a, b) with the point on the ray of
    /// image coordinates `(a, b)` ∈ [−1, 1]² (perspective: `(a, b) · depth`).
    inv: DMat3,
    ortho: bool,
    size: [f64; 2],
}

impl Projection {
    fn new(s: &RaySetup) -> Option<Projection> {
        let m = DMat3::from_cols(s.f, s.r, s.u);
        let inv = m.inverse();
        inv.is_finite().then_some(Projection {
            o: s.o,
            inv,
            ortho: s.ortho,
            size: [s.width as f64, s.height as f64],
        })
    }

    /// The pixels whose rays may pass through the box `[lo, hi]`.
    fn rect(&self, lo: DVec3, hi: DVec3) -> Reach {
        let (mut a0, mut a1, mut b0, mut b1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        let mut ahead = 0;
        for c in 0..8 {
            let p = DVec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            );
            let q = self.inv * (p - self.o);
            let (a, b) = if self.ortho {
                (q.y, q.z)
            } else {
                // Rays leave the eye forwards (t ≥ 0): a box wholly behind
                // its plane is never reached, one across it may be reached
                // anywhere.
                if q.x <= 1e-9 * q.length() {
                    continue;
                }
                ahead += 1;
                (q.y / q.x, q.z / q.x)
            };
            a0 = a0.min(a);
            a1 = a1.max(a);
            b0 = b0.min(b);
            b1 = b1.max(b);
        }
        if !self.ortho && ahead < 8 {
            return if ahead == 0 {
                Reach::Nothing
            } else {
                Reach::Everything
            };
        }
        if !(a0.is_finite() && a1.is_finite() && b0.is_finite() && b1.is_finite()) {
            return Reach::Everything;
        }
        // Pixel x's ray has a = 2(x + ½)/W − 1; pixel y's b = 1 − 2(y + ½)/H.
        let [w, h] = self.size;
        let range = |lo: f64, hi: f64, n: f64| -> Option<(usize, usize)> {
            let first = (lo - 0.5 - PIXEL_SLACK).ceil().max(0.0);
            let last = (hi - 0.5 + PIXEL_SLACK).floor().min(n - 1.0);
            (first <= last).then_some((first as usize, last as usize))
        };
        let Some((x0, x1)) = range((a0 + 1.0) * w * 0.5, (a1 + 1.0) * w * 0.5, w) else {
            return Reach::Nothing;
        };
        let Some((y0, y1)) = range((1.0 - b1) * h * 0.5, (1.0 - b0) * h * 0.5, h) else {
            return Reach::Nothing;
        };
        Reach::Pixels([x0, y0, x1, y1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::line::Segment;
    use crate::render::{GridTransform, RayKind};
    use rand::{Rng, SeedableRng};

    /// The walks stay within ½ of the segment (per axis, from a visited
    /// voxel's centre): the premise of [`REACH`], checked for every ray
    /// kind on random segments, short and long, on and off lattice planes.
    #[test]
    fn walks_stay_within_half_a_voxel_of_the_segment() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2711);
        for round in 0..2000 {
            let span = if round % 3 == 0 { 4.0 } else { 60.0 };
            let p = |rng: &mut rand_chacha::ChaCha8Rng| -> [f64; 3] {
                std::array::from_fn(|_| {
                    let x: f64 = rng.random_range(0.0..span);
                    if rng.random_bool(0.2) {
                        x.round() + 0.5
                    } else {
                        x
                    }
                })
            };
            let (a, b) = (p(&mut rng), p(&mut rng));
            let Ok(seg) = Segment::from_f64(a, b) else {
                continue;
            };
            let (a, b) = (DVec3::from_array(a), DVec3::from_array(b));
            for kind in [
                RayKind::Six,
                RayKind::TwentySix,
                RayKind::Adaptive,
                RayKind::AmanatidesWoo,
            ] {
                for v in crate::render::walk::visited_voxels(&seg, kind, rng.random()) {
                    let d = linf_to_segment(v.as_dvec3(), a, b);
                    assert!(d <= 0.5 + 1e-6, "{kind:?} {seg:?}: {v} at {d}");
                }
            }
        }
    }

    /// L∞ distance from `p` to segment `[a, b]` (a convex function of the
    /// segment parameter: ternary search).
    fn linf_to_segment(p: DVec3, a: DVec3, b: DVec3) -> f64 {
        let f = |t: f64| (a + (b - a) * t - p).abs().max_element();
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..200 {
            let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
            if f(m1) <= f(m2) {
                hi = m2;
            } else {
                lo = m1;
            }
        }
        f((lo + hi) * 0.5)
    }

    /// A marked tile holds every pixel whose ray passes through a brick
    /// that matters, and far-away tiles are culled: random bricks, random
    /// perspective and orthographic cameras, anisotropic frames.
    #[test]
    fn marked_tiles_hold_every_ray_through_a_brick_that_matters() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(99);
        let mut culled = 0;
        for round in 0..60 {
            let dims = [40 + round % 7, 33, 48].map(|d| d as usize);
            let bd = dims.map(|d| d.div_ceil(8) as i32);
            let n = (bd[0] * bd[1] * bd[2]) as usize;
            let on: Vec<bool> = (0..n).map(|_| rng.random_bool(0.04)).collect();
            // Cubic voxels, or anisotropic and sheared axes.
            let axes = if round % 2 == 0 {
                DMat3::IDENTITY
            } else {
                DMat3::from_cols(
                    DVec3::new(1.0, 0.0, 0.0),
                    DVec3::new(0.2, 0.7, 0.0),
                    DVec3::new(0.0, -0.1, 1.6),
                )
            };
            let xf = GridTransform::new(DVec3::new(-3.0, 2.0, 5.0), axes).unwrap();
            let target = xf.grid_to_world(DVec3::from_array(dims.map(|d| d as f64 * 0.5)));
            let dir = DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let dist = rng.random_range(20.0..200.0);
            let cam = if round % 3 == 0 {
                Camera::orthographic(target + dir * dist, target, DVec3::Z, 70.0)
            } else {
                Camera::perspective(target + dir * dist, target, DVec3::Z, 40.0)
            };
            let (w, h) = (48, 40);
            let setup = RaySetup::new(
                &cam,
                &xf,
                Some((IVec3::ZERO, IVec3::from_array(dims.map(|d| d as i32)) - 1)),
                w,
                h,
            );
            let mask = TileMask::new(&setup, bd, |i| on[i]);
            culled += mask.culled();
            for y in 0..h {
                for x in 0..w {
                    let (ray, seg) = setup.pixel(x, y);
                    if seg.is_none() {
                        continue;
                    }
                    // Sample the ray densely; any centre within ½ of it in
                    // a brick that matters needs the tile.
                    let (t0, t1) = ray.clip(setup.lo, setup.hi).unwrap();
                    let steps = 400;
                    for s in 0..=steps {
                        let p = ray.o + ray.d * (t0 + (t1 - t0) * s as f64 / steps as f64);
                        let v = p.round().as_ivec3();
                        let b: IVec3 = v >> 3;
                        if (0..3).any(|k| b[k] < 0 || b[k] >= bd[k]) {
                            continue;
                        }
                        let i = (b.x + bd[0] * (b.y + bd[1] * b.z)) as usize;
                        if on[i] {
                            assert!(
                                mask.may_see(x, y),
                                "round {round}: pixel ({x}, {y}) brick {b}"
                            );
                        }
                    }
                }
            }
        }
        assert!(culled > 0, "no tile was ever culled");
    }
}
