//! Tiled runs into one OME-Zarr store (`voxkit voxelize MESH … -o out.zarr
//! --tile-size N --plan | --tile I,J,K | --finish`): the options checked,
//! then [`crate::tiled::plan`], [`crate::tiled::run_tile`] or
//! [`crate::tiled::finish`], whose JSON object is printed (one line; with
//! `--tile` and without `--json`, a summary).

use std::io::Write;

use super::CliError;
use super::voxelize::{VoxelizeArgs, voxelize_options};

/// Parses `I,J,K` (non-negative tile indices).
pub(crate) fn parse_tile(s: &str) -> Result<[u32; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected I,J,K, got {s:?}"));
    }
    let mut t = [0u32; 3];
    for (slot, p) in t.iter_mut().zip(&parts) {
        *slot = p
            .parse()
            .map_err(|_| format!("{p:?} is not a tile index (0, 1, 2, …)"))?;
    }
    Ok(t)
}

/// Runs `--plan` or `--tile`.
pub(super) fn run(args: &VoxelizeArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let tile_size = args.tile_size.unwrap_or(0);
    if args.inputs.len() != 1 || args.inputs[0].is_dir() || super::batch::is_batch(&args.inputs) {
        return Err(CliError::bad_input("a tiled run takes one mesh"));
    }
    if args.measure || args.format.is_some() {
        return Err(CliError::bad_input(
            "--measure and --format do not apply to tiled runs",
        ));
    }
    if args.pyramid && !args.plan {
        return Err(CliError::bad_input(
            "in a tiled run, --pyramid goes with --plan (the tiles then write the levels they can, --finish the rest)",
        ));
    }
    let opts = voxelize_options(args)?;
    let mesh = &args.inputs[0];
    if args.plan {
        let j = crate::tiled::plan(
            mesh,
            &args.output,
            &opts,
            tile_size,
            args.force,
            args.pyramid,
        )?;
        writeln!(out, "{j}")?;
        return Ok(());
    }
    if args.finish {
        let j = crate::tiled::finish(&args.output, opts.limit)?;
        writeln!(out, "{j}")?;
        return Ok(());
    }
    let Some(tile) = args.tile else {
        return Err(CliError::bad_input(
            "--tile-size needs --plan, --tile I,J,K or --finish",
        ));
    };
    let j = crate::tiled::run_tile(mesh, &args.output, &opts, tile_size, tile)?;
    if args.json {
        writeln!(out, "{j}")?;
    } else {
        writeln!(
            out,
            "{} tile {tile:?}: {} voxels from {} triangles, {} shards written ({} empty); voxelize {:.1} ms, write {:.1} ms; peak RSS {:.1} MiB",
            args.output.display(),
            j["voxels"],
            j["triangles"],
            j["shards"],
            j["empty_shards"],
            j["voxelize_ms"].as_f64().unwrap_or(f64::NAN),
            j["write_ms"].as_f64().unwrap_or(f64::NAN),
            j["peak_rss_mib"].as_f64().unwrap_or(f64::NAN),
        )?;
    }
    Ok(())
}
