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

/// Parses one segment from its six number fields `x0 y0 z0 x1 y1 z1`;
/// `place` (e.g. `line 3`) and `text` (the input as given) name it in
/// errors. Fewer or more fields, a field that is not a number, and
/// coordinates outside what [`Segment::from_f64`] accepts (NaN, ±inf,
/// beyond ±2^30) are errors with exit code 2.
///
/// ```
/// use voxkit::cli::line::parse_segment;
/// assert!(parse_segment(&["0", "0", "0", "1", "2", "3.5"], "line 1", "").is_ok());
/// assert_eq!(parse_segment(&["0", "0", "0", "1", "2"], "line 1", "").unwrap_err().code, 2);
/// assert!(parse_segment(&["0", "0", "0", "1", "2", "inf"], "line 1", "").is_err());
/// ```
pub fn parse_segment(fields: &[&str], place: &str, text: &str) -> Result<Segment, CliError> {
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

/// Parses stdin line `number` (1-based, for errors): a segment, or `None`
/// for a blank line.
///
/// ```
/// use voxkit::cli::line::parse_line;
/// assert!(parse_line("  \t ", 1).unwrap().is_none());
/// assert!(parse_line("0 0 0  1 1 1", 2).unwrap().is_some());
/// assert!(parse_line("0 0 0 1 1", 3).unwrap_err().message.starts_with("line 3"));
/// ```
pub fn parse_line(line: &str, number: usize) -> Result<Option<Segment>, CliError> {
    let fields: Vec<&str> = line.split_whitespace().collect();
    if fields.is_empty() {
        return Ok(None);
    }
    parse_segment(&fields, &format!("line {number}"), line.trim()).map(Some)
}

/// The voxels of `seg` drawn by `algo` (`flag_box`: see
/// [`LineArgs::flag_box`], checked to hold 6 numbers by the caller), as an
/// iterator: a segment may have up to ~2^31 voxels, so callers stream them
/// rather than collect them.
pub fn voxels<'a>(
    algo: LineAlgo,
    flag_box: Option<&'a [i32]>,
    seg: &Segment,
) -> Result<Box<dyn Iterator<Item = IVec3> + 'a>, CliError> {
    Ok(match algo {
        LineAlgo::TwentySix => Box::new(Line26::new(seg)),
        LineAlgo::Eighteen => Box::new(Line18::new(seg)),
        LineAlgo::Tripod => Box::new(Tripod6::new(seg)),
        LineAlgo::Adaptive => Box::new(AdaptiveRay::new(seg, move |v: IVec3| match flag_box {
            Some(b) => {
                let (lo, hi) = (IVec3::new(b[0], b[1], b[2]), IVec3::new(b[3], b[4], b[5]));
                v.cmpge(lo).all() && v.cmple(hi).all()
            }
            None => false,
        })),
        LineAlgo::Aw => {
            // Amanatides–Woo runs in f64 on the segment's (fixed-point) endpoints.
            let p = |q: crate::fixed::FixedPoint| {
                glam::DVec3::new(
                    crate::fixed::to_f64(q[0]),
                    crate::fixed::to_f64(q[1]),
                    crate::fixed::to_f64(q[2]),
                )
            };
            Box::new(crate::line::amanatides_woo::aw_line(
                p(seg.a()),
                p(seg.b()),
            )?)
        }
    })
}

/// Writes one JSON array of the voxels, streamed: a segment of 10^9 voxels
/// (`voxkit line 0 0 0 1e9 1e9 1e9`) prints in constant memory instead of
/// collecting gigabytes first.
fn write_line(out: &mut dyn Write, vs: impl Iterator<Item = IVec3>) -> Result<(), CliError> {
    out.write_all(b"[")?;
    for (i, v) in vs.enumerate() {
        if i > 0 {
            out.write_all(b",")?;
        }
        write!(out, "[{},{},{}]", v.x, v.y, v.z)?;
    }
    out.write_all(b"]\n")?;
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
            write_line(out, voxels(args.algo, args.flag_box.as_deref(), &seg)?)?;
        }
        return Ok(());
    }
    let stdin = std::io::stdin();
    for (i, line) in stdin.lock().lines().enumerate() {
        let Some(seg) = parse_line(&line?, i + 1)? else {
            continue;
        };
        write_line(out, voxels(args.algo, args.flag_box.as_deref(), &seg)?)?;
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
