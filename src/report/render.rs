//! The report's rendering section: ms per frame against pixels differing
//! from the exact 6-ray image, per ray kind, with and without empty-space
//! skipping; and the image error against the rasterized mesh per voxel
//! resolution (what a resolution buys).

use super::document::PlotDir;
use super::plot::{Chart, Series};
use super::timing::{Timing, time_calls};
use crate::camera::SceneAxes;
use crate::error::{Result, VoxkitError};
use crate::grid::MemoryLimit;
use crate::mesh::Mesh;
use crate::render::measure::{MeshImageError, against_mesh};
use crate::render::{
    GridTransform, OccupancyGrid, RayKind, RenderImage, RenderOptions, RenderStats, default_camera,
    render_grid,
};
use crate::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, voxelize_mesh};

/// One ray kind with or without skipping.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderRow {
    /// Ray kind.
    pub kind: RayKind,
    /// Empty-space skipping on.
    pub skip: bool,
    /// Wall time of `render_grid`, per frame.
    pub time: Timing,
    /// Pixels whose first hit differs from the 6-ray image (with skipping).
    pub differing: u64,
    /// Voxels visited over the frame.
    pub voxels_visited: u64,
    /// Empty-space jumps over the frame.
    pub jumps: u64,
}

/// Image error of one voxel resolution against the rasterized mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshErrorRow {
    /// `-r` of the thin voxelization.
    pub resolution: u32,
    /// Adaptive ray with skipping, per frame.
    pub time: Timing,
    /// The image error (depths in voxels).
    pub error: MeshImageError,
    /// Mean depth error in world units, as a share of the mesh's bbox diagonal.
    pub depth_mean_share: f64,
}

/// What both parts render: a mesh voxelized thin at `resolution`, framed by
/// the default three-quarter camera.
struct Scene {
    occ: OccupancyGrid,
    xf: GridTransform,
    camera: crate::camera::Camera,
    voxel_size: f64,
}

fn scene(mesh: &Mesh, resolution: u32, size: u32) -> Result<Scene> {
    let v = voxelize_mesh(mesh, &VoxelizeOptions::new(resolution, VoxelizeMode::Thin))?;
    let occ = OccupancyGrid::new(&v.grid, v.frame.dims, MemoryLimit::DEFAULT)?;
    let xf = GridTransform::from_frame(&v.frame)?;
    let camera = default_camera(&occ, &xf, &SceneAxes::Y_UP, size, size)?;
    Ok(Scene {
        occ,
        xf,
        camera,
        voxel_size: v.frame.voxel_size,
    })
}

fn timed_render(
    s: &Scene,
    opts: &RenderOptions,
    reps: usize,
) -> Result<(Timing, RenderImage, RenderStats)> {
    let mut last = None;
    let time = time_calls(reps, || -> Result<()> {
        last = Some(render_grid(&s.occ, &s.xf, &s.camera, opts)?);
        Ok(())
    })?;
    let (img, stats) = last.ok_or_else(|| VoxkitError::invalid("no frame rendered"))?;
    Ok((time, img, stats))
}

/// Every ray kind, skipping on and off, on `mesh` voxelized thin at
/// `resolution`, `size`² frames; `step` is told each case.
pub fn render_report(
    mesh: &Mesh,
    resolution: u32,
    size: u32,
    reps: usize,
    step: &mut dyn FnMut(&str),
) -> Result<Vec<RenderRow>> {
    let s = scene(mesh, resolution, size)?;
    let base = RenderOptions {
        width: size,
        height: size,
        ..RenderOptions::default()
    };
    let mut six: Option<RenderImage> = None;
    let mut rows = Vec::new();
    for skip in [true, false] {
        for kind in RayKind::ALL {
            step(&format!(
                "render {}{}",
                kind.name(),
                if skip { "" } else { " no skip" }
            ));
            let opts = RenderOptions {
                ray: kind,
                skip,
                ..base
            };
            let (time, img, stats) = timed_render(&s, &opts, reps)?;
            let reference = six.get_or_insert_with(|| img.clone());
            rows.push(RenderRow {
                kind,
                skip,
                time,
                differing: img.differing_hits(reference),
                voxels_visited: stats.voxels_visited,
                jumps: stats.bricks_skipped,
            });
        }
    }
    Ok(rows)
}

/// Cases of [`render_report`].
pub fn render_case_count() -> u64 {
    2 * RayKind::ALL.len() as u64
}

