//! The `voxkit` command line: clap subcommands, and the one place where errors
//! become exit codes.
//!
//! Exit codes: 0 success; 1 a check ran and found a problem; 2 bad input
//! (unparsable arguments, malformed lines or files, limits exceeded; for
//! `voxelize` in batch mode: any mesh failed, the others having been done).

use std::io::Write;

use clap::{Parser, Subcommand};

mod batch;
mod check;
mod demo;
pub mod line;
mod measure;
pub(crate) mod render;
mod report;
mod tiles;
mod triangle;
mod voxelize;

pub use check::{CheckArgs, dilate26, enclosed_empty};
pub use demo::DemoArgs;
pub use line::LineArgs;
pub use measure::MeasureArgs;
pub use render::RenderArgs;
pub use report::ReportArgs;
pub use triangle::TriangleArgs;
pub use voxelize::{FormatArg, ModeArg, VoxelizeArgs};

/// Discrete 3D lines, voxelization and discrete ray casting.
#[derive(Debug, Parser)]
#[command(name = "voxkit", version, about)]
pub struct Cli {
    /// The subcommand.
    #[command(subcommand)]
    pub command: Command,
}

/// voxkit's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// The toolkit on a bundled mesh: draw every kind of line, voxelize the mesh in
    /// every mode and render it with every ray kind (files in out/); print speed
    /// against error.
    Demo(DemoArgs),
    /// Voxelize 3D segments (`x0 y0 z0 x1 y1 z1`, grid space) and print one JSON
    /// array of `[x,y,z]` voxels per segment.
    Line(LineArgs),
    /// Kahan–Kelsen indexing of the lattice points of a triangle.
    Triangle(TriangleArgs),
    /// Voxelize a mesh (OBJ / glTF / PLY / STL / OFF) into a voxel file, or many
    /// (directories, glob patterns) into a folder.
    Voxelize(VoxelizeArgs),
    /// Check a voxel file's surface for N-tunnels (exit 1 if one exists).
    Check(CheckArgs),
    /// Measure any tool's voxels against the exact conservative set of a mesh.
    Measure(MeasureArgs),
    /// Render a voxel file, a mesh or a scalar volume with discrete rays (PNG, EXR, GIF).
    Render(RenderArgs),
    /// Run every measurement and write one Markdown report with SVG plots
    /// (speed beside error; `--quick` for the one-minute version).
    Report(ReportArgs),
}

/// A command-line failure: the message for stderr and the exit code.
#[derive(Debug)]
pub struct CliError {
    /// One line for stderr.
    pub message: String,
    /// Process exit code.
    pub code: i32,
}

impl CliError {
    /// Bad input: exit code 2.
    pub fn bad_input(message: impl Into<String>) -> Self {
        CliError {
            message: message.into(),
            code: 2,
        }
    }
}

impl From<crate::VoxkitError> for CliError {
    fn from(e: crate::VoxkitError) -> Self {
        CliError::bad_input(e.to_string())
    }
}

impl From<std::io::Error> for CliError {
    /// A closed stdout (`voxkit line ... | head`) is not a failure: the
    /// reader has what it wanted, so the command ends quietly with exit 0, as
    /// ripgrep does ([`CliError::is_quiet`]). Every other I/O error is bad
    /// input.
    fn from(e: std::io::Error) -> Self {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            return CliError {
                message: String::new(),
                code: 0,
            };
        }
        CliError::bad_input(format!("i/o error: {e}"))
    }
}

impl CliError {
    /// Whether this is the quiet end of a closed stdout (exit 0, nothing
    /// printed).
    pub fn is_quiet(&self) -> bool {
        self.code == 0 && self.message.is_empty()
    }
}

/// Prints a reader's warnings about `path` to stderr, one line each:
/// `warning: FILE: WHAT`. Every command that loads a mesh (or a grid whose
/// reader reports what it ignored) calls this once per file, and lists the
/// same strings under `warnings` in its `--json` output; see
/// [`crate::mesh::LoadSummary::warnings`].
pub fn print_warnings(path: &std::path::Path, warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
}

/// Runs a parsed command, writing its output to `out`.
pub fn run(cli: Cli, out: &mut dyn Write) -> Result<(), CliError> {
    match cli.command {
        Command::Demo(args) => demo::run(args, out),
        Command::Line(args) => line::run(args, out),
        Command::Triangle(args) => triangle::run(args, out),
        Command::Voxelize(args) => voxelize::run(args, out),
        Command::Check(args) => check::run(args, out),
        Command::Measure(args) => measure::run(args, out),
        Command::Render(args) => render::run(args, out),
        Command::Report(args) => report::run(args, out),
    }
}

/// The longest error line printed, in characters: a dependency's message
/// can quote a whole JSON document or header.
const MAX_ERROR_CHARS: usize = 600;

/// `message` as one line of at most [`MAX_ERROR_CHARS`] characters: line
/// breaks and other control characters become spaces (every reader's
/// message is meant to be one line already; this keeps the contract when a
/// dependency's text is not), and a longer message is cut with `…`.
fn one_line(message: &str) -> String {
    let mut out: String = message
        .trim_end()
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    if let Some((cut, _)) = out.char_indices().nth(MAX_ERROR_CHARS) {
        out.truncate(cut);
        out.push('…');
    }
    out
}

/// Entry point of the binary: parses `std::env::args`, runs, and returns the
/// process exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let result = run(cli, &mut out).and_then(|()| out.flush().map_err(CliError::from));
    match result {
        Ok(()) => 0,
        Err(e) if e.is_quiet() => 0,
        Err(e) => {
            let _ = out.flush();
            eprintln!("voxkit: {}", one_line(&e.message));
            e.code
        }
    }
}

#[cfg(test)]
mod one_line_tests {
    use super::*;

    #[test]
    fn messages_print_on_one_bounded_line() {
        assert_eq!(
            one_line("a.ply: line 3:\n  bad\r\n"),
            "a.ply: line 3:   bad"
        );
        assert_eq!(one_line("x  y"), "x  y");
        let long = one_line(&"é".repeat(2 * MAX_ERROR_CHARS));
        assert_eq!(long.chars().count(), MAX_ERROR_CHARS + 1);
        assert!(long.ends_with('…'));
    }
}
