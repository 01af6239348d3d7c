//! 3D triangle mesh → image: project with a [`Camera`], clip against the
//! near and far planes (and a guard band that keeps screen coordinates in
//! the rasterizer's fixed-point range), rasterize with the top-left rule,
//! a z-buffer and Gouraud (or flat) shading.
//!
//! Lighting is Lambert with a headlight: each vertex gets
//! `base · (ambient + (1 − ambient)·|n · l|)`, `n` the area-weighted vertex
//! normal, `l` the direction from the vertex to the eye (the reverse view
//! direction for orthographic cameras). `|n · l|` makes faces two-sided, so
//! inconsistent winding in the input does not darken faces.
//!
//! Clipping is Sutherland–Hodgman in homogeneous clip space, attributes
//! interpolated linearly there, so a triangle crossing the near plane is
//! cut exactly where it crosses, never wrapped through infinity.

use glam::{Vec3, Vec4};

use super::framebuffer::{MAX_DIM, RenderTarget, Rgb8};
use super::interp::{DepthTest, ShadedVertex, Shading, draw_shaded};
use crate::camera::Camera;
use crate::error::{Result, VoxkitError};

/// Guard band: clip-space `|x|, |y| ≤ GUARD · w`. With framebuffers up to
/// 2^15 pixels this keeps screen coordinates within ±2^20 pixels.
const GUARD: f32 = 16.0;

/// How a mesh's vertices are coloured before interpolation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Lighting {
    /// Lambert with a headlight (see the module doc).
    #[default]
    Headlight,
    /// Use the vertex colours (or the base colour) unlit.
    Unlit,
}

/// Options for [`render_mesh`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshRenderOptions {
    /// Background colour.
    pub background: Rgb8,
    /// Colour of every vertex when no per-vertex colours are given.
    pub base_color: [f32; 3],
    /// Ambient fraction in `[0, 1]` for [`Lighting::Headlight`].
    pub ambient: f32,
    /// Lighting model.
    pub lighting: Lighting,
    /// Flat or Gouraud.
    pub shading: Shading,
}

impl Default for MeshRenderOptions {
    fn default() -> Self {
        MeshRenderOptions {
            background: [0, 0, 0],
            base_color: [0.8, 0.8, 0.8],
            ambient: 0.15,
            lighting: Lighting::Headlight,
            shading: Shading::Gouraud,
        }
    }
}

/// Area-weighted vertex normals (unit, or zero for vertices of degenerate
/// faces only). Indices must be valid.
pub fn vertex_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in indices {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        // |cross| is twice the area, so the sum is area-weighted.
        let fnorm = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += fnorm;
        }
    }
    n.iter().map(|v| v.normalize_or_zero()).collect()
}

/// A clip-space vertex with its colour.
#[derive(Clone, Copy, Debug)]
struct ClipVertex {
    pos: Vec4,
    color: Vec3,
}

/// Keeps the part of `poly` where `plane · pos ≥ 0`.
fn clip_polygon(poly: &[ClipVertex], plane: Vec4, out: &mut Vec<ClipVertex>) {
    out.clear();
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = (plane.dot(a.pos), plane.dot(b.pos));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            out.push(ClipVertex {
                pos: a.pos + (b.pos - a.pos) * t,
                color: a.color + (b.color - a.color) * t,
            });
        }
    }
}

/// The clip planes as `plane · (x, y, z, w) ≥ 0`.
const PLANES: [Vec4; 6] = [
    Vec4::new(0.0, 0.0, 1.0, 0.0),    // near: z ≥ 0
    Vec4::new(0.0, 0.0, -1.0, 1.0),   // far: z ≤ w
    Vec4::new(1.0, 0.0, 0.0, GUARD),  // x ≥ −G·w
    Vec4::new(-1.0, 0.0, 0.0, GUARD), // x ≤ G·w
    Vec4::new(0.0, 1.0, 0.0, GUARD),  // y ≥ −G·w
    Vec4::new(0.0, -1.0, 0.0, GUARD), // y ≤ G·w
];

