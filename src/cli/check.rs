//! `voxkit check GRID --tunnels 6|26 [--close K] [--json]`
//!
//! Reads a voxel file (any supported format) and decides whether its surface
//! has an N-tunnel. Always prints one line of JSON (`--json` is accepted for
//! symmetry with the other commands):
//! `{"grid", "dims", "voxels", "tiles", "tunnels": N, "close": K, "enclosed": e,
//! "tunnel": bool, "first_inside_reached": [x,y,z] | null, "outside_empty",
//! "inside_empty", "warnings": [...]}` (what the reader skipped, e.g. a .vox
//! file's hidden layers; each also printed to stderr as `warning: …`). Exit code 1 if a tunnel exists, 0 if not, 2 for bad
//! input.
//!
//! # What counts as inside
//! A grid file carries no mesh, and a surface with a tunnel may have its
//! inside and outside in one empty component, so "inside" must be defined
//! from the occupied voxels in a way that a small hole does not change:
//! * close the surface: dilate the occupied set `K` times by the 26-
//!   neighbourhood (default `K = 1`, which bridges gaps up to two voxels);
//! * the **inside** is every empty voxel of the dilated set that is not
//!   6-connected to the grid border (space beyond the grid counts as empty
//!   and connected);
//! * a **tunnel** is an N-path of empty voxels of the *original* grid from
//!   the border to an inside voxel ([`closed_surface_tunnels`]).
//!
//! Soundness: a path of empty original voxels that reaches the inside must
//! pass through the dilated shell, i.e. through voxels within `K` of the
//! surface that the surface leaves open: a real gap. A surface whose opening
//! is wider than about `2K` voxels is seen as open (nothing enclosed behind
//! it, `"enclosed": 0`, no tunnel); raise `--close`. With `--close 0`, the
//! inside is what the surface itself encloses under 6-connectivity, which
//! detects 26-leaks of a 6-tight surface.

use std::io::Write;
use std::path::PathBuf;

use super::CliError;
use crate::grid::{BitGrid, MemoryLimit, Voxel};
use crate::io::read_voxels_warned;
use crate::metric::Connectivity;
use crate::topology::tunnels::closed_surface_tunnels;

/// Arguments of `voxkit check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// The voxel file (.binvox, .vox, .npy, .nrrd) or OME-Zarr store (.zarr).
    pub grid: PathBuf,
    /// Connectivity of the empty paths searched: 6 or 26.
    #[arg(long, value_name = "6|26", value_parser = clap::builder::PossibleValuesParser::new(["6", "26"]))]
    pub tunnels: String,
    /// Dilations (26-neighbourhood) that close the surface to define its inside.
    #[arg(long, value_name = "K", default_value_t = 1)]
    pub close: u32,
    /// Print JSON (always done; accepted for symmetry).
    #[arg(long)]
    pub json: bool,
    /// Memory limit in MiB.
    #[arg(long, value_name = "MIB", default_value_t = 4096)]
    pub max_memory: u64,
}

/// The occupied set dilated once by the 26-neighbourhood (clipped to the grid).
pub fn dilate26(g: &BitGrid, limit: MemoryLimit) -> crate::Result<BitGrid> {
    let mut out = BitGrid::new(g.dims(), limit)?;
    for v in g.iter_ones() {
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    out.set(v + Voxel::new(dx, dy, dz), true);
                }
            }
        }
    }
    Ok(out)
}

/// Empty voxels of `g` not 6-connected to the grid border.
pub fn enclosed_empty(g: &BitGrid, limit: MemoryLimit) -> crate::Result<Vec<Voxel>> {
    let [nx, ny, nz] = g.dims();
    let mut seen = BitGrid::new(g.dims(), limit)?;
    let mut stack: Vec<Voxel> = Vec::new();
    let push = |v: Voxel, seen: &mut BitGrid, stack: &mut Vec<Voxel>| {
        if let Some(i) = g.linear_index(v)
            && !g.get_index(i)
            && !seen.get_index(i)
        {
            seen.set_index(i, true);
            stack.push(v);
        }
    };
    let (nx, ny, nz) = (nx as i32, ny as i32, nz as i32);
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if x == 0 || y == 0 || z == 0 || x == nx - 1 || y == ny - 1 || z == nz - 1 {
                    push(Voxel::new(x, y, z), &mut seen, &mut stack);
                }
            }
        }
    }
    while let Some(v) = stack.pop() {
        for d in [
            Voxel::X,
            Voxel::NEG_X,
            Voxel::Y,
            Voxel::NEG_Y,
            Voxel::Z,
            Voxel::NEG_Z,
        ] {
            push(v + d, &mut seen, &mut stack);
        }
    }
    let mut out = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let v = Voxel::new(x, y, z);
                if !g.get(v) && !seen.get(v) {
                    out.push(v);
                }
            }
        }
    }
    Ok(out)
}

/// Runs `voxkit check`.
pub fn run(args: CheckArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let limit = MemoryLimit::new(args.max_memory.saturating_mul(1 << 20));
    let conn = if args.tunnels == "6" {
        Connectivity::Six
    } else {
        Connectivity::TwentySix
    };
    let (grid, frame, warnings) = read_voxels_warned(&args.grid, limit)?;
    super::print_warnings(&args.grid, &warnings);
    let occ = grid.to_bit_grid(frame.dims, limit)?;
    let mut closed = occ.clone();
    for _ in 0..args.close {
        closed = dilate26(&closed, limit)?;
    }
    let inside = enclosed_empty(&closed, limit)?;
    drop(closed);
    limit.check("inside seeds", inside.len() as u128, 12)?;
    let verdict = closed_surface_tunnels(&occ, conn, &inside)?;
    let j = serde_json::json!({
        "grid": args.grid.display().to_string(),
        "dims": frame.dims,
        "voxels": grid.count(),
        "tiles": grid.tile_count(),
        "tunnels": args.tunnels.parse::<u32>().unwrap_or(0),
        "close": args.close,
        "enclosed": inside.len(),
        "tunnel": verdict.tunnel,
        "first_inside_reached": verdict.first_inside_reached.map(|v| v.to_array()),
        "outside_empty": verdict.outside_empty,
        "inside_empty": verdict.inside_empty,
        "warnings": warnings,
    });
    writeln!(out, "{j}")?;
    if verdict.tunnel {
        let v = verdict
            .first_inside_reached
            .map(|v| v.to_array())
            .unwrap_or_default();
        return Err(CliError {
            message: format!(
                "{}-tunnel: the outside reaches inside voxel {v:?}",
                args.tunnels
            ),
            code: 1,
        });
    }
    Ok(())
}
