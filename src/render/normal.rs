//! Smooth normals of voxel surfaces: a plane fitted to the occupied voxels
//! around a hit.
//!
//! The occupancy gradient over the 3×3×3 neighbours (the previous smooth
//! normal) takes only a few dozen directions, and along a digital plane of
//! slope `p/q` it cycles through them with the plane's staircase: on curved
//! surfaces those cycles line up into moiré bands. A wider window sees
//! several periods of the staircase at once, and a least-squares plane
//! through them is close to the continuous surface's tangent plane wherever
//! the window sits.
//!
//! The fit: the Gaussian-weighted (σ = [`SIGMA`]) covariance `C` of the
//! centres of the *surface* voxels (occupied, with an empty 6-neighbour)
//! within the 7³ window around the hit. A solid's interior would pull a
//! fit into its bulk; its surface voxels form a digital plane like a thin
//! sheet's. `C`'s eigenvector of least variance is the plane's normal. It
//! is taken as `n ∝ (C + εI)⁻ᵏ u` (`k` = [`POWER`]), `u` pointing back along
//! the ray: with `C`'s eigenpairs `(λᵢ, eᵢ)` that is
//! `Σ (eᵢ·u) eᵢ / (λᵢ + ε)ᵏ`, so
//! - on a sheet (one small `λ`) it is the plane's normal, facing the viewer;
//! - on a rod (two small `λ`, thin features one or two voxels wide) it is
//!   the view direction with its component along the rod removed;
//! - on a lone voxel or a blob it is the view direction.
//!
//! No eigen-decomposition, no thresholds (which would draw seams), and
//! `n·u > 0` always. The window's moments come from whole mask rows: the
//! 9³ occupancy around the hit as 81 rows of 9 bits (from at most 2×2×2
//! bricks), the surface voxels by shifts and ands of neighbouring rows, and
//! per 7-bit row pattern a 128-entry table of its weighted moments. On
//! x86-64 a layer's rows sit in the 16-bit lanes of an SSE2 register (a
//! brick pair's eight rows by one byte interleave) and the surface test
//! takes seven rows at once; the sums run in the same order, so the
//! moments are the same bits. A render keeps, per hit voxel, the inverse
//! the normal needs ([`Fit`]) for the neighbouring pixels that hit it too.
//!
//! Measured on digital planes of random directions (naive, standard, and a
//! half-space's boundary), the angle to the true normal averages about 1°
//! (99th percentile about 6°); the 3×3×3 gradient it replaces averaged 31°
//! on naive planes, where its sum vanished on one voxel in five.

use std::sync::LazyLock;

use glam::{DMat3, DVec3, IVec3};

use crate::grid::brick::BrickMask;

/// Half the window's side, in voxels.
pub const RADIUS: i32 = 3;
/// The Gaussian weights' standard deviation, in voxels.
pub const SIGMA: f64 = 2.0;
/// `ε` of the fit, as a share of the covariance's mean eigenvalue.
const EPSILON: f64 = 0.02;
/// The power of `(C + εI)⁻¹` applied to the view direction: the larger,
/// the less of the view direction leaks into a sheet's normal.
const POWER: usize = 4;

/// The Gaussian weight of offset `d` along one axis.
fn weight(d: i32) -> f64 {
    (-f64::from(d * d) / (2.0 * SIGMA * SIGMA)).exp()
}

/// The weights' tables, computed once.
struct Tables {
    /// Per offset `d` along an axis (at `d + RADIUS`), `g(d)·(1, d, d²)`.
    axis: [[f64; 3]; 7],
    /// Per 7-bit row pattern (bit `i`: offset `i − 3`), `Σ g(dx)·(1, dx,
    /// dx²)` over its set bits.
    rows: [[f64; 3]; 128],
}

static TABLES: LazyLock<Tables> = LazyLock::new(|| Tables {
    axis: std::array::from_fn(|i| {
        let d = i as i32 - RADIUS;
        let (g, x) = (weight(d), f64::from(d));
        [g, g * x, g * x * x]
    }),
    rows: std::array::from_fn(|bits| {
        let mut m = [0.0; 3];
        for i in 0..7 {
            if bits >> i & 1 == 1 {
                let d = i - RADIUS;
                let (g, x) = (weight(d), f64::from(d));
                m[0] += g;
                m[1] += g * x;
                m[2] += g * x * x;
            }
        }
        m
    }),
});

