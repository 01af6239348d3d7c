//! `voxkit demo`: the toolkit on an embedded default, printing speed against
//! error.

use std::io::Write;

use super::CliError;
use crate::report::{LineReportConfig, line_report};

/// Arguments of `voxkit demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Random segments timed per line algorithm.
    #[arg(long, default_value_t = 20_000)]
    pub segments: usize,
    /// Seed of the random segments.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
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
    Ok(())
}
