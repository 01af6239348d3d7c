//! Attribute interpolation over rasterized triangles: barycentric weights
//! from the exact incremental edge values, flat and Gouraud shading,
//! painter's order by mean depth, and a z-buffer.
//!
//! The rasterizer ([`super::raster`]) steps the three edge functions with
//! one integer add per pixel; at a pixel their values `w_i` are the
//! barycentric weights times `area2`, exactly. An attribute is then
//! `Σ λ_i·q_i` with `λ_i = w_i / area2` (in `f64`). At a vertex placed on a
//! pixel centre the weights are exactly `(area2, 0, 0)`, so `λ = (1, 0, 0)`
//! and the attribute **equals the vertex value bit for bit**, which an
//! accumulated floating-point increment (`q += c_x` per pixel, as in the
//! Cornell notes' `linInterp`) cannot promise.
//!
//! Interpolation is affine in screen space (classic Gouraud). Depth given
//! as NDC `z` is affine in screen space, so the z-buffer is exact for it.

use super::framebuffer::{RenderTarget, Rgb8};
use super::raster::{FixedTriangle, TriangleSetup, walk_fragments};
use crate::error::{Result, VoxkitError};

/// How a triangle's colour varies over its pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    /// One colour per triangle: the mean of its vertex colours.
    Flat,
    /// Vertex colours interpolated linearly (Gouraud).
    #[default]
    Gouraud,
}

/// Whether drawing consults the depth buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DepthTest {
    /// Draw a pixel only if its depth is strictly less than the stored one,
    /// then store it.
    #[default]
    Less,
    /// Always draw (painter's algorithm); depth is still stored.
    Always,
}

/// A screen-space vertex: position in pixels (y down), depth (smaller is
/// nearer) and a linear RGB colour in `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadedVertex {
    /// Position in pixels, `[x, y]`.
    pub pos: [f32; 2],
    /// Depth (smaller is nearer).
    pub depth: f32,
    /// Colour, components in `[0, 1]`.
    pub color: [f32; 3],
}

/// Barycentric weights `λ_i = w_i / area2` from a fragment's exact edge
/// values (see the module doc for why this is exact at vertices).
///
/// ```
/// use voxkit::triangle::barycentric;
/// assert_eq!(barycentric([8, 0, 0], 8), [1.0, 0.0, 0.0]);
/// assert_eq!(barycentric([2, 2, 4], 8), [0.25, 0.25, 0.5]);
/// ```
#[inline]
pub fn barycentric(w: [i64; 3], area2: i64) -> [f64; 3] {
    let a = area2 as f64;
    w.map(|wi| wi as f64 / a)
}

/// `Σ λ_i·q_i` per component, evaluated in `f64`.
#[inline]
pub fn interpolate<const N: usize>(lambda: [f64; 3], q: [[f32; N]; 3]) -> [f32; N] {
    std::array::from_fn(|k| {
        (lambda[0] * q[0][k] as f64 + lambda[1] * q[1][k] as f64 + lambda[2] * q[2][k] as f64)
            as f32
    })
}

/// A `[0, 1]` colour to 8 bits (clamped, rounded to nearest; NaN → 0).
#[inline]
pub fn to_rgb8(c: [f32; 3]) -> Rgb8 {
    c.map(|v| {
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        (v * 255.0 + 0.5) as u8
    })
}

/// An attribute set up over a triangle: evaluates the interpolated value
/// at any pixel centre from the same exact edge values the rasterizer uses.
#[derive(Clone, Copy, Debug)]
pub struct Interpolator<const N: usize> {
    setup: TriangleSetup,
    q: [[f32; N]; 3],
}

impl<const N: usize> Interpolator<N> {
    /// Sets up `q` (one value per vertex) over `tri` for a `width × height`
    /// framebuffer; `None` for a degenerate or off-screen triangle.
    pub fn new(tri: &FixedTriangle, q: [[f32; N]; 3], width: u32, height: u32) -> Option<Self> {
        TriangleSetup::new(tri, width, height).map(|setup| Interpolator { setup, q })
    }

    /// The value at the centre of pixel `(x, y)` (any pixel, covered or not).
    pub fn at_pixel(&self, x: i64, y: i64) -> [f32; N] {
        interpolate(
            barycentric(self.setup.weights_at(x, y), self.setup.area2),
            self.q,
        )
    }