/// Weighted moments of the occupied voxel centres in the window, relative
/// to its centre: `Σw`, `Σw·o`, `Σw·o oᵀ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moments {
    /// `Σw`.
    pub w: f64,
    /// `Σw·o`.
    pub first: DVec3,
    /// `Σw·o oᵀ` (symmetric).
    pub second: DMat3,
}

impl Moments {
    /// The moments of the window around `v`, from the occupancy masks of
    /// the (at most 2×2×2) bricks it meets; `mask_of` returns empty masks
    /// outside the grid.
    pub fn around(v: IVec3, mask_of: impl Fn(IVec3) -> BrickMask) -> Moments {
        const R: i32 = RADIUS + 1;
        const W: usize = 2 * R as usize + 1;
        // Loops over exclusive index ranges (`a = dz + R` and so on), not
        // `-R..=R`: inclusive ranges kept an exhaustion flag and bounds
        // checks in these small loops, most of the call's time.
        let lo = v - R;
        // The 9-voxel window spans exactly two bricks along each axis.
        let b0: IVec3 = lo >> 3;
        let mut masks = [[[[0u64; 8]; 2]; 2]; 2];
        for (iz, plane) in masks.iter_mut().enumerate() {
            for (iy, pair) in plane.iter_mut().enumerate() {
                for (ix, m) in pair.iter_mut().enumerate() {
                    *m = mask_of(b0 + IVec3::new(ix as i32, iy as i32, iz as i32));
                }
            }
        }
        let shift = (lo.x & 7) as u32;
        let tables = &*TABLES;
        let [mut s, mut sx, mut sy, mut sz] = [0.0; 4];
        let [mut sxx, mut syy, mut szz, mut sxy, mut sxz, mut syz] = [0.0; 6];
        // Layers dz = a − R and rows dy = b − R for a, b in 1..W − 1, in
        // the order of dz and dy from −RADIUS to RADIUS; `surface(a)`: per
        // row b, the 7 bits (offsets −3..=3) of its surface voxels.
        let mut add_layer = |a: usize, surface: &[u32; W]| {
            // Per layer: Σ over rows of g(dy)·dyᵖ times the row's moments.
            let [mut a0, mut a1, mut a2, mut b0, mut b1, mut c0] = [0.0; 6];
            for (b, &bits) in surface.iter().enumerate().take(W - 1).skip(1) {
                if bits == 0 {
                    continue;
                }
                let [r0, r1, r2] = tables.rows[bits as usize];
                let [g, gy, gyy] = tables.axis[b - 1];
                a0 += g * r0;
                a1 += gy * r0;
                a2 += gyy * r0;
                b0 += g * r1;
                b1 += gy * r1;
                c0 += g * r2;
            }
            let [g, gz, gzz] = tables.axis[a - 1];
            s += g * a0;
            sy += g * a1;
            syy += g * a2;
            sx += g * b0;
            sxy += g * b1;
            sxx += g * c0;
            sz += gz * a0;
            szz += gzz * a0;
            sxz += gz * b0;
            syz += gz * a1;
        };
        #[cfg(target_arch = "x86_64")]
        // SAFETY: SSE2 is part of every x86-64 CPU.
        unsafe {
            surface_rows_sse2(lo, b0, shift, &masks, &mut add_layer)
        };
        #[cfg(not(target_arch = "x86_64"))]
        surface_rows(lo, b0, shift, &masks, &mut add_layer);
        Moments {
            w: s,
            first: DVec3::new(sx, sy, sz),
            second: DMat3::from_cols(
                DVec3::new(sxx, sxy, sxz),
                DVec3::new(sxy, syy, syz),
                DVec3::new(sxz, syz, szz),
            ),
        }
    }

    /// The fitted normal (see the [module docs](self)), unit length and
    /// facing `toward` (`n·toward > 0`); `toward` itself where the window
    /// is empty.
    pub fn normal(&self, toward: DVec3) -> DVec3 {
        Fit::of(self).normal(toward)
    }
}

