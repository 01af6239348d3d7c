//! `voxkit report`: runs every measurement and writes one Markdown report
//! with SVG plots, speed beside error (see [`crate::report::document`]).

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use super::CliError;
use crate::report::document::{ReportSettings, Tier, write_report};

/// Arguments of `voxkit report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Small sizes and few repetitions: under a minute on two cores.
    #[arg(long)]
    pub quick: bool,
    /// The Markdown report; its plots go to the directory named after it
    /// (docs/report.md → docs/report/). Both are overwritten.
    #[arg(short = 'o', long, default_value = "docs/report.md")]
    pub output: PathBuf,
    /// No progress bar.
    #[arg(short = 'q', long)]
    pub quiet: bool,
}

/// Runs `voxkit report`.
pub fn run(args: ReportArgs, out: &mut dyn Write) -> Result<(), CliError> {
    // Refuse a bad -o before minutes of measuring.
    crate::report::document::prepare_output(&args.output)?;
    let settings = ReportSettings::new(if args.quick { Tier::Quick } else { Tier::Full });
    let meshes = vec![
        (
            "stanford-bunny.obj".to_string(),
            crate::mesh::bundled::bunny()?,
        ),
        ("spot.obj".to_string(), crate::mesh::bundled::spot()?),
    ];
    let bar = (!args.quiet && std::io::stderr().is_terminal()).then(|| {
        let b = indicatif::ProgressBar::new(settings.step_count(meshes.len()));
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {elapsed_precise} [{bar:30}] {pos}/{len} {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b.enable_steady_tick(std::time::Duration::from_millis(120));
        b
    });
    let mut started = false;
    let mut step = |what: &str| {
        if let Some(b) = &bar {
            if started {
                b.inc(1);
            }
            b.set_message(what.to_string());
        }
        started = true;
    };
    let repo = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    let outcome = write_report(&settings, &meshes, &args.output, &repo, &mut step);
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let outcome = outcome?;
    writeln!(
        out,
        "Wrote {} and {} plots in {} ({:.1} s).",
        outcome.markdown.display(),
        outcome.plots.len(),
        crate::report::document::PlotDir::for_report(&outcome.markdown)
            .dir
            .display(),
        outcome.seconds
    )?;
    Ok(())
}
