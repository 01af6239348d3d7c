//! `voxkit demo`: the toolkit on an embedded default, printing speed against
//! error.
//!
//! Three stages, one progress bar: every line algorithm on random segments;
//! the bundled mesh voxelized in every mode (written to `out/`, measured
//! against the exact conservative set); the thin voxels rendered with every
//! ray kind (pictures in `out/`, measured against the 6-ray image and the
//! rasterized mesh). Times are printed in seconds.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;

use super::CliError;
use crate::grid::MemoryLimit;
use crate::mesh::Mesh;
use crate::render::{
    GridTransform, OccupancyGrid, RayKind, RenderOptions, default_camera, render_grid,
};
use crate::report::{LineReportConfig, line_report};
use crate::voxelize::measure::measure_voxelization;
use crate::voxelize::pipeline::{Voxelization, VoxelizeMode, VoxelizeOptions, voxelize_mesh};

/// The modes the demo runs, in table order.
const MODES: [VoxelizeMode; 4] = [
    VoxelizeMode::Thin,
    VoxelizeMode::Thick,
    VoxelizeMode::Conservative,
    VoxelizeMode::Solid,
];

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
    /// Side of the rendered pictures in pixels.
    #[arg(long, default_value_t = 768)]
    pub size: u32,
    /// Directory for the demo's files (created if missing; files overwritten).
    #[arg(long, default_value = "out")]
    pub out_dir: PathBuf,
    /// No progress bar.
    #[arg(short = 'q', long)]
    pub quiet: bool,
}

/// A progress bar over the demo's steps on stderr, when it is a terminal.
struct Steps(Option<indicatif::ProgressBar>);

impl Steps {
    fn new(total: u64, quiet: bool) -> Self {
        Steps((!quiet && std::io::stderr().is_terminal()).then(|| {
            let b = indicatif::ProgressBar::new(total);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} {elapsed_precise} [{bar:30}] {pos}/{len} {msg}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b.enable_steady_tick(std::time::Duration::from_millis(120));
            b
        }))
    }

    fn start(&self, what: &str) {
        if let Some(b) = &self.0 {
            b.set_message(what.to_string());
        }
    }

    fn done(&self) {
        if let Some(b) = &self.0 {
            b.inc(1);
        }
    }
}

impl Drop for Steps {
    fn drop(&mut self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
        }
    }
}

/// Runs `voxkit demo`.
pub fn run(args: DemoArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let t0 = Instant::now();
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| CliError::bad_input(format!("{}: {e}", args.out_dir.display())))?;
    let steps = Steps::new(
        1 + MODES.len() as u64 + 1 + RayKind::ALL.len() as u64,
        args.quiet,
    );
    steps.start("lines");
    lines_demo(&args, out)?;
    steps.done();
    let mesh = crate::mesh::bundled::spot()?;
    let thin = voxelize_demo(&args, &mesh, &steps, out)?;
    render_demo(&args, &thin, &mesh, &steps, out)?;
    drop(steps);
    writeln!(
        out,
        "\nDone in {:.1} s; files in {}.",
        t0.elapsed().as_secs_f64(),
        args.out_dir.display()
    )?;
    Ok(())
}