    /// Calls `visit(x, y, value)` for every covered pixel.
    pub fn for_each<F: FnMut(u32, u32, [f32; N])>(&self, mut visit: F) {
        walk_fragments(&self.setup, |f| {
            visit(
                f.x,
                f.y,
                interpolate(barycentric(f.w, self.setup.area2), self.q),
            )
        });
    }
}

/// Draws one triangle into `target` with the given shading and depth test;
/// returns the number of pixels written. Errors on non-finite or
/// out-of-range positions (see [`super::to_subpixel`]).
///
/// ```
/// use voxkit::triangle::{draw_shaded, DepthTest, RenderTarget, ShadedVertex, Shading};
/// let mut t = RenderTarget::new(8, 8, [0, 0, 0]).unwrap();
/// let v = |x: f32, y: f32, c: [f32; 3]| ShadedVertex { pos: [x, y], depth: 0.5, color: c };
/// let tri = [v(0.0, 0.0, [1.0, 0.0, 0.0]), v(8.0, 0.0, [0.0, 1.0, 0.0]), v(0.0, 8.0, [0.0, 0.0, 1.0])];
/// let n = draw_shaded(&mut t, &tri, Shading::Gouraud, DepthTest::Less).unwrap();
/// assert_eq!(n, 28); // centres with x + y ≤ 6: the hypotenuse is a right edge
/// assert_eq!(t.depth.get(0, 0), Some(0.5));
/// ```
pub fn draw_shaded(
    target: &mut RenderTarget,
    verts: &[ShadedVertex; 3],
    shading: Shading,
    depth_test: DepthTest,
) -> Result<usize> {
    if verts
        .iter()
        .any(|v| !v.depth.is_finite() || v.color.iter().any(|c| !c.is_finite()))
    {
        return Err(VoxkitError::invalid(
            "shaded vertex has a non-finite depth or colour",
        ));
    }
    let tri = FixedTriangle::from_pixels(verts.map(|v| v.pos))?;
    let (w, h) = (target.width(), target.height());
    let Some(setup) = TriangleSetup::new(&tri, w, h) else {
        return Ok(0);
    };
    let depths = verts.map(|v| [v.depth]);
    let colors = verts.map(|v| v.color);
    let flat = {
        let c = colors;
        to_rgb8(std::array::from_fn(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0))
    };
    let mut count = 0;
    let width = w as usize;
    let (color_buf, depth_buf) = (target.color.pixels_mut(), target.depth.pixels_mut());
    walk_fragments(&setup, |f| {
        let lambda = barycentric(f.w, setup.area2);
        let [z] = interpolate(lambda, depths);
        let i = f.x as usize + width * f.y as usize;
        if depth_test == DepthTest::Less && z >= depth_buf[i] {
            return;
        }
        depth_buf[i] = z;
        color_buf[i] = match shading {
            Shading::Flat => flat,
            Shading::Gouraud => to_rgb8(interpolate(lambda, colors)),
        };
        count += 1;
    });
    Ok(count)
}

/// Painter's order: triangle indices sorted by mean vertex depth, farthest
/// first (stable, so equal depths keep input order; NaN sorts first).
pub fn painter_order(tris: &[[ShadedVertex; 3]]) -> Vec<usize> {
    let key = |t: &[ShadedVertex; 3]| (t[0].depth + t[1].depth + t[2].depth) / 3.0;
    let mut order: Vec<usize> = (0..tris.len()).collect();
    order.sort_by(|&a, &b| key(&tris[b]).total_cmp(&key(&tris[a])));
    order
}

/// Draws `tris` back to front in [`painter_order`] without a depth test.
pub fn draw_painter(
    target: &mut RenderTarget,
    tris: &[[ShadedVertex; 3]],
    shading: Shading,
) -> Result<()> {
    for i in painter_order(tris) {
        draw_shaded(target, &tris[i], shading, DepthTest::Always)?;
    }
    Ok(())
}

/// Draws `tris` in input order with the z-buffer ([`DepthTest::Less`]).
pub fn draw_zbuffer(
    target: &mut RenderTarget,
    tris: &[[ShadedVertex; 3]],
    shading: Shading,
) -> Result<()> {
    for t in tris {
        draw_shaded(target, t, shading, DepthTest::Less)?;
    }
    Ok(())
}
