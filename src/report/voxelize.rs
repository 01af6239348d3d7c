//! The report's voxelization section: every mode × exact or snapped
//! vertices × resolution on the bundled meshes — time, memory and the exact
//! error measures of [`crate::voxelize::measure`] — and a Pareto plot of
//! time against geometric error.

use super::document::PlotDir;
use super::plot::{Chart, Series, pareto_front};
use super::timing::{Timing, time_calls};
use crate::error::{Result, VoxkitError};
use crate::grid::MemoryLimit;
use crate::mesh::Mesh;
use crate::voxelize::measure::{ErrorMeasures, measure_voxelization};
use crate::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, voxelize_mesh};

/// The modes, in table order.
pub const MODES: [VoxelizeMode; 4] = [
    VoxelizeMode::Thin,
    VoxelizeMode::Thick,
    VoxelizeMode::Conservative,
    VoxelizeMode::Solid,
];

/// One voxelization case.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelizeRow {
    /// Mesh name.
    pub mesh: String,
    /// Mode.
    pub mode: VoxelizeMode,
    /// Vertices snapped to the voxel lattice (`--snap`) instead of 1/256 voxel.
    pub snap: bool,
    /// `-r`.
    pub resolution: u32,
    /// Wall time of `voxelize_mesh`.
    pub time: Timing,
    /// Voxels set.
    pub voxels: u64,
    /// The voxelizer's own estimate before the run (what `--max-memory` is checked against).
    pub estimated_bytes: u64,
    /// Heap bytes of the resulting brick grid.
    pub grid_bytes: u64,
    /// The exact error measures.
    pub error: ErrorMeasures,
    /// `max_distance` in world units as a share of the mesh's bounding-box diagonal.
    pub max_distance_share: f64,
}

/// Voxelizes every mesh in every mode, exact and snapped, at every
/// resolution; `step` is told each case before it runs.
pub fn voxelize_report(
    meshes: &[(String, Mesh)],
    resolutions: &[u32],
    reps: usize,
    step: &mut dyn FnMut(&str),
) -> Result<Vec<VoxelizeRow>> {
    let mut rows = Vec::new();
    for (name, mesh) in meshes {
        let (lo, hi) = mesh.bounds();
        let diagonal = (hi - lo).length();
        for &resolution in resolutions {
            for mode in MODES {
                for snap in [false, true] {
                    step(&format!(
                        "voxelize {name} {} -r {resolution}{}",
                        mode.name(),
                        if snap { " --snap" } else { "" }
                    ));
                    let mut opts = VoxelizeOptions::new(resolution, mode);
                    opts.snap = snap;
                    let mut last = None;
                    let time = time_calls(reps, || -> Result<()> {
                        last = Some(voxelize_mesh(mesh, &opts)?);
                        Ok(())
                    })?;
                    let v = last.ok_or_else(|| VoxkitError::invalid("no voxelization ran"))?;
                    let error = measure_voxelization(&v, MemoryLimit::DEFAULT)?;
                    rows.push(VoxelizeRow {
                        mesh: name.clone(),
                        mode,
                        snap,
                        resolution,
                        time,
                        voxels: v.stats.voxels,
                        estimated_bytes: v.stats.estimated_bytes,
                        grid_bytes: v.grid.heap_bytes() as u64,
                        max_distance_share: error.max_distance * v.frame.voxel_size
                            / diagonal.max(f64::MIN_POSITIVE),
                        error,
                    });
                }
            }
        }
    }
    Ok(rows)
}

/// The cases [`voxelize_report`] runs.
pub fn case_count(meshes: usize, resolutions: usize) -> u64 {
    (meshes * resolutions * MODES.len() * 2) as u64
}

