//! The report document: which measurements run at which size ([`Tier`],
//! [`ReportSettings`]), where the plots go ([`PlotDir`]), and the Markdown
//! that puts speed beside error ([`write_report`]).
//!
//! The report and its plots are regenerated on every run: existing files
//! are overwritten, each written atomically (a temporary file renamed into
//! place), the Markdown last, so an interrupted run never leaves a partial
//! file and never a report pointing at plots that were not written.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::machine::MachineInfo;
use super::plot::Chart;
use super::{LineReportConfig, line_report};
use crate::error::{Result, VoxkitError};
use crate::mesh::Mesh;

/// How much to measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tier {
    /// Small sizes, few repetitions: under a minute on two loaded cores.
    Quick,
    /// The sizes of the benches (about ten minutes on two cores).
    Full,
}

/// Sizes and repetitions of every measurement.
#[derive(Clone, Debug)]
pub struct ReportSettings {
    /// Which tier these are.
    pub tier: Tier,
    /// Random line segments.
    pub lines: LineReportConfig,
    /// Target voxels per ray of the f32/f64 A–W comparison.
    pub long_ray_lengths: Vec<u64>,
    /// Rays per length.
    pub long_rays: usize,
    /// Fat triangle radii (about 2r² points).
    pub fat_radii: Vec<i64>,
    /// Skinny triangle long sides.
    pub skinny_sides: Vec<i64>,
    /// Timed batches per triangle.
    pub triangle_reps: usize,
    /// Seconds per triangle batch.
    pub triangle_batch_s: f64,
    /// Voxelization resolutions.
    pub voxel_resolutions: Vec<u32>,
    /// Timed runs per voxelization case.
    pub voxel_reps: usize,
    /// Voxel resolution of the ray-kind comparison.
    pub render_resolution: u32,
    /// Frame side of the ray-kind comparison.
    pub render_size: u32,
    /// Timed frames per rendering case.
    pub render_reps: usize,
    /// Voxel resolutions of the image error against the mesh.
    pub mesh_error_resolutions: Vec<u32>,
    /// Frame side of the image error against the mesh.
    pub mesh_error_size: u32,
}

impl ReportSettings {
    /// The settings of a tier.
    pub fn new(tier: Tier) -> Self {
        match tier {
            Tier::Quick => ReportSettings {
                tier,
                lines: LineReportConfig {
                    segments: 4_000,
                    judged: 500,
                    grid: 128,
                    reps: 3,
                    ..LineReportConfig::default()
                },
                long_ray_lengths: vec![1_000, 10_000, 100_000],
                long_rays: 8,
                fat_radii: vec![10, 100, 1000],
                skinny_sides: vec![100, 10_000, 1_000_000],
                triangle_reps: 3,
                triangle_batch_s: 0.002,
                voxel_resolutions: vec![64, 128],
                voxel_reps: 2,
                render_resolution: 64,
                render_size: 192,
                render_reps: 2,
                mesh_error_resolutions: vec![32, 64, 128],
                mesh_error_size: 160,
            },
            Tier::Full => ReportSettings {
                tier,
                // 20,000 64-voxel segments in a 512³ grid: the bench's
                // `grid512` setting (`cargo bench --bench lines -- grid512`).
                lines: LineReportConfig {
                    grid: 512,
                    reps: 7,
                    ..LineReportConfig::default()
                },
                long_ray_lengths: vec![1_000, 10_000, 100_000, 1_000_000],
                long_rays: 24,
                // 70 and 700: the bench's fat_1e4 and fat_1e6.
                fat_radii: vec![10, 30, 70, 300, 700],
                skinny_sides: vec![100, 1_000, 10_000, 100_000, 1_000_000],
                triangle_reps: 7,
                triangle_batch_s: 0.01,
                voxel_resolutions: vec![128, 256, 512, 1024],
                voxel_reps: 3,
                render_resolution: 256,
                render_size: 1024,
                render_reps: 5,
                mesh_error_resolutions: vec![64, 128, 256, 512],
                mesh_error_size: 512,
            },
        }
    }

    /// Progress steps of a run on `meshes` meshes.
    pub fn step_count(&self, meshes: usize) -> u64 {
        4 + super::voxelize::case_count(meshes, self.voxel_resolutions.len())
            + super::render::render_case_count()
            + self.mesh_error_resolutions.len() as u64
    }
}