/// The part of [`Moments::normal`] that depends on the window alone:
/// `(C + εI)⁻¹`, or `None` for an empty window. Worked out once per hit
/// voxel and kept with it (neighbouring pixels hit the same voxel along
/// different rays), it gives each ray's normal by [`Fit::normal`] with the
/// same operations as computing it afresh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Fit {
    inv: Option<DMat3>,
}

impl Fit {
    /// The fit of `m`'s window.
    pub(crate) fn of(m: &Moments) -> Fit {
        if m.w <= 0.0 {
            return Fit { inv: None };
        }
        let mean = m.first / m.w;
        let c = m.second * (1.0 / m.w) - outer(mean, mean);
        let eps = EPSILON * (c.x_axis.x + c.y_axis.y + c.z_axis.z) / 3.0 + 1e-9;
        let a = c + DMat3::from_diagonal(DVec3::splat(eps));
        // `a` is symmetric positive definite (`c` is a covariance, `eps > 0`).
        Fit {
            inv: Some(a.inverse()),
        }
    }

    /// [`Moments::normal`] of the window fitted.
    #[inline]
    pub(crate) fn normal(&self, toward: DVec3) -> DVec3 {
        let Some(inv) = self.inv else {
            return toward.normalize_or_zero();
        };
        let mut n = toward;
        for _ in 0..POWER {
            n = inv * n;
        }
        n.normalize_or(toward.normalize_or_zero())
    }
}

/// The side of the occupancy block [`Moments::around`] reads: the window
/// and one voxel more each way (the surface test looks at 6-neighbours).
const BLOCK: usize = 2 * (RADIUS as usize + 1) + 1;

/// The 2×2×2 bricks' masks around a window, by `[z][y][x]` brick.
type Masks = [[[BrickMask; 2]; 2]; 2];

/// The surface bits of the window's rows, layer by layer (`add(a, rows)`
/// for a = 1..BLOCK − 1, rows b = 1..BLOCK − 1 of `rows` meaningful): row
/// by row, on any target. The reference [`surface_rows_sse2`] is pinned to.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn surface_rows(
    lo: IVec3,
    b0: IVec3,
    shift: u32,
    masks: &Masks,
    add: &mut impl FnMut(usize, &[u32; BLOCK]),
) {
    const W: usize = BLOCK;
    // Rows of 9 bits (offsets −4..=4) of the occupancy around v.
    let rows_y: [(usize, u32); W] = std::array::from_fn(|b| {
        let y = lo.y + b as i32;
        ((((y >> 3) - b0.y) & 1) as usize, 8 * (y & 7) as u32)
    });
    let mut occ = [[0u32; W]; W];
    for (a, layer) in occ.iter_mut().enumerate() {
        let z = lo.z + a as i32;
        let (iz, lz) = ((((z >> 3) - b0.z) & 1) as usize, (z & 7) as usize);
        for (row_out, &(iy, ly)) in layer.iter_mut().zip(&rows_y) {
            let pair = &masks[iz][iy];
            let row = (pair[0][lz] >> ly & 0xff) | (pair[1][lz] >> ly & 0xff) << 8;
            *row_out = (row >> shift & 0x1ff) as u32;
        }
    }
    for a in 1..W - 1 {
        let mut surface = [0u32; W];
        for (b, out) in surface.iter_mut().enumerate().take(W - 1).skip(1) {
            let o = occ[a][b];
            // Surface voxels: occupied with an empty 6-neighbour.
            let inner = o
                & (o << 1)
                & (o >> 1)
                & occ[a][b - 1]
                & occ[a][b + 1]
                & occ[a - 1][b]
                & occ[a + 1][b];
            *out = (o & !inner) >> 1 & 0x7f;
        }
        add(a, &surface);
    }
}