/// The voxelization section's Markdown, with its plots written to `plots`.
pub fn section(rows: &[VoxelizeRow], plots: &PlotDir) -> Result<String> {
    let reps = rows.first().map_or(0, |r| r.time.reps);
    let mut md = format!(
        "Each case is one `voxelize_mesh` call (fitting, quantization, the mode's kernel, the \
         brick grid; all cores). Time: one warm-up run, then the median of {reps} runs. \
         **Memory**: the voxelizer's own estimate before the run (what `--max-memory` is \
         checked against) and the heap bytes of the resulting brick grid — per case, which the \
         process's peak RSS is not. **Error**, by `voxkit::voxelize::measure` against the exact \
         conservative voxel set of the *exact* (unsnapped) mesh: **missing** / **extra** \
         voxels; **max / mean dist**: distance from output voxel centres to the surface in \
         voxels (over voxels within 1.5 of it: solid's interior is excluded and counted as \
         extra); **max dist % diag**: max dist in world units as a share of the mesh's \
         bounding-box diagonal (comparable across resolutions: the error of the second Pareto plot; the first uses (missing + extra) / exact voxels); \
         **6/26-tunnel**: whether an empty 6- (26-) connected path crosses the surface \
         (computed on closed meshes only; `-` otherwise). By design thin misses voxels \
         (6-tunnel-free, not 26), thick is 26-tunnel-free, conservative is the exact set, and \
         solid's extra voxels are its interior.\n\n\
         | mesh | mode | snap | -r | ms | voxels | estimate MiB | grid MiB | missing | extra | max dist | mean dist | max dist % diag | 6-tunnel | 26-tunnel |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    );
    let verdict = |t: Option<bool>| match t {
        Some(true) => "yes",
        Some(false) => "no",
        None => "-",
    };
    let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
    for r in rows {
        md.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} | {} | {:.2} | {:.2} | {} | {} | {:.3} | {:.3} | {:.3} | {} | {} |\n",
            r.mesh,
            r.mode.name(),
            if r.snap { "yes" } else { "no" },
            r.resolution,
            1e3 * r.time.median,
            r.voxels,
            mib(r.estimated_bytes),
            mib(r.grid_bytes),
            r.error.missing,
            r.error.extra,
            r.error.max_distance,
            r.error.mean_distance,
            100.0 * r.max_distance_share,
            verdict(r.error.tunnel6),
            verdict(r.error.tunnel26),
        ));
    }
    md.push('\n');
    let mut meshes: Vec<&str> = rows.iter().map(|r| r.mesh.as_str()).collect();
    meshes.dedup();
    for mesh in meshes {
        let of_mesh: Vec<&VoxelizeRow> = rows.iter().filter(|r| r.mesh == mesh).collect();
        for error in [ParetoError::Set, ParetoError::Distance] {
            md.push_str(&pareto(mesh, &of_mesh, error, plots)?);
        }
    }
    Ok(md)
}

/// The error axis of a Pareto plot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ParetoError {
    /// (missing + extra) / reference voxels, surface modes only (solid's
    /// extra voxels are its interior by design).
    Set,
    /// Max voxel-centre distance to the surface, % of the bbox diagonal
    /// (world units: comparable across resolutions).
    Distance,
}

impl ParetoError {
    fn of(self, r: &VoxelizeRow) -> Option<f64> {
        match self {
            ParetoError::Set => (r.mode != VoxelizeMode::Solid).then(|| {
                100.0 * (r.error.missing + r.error.extra) as f64
                    / r.error.reference_voxels.max(1) as f64
            }),
            ParetoError::Distance => Some(100.0 * r.max_distance_share),
        }
    }
}

/// One Pareto plot (time against `error`) of one mesh's cases, with the
/// front named in a line of Markdown.
fn pareto(
    mesh: &str,
    rows: &[&VoxelizeRow],
    error: ParetoError,
    plots: &PlotDir,
) -> Result<String> {
    let point = |r: &VoxelizeRow| error.of(r).map(|e| (1e3 * r.time.median, e));
    let mut series = Vec::new();
    for mode in MODES {
        for snap in [false, true] {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.mode == mode && r.snap == snap)
                .filter_map(|r| point(r))
                .collect();
            if pts.is_empty() {
                continue;
            }
            let mut s = Series::points(
                format!("{}{}", mode.name(), if snap { " snapped" } else { "" }),
                pts,
            );
            s.hollow = snap;
            series.push(s);
        }
    }
    let all: Vec<(f64, f64)> = rows.iter().filter_map(|r| point(r)).collect();
    let front = pareto_front(&all);
    let named: Vec<String> = front
        .iter()
        .filter_map(|p| rows.iter().find(|r| point(r) == Some(*p)))
        .map(|r| {
            format!(
                "{} {}-r {}",
                r.mode.name(),
                if r.snap { "--snap " } else { "" },
                r.resolution
            )
        })
        .collect();
    let (what, y_label, log_y, tag) = match error {
        ParetoError::Set => (
            "missing + extra voxels against the exact conservative set, thin/thick/conservative",
            "(missing + extra) / exact voxels (%)",
            false,
            "set",
        ),
        ParetoError::Distance => (
            "max voxel distance to the surface as % of the bbox diagonal, every mode",
            "max voxel distance to the surface (% of bbox diagonal)",
            true,
            "distance",
        ),
    };
    let slug: String = mesh
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let mut md = format!(
        "\n**Pareto front, {mesh}** (time against {what}; one point per mode, snap and resolution; hollow markers are snapped): {}.\n\n",
        named.join(", ")
    );
    md.push_str(&plots.write(
        &format!("voxelize_pareto_{tag}_{slug}.svg"),
        &Chart {
            title: format!("Voxelization of {mesh}: time against error ({tag})"),
            x_label: "ms per voxelization".into(),
            y_label: y_label.into(),
            log_x: true,
            log_y,
            series,
            front: Some(Series::line("Pareto front", front)),
        },
    )?);
    Ok(md)
}
