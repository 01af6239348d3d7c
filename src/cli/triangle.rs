//! `voxkit triangle` (TEMPORARY SCAFFOLD: replaced by its owner before landing).

use std::io::Write;

use super::CliError;

/// Arguments of `voxkit triangle`.
#[derive(Debug, clap::Args)]
pub struct TriangleArgs {}

/// Runs `voxkit triangle`.
pub fn run(_args: TriangleArgs, _out: &mut dyn Write) -> Result<(), CliError> {
    Err(CliError::bad_input("not built yet"))
}
