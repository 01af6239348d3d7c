//! `voxkit voxelize MESH (-r N | --voxel-size H [--origin X,Y,Z]) -o OUT [--mode thin|thick|conservative|solid] [--snap [--kahan-kelsen]] [--json] [--measure] [--force] [--max-memory MIB] [-q]`
//!
//! Loads a mesh, voxelizes it ([`voxelize_mesh`]) and writes a
//! `.binvox`, `.vox`, `.npy` or `.nrrd` file or an OME-Zarr store `.zarr`
//! (by extension; `--pyramid` adds the store's max-pooled levels). An
//! existing output is refused without `--force` (exit 2, checked before any
//! work).
//!
//! `--tile-size N --plan` / `--tile I,J,K` run one grid in tiles into one
//! store ([`super::tiles`], [`crate::tiled`]).
//!
//! Several inputs, a directory or a glob pattern select batch mode
//! (`voxkit voxelize DIR|GLOB|MESH… -o OUTDIR [--format FORMAT]`,
//! [`super::batch`]), which takes the same options.
//!
//! `-r N` fits `N` voxels along the mesh's longest side; `--voxel-size H`
//! puts the grid on the lattice of voxels of edge `H` whose corners include
//! `--origin` (default: the mesh's bounding-box min) and covers the mesh
//! ([`Lattice`]).
//!
//! `--json` prints one line with the keys `mesh`, `mode`, `resolution`
//! (`null` with `--voxel-size`), `voxel_size`, `origin` (the grid's min
//! corner), `snap`, `kahan_kelsen`, `dims`, `triangles`, `skipped_triangles`, `segments`, `voxels`,
//! `bricks`, `estimated_mib`, `load_ms`, `quantize_ms`, `kernel_ms`,
//! `polyline_ms`, `voxelize_ms` (the
//! whole voxelization, quantization included), `write_ms`, `warnings` (what
//! the mesh loader ignored, also printed to stderr as `warning: FILE: ...`),
//! `peak_rss_mib`
//! (VmHWM of `/proc/self/status`, `null` where unavailable) and, with
//! `--measure`, `measure_ms`, `reference_voxels`, `missing`, `extra`,
//! `max_distance`, `mean_distance`, `far_voxels`, `closed`, `tunnel6`,
//! `tunnel26` (`null` when skipped) and `measure_note`. Without `--json` a
//! short human summary is printed. A progress bar goes to stderr when it is a
//! terminal and `-q` is not given.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use super::CliError;
use crate::grid::MemoryLimit;
use crate::io::{VoxelFormat, write_voxels_limited};
use crate::mesh::Mesh;
use crate::voxelize::measure::{ErrorMeasures, measure_voxelization};
use crate::voxelize::pipeline::{
    Lattice, Progress, Voxelization, VoxelizeMode, VoxelizeOptions, voxelize_mesh,
};
use crate::voxelize::solid::InsideTest;

/// The `--mode` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    /// 6-tunnel-free surface.
    Thin,
    /// 26-tunnel-free surface.
    Thick,
    /// Every voxel whose closed cube meets the surface.
    Conservative,
    /// Surface plus interior (generalized winding number ≥ ½; see --inside).
    Solid,
}

impl From<ModeArg> for VoxelizeMode {
    fn from(m: ModeArg) -> Self {
        match m {
            ModeArg::Thin => VoxelizeMode::Thin,
            ModeArg::Thick => VoxelizeMode::Thick,
            ModeArg::Conservative => VoxelizeMode::Conservative,
            ModeArg::Solid => VoxelizeMode::Solid,
        }
    }
}

/// The `--format` values (batch mode's output format).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FormatArg {
    /// `.binvox`.
    Binvox,
    /// MagicaVoxel `.vox`.
    Vox,
    /// NumPy `.npy`.
    Npy,
    /// `.nrrd`.
    Nrrd,
    /// OME-Zarr store (a directory).
    Zarr,
}

