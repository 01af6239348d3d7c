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
