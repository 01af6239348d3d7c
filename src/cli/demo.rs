//! `voxkit demo`: the toolkit on an embedded default, printing speed against
//! error.

use std::io::Write;

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;

use super::CliError;
use crate::grid::MemoryLimit;
use crate::report::{LineReportConfig, line_report};
use crate::voxelize::measure::measure_voxelization;
use crate::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, voxelize_mesh};

/// The bundled mesh: Spot by Keenan Crane (CC0), embedded so the demo runs
/// from any directory.
const SPOT_OBJ: &str = include_str!("../../data/meshes/obj/spot.obj");

/// Arguments of `voxkit demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Random segments timed per line algorithm.
    #[arg(long, default_value_t = 20_000)]
    pub segments: usize,
    /// Seed of the random segments.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// Voxelization resolution for the bundled mesh.
    #[arg(long, default_value_t = 256)]
    pub resolution: u32,
    /// Directory for the demo's files (created if missing; files overwritten).
    #[arg(long, default_value = "out")]
    pub out_dir: PathBuf,
}

/// Runs `voxkit demo`.
pub fn run(args: DemoArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let cfg = LineReportConfig {
        segments: args.segments.max(1),
        judged: args.segments.clamp(1, 2_000),
        seed: args.seed,
        ..LineReportConfig::default()
    };
    writeln!(
        out,
        "Lines: {} random segments of {} voxels with sub-voxel endpoints in a {}³ u8 grid \
         (seed {}); errors judged exactly on the first {}.",
        cfg.segments, cfg.length, cfg.grid, cfg.seed, cfg.judged
    )?;
    let rows = line_report(&cfg)?;
    writeln!(out)?;
    writeln!(
        out,
        "| algorithm | voxels/line | Mvoxels/s | untouched voxels | containment | connected | mismatch |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|")?;
    for r in &rows {
        writeln!(
            out,
            "| {} | {:.1} | {:.0} | {:.3}% | {:.1}% | {:.1}% | {:.2}% |",
            r.algorithm.name(),
            r.voxels_per_line,
            r.voxels_per_second / 1e6,
            100.0 * r.untouched,
            100.0 * r.containment,
            100.0 * r.connected,
            100.0 * r.mismatch
        )?;
    }
    writeln!(out)?;
    writeln!(
        out,
        "untouched: listed voxels the segment does not touch; containment: lines whose voxels \
         cover the segment; mismatch: A-W lines differing from the exact tripod line, adaptive \
         rays whose first hit on a ball differs from the tripod line's."
    )?;
    writeln!(out)?;
    voxelize_demo(&args, out)
}

/// Voxelizes the bundled mesh in every surface mode, writes the thin result
/// and a rendering of the mesh, and prints speed against error.
fn voxelize_demo(args: &DemoArgs, out: &mut dyn Write) -> Result<(), CliError> {
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| CliError::bad_input(format!("{}: {e}", args.out_dir.display())))?;
    let mesh = crate::mesh::obj::parse_str(SPOT_OBJ, "spot.obj (bundled)")?;
    writeln!(
        out,
        "Voxelization: spot.obj (bundled, {} triangles) at -r {}; errors against the exact \
         conservative set of the same fixed-point triangles.",
        mesh.triangles.len(),
        args.resolution
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "| mode | voxelize ms | voxels | missing | extra | max dist | mean dist | 6-tunnel | 26-tunnel |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|---|---|")?;
    let mut thin = None;
    let verdict = |t: Option<bool>| match t {
        Some(true) => "yes",
        Some(false) => "no",
        None => "-",
    };
    for mode in [
        VoxelizeMode::Thin,
        VoxelizeMode::Thick,
        VoxelizeMode::Conservative,
    ] {
        let t0 = Instant::now();
        let v = voxelize_mesh(&mesh, &VoxelizeOptions::new(args.resolution, mode))?;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let m = measure_voxelization(&v, MemoryLimit::DEFAULT)?;
        writeln!(
            out,
            "| {} | {ms:.1} | {} | {} | {} | {:.3} | {:.3} | {} | {} |",
            mode.name(),
            v.stats.voxels,
            m.missing,
            m.extra,
            m.max_distance,
            m.mean_distance,
            verdict(m.tunnel6),
            verdict(m.tunnel26)
        )?;
        if mode == VoxelizeMode::Thin {
            let path = args.out_dir.join("spot_thin.binvox");
            crate::io::write_voxels(&path, &v.grid, &v.frame, true)?;
            thin = Some(v);
        }
    }
    // A reference image of the mesh itself (the ray caster will render the voxels).
    let positions: Vec<Vec3> = mesh.positions.iter().map(|p| p.as_vec3()).collect();
    let (lo, hi) = mesh.bounds();
    let centre = (lo + hi) * 0.5;
    let eye = centre + glam::DVec3::new(1.6, 0.7, -1.4) * (hi - lo).length();
    let mut camera = crate::camera::Camera::perspective(eye, centre, glam::DVec3::Y, 35.0);
    camera.fit_clip(lo, hi);
    let png = args.out_dir.join("spot.png");
    crate::triangle::render_mesh_png(
        &positions,
        &mesh.triangles,
        None,
        &camera,
        512,
        512,
        &crate::triangle::MeshRenderOptions::default(),
        &png,
        true,
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "Wrote {} and {} (rasterized mesh, z-buffer + Gouraud).",
        args.out_dir.join("spot_thin.binvox").display(),
        png.display()
    )?;
    if let Some(v) = thin {
        render_demo(args, &v, &mesh, out)?;
    }
    Ok(())
}