impl FormatArg {
    /// The file extension of the format (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            FormatArg::Binvox => "binvox",
            FormatArg::Vox => "vox",
            FormatArg::Npy => "npy",
            FormatArg::Nrrd => "nrrd",
            FormatArg::Zarr => "zarr",
        }
    }
}

/// Arguments of `voxkit voxelize`.
#[derive(Debug, clap::Args)]
pub struct VoxelizeArgs {
    /// The mesh (.obj, .gltf, .glb, .ply, .stl, .off). Batch mode: several
    /// meshes, directories (walked recursively for files with a mesh
    /// extension) or quoted glob patterns (`'data/**/*.obj'`).
    #[arg(required = true, value_name = "MESH|DIR|GLOB")]
    pub inputs: Vec<PathBuf>,
    /// Voxels along the longest side of the bounding box.
    #[arg(
        short = 'r',
        long = "resolution",
        value_name = "N",
        required_unless_present = "voxel_size",
        conflicts_with = "voxel_size"
    )]
    pub resolution: Option<u32>,
    /// Voxel edge length in world units (instead of -r): the grid covers the
    /// mesh on the lattice of this size through --origin.
    #[arg(long, value_name = "H")]
    pub voxel_size: Option<f64>,
    /// With --voxel-size: a voxel corner of the lattice (world); default: the
    /// mesh's bounding-box min.
    #[arg(long, value_name = "X,Y,Z", requires = "voxel_size", value_parser = super::render::parse_vec3, allow_hyphen_values = true)]
    pub origin: Option<glam::DVec3>,
    /// Output file (.binvox, .vox, .npy, .nrrd) or OME-Zarr store (.zarr, a
    /// directory); in batch mode the output directory (created if missing).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
    /// Batch mode: the format of every output [default: binvox]. (A single
    /// mesh's format is its output's extension.)
    #[arg(long, value_enum, value_name = "FORMAT")]
    pub format: Option<FormatArg>,
    /// Tiled runs into a .zarr store: the edge of a tile in voxels (a
    /// multiple of 512, one shard). With --plan or --tile.
    #[arg(long, value_name = "N")]
    pub tile_size: Option<u32>,
    /// With --tile-size: write the store's metadata and print (JSON) the
    /// tiles whose box meets the mesh; voxelize nothing.
    #[arg(long, requires = "tile_size", conflicts_with = "tile")]
    pub plan: bool,
    /// With --tile-size: voxelize tile I,J,K alone into the planned store
    /// (its shards only, never the metadata); its voxels are those of the
    /// whole-grid run there.
    #[arg(long, value_name = "I,J,K", requires = "tile_size", value_parser = super::tiles::parse_tile)]
    pub tile: Option<[u32; 3]>,
    /// With --tile-size, after every tile: build the pyramid levels that
    /// span several tiles (a store planned with --plan --pyramid).
    #[arg(long, requires = "tile_size", conflicts_with_all = ["tile", "plan"])]
    pub finish: bool,
    /// With a .zarr output: also write multiscale levels 1, 2, … (occupancy
    /// max-pooled by 2 per level) until the largest extent fits 64 voxels.
    /// In a tiled run, with --plan (the tiles write what they can, --finish
    /// the rest).
    #[arg(long)]
    pub pyramid: bool,
    /// Which voxel set.
    #[arg(long, value_enum, default_value = "thin")]
    pub mode: ModeArg,
    /// Solid mode's inside test: the generalized winding number (robust to
    /// holes, flipped faces and overlaps) or crossing parity (watertight
    /// meshes only, fastest).
    #[arg(long, value_enum, default_value = "winding")]
    pub inside: InsideTest,
    /// Snap vertices to the voxel lattice (less exact).
    #[arg(long)]
    pub snap: bool,
    /// With --snap: enumerate lattice points by Kahan–Kelsen indexing (same
    /// voxels; evens out meshes with a few huge triangles).
    #[arg(long, requires = "snap")]
    pub kahan_kelsen: bool,
    /// Print one line of JSON.
    #[arg(long)]
    pub json: bool,
    /// Also compute error measures against the exact conservative set
    /// (single mesh only).
    #[arg(long)]
    pub measure: bool,
    /// Overwrite an existing output (batch mode: instead of skipping it).
    #[arg(long)]
    pub force: bool,
    /// Memory limit in MiB (estimated before allocating).
    #[arg(long, value_name = "MIB", default_value_t = 4096)]
    pub max_memory: u64,
    /// No progress bar.
    #[arg(short = 'q', long)]
    pub quiet: bool,
}

