//! `voxkit demo` (TEMPORARY SCAFFOLD: replaced by its owner before landing).

use std::io::Write;

use super::CliError;

/// Arguments of `voxkit demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {}

/// Runs `voxkit demo`.
pub fn run(_args: DemoArgs, _out: &mut dyn Write) -> Result<(), CliError> {
    Err(CliError::bad_input("not built yet"))
}