/// Renders the thin voxelization with every ray kind (with skipping), and
/// prints time, work and error against the 6-ray image and the rasterized
/// mesh; writes the adaptive image.
fn render_demo(
    args: &DemoArgs,
    v: &crate::voxelize::pipeline::Voxelization,
    mesh: &crate::mesh::Mesh,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    use crate::render::{
        GridTransform, OccupancyGrid, RayKind, RenderOptions, default_camera, render_grid,
    };
    let (w, h) = (768, 768);
    let t = Instant::now();
    let occ = OccupancyGrid::new(&v.grid, v.frame.dims, MemoryLimit::DEFAULT)?;
    let prepare_ms = t.elapsed().as_secs_f64() * 1e3;
    let xf = GridTransform::from_frame(&v.frame)?;
    // Spot looks down −Z: the three-quarter view of her face.
    let axes = crate::camera::SceneAxes {
        up: glam::DVec3::Y,
        front: glam::DVec3::NEG_Z,
        right: glam::DVec3::NEG_X,
    };
    let cam = default_camera(&occ, &xf, &axes, w, h)?;
    let opts = RenderOptions {
        width: w,
        height: h,
        ..RenderOptions::default()
    };
    writeln!(out)?;
    writeln!(
        out,
        "Rendering: the thin voxels ({} in {:?}) at {w}x{h}, default camera, skipping on \
         (render structures built in {prepare_ms:.1} ms, {:.1} MiB); differing: pixels whose \
         first hit differs from the 6-ray image; mesh depth: mean |depth - rasterized mesh \
         depth| in voxels.",
        occ.voxel_count(),
        v.frame.dims,
        occ.heap_bytes() as f64 / (1 << 20) as f64
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "| ray | ms/frame | voxels visited | jumps | differing | mesh depth | silhouette |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|")?;
    let six = render_grid(
        &occ,
        &xf,
        &cam,
        &RenderOptions {
            ray: RayKind::Six,
            ..opts
        },
    )?
    .0;
    for kind in RayKind::ALL {
        let (img, stats) = render_grid(&occ, &xf, &cam, &RenderOptions { ray: kind, ..opts })?;
        let m = crate::render::measure::against_mesh(&img, mesh, &cam, v.frame.voxel_size)?;
        writeln!(
            out,
            "| {} | {:.1} | {} | {} | {} | {:.3} | {:.2}% |",
            kind.name(),
            stats.render_ms,
            stats.voxels_visited,
            stats.bricks_skipped,
            img.differing_hits(&six),
            m.depth_mean,
            100.0 * m.silhouette_disagree
        )?;
        if kind == RayKind::Adaptive {
            let path = args.out_dir.join("spot_render.png");
            crate::io::image::write_png_rgba(&path, w, h, &img.to_rgba8(opts.background), true)?;
        }
    }
    writeln!(out)?;
    writeln!(
        out,
        "Wrote {} (adaptive rays).",
        args.out_dir.join("spot_render.png").display()
    )?;
    Ok(())
}