/// The adaptive ray (skipping on) at each voxel resolution, against the
/// rasterized mesh with the same camera.
pub fn mesh_error_report(
    mesh: &Mesh,
    resolutions: &[u32],
    size: u32,
    reps: usize,
    step: &mut dyn FnMut(&str),
) -> Result<Vec<MeshErrorRow>> {
    let (lo, hi) = mesh.bounds();
    let diagonal = (hi - lo).length().max(f64::MIN_POSITIVE);
    let mut rows = Vec::new();
    for &resolution in resolutions {
        step(&format!("render against the mesh, -r {resolution}"));
        let s = scene(mesh, resolution, size)?;
        let opts = RenderOptions {
            width: size,
            height: size,
            ..RenderOptions::default()
        };
        let (time, img, _) = timed_render(&s, &opts, reps)?;
        let error = against_mesh(&img, mesh, &s.camera, s.voxel_size)?;
        rows.push(MeshErrorRow {
            resolution,
            time,
            depth_mean_share: error.depth_mean * s.voxel_size / diagonal,
            error,
        });
    }
    Ok(rows)
}

/// The rendering section's Markdown, with its plots written to `plots`.
pub fn section(
    mesh_name: &str,
    resolution: u32,
    size: u32,
    rows: &[RenderRow],
    mesh_size: u32,
    mesh_rows: &[MeshErrorRow],
    plots: &PlotDir,
) -> Result<String> {
    let reps = rows.first().map_or(0, |r| r.time.reps);
    let mut md = format!(
        "{mesh_name} voxelized thin at -r {resolution}, {size}×{size} frames, default \
         three-quarter camera, all cores. Time: wall time of `render_grid`, one warm-up frame, \
         then the median of {reps} frames. **differing**: pixels whose first hit differs from \
         the exact 6-ray image (the 6-ray, skipping on, is the reference; skipping never \
         changes a hit, so the no-skip rows must agree with their skipping rows).\n\n\
         | ray | skipping | ms/frame | time spread | differing pixels | voxels visited | jumps |\n\
         |---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        md.push_str(&format!(
            "| {} | {} | {:.2} | {:.0}% | {} | {} | {} |\n",
            r.kind.name(),
            if r.skip { "on" } else { "off" },
            1e3 * r.time.median,
            100.0 * r.time.spread(),
            r.differing,
            r.voxels_visited,
            r.jumps,
        ));
    }
    md.push('\n');
    let series = RayKind::ALL
        .iter()
        .flat_map(|&kind| {
            [true, false].map(|skip| {
                let mut s = Series::points(
                    format!("{}{}", kind.name(), if skip { "" } else { " (no skip)" }),
                    rows.iter()
                        .filter(|r| r.kind == kind && r.skip == skip)
                        .map(|r| (1e3 * r.time.median, r.differing as f64))
                        .collect(),
                );
                s.hollow = !skip;
                s
            })
        })
        .collect();
    md.push_str(&plots.write(
        "render_rays.svg",
        &Chart {
            title: format!("Rendering {mesh_name} thin -r {resolution}: time against error"),
            x_label: "ms per frame".into(),
            y_label: "pixels differing from the 6-ray image".into(),
            log_x: true,
            log_y: false,
            series,
            front: None,
        },
    )?);

    let mreps = mesh_rows.first().map_or(0, |r| r.time.reps);
    md.push_str(&format!(
        "\n### Image error against the mesh, per voxel resolution\n\n\
         {mesh_name} voxelized thin at each -r, adaptive rays with skipping, \
         {mesh_size}×{mesh_size}, against the triangle rasterizer's image of the mesh itself \
         with the same camera (`voxkit::render::measure`). Time: median of {mreps} frames after \
         a warm-up. **depth mean / max**: |voxel depth − mesh depth| over pixels both hit, in \
         voxels; **% diag**: the mean in world units as a share of the bounding-box diagonal; \
         **silhouette**: share of the pixels covered by either image where only one is hit.\n\n\
         | -r | ms/frame | pixels both hit | depth mean (voxels) | depth max (voxels) | depth mean % diag | silhouette |\n\
         |---|---|---|---|---|---|---|\n"
    ));
    for r in mesh_rows {
        md.push_str(&format!(
            "| {} | {:.2} | {} | {:.3} | {:.3} | {:.4} | {:.2}% |\n",
            r.resolution,
            1e3 * r.time.median,
            r.error.both,
            r.error.depth_mean,
            r.error.depth_max,
            100.0 * r.depth_mean_share,
            100.0 * r.error.silhouette_disagree,
        ));
    }
    md.push('\n');
    md.push_str(&plots.write(
        "render_mesh_error.svg",
        &Chart {
            title: format!("Rendering {mesh_name}: error against the mesh per resolution"),
            x_label: "voxel resolution (-r)".into(),
            y_label: "error (%)".into(),
            log_x: true,
            log_y: false,
            series: vec![
                Series::line(
                    "silhouette disagreement (% of covered pixels)",
                    mesh_rows
                        .iter()
                        .map(|r| (r.resolution as f64, 100.0 * r.error.silhouette_disagree))
                        .collect(),
                ),
                Series::line(
                    "mean depth error (% of bbox diagonal)",
                    mesh_rows
                        .iter()
                        .map(|r| (r.resolution as f64, 100.0 * r.depth_mean_share))
                        .collect(),
                ),
            ],
            front: None,
        },
    )?);
    Ok(md)
}