/// Renders a triangle mesh into a new `width × height` [`RenderTarget`]
/// (colour + depth, depth = NDC z in `[0, 1]`, `+∞` for background).
///
/// `colors`, if given, has one linear RGB colour in `[0, 1]` per vertex.
/// Errors ([`VoxkitError::Invalid`]) on an invalid camera, size, non-finite
/// positions or colours, a colour count that differs from the vertex
/// count, or an index out of range.
///
/// ```
/// use glam::Vec3;
/// use glam::DVec3;
/// use voxkit::camera::Camera;
/// use voxkit::triangle::{render_mesh, MeshRenderOptions};
/// let pos = [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
/// let cam = Camera::orthographic(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 4.0);
/// let img = render_mesh(&pos, &[[0, 1, 2]], None, &cam, 40, 40, &MeshRenderOptions::default()).unwrap();
/// assert_ne!(img.color.get(20, 20), Some([0, 0, 0])); // the centre is lit
/// assert_eq!(img.color.get(2, 2), Some([0, 0, 0])); // the corner is background
/// ```
pub fn render_mesh(
    positions: &[Vec3],
    indices: &[[u32; 3]],
    colors: Option<&[Vec3]>,
    camera: &Camera,
    width: u32,
    height: u32,
    opts: &MeshRenderOptions,
) -> Result<RenderTarget> {
    camera.validate()?;
    if width == 0 || height == 0 || width > MAX_DIM || height > MAX_DIM {
        return Err(VoxkitError::invalid(format!(
            "image size {width}x{height} outside 1..={MAX_DIM}"
        )));
    }
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(VoxkitError::invalid(format!("vertex {i} is not finite")));
    }
    if let Some(c) = colors {
        if c.len() != positions.len() {
            return Err(VoxkitError::invalid(format!(
                "{} colours for {} vertices",
                c.len(),
                positions.len()
            )));
        }
        if let Some(i) = c.iter().position(|p| !p.is_finite()) {
            return Err(VoxkitError::invalid(format!("colour {i} is not finite")));
        }
    }
    if let Some((t, _)) = indices
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&i| i as usize >= positions.len()))
    {
        return Err(VoxkitError::invalid(format!(
            "triangle {t} has an index out of range (vertices: {})",
            positions.len()
        )));
    }
    let mut target = RenderTarget::new(width, height, opts.background)?;
    let vp = camera.view_projection(width, height);
    let base = |i: usize| colors.map_or(Vec3::from(opts.base_color), |c| c[i]);
    let shaded: Vec<Vec3> = match opts.lighting {
        Lighting::Unlit => (0..positions.len()).map(base).collect(),
        Lighting::Headlight => {
            let normals = vertex_normals(positions, indices);
            let ambient = opts.ambient.clamp(0.0, 1.0);
            let ortho = matches!(
                camera.projection,
                crate::camera::Projection::Orthographic { .. }
            );
            let fwd = camera.forward().as_vec3();
            let eye = camera.eye.as_vec3();
            (0..positions.len())
                .map(|i| {
                    let l = if ortho {
                        -fwd
                    } else {
                        (eye - positions[i]).normalize_or_zero()
                    };
                    base(i) * (ambient + (1.0 - ambient) * normals[i].dot(l).abs())
                })
                .collect()
        }
    };
    let clip: Vec<Vec4> = positions.iter().map(|&p| vp * p.extend(1.0)).collect();
    let (w, h) = (width as f32, height as f32);
    let mut poly = Vec::with_capacity(12);
    let mut tmp = Vec::with_capacity(12);
    for t in indices {
        poly.clear();
        poly.extend(t.map(|i| ClipVertex {
            pos: clip[i as usize],
            color: shaded[i as usize],
        }));
        for plane in PLANES {
            clip_polygon(&poly, plane, &mut tmp);
            std::mem::swap(&mut poly, &mut tmp);
            if poly.len() < 3 {
                break;
            }
        }
        if poly.len() < 3 {
            continue;
        }
        let screen: Vec<ShadedVertex> = poly
            .iter()
            .map(|v| {
                // w ≥ near > 0 for perspective (z ≥ 0 was enforced), w = 1
                // for orthographic.
                let inv = 1.0 / v.pos.w;
                ShadedVertex {
                    pos: [
                        (v.pos.x * inv + 1.0) * 0.5 * w,
                        (1.0 - v.pos.y * inv) * 0.5 * h,
                    ],
                    depth: v.pos.z * inv,
                    color: v.color.to_array(),
                }
            })
            .collect();
        if screen
            .iter()
            .any(|v| !(v.depth.is_finite() && v.pos[0].is_finite() && v.pos[1].is_finite()))
        {
            continue; // a vertex with w → 0 that survived clipping by rounding
        }
        for k in 1..screen.len() - 1 {
            draw_shaded(
                &mut target,
                &[screen[0], screen[k], screen[k + 1]],
                opts.shading,
                DepthTest::Less,
            )?;
        }
    }
    Ok(target)
}

/// [`render_mesh`], then writes the colour image as PNG to `path` through
/// [`crate::io::atomic_write`] (refusing an existing file unless
/// `overwrite`). Returns the rendered target as well.
#[allow(clippy::too_many_arguments)]
pub fn render_mesh_png(
    positions: &[Vec3],
    indices: &[[u32; 3]],
    colors: Option<&[Vec3]>,
    camera: &Camera,
    width: u32,
    height: u32,
    opts: &MeshRenderOptions,
    path: &std::path::Path,
    overwrite: bool,
) -> Result<RenderTarget> {
    let target = render_mesh(positions, indices, colors, camera, width, height, opts)?;
    target.color.write_png(path, overwrite)?;
    Ok(target)
}