/// Peak resident set size in MiB (VmHWM), where `/proc` has it.
pub use crate::tiled::peak_rss_mib;

/// Adds the `--measure` keys (`measure_ms`, `reference_voxels`, `missing`,
/// `extra`, `max_distance`, `mean_distance`, `far_voxels`, `closed`,
/// `tunnel6`, `tunnel26`, `measure_note`) to a JSON object.
pub(crate) fn insert_measures(
    obj: &mut serde_json::Map<String, serde_json::Value>,
    m: &ErrorMeasures,
    measure_ms: f64,
) {
    for (k, val) in [
        ("measure_ms", serde_json::json!(measure_ms)),
        ("reference_voxels", m.reference_voxels.into()),
        ("missing", m.missing.into()),
        ("extra", m.extra.into()),
        ("max_distance", m.max_distance.into()),
        ("mean_distance", m.mean_distance.into()),
        ("far_voxels", m.far_voxels.into()),
        ("closed", m.closed.into()),
        ("tunnel6", serde_json::json!(m.tunnel6)),
        ("tunnel26", serde_json::json!(m.tunnel26)),
        ("measure_note", serde_json::json!(m.note)),
    ] {
        obj.insert(k.to_string(), val);
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The voxelizer's options from the arguments (lattice, mode, snapping,
/// inside test, memory limit), shared by single-mesh and batch mode.
pub(super) fn voxelize_options(args: &VoxelizeArgs) -> Result<VoxelizeOptions, CliError> {
    // clap's `requires` is not checked when the required argument conflicts
    // with a present one (`-r`), so `-r N --origin …` is refused here.
    if args.origin.is_some() && args.voxel_size.is_none() {
        return Err(CliError::bad_input(
            "--origin applies only with --voxel-size",
        ));
    }
    let lattice = match (args.resolution, args.voxel_size) {
        (_, Some(voxel_size)) => Lattice::VoxelSize {
            voxel_size,
            origin: args.origin,
        },
        (Some(n), None) => Lattice::Resolution(n),
        (None, None) => {
            return Err(CliError::bad_input("give -r N or --voxel-size H"));
        }
    };
    let mut opts = VoxelizeOptions::on_lattice(lattice, args.mode.into());
    opts.snap = args.snap;
    opts.kahan_kelsen = args.kahan_kelsen;
    opts.inside = args.inside;
    opts.limit = MemoryLimit::new(args.max_memory.saturating_mul(1 << 20));
    Ok(opts)
}

/// The `--json` keys of one voxelized mesh, without the `--measure` keys and
/// `peak_rss_mib` (see the module docs); `warnings` are the loader's.
pub(super) fn result_json(
    args: &VoxelizeArgs,
    mesh: &Path,
    output: &Path,
    v: &Voxelization,
    load_ms: f64,
    write_ms: f64,
    warnings: &[String],
) -> serde_json::Value {
    let s = &v.stats;
    let mut j = serde_json::json!({
        "mesh": mesh.display().to_string(),
        "output": output.display().to_string(),
        "mode": VoxelizeMode::from(args.mode).name(),
        "resolution": args.resolution,
        "voxel_size": v.frame.voxel_size,
        "origin": v.frame.origin.to_array(),
        "snap": args.snap,
        "kahan_kelsen": args.kahan_kelsen,
        "dims": v.frame.dims,
        "triangles": s.triangles,
        "skipped_triangles": s.skipped_triangles,
        "segments": s.segments,
        "voxels": s.voxels,
        "bricks": s.bricks,
        "estimated_mib": s.estimated_bytes as f64 / (1u64 << 20) as f64,
        "load_ms": load_ms,
        "quantize_ms": s.quantize_ms,
        "kernel_ms": s.kernel_ms,
        "polyline_ms": s.polyline_ms,
        "voxelize_ms": s.total_ms,
        "write_ms": write_ms,
        "warnings": warnings,
    });
    if let Some(solid) = &s.solid {
        let obj = j.as_object_mut().expect("json! of an object literal");
        obj.insert("inside".into(), args.inside.name().into());
        obj.insert("caps".into(), solid.caps.into());
        obj.insert("crossings".into(), solid.crossings.into());
        obj.insert("refined_bricks".into(), solid.refined_bricks.into());
        obj.insert("winding_ambiguous".into(), solid.ambiguous.into());
        obj.insert("winding_point_queries".into(), solid.point_queries.into());
        obj.insert("winding_box_queries".into(), solid.box_queries.into());
        obj.insert("winding_straddling".into(), solid.straddling.into());
        obj.insert(
            "winding_gradient_centres".into(),
            solid.gradient_centres.into(),
        );
        obj.insert("winding_taylor_centres".into(), solid.taylor_centres.into());
        let ms = |us: u64| us as f64 / 1000.0;
        obj.insert("solid_caps_ms".into(), ms(solid.caps_us).into());
        obj.insert("solid_trees_ms".into(), ms(solid.trees_us).into());
        obj.insert("solid_regions_ms".into(), ms(solid.regions_us).into());
        obj.insert(
            "solid_far_field_cpu_ms".into(),
            ms(solid.far_field_us).into(),
        );
        obj.insert(
            "solid_near_field_cpu_ms".into(),
            ms(solid.near_field_us).into(),
        );
        obj.insert("solid_refine_cpu_ms".into(), ms(solid.refine_us).into());
        obj.insert("solid_taylor_cpu_ms".into(), ms(solid.taylor_us).into());
    }
    j
}

/// Writes one voxelization to `output` (format by extension; a `.zarr`
/// store with its pyramid when `--pyramid`), shared by single-mesh and
/// batch mode.
pub(super) fn write_output(
    args: &VoxelizeArgs,
    output: &Path,
    v: &Voxelization,
    limit: MemoryLimit,
) -> crate::error::Result<()> {
    if crate::io::zarr::is_zarr_path(output) {
        let levels = if args.pyramid {
            crate::io::zarr::pyramid_levels(v.frame.dims)
        } else {
            1
        };
        v.grid.check_inside(v.frame.dims)?;
        return crate::io::zarr::write(output, &v.grid, &v.frame, args.force, levels).map(|_| ());
    }
    write_voxels_limited(output, &v.grid, &v.frame, args.force, limit)
}

/// Runs `voxkit voxelize`: batch mode ([`super::batch`]) for several inputs,
/// a directory or a glob pattern, otherwise one mesh.
pub fn run(args: VoxelizeArgs, out: &mut dyn Write) -> Result<(), CliError> {
    if args.tile_size.is_some() {
        return super::tiles::run(&args, out);
    }
    if super::batch::is_batch(&args.inputs) {
        return super::batch::run(&args, out);
    }
    if args.format.is_some() {
        return Err(CliError::bad_input(
            "--format applies to batch mode; a single mesh's format is the extension of -o",
        ));
    }
    let mesh_path = &args.inputs[0];
    VoxelFormat::from_path(&args.output)?;
    if args.pyramid && !crate::io::zarr::is_zarr_path(&args.output) {
        return Err(CliError::bad_input("--pyramid applies to a .zarr output"));
    }
    let mut opts = voxelize_options(&args)?;
    if !args.force && args.output.exists() {
        return Err(CliError::bad_input(format!(
            "{} exists (use --force to overwrite)",
            args.output.display()
        )));
    }
    let limit = opts.limit;
    let t = Instant::now();
    let mesh = Mesh::load(mesh_path)?;
    let load_ms = ms(t);
    super::print_warnings(mesh_path, &mesh.summary.warnings);

    let bar = (!args.quiet && std::io::stderr().is_terminal()).then(|| {
        let b = indicatif::ProgressBar::new(4);
        b.set_style(
            indicatif::ProgressStyle::with_template("{spinner} {elapsed_precise} [{bar:30}] {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b.enable_steady_tick(std::time::Duration::from_millis(120));
        b
    });
    if let Some(b) = &bar {
        let b = b.clone();
        opts.progress = Some(Arc::new(move |p: Progress| {
            b.set_length(p.total + 2);
            b.set_position(p.done);
            match p.step {
                Some((done, total)) => b.set_message(format!("{} {done}/{total} bricks", p.phase)),
                None => b.set_message(p.phase),
            }
        }));
    }
    let result = voxelize_mesh(&mesh, &opts);
    let v = match result {
        Ok(v) => v,
        Err(e) => {
            if let Some(b) = &bar {
                b.finish_and_clear();
            }
            return Err(e.into());
        }
    };
    if let Some(b) = &bar {
        b.set_message("write");
    }
    let t = Instant::now();
    let written = write_output(&args, &args.output, &v, limit);
    let write_ms = ms(t);
    let measured = if args.measure && written.is_ok() {
        if let Some(b) = &bar {
            b.set_message("measure");
        }
        let t = Instant::now();
        Some((measure_voxelization(&v, limit), ms(t)))
    } else {
        None
    };
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    written?;
    let s = &v.stats;
    let mut j = result_json(
        &args,
        mesh_path,
        &args.output,
        &v,
        load_ms,
        write_ms,
        &mesh.summary.warnings,
    );
    if let Some((m, measure_ms)) = measured {
        let m = m?;
        insert_measures(
            j.as_object_mut().expect("json! of an object literal"),
            &m,
            measure_ms,
        );
    }
    j.as_object_mut()
        .expect("json! of an object literal")
        .insert("peak_rss_mib".into(), serde_json::json!(peak_rss_mib()));
    if args.json {
        writeln!(out, "{j}")?;
    } else {
        writeln!(
            out,
            "{}: {} voxels in {} bricks, grid {:?}, {} triangles ({} skipped), {} segments; load {:.1} ms, voxelize {:.1} ms, write {:.1} ms; peak RSS {:.1} MiB",
            args.output.display(),
            s.voxels,
            s.bricks,
            v.frame.dims,
            s.triangles,
            s.skipped_triangles,
            s.segments,
            load_ms,
            s.total_ms,
            write_ms,
            peak_rss_mib().unwrap_or(f64::NAN)
        )?;
        if let Some(obj) = j.as_object()
            && obj.contains_key("missing")
        {
            writeln!(
                out,
                "measure: missing {} extra {} of {} reference voxels; distance max {:.4} mean {:.4} (far {}); closed {}, 6-tunnel {}, 26-tunnel {}{}",
                obj["missing"],
                obj["extra"],
                obj["reference_voxels"],
                obj["max_distance"].as_f64().unwrap_or(f64::NAN),
                obj["mean_distance"].as_f64().unwrap_or(f64::NAN),
                obj["far_voxels"],
                obj["closed"],
                obj["tunnel6"],
                obj["tunnel26"],
                obj["measure_note"]
                    .as_str()
                    .map(|n| format!(" ({n})"))
                    .unwrap_or_default()
            )?;
        }
    }
    Ok(())
}