/// Where a report's plots go: the directory beside the Markdown named after
/// it (`docs/report.md` → `docs/report/`), linked relatively.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotDir {
    /// The directory.
    pub dir: PathBuf,
    /// Its name as the report links it (relative to the report's directory).
    pub link: String,
}

impl PlotDir {
    /// The plot directory of the report at `markdown`: its file stem beside
    /// it, or `<name>.plots` when the report's name has no extension.
    ///
    /// ```
    /// use std::path::Path;
    /// use voxkit::report::document::PlotDir;
    /// let p = PlotDir::for_report(Path::new("docs/report.md"));
    /// assert_eq!((p.dir.as_path(), p.link.as_str()), (Path::new("docs/report"), "report"));
    /// assert_eq!(PlotDir::for_report(Path::new("r")).link, "r.plots");
    /// ```
    pub fn for_report(markdown: &Path) -> PlotDir {
        let name = markdown
            .file_name()
            .map_or("report".into(), |n| n.to_string_lossy().into_owned());
        let link = match markdown.extension() {
            Some(_) => markdown
                .file_stem()
                .map_or("report".into(), |s| s.to_string_lossy().into_owned()),
            None => format!("{name}.plots"),
        };
        let parent = markdown.parent().unwrap_or(Path::new(""));
        PlotDir {
            dir: parent.join(&link),
            link,
        }
    }

    /// Writes `chart` as `file` in the directory; returns the Markdown image
    /// line that shows it.
    pub fn write(&self, file: &str, chart: &Chart) -> Result<String> {
        super::plot::write_svg(chart, &self.dir.join(file))?;
        Ok(format!("![{}]({}/{file})\n", chart.title, self.link))
    }
}

/// **The numerical-stability section**, around `body` (Markdown).
pub fn stability_section(body: &str) -> String {
    format!("## Numerical stability\n\n{}\n\n", body.trim_end())
}

/// The stability section's body: what the suite is, a verdict count and the
/// table of [`crate::stability::markdown_table`].
fn stability_body(results: &[crate::stability::CaseResult]) -> String {
    let failed = results.iter().filter(|r| !r.passed).count();
    format!(
        "Hard inputs against independent exact oracles or stated bounds \
         (`voxkit::stability`, also `cargo test --release --test stability`; see \
         [stability.md](stability.md)): range ends, ties, slivers, damaged meshes, scales, \
         long rays, grazing render rays. **{} of {} cases pass.**\n\n{}",
        results.len() - failed,
        results.len(),
        crate::stability::markdown_table(results)
    )
}

/// What [`write_report`] wrote.
#[derive(Clone, Debug)]
pub struct ReportOutcome {
    /// The Markdown file.
    pub markdown: PathBuf,
    /// The plots, in the order the report shows them.
    pub plots: Vec<PathBuf>,
    /// Wall time of the whole run, seconds.
    pub seconds: f64,
}

/// Checks that `markdown` can be written before minutes are spent
/// measuring: not a directory, its directory exists (or can be made) and
/// accepts files. Creates the plot directory.
pub fn prepare_output(markdown: &Path) -> Result<PlotDir> {
    let io = |path: &Path, source| VoxkitError::Io {
        path: path.to_path_buf(),
        source,
    };
    if markdown.is_dir() {
        return Err(VoxkitError::invalid(format!(
            "{}: is a directory (give the report's file name, e.g. docs/report.md)",
            markdown.display()
        )));
    }
    if markdown.file_name().is_none() {
        return Err(VoxkitError::invalid(format!(
            "{}: not a file name",
            markdown.display()
        )));
    }
    let plots = PlotDir::for_report(markdown);
    std::fs::create_dir_all(&plots.dir).map_err(|e| io(&plots.dir, e))?;
    // A probe file: the directory must accept new files (read-only mounts,
    // permissions), as the atomic writes will need.
    let probe = plots.dir.join(".voxkit-report-probe");
    std::fs::write(&probe, b"").map_err(|e| io(&probe, e))?;
    let _ = std::fs::remove_file(&probe);
    Ok(plots)
}

