//! Image error of a voxel render against the triangle rasterizer's render of
//! the mesh itself with the same camera: what a resolution buys.

use glam::{DVec3, DVec4, Vec3};

use crate::camera::Camera;
use crate::error::Result;
use crate::mesh::Mesh;
use crate::triangle::{MeshRenderOptions, render_mesh};

use super::RenderImage;

/// Depth and silhouette error of a voxel image against the mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshImageError {
    /// Pixels where both the voxels and the mesh are hit.
    pub both: u64,
    /// Mean `|depth_voxels − depth_mesh|` over those pixels, in voxels.
    pub depth_mean: f64,
    /// Largest such difference, in voxels.
    pub depth_max: f64,
    /// Share of the pixels covered by either where only one is hit.
    pub silhouette_disagree: f64,
}

/// Compares `img` (rendered with `camera`) against the rasterized `mesh`
/// (z-buffer, same camera and size), depths in units of `voxel_size`.
/// The rasterizer's depth is NDC `z` in `f32`, unprojected in `f64`; its
/// clip distances are refitted to the mesh so that nothing is clipped.
pub fn against_mesh(
    img: &RenderImage,
    mesh: &Mesh,
    camera: &Camera,
    voxel_size: f64,
) -> Result<MeshImageError> {
    let (w, h) = (img.width, img.height);
    let mut cam = *camera;
    let (lo, hi) = mesh.bounds();
    cam.fit_clip(lo, hi);
    let positions: Vec<Vec3> = mesh.positions.iter().map(|p| p.as_vec3()).collect();
    let raster = render_mesh(
        &positions,
        &mesh.triangles,
        None,
        &cam,
        w,
        h,
        &MeshRenderOptions::default(),
    )?;
    let inv = {
        let (_, u, f) = cam.basis();
        let view = glam::dcamera::rh::view::look_to_mat4(cam.eye, f, u);
        let proj = match cam.projection {
            crate::camera::Projection::Perspective { fov_y_deg } => {
                glam::dcamera::rh::proj::directx::perspective(
                    fov_y_deg.to_radians(),
                    w as f64 / h as f64,
                    cam.near,
                    cam.far,
                )
            }
            crate::camera::Projection::Orthographic { height } => {
                let (hh, hw) = (height * 0.5, height * 0.5 * w as f64 / h as f64);
                glam::dcamera::rh::proj::directx::orthographic(-hw, hw, -hh, hh, cam.near, cam.far)
            }
        };
        (proj * view).inverse()
    };
    let (mut both, mut sum, mut max, mut either, mut one) = (0u64, 0.0, 0.0f64, 0u64, 0u64);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let zm = raster.depth.get(x, y).unwrap_or(f32::INFINITY);
            let mesh_hit = zm.is_finite();
            let vox_hit = img.depth[i].is_finite();
            if mesh_hit || vox_hit {
                either += 1;
            }
            if mesh_hit != vox_hit {
                one += 1;
                continue;
            }
            if !mesh_hit {
                continue;
            }
            let ndc = DVec4::new(
                2.0 * (x as f64 + 0.5) / w as f64 - 1.0,
                1.0 - 2.0 * (y as f64 + 0.5) / h as f64,
                zm as f64,
                1.0,
            );
            let p = inv * ndc;
            let p = DVec3::new(p.x, p.y, p.z) / p.w;
            let (o, d) = camera.primary_ray(x as f64 + 0.5, y as f64 + 0.5, w, h);
            let t_mesh = (p - o).dot(d);
            let diff = (img.depth[i] as f64 - t_mesh).abs() / voxel_size;
            both += 1;
            sum += diff;
            max = max.max(diff);
        }
    }
    Ok(MeshImageError {
        both,
        depth_mean: if both > 0 { sum / both as f64 } else { 0.0 },
        depth_max: max,
        silhouette_disagree: if either > 0 {
            one as f64 / either as f64
        } else {
            0.0
        },
    })
}

/// How far one image's pixels lie from a reference's, in 8-bit levels of
/// their PNG colours (each composited over the same background).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImageDifference {
    /// Mean over pixels of the largest channel difference.
    pub mean: f64,
    /// 99th percentile of it.
    pub p99: u8,
    /// Largest.
    pub max: u8,
    /// Share of the pixels off by more than 2 levels.
    pub over_2: f64,
}

/// The difference of `img` from `reference` (same size) as their PNGs
/// over `background` would show it: what an approximate method (shear-warp)
/// costs against the exact 6-ray image.
///
/// ```
/// use voxkit::render::measure::image_difference;
/// use voxkit::render::RenderImage;
/// let mut a = RenderImage { width: 2, height: 1, color: vec![[0.0; 4]; 2], depth: vec![0.0; 2], hit: vec![None; 2] };
/// let b = a.clone();
/// a.color[1] = [1.0, 1.0, 1.0, 1.0]; // white over black: 255 levels off
/// let d = image_difference(&a, &b, [0.0; 3]);
/// assert_eq!((d.max, d.mean, d.over_2), (255, 127.5, 0.5));
/// ```
pub fn image_difference(
    img: &RenderImage,
    reference: &RenderImage,
    background: [f32; 3],
) -> ImageDifference {
    let (a, b) = (img.to_rgba8(background), reference.to_rgba8(background));
    let mut hist = [0u64; 256];
    for (p, q) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        let d = (0..3).map(|k| p[k].abs_diff(q[k])).max().unwrap_or(0);
        hist[d as usize] += 1;
    }
    let n: u64 = hist.iter().sum();
    if n == 0 {
        return ImageDifference::default();
    }
    let total: u64 = hist.iter().enumerate().map(|(d, c)| d as u64 * c).sum();
    let rank = (n as f64 * 0.99).ceil() as u64;
    let (mut seen, mut p99) = (0, 0);
    for (d, &c) in hist.iter().enumerate() {
        seen += c;
        if seen >= rank {
            p99 = d as u8;
            break;
        }
    }
    ImageDifference {
        mean: total as f64 / n as f64,
        p99,
        max: hist.iter().rposition(|&c| c > 0).unwrap_or(0) as u8,
        over_2: hist[3..].iter().sum::<u64>() as f64 / n as f64,
    }
}