/// [`surface_rows`] with the rows of a layer in the 16-bit lanes of SSE2
/// registers (part of every x86-64 CPU): a brick pair's eight rows by one
/// byte interleave, the surface test for seven rows at once. The same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
fn surface_rows_sse2(
    lo: IVec3,
    b0: IVec3,
    shift: u32,
    masks: &Masks,
    add: &mut impl FnMut(usize, &[u32; BLOCK]),
) {
    use std::arch::x86_64::*;
    const W: usize = BLOCK;
    let as_u128 = |x: __m128i| -> u128 {
        // SAFETY: both are 16 bytes of plain data.
        unsafe { std::mem::transmute::<__m128i, u128>(x) }
    };
    let from_u128 = |x: u128| -> __m128i {
        // SAFETY: as above.
        unsafe { std::mem::transmute::<u128, __m128i>(x) }
    };
    let nine = _mm_set1_epi16(0x1ff);
    let count = _mm_cvtsi32_si128(shift as i32);
    // Lane r of a layer's register: row r of the window (rows 0..8); row 8
    // apart.
    let ly0 = (lo.y & 7) as u32;
    let mut rows = [_mm_setzero_si128(); W];
    let mut row8 = [0i32; W];
    for (a, (r, r8)) in rows.iter_mut().zip(&mut row8).enumerate() {
        let z = lo.z + a as i32;
        let (iz, lz) = ((((z >> 3) - b0.z) & 1) as usize, (z & 7) as usize);
        // Rows y of brick pair iy (x bricks side by side): lane y holds
        // byte y of the low brick and, above it, of the high one.
        let pair = |iy: usize| {
            let [p0, p1] = [masks[iz][iy][0][lz], masks[iz][iy][1][lz]];
            let both =
                _mm_unpacklo_epi8(_mm_cvtsi64_si128(p0 as i64), _mm_cvtsi64_si128(p1 as i64));
            as_u128(_mm_and_si128(_mm_srl_epi16(both, count), nine))
        };
        // The window's rows y = lo.y + b lie at lanes ly0 + b of the two
        // pairs end to end.
        let (first, second) = (pair(0), pair(1));
        let s = 16 * ly0;
        let window = if s == 0 {
            first
        } else {
            first >> s | second << (128 - s)
        };
        *r = from_u128(window);
        *r8 = (second >> s & 0xffff) as i32;
    }
    let seven = _mm_set1_epi16(0x7f);
    for a in 1..W - 1 {
        let o = rows[a];
        let up = _mm_slli_si128::<2>(o);
        let down = _mm_insert_epi16::<7>(_mm_srli_si128::<2>(o), row8[a]);
        // Surface voxels: occupied with an empty 6-neighbour.
        let inner = _mm_and_si128(
            _mm_and_si128(
                _mm_and_si128(o, _mm_slli_epi16::<1>(o)),
                _mm_and_si128(_mm_srli_epi16::<1>(o), up),
            ),
            _mm_and_si128(_mm_and_si128(down, rows[a - 1]), rows[a + 1]),
        );
        let bits = as_u128(_mm_and_si128(
            _mm_srli_epi16::<1>(_mm_andnot_si128(inner, o)),
            seven,
        ));
        let surface: [u32; W] = std::array::from_fn(|b| {
            if b < 8 {
                (bits >> (16 * b) & 0x7f) as u32
            } else {
                0
            }
        });
        add(a, &surface);
    }
}

/// The moments of the voxels hit along a band of image rows, by column:
/// neighbouring pixels often hit the same voxel (a 512³ grid fills a
/// 1024² image with 2–4 pixels per voxel), and its moments depend on the
/// voxel alone, so reusing them changes no pixel.
pub(crate) struct FitCache {
    /// Per column, the last voxel hit there and its fit.
    row: Vec<Option<(IVec3, Fit)>>,
}

impl FitCache {
    /// An empty cache for rows of `width` pixels.
    pub(crate) fn new(width: usize) -> FitCache {
        FitCache {
            row: vec![None; width],
        }
    }

    /// The fit around `v`, hit at column `x` of the current row: that of
    /// the pixel to the left or above where it hit `v` too, else the fit
    /// of `compute()`'s moments.
    pub(crate) fn fit(&mut self, x: usize, v: IVec3, compute: impl FnOnce() -> Moments) -> Fit {
        let left = x.checked_sub(1).and_then(|l| self.row[l]);
        let same = |e: Option<(IVec3, Fit)>| e.filter(|&(u, _)| u == v);
        let f = match same(left).or(same(self.row[x])) {
            Some((_, f)) => f,
            None => Fit::of(&compute()),
        };
        self.row[x] = Some((v, f));
        f
    }
}