/// Every line algorithm on the same random segments: speed and exact error.
fn lines_demo(args: &DemoArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let cfg = LineReportConfig {
        segments: args.segments.max(1),
        judged: args.segments.clamp(1, 2_000),
        seed: args.seed,
        ..LineReportConfig::default()
    };
    let t = Instant::now();
    let rows = line_report(&cfg)?;
    writeln!(
        out,
        "Lines: {} random segments of {} voxels with sub-voxel endpoints in a {}³ u8 grid \
         (seed {}), errors judged exactly on the first {} ({:.2} s):",
        cfg.segments,
        cfg.length,
        cfg.grid,
        cfg.seed,
        cfg.judged,
        t.elapsed().as_secs_f64()
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "| algorithm | voxels/line | Mvoxels/s | s per 10^6 voxels | untouched voxels | containment | connected | mismatch |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|---|")?;
    for r in &rows {
        writeln!(
            out,
            "| {} | {:.1} | {:.0} | {:.4} | {:.3}% | {:.1}% | {:.1}% | {:.2}% |",
            r.algorithm.name(),
            r.voxels_per_line,
            r.voxels_per_second / 1e6,
            1e6 / r.voxels_per_second,
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
    Ok(())
}

/// Voxelizes the bundled mesh in every mode, writes each result and a
/// rasterized picture of the mesh, and prints speed against error. Returns
/// the thin voxels for the renderer.
fn voxelize_demo(
    args: &DemoArgs,
    mesh: &Mesh,
    steps: &Steps,
    out: &mut dyn Write,
) -> Result<Voxelization, CliError> {
    writeln!(out)?;
    writeln!(
        out,
        "Voxelization: spot.obj (bundled, {} triangles) at -r {}; errors against the exact \
         conservative set of the same fixed-point triangles:",
        mesh.triangles.len(),
        args.resolution
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "| mode | voxelize s | voxels | missing | extra | max dist | mean dist | 6-tunnel | 26-tunnel | file |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|---|---|---|")?;
    let verdict = |t: Option<bool>| match t {
        Some(true) => "yes",
        Some(false) => "no",
        None => "-",
    };
    let mut thin = None;
    for mode in MODES {
        steps.start(&format!("voxelize {}", mode.name()));
        let t = Instant::now();
        let v = voxelize_mesh(mesh, &VoxelizeOptions::new(args.resolution, mode))?;
        let seconds = t.elapsed().as_secs_f64();
        let m = measure_voxelization(&v, MemoryLimit::DEFAULT)?;
        let path = args.out_dir.join(format!("spot_{}.binvox", mode.name()));
        crate::io::write_voxels(&path, &v.grid, &v.frame, true)?;
        writeln!(
            out,
            "| {} | {seconds:.4} | {} | {} | {} | {:.3} | {:.3} | {} | {} | {} |",
            mode.name(),
            v.stats.voxels,
            m.missing,
            m.extra,
            m.max_distance,
            m.mean_distance,
            verdict(m.tunnel6),
            verdict(m.tunnel26),
            path.display()
        )?;
        steps.done();
        if mode == VoxelizeMode::Thin {
            thin = Some(v);
        }
    }
    writeln!(out)?;
    writeln!(
        out,
        "thin: 6-tunnel-free, all voxels within half a voxel of the surface (a 26-tunnel is \
         expected); thick: 26-tunnel-free; conservative: exactly the voxels whose closed cube \
         meets the surface; solid: the thin surface plus the interior (winding number ≥ 1/2 at \
         voxel centres), so its extra voxels are the interior and its distances are over \
         voxels within 1.5 of the surface."
    )?;
    steps.start("rasterize mesh");
    let png = rasterize_mesh(mesh, &args.out_dir, args.size)?;
    steps.done();
    writeln!(
        out,
        "Wrote {} (rasterized mesh, z-buffer + Gouraud).",
        png.display()
    )?;
    Ok(thin.expect("MODES contains Thin"))
}

/// A reference picture of the mesh itself, by the triangle rasterizer.
fn rasterize_mesh(mesh: &Mesh, dir: &Path, size: u32) -> Result<PathBuf, CliError> {
    let positions: Vec<Vec3> = mesh.positions.iter().map(|p| p.as_vec3()).collect();
    let (lo, hi) = mesh.bounds();
    let centre = (lo + hi) * 0.5;
    let eye = centre + glam::DVec3::new(1.6, 0.7, -1.4) * (hi - lo).length();
    let mut camera = crate::camera::Camera::perspective(eye, centre, glam::DVec3::Y, 35.0);
    camera.fit_clip(lo, hi);
    let png = dir.join("spot_mesh.png");
    crate::triangle::render_mesh_png(
        &positions,
        &mesh.triangles,
        None,
        &camera,
        size,
        size,
        &crate::triangle::MeshRenderOptions::default(),
        &png,
        true,
    )?;
    Ok(png)
}

/// Renders the thin voxelization with every ray kind (with skipping), prints
/// time, work and error against the 6-ray image and the rasterized mesh, and
/// writes one PNG per ray kind plus the adaptive frame as EXR (colour + depth).
fn render_demo(
    args: &DemoArgs,
    v: &Voxelization,
    mesh: &Mesh,
    steps: &Steps,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let (w, h) = (args.size.max(1), args.size.max(1));
    let t = Instant::now();
    let occ = OccupancyGrid::new(&v.grid, v.frame.dims, MemoryLimit::DEFAULT)?;
    let prepare_s = t.elapsed().as_secs_f64();
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
         (render structures built in {prepare_s:.4} s, {:.1} MiB); differing: pixels whose \
         first hit differs from the 6-ray image; mesh depth: mean |depth - rasterized mesh \
         depth| in voxels:",
        occ.voxel_count(),
        v.frame.dims,
        occ.heap_bytes() as f64 / (1 << 20) as f64
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "| ray | s/frame | voxels visited | jumps | differing | mesh depth | silhouette | file |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|---|")?;
    let mut six = None;
    for kind in RayKind::ALL {
        steps.start(&format!("render {}", kind.name()));
        let (img, stats) = render_grid(&occ, &xf, &cam, &RenderOptions { ray: kind, ..opts })?;
        if kind == RayKind::Six {
            six = Some(img.clone());
        }
        let six = six
            .as_ref()
            .expect("RayKind::ALL starts with the 6-ray, the reference");
        let m = crate::render::measure::against_mesh(&img, mesh, &cam, v.frame.voxel_size)?;
        let path = args.out_dir.join(format!("spot_ray_{}.png", kind.name()));
        crate::io::image::write_png_rgba(&path, w, h, &img.to_rgba8(opts.background), true)?;
        if kind == RayKind::Adaptive {
            let exr = args.out_dir.join("spot_ray_adaptive.exr");
            crate::io::image::write_exr(&exr, w, h, &img.color, &img.depth, true)?;
        }
        writeln!(
            out,
            "| {} | {:.4} | {} | {} | {} | {:.3} | {:.2}% | {} |",
            kind.name(),
            stats.render_ms / 1e3,
            stats.voxels_visited,
            stats.bricks_skipped,
            img.differing_hits(six),
            m.depth_mean,
            100.0 * m.silhouette_disagree,
            path.display()
        )?;
        steps.done();
    }
    writeln!(
        out,
        "\nThe adaptive frame is also in {} (R,G,B,A and Z = distance along the ray).",
        args.out_dir.join("spot_ray_adaptive.exr").display()
    )?;
    Ok(())
}
