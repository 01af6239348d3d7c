//! `voxkit line` (TEMPORARY SCAFFOLD: replaced by its owner before landing).

use std::io::Write;

use super::CliError;

/// Arguments of `voxkit line`.
#[derive(Debug, clap::Args)]
pub struct LineArgs {}

/// Runs `voxkit line`.
pub fn run(_args: LineArgs, _out: &mut dyn Write) -> Result<(), CliError> {
    Err(CliError::bad_input("not built yet"))
}
