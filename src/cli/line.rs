//! `voxkit line`: voxelize segments and print their voxels as JSON.
//!
//! Segments are `x0 y0 z0 x1 y1 z1` in grid space (floats allowed), either as
//! positional numbers (6 per segment) or, when none are given, one per stdin
//! line (blank lines skipped). Output: one JSON array of `[x,y,z]` per
//! segment, one per line, in input order. A malformed segment is an error
//! naming its line (or argument position) and content, exit code 2; nothing
//! is printed for it or after it.

use std::io::{BufRead, Write};

use glam::IVec3;

use super::CliError;
use crate::line::{AdaptiveRay, Line18, Line26, Segment, Tripod6};

/// Which line algorithm `voxkit line` draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LineAlgo {
    /// 26-connected midpoint line (Fig. 4).
    #[value(name = "26")]
    TwentySix,
    /// 18-connected line.
    #[value(name = "18")]
    Eighteen,
    /// Tripod 6-connected line with containment (Fig. 6).
    Tripod,
    /// Amanatides–Woo traversal in floating point (Fig. 7).
    Aw,
    /// Adaptive 26↔6 ray. There is no grid on the command line: without
    /// `--flag-box` nothing is flagged and it is the 26-line.
    Adaptive,
}

/// Arguments of `voxkit line`.
#[derive(Debug, clap::Args)]
pub struct LineArgs {
    /// Line algorithm.
    #[arg(long, value_enum, default_value = "26")]
    pub algo: LineAlgo,

    /// For `--algo adaptive`: voxels in this inclusive box
    /// `X0,Y0,Z0,X1,Y1,Z1` carry a proximity flag.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub flag_box: Option<Vec<i32>>,

    /// Segments as `x0 y0 z0 x1 y1 z1 ...` (6 numbers each); read from stdin
    /// when absent.
    #[arg(allow_negative_numbers = true)]
    pub coords: Vec<String>,
}

fn parse_segment(fields: &[&str], place: &str, text: &str) -> Result<Segment, CliError> {
    if fields.len() != 6 {
        return Err(CliError::bad_input(format!(
            "{place}: expected 6 numbers `x0 y0 z0 x1 y1 z1`, got {}: {text:?}",
            fields.len()
        )));
    }
    let mut v = [0f64; 6];
    for (k, f) in fields.iter().enumerate() {
        v[k] = f.parse::<f64>().map_err(|_| {
            CliError::bad_input(format!("{place}: {f:?} is not a number in {text:?}"))
        })?;
    }
    Segment::from_f64([v[0], v[1], v[2]], [v[3], v[4], v[5]])
        .map_err(|e| CliError::bad_input(format!("{place}: {e} in {text:?}")))
}

fn voxels(args: &LineArgs, seg: &Segment) -> Result<Vec<IVec3>, CliError> {
    Ok(match args.algo {
        LineAlgo::TwentySix => Line26::new(seg).collect(),
        LineAlgo::Eighteen => Line18::new(seg).collect(),
        LineAlgo::Tripod => Tripod6::new(seg).collect(),
        LineAlgo::Adaptive => {
            let fb = args.flag_box.clone();
            AdaptiveRay::new(seg, move |v: IVec3| match &fb {
                Some(b) => {
                    let (lo, hi) = (IVec3::new(b[0], b[1], b[2]), IVec3::new(b[3], b[4], b[5]));
                    v.cmpge(lo).all() && v.cmple(hi).all()
                }
                None => false,
            })
            .collect()
        }
        LineAlgo::Aw => aw_voxels(seg)?,
    })
}

fn aw_voxels(seg: &Segment) -> Result<Vec<IVec3>, CliError> {
    // Amanatides–Woo runs in f64 on the segment's (fixed-point) endpoints.
    let p = |q: crate::fixed::FixedPoint| {
        glam::DVec3::new(
            crate::fixed::to_f64(q[0]),
            crate::fixed::to_f64(q[1]),
            crate::fixed::to_f64(q[2]),
        )
    };
    Ok(crate::line::amanatides_woo::aw_line(p(seg.a()), p(seg.b()))?.collect())
}

fn write_line(out: &mut dyn Write, vs: &[IVec3]) -> Result<(), CliError> {
    let mut s = String::with_capacity(vs.len() * 12 + 2);
    s.push('[');
    for (i, v) in vs.iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        s.push_str(&format!("[{},{},{}]", v.x, v.y, v.z));
    }
    s.push_str("]\n");
    out.write_all(s.as_bytes())?;
    Ok(())
}

/// Runs `voxkit line`.
pub fn run(args: LineArgs, out: &mut dyn Write) -> Result<(), CliError> {
    if args.flag_box.as_ref().is_some_and(|b| b.len() != 6) {
        return Err(CliError::bad_input(
            "--flag-box needs 6 integers X0,Y0,Z0,X1,Y1,Z1",
        ));
    }
    if args.flag_box.is_some() && args.algo != LineAlgo::Adaptive {
        return Err(CliError::bad_input(
            "--flag-box only applies to --algo adaptive",
        ));
    }
    if !args.coords.is_empty() {
        if !args.coords.len().is_multiple_of(6) {
            return Err(CliError::bad_input(format!(
                "expected 6 numbers per segment, got {} arguments",
                args.coords.len()
            )));
        }
        for (i, chunk) in args.coords.chunks(6).enumerate() {
            let fields: Vec<&str> = chunk.iter().map(String::as_str).collect();
            let text = chunk.join(" ");
            let seg = parse_segment(&fields, &format!("segment {}", i + 1), &text)?;
            write_line(out, &voxels(&args, &seg)?)?;
        }
        return Ok(());
    }
    let stdin = std::io::stdin();
    for (i, line) in stdin.lock().lines().enumerate() {
        let line = line?;
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.is_empty() {
            continue;
        }
        let seg = parse_segment(&fields, &format!("line {}", i + 1), line.trim())?;
        write_line(out, &voxels(&args, &seg)?)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn run_args(args: &[&str]) -> Result<String, CliError> {
        let cli = crate::cli::Cli::try_parse_from(args)
            .map_err(|e| CliError::bad_input(e.to_string()))?;
        let mut out = Vec::new();
        crate::cli::run(cli, &mut out)?;
        Ok(String::from_utf8(out).unwrap())
    }

    #[test]
    fn prints_one_json_array_per_segment() {
        let out = run_args(&[
            "voxkit", "line", "0", "0", "0", "1", "0", "1", "0", "0", "0", "-2", "0", "0",
        ])
        .unwrap();
        assert_eq!(out, "[[0,0,0],[1,0,1]]\n[[0,0,0],[-1,0,0],[-2,0,0]]\n");
        let out = run_args(&[
            "voxkit", "line", "--algo", "tripod", "0", "0", "0", "1", "1", "0",
        ])
        .unwrap();
        let v: Vec<[i32; 3]> = serde_json::from_str(out.trim()).unwrap();
        assert_eq!(v.len(), 3);
    }

    #[test]
    fn bad_segments_are_exit_code_2() {
        for args in [
            &["voxkit", "line", "0", "0", "0", "1", "0"][..],
            &["voxkit", "line", "0", "0", "0", "1", "0", "nan"][..],
            &["voxkit", "line", "0", "0", "0", "1", "0", "3e9"][..],
        ] {
            let e = run_args(args).unwrap_err();
            assert_eq!(e.code, 2, "{args:?}");
        }
    }
}
