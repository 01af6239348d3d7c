//! `voxkit triangle X0 Y0 X1 Y1 X2 Y2 [--index I | --all | --sample N [--seed S] | --locate X Y]`
//!
//! Kahan–Kelsen indexing of the lattice points of a closed lattice triangle
//! (vertex coordinates integers within ±2^30; collinear vertices give the
//! points of their segment). Prints one line of JSON:
//!
//! * no option: `{"count": k}`;
//! * `--index I`: `{"count": k, "points": [[x, y]]}` (the point with index `I`);
//! * `--all`: `{"count": k, "points": [...]}` in index order (at most
//!   [`MAX_LISTED`] points, otherwise bad input);
//! * `--sample N [--seed S]`: `N` uniform random points (with repetition),
//!   reproducible: the seed defaults to 0;
//! * `--locate X Y`: `{"count": k, "index": i}`, or `"index": null` outside.
//!
//! Bad input (non-integers, coordinates out of range, `I ≥ k`, too many
//! points) exits with code 2 and prints nothing on stdout.

use std::io::Write;

use rand::SeedableRng;
use rand::rngs::StdRng;

use super::CliError;
use crate::triangle::{LatticePoint, TriangleIndex};

/// Most points `--all` or `--sample` will print.
pub const MAX_LISTED: u64 = 10_000_000;

/// Arguments of `voxkit triangle`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct TriangleArgs {
    /// The vertices: X0 Y0 X1 Y1 X2 Y2 (integers within ±2^30).
    #[arg(num_args = 6, value_names = ["X0", "Y0", "X1", "Y1", "X2", "Y2"], required = true)]
    pub coords: Vec<i64>,
    /// Print the point with this index.
    #[arg(long, value_name = "I", group = "mode")]
    pub index: Option<u64>,
    /// Print every point in index order.
    #[arg(long, group = "mode")]
    pub all: bool,
    /// Print N uniformly random points.
    #[arg(long, value_name = "N", group = "mode")]
    pub sample: Option<u64>,
    /// Seed of `--sample` (default 0).
    #[arg(long, value_name = "S", requires = "sample")]
    pub seed: Option<u64>,
    /// Print the index of the point (X, Y), or null if it is outside.
    #[arg(long, num_args = 2, value_names = ["X", "Y"], group = "mode", allow_negative_numbers = true)]
    pub locate: Option<Vec<i64>>,
}

fn write_points(
    out: &mut dyn Write,
    count: u64,
    pts: impl Iterator<Item = LatticePoint>,
) -> std::io::Result<()> {
    write!(out, "{{\"count\":{count},\"points\":[")?;
    for (n, [x, y]) in pts.enumerate() {
        if n > 0 {
            out.write_all(b",")?;
        }
        write!(out, "[{x},{y}]")?;
    }
    out.write_all(b"]}\n")
}

/// Runs `voxkit triangle`.
pub fn run(args: TriangleArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let c = &args.coords;
    if c.len() != 6 {
        return Err(CliError::bad_input(
            "expected six integers X0 Y0 X1 Y1 X2 Y2",
        ));
    }
    let tri = TriangleIndex::new([[c[0], c[1]], [c[2], c[3]], [c[4], c[5]]])?;
    let k = tri.len();
    if let Some(i) = args.index {
        let p = tri.point(i).ok_or_else(|| {
            CliError::bad_input(format!(
                "index {i} out of range: the triangle has {k} points"
            ))
        })?;
        write_points(out, k, std::iter::once(p))?;
    } else if args.all {
        if k > MAX_LISTED {
            return Err(CliError::bad_input(format!(
                "--all would print {k} points (limit {MAX_LISTED}); use --index or --sample"
            )));
        }
        write_points(out, k, tri.iter())?;
    } else if let Some(n) = args.sample {
        if n > MAX_LISTED {
            return Err(CliError::bad_input(format!(
                "--sample {n} exceeds the limit of {MAX_LISTED} points"
            )));
        }
        let mut rng = StdRng::seed_from_u64(args.seed.unwrap_or(0));
        write_points(out, k, (0..n).map(|_| tri.sample(&mut rng)))?;
    } else if let Some(l) = &args.locate {
        match tri.index_of([l[0], l[1]]) {
            Some(i) => writeln!(out, "{{\"count\":{k},\"index\":{i}}}")?,
            None => writeln!(out, "{{\"count\":{k},\"index\":null}}")?,
        }
    } else {
        writeln!(out, "{{\"count\":{k}}}")?;
    }
    Ok(())
}