/// `a bᵀ`.
fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BrickGrid, MemoryLimit};
    use crate::render::occupancy::{OccupancyGrid, RenderBricks};
    use rand::{Rng, SeedableRng};

    /// The moments from mask rows equal a voxel-by-voxel sum, across brick
    /// borders and at the grid's faces.
    #[test]
    fn window_moments_match_brute_force() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
        let dims = [20, 19, 21];
        let mut g = BrickGrid::new();
        for _ in 0..6000 {
            g.insert(IVec3::new(
                rng.random_range(0..20),
                rng.random_range(0..19),
                rng.random_range(0..21),
            ));
        }
        let occ = OccupancyGrid::new(&g, dims, MemoryLimit::DEFAULT).unwrap();
        for z in -1..22 {
            for y in -1..20 {
                for x in -1..21 {
                    let v = IVec3::new(x, y, z);
                    let mut want = Moments {
                        w: 0.0,
                        first: DVec3::ZERO,
                        second: DMat3::ZERO,
                    };
                    for dz in -RADIUS..=RADIUS {
                        for dy in -RADIUS..=RADIUS {
                            for dx in -RADIUS..=RADIUS {
                                let o = IVec3::new(dx, dy, dz);
                                let occupied = |u: IVec3| g.contains(u) && occ.in_grid(u);
                                let u = v + o;
                                let surface = occupied(u)
                                    && [IVec3::X, IVec3::Y, IVec3::Z]
                                        .iter()
                                        .any(|&e| !occupied(u + e) || !occupied(u - e));
                                if !surface {
                                    continue;
                                }
                                let w = weight(dx) * weight(dy) * weight(dz);
                                let o = o.as_dvec3();
                                want.w += w;
                                want.first += w * o;
                                want.second += outer(o, o) * w;
                            }
                        }
                    }
                    let got = Moments::around(v, |b| occ.occupancy_mask(b));
                    assert!((got.w - want.w).abs() < 1e-9, "{v} {got:?} {want:?}");
                    assert!((got.first - want.first).length() < 1e-9, "{v}");
                    assert!(
                        got.second.abs_diff_eq(want.second, 1e-9),
                        "{v} {got:?} {want:?}"
                    );
                }
            }
        }
    }

    /// The SSE2 rows give the row-by-row surface bits, layer for layer,
    /// for random masks (sparse, dense, full) at every window position
    /// within the bricks.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn sse2_surface_rows_are_the_rows() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        for round in 0..3000 {
            let density = [0.05, 0.5, 0.95, 1.0][round % 4];
            let mut masks: Masks = [[[[0; 8]; 2]; 2]; 2];
            for m in masks.iter_mut().flatten().flatten().flatten() {
                for bit in 0..64 {
                    if rng.random_bool(density) {
                        *m |= 1 << bit;
                    }
                }
            }
            let lo = IVec3::new(
                rng.random_range(-20..20),
                rng.random_range(-20..20),
                rng.random_range(-20..20),
            );
            let (b0, shift) = (lo >> 3, (lo.x & 7) as u32);
            let collect = |sse2: bool| {
                let mut got = Vec::new();
                let mut add = |a: usize, rows: &[u32; BLOCK]| got.push((a, rows[1..8].to_vec()));
                if sse2 {
                    // SAFETY: SSE2 is part of every x86-64 CPU.
                    unsafe { surface_rows_sse2(lo, b0, shift, &masks, &mut add) };
                } else {
                    surface_rows(lo, b0, shift, &masks, &mut add);
                }
                got
            };
            assert_eq!(collect(true), collect(false), "round {round} at {lo}");
        }
    }

    /// The cache hands out the fit of the voxel asked for, whatever the
    /// order of hits along and across rows, and its normals are those of
    /// the voxel's moments, bit for bit.
    #[test]
    fn fit_cache_returns_each_voxels_own_fit() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut g = BrickGrid::new();
        for _ in 0..3000 {
            g.insert(IVec3::new(
                rng.random_range(0..16),
                rng.random_range(0..16),
                rng.random_range(0..16),
            ));
        }
        let occ = OccupancyGrid::new(&g, [16; 3], MemoryLimit::DEFAULT).unwrap();
        let fresh = |v: IVec3| Moments::around(v, |b| occ.occupancy_mask(b));
        let width = 12;
        let mut cache = FitCache::new(width);
        let (mut computed, mut asked) = (0, 0);
        for _row in 0..40 {
            for x in 0..width {
                if rng.random_bool(0.2) {
                    continue; // a miss
                }
                // Few distinct voxels: neighbours often repeat one.
                let v = IVec3::new(rng.random_range(4..6), rng.random_range(4..6), 5);
                let f = cache.fit(x, v, || {
                    computed += 1;
                    fresh(v)
                });
                asked += 1;
                assert_eq!(f, Fit::of(&fresh(v)), "{v}");
                let toward = DVec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                let n = f.normal(toward);
                assert_eq!(
                    n.to_array().map(f64::to_bits),
                    fresh(v).normal(toward).to_array().map(f64::to_bits)
                );
            }
        }
        assert!(computed < asked);
    }

    /// The angle in degrees between the fitted normal and the plane's
    /// (either orientation), over the voxels of the digital plane
    /// `0 ≤ n·v + c < width` that are at least `RADIUS` inside a 32³ box:
    /// (mean, max).
    fn plane_errors(n: DVec3, c: f64, width: f64, toward: DVec3, solid: bool) -> (f64, f64) {
        let inside = |v: IVec3| {
            let s = n.dot(v.as_dvec3()) + c;
            if solid {
                s < width
            } else {
                (0.0..width).contains(&s)
            }
        };
        let mask_of = |b: IVec3| -> BrickMask {
            std::array::from_fn(|lz| {
                let mut word = 0u64;
                for i in 0..64 {
                    let v = b * 8 + IVec3::new(i % 8, i / 8, lz as i32);
                    if inside(v) {
                        word |= 1 << i;
                    }
                }
                word
            })
        };
        let (mut sum, mut max, mut count) = (0.0, 0.0f64, 0);
        for z in 0..32 {
            for y in 0..32 {
                for x in 0..32 {
                    let v = IVec3::new(x, y, z);
                    // Surface voxels only: in the set with a 6-neighbour out.
                    let surface = inside(v)
                        && [IVec3::X, IVec3::Y, IVec3::Z]
                            .iter()
                            .any(|&e| !inside(v + e) || !inside(v - e));
                    if !surface {
                        continue;
                    }
                    let got = Moments::around(v + 64, |b| mask_of(b - 8)).normal(toward);
                    assert!(got.dot(toward) > 0.0);
                    let cos = got.dot(n.normalize()).abs().min(1.0);
                    let deg = cos.acos().to_degrees();
                    sum += deg;
                    max = max.max(deg);
                    count += 1;
                }
            }
        }
        assert!(count > 50);
        (sum / count as f64, max)
    }

    /// On digital planes (naive and standard, and a solid's boundary) of
    /// random directions the fitted normal stays within a few degrees of
    /// the plane's everywhere: no bands.
    #[test]
    fn planes_get_their_normal_everywhere() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut worst = [(0.0f64, 0.0f64); 3];
        for _ in 0..40 {
            let n = DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            if n.length() < 0.2 {
                continue;
            }
            let c = -n.dot(DVec3::splat(16.0)) + rng.random_range(0.0..1.0);
            let toward = (n.normalize() * rng.random_range(0.2..1.0)
                + DVec3::new(
                    rng.random_range(-0.5..0.5),
                    rng.random_range(-0.5..0.5),
                    rng.random_range(-0.5..0.5),
                ))
            .normalize();
            let inf = n.abs().max_element();
            let one = n.abs().element_sum();
            for (k, (width, solid)) in [(inf, false), (one, false), (inf, true)]
                .into_iter()
                .enumerate()
            {
                let (mean, max) = plane_errors(n, c, width, toward, solid);
                worst[k] = (worst[k].0.max(mean), worst[k].1.max(max));
            }
        }
        eprintln!("worst per plane (mean, max) degrees: naive, standard, solid: {worst:?}");
        for (mean, max) in worst {
            assert!(mean < 4.5 && max < 15.0, "{worst:?}");
        }
    }
}