/// Runs every measurement of `settings` and writes the report to `markdown`
/// with its plots beside it. `meshes` are the meshes voxelized (the first is
/// also rendered); `repo` is where `git` is asked for the commit; `step` is
/// told each step before it runs.
pub fn write_report(
    settings: &ReportSettings,
    meshes: &[(String, Mesh)],
    markdown: &Path,
    repo: &Path,
    step: &mut dyn FnMut(&str),
) -> Result<ReportOutcome> {
    let t0 = Instant::now();
    let plots = prepare_output(markdown)?;
    let (render_name, render_mesh) = meshes
        .first()
        .ok_or_else(|| VoxkitError::invalid("report: no mesh to measure"))?;
    let mut machine = MachineInfo::collect(repo);

    step("lines");
    let line_rows = line_report(&settings.lines)?;
    step("A–W f32/f64 long rays");
    let long = super::lines::long_ray_report(&settings.long_ray_lengths, settings.long_rays, 11)?;
    let lines_md = super::lines::section(&settings.lines, &line_rows, &long, &plots)?;

    step("triangles");
    let tri = super::triangles::triangle_report(
        &settings.fat_radii,
        &settings.skinny_sides,
        settings.triangle_reps,
        settings.triangle_batch_s,
    )?;
    let tri_md = super::triangles::section(&tri, &plots)?;

    let vox = super::voxelize::voxelize_report(
        meshes,
        &settings.voxel_resolutions,
        settings.voxel_reps,
        step,
    )?;
    let vox_md = super::voxelize::section(&vox, &plots)?;

    let rays = super::render::render_report(
        render_mesh,
        settings.render_resolution,
        settings.render_size,
        settings.render_reps,
        step,
    )?;
    let mesh_rows = super::render::mesh_error_report(
        render_mesh,
        &settings.mesh_error_resolutions,
        settings.mesh_error_size,
        settings.render_reps,
        step,
    )?;
    let render_md = super::render::section(
        render_name,
        settings.render_resolution,
        settings.render_size,
        &rays,
        settings.mesh_error_size,
        &mesh_rows,
        &plots,
    )?;
    // The stability suite's quick tier is what CI runs; the full report
    // adds the long tier (minutes: rays of 2·10^6 voxels, 2^20-voxel spans).
    let stability_tier = match settings.tier {
        Tier::Quick => crate::stability::Tier::Quick,
        Tier::Full => crate::stability::Tier::Long,
    };
    step("numerical stability");
    let stability_md = stability_body(&crate::stability::run_all(stability_tier));
    machine.finish();
    let seconds = t0.elapsed().as_secs_f64();

    let tier = match settings.tier {
        Tier::Quick => "quick (`voxkit report --quick`)",
        Tier::Full => "full (`voxkit report`)",
    };
    let mut md = String::new();
    md.push_str(&format!(
        "# voxkit: speed against error\n\n\
         Generated by `voxkit report`, {tier} tier, in {seconds:.0} s. Every table puts a \
         time beside an error measure, and says what its error means. Regenerate with \
         `cargo run --release -- report -o {}` (add `--quick` for the one-minute version); the \
         file and its plots in `{}/` are overwritten.\n\n\
         ## Machine\n\n{}\n\
         **Timing**: wall clock; one warm-up run, then the median of several timed \
         repetitions (the count is stated per section; very short operations run in batches \
         and are divided by the batch size). *time spread* is (slowest − fastest) / median of \
         the repetitions: the run-to-run noise on this machine. Numbers from a loaded machine \
         (see the load averages) are slower and noisier than on an idle one; errors do not \
         depend on the machine.\n\n",
        markdown.display(),
        plots.link,
        machine.markdown(),
    ));
    md.push_str("## Lines\n\n");
    md.push_str(&lines_md);
    md.push_str("\n## Triangle indexing\n\n");
    md.push_str(&tri_md);
    md.push_str("\n## Voxelization\n\n");
    md.push_str(&vox_md);
    md.push_str("\n## Rendering\n\n");
    md.push_str(&render_md);
    md.push('\n');
    md.push_str(&stability_section(&stability_md));

    let plot_files = plot_links(&md)
        .into_iter()
        .map(|l| plots.dir.join(l))
        .collect();
    crate::io::atomic_write(markdown, true, |w| Ok(w.write_all(md.as_bytes())?))?;
    Ok(ReportOutcome {
        markdown: markdown.to_path_buf(),
        plots: plot_files,
        seconds,
    })
}

/// The file names of the images a report links (`![…](dir/file)`).
pub fn plot_links(md: &str) -> Vec<String> {
    md.lines()
        .filter(|l| l.starts_with("!["))
        .filter_map(|l| l.rsplit_once("](")?.1.strip_suffix(')'))
        .filter_map(|target| target.rsplit_once('/').map(|(_, f)| f.to_string()))
        .collect()
}
