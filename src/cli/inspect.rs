//! `vadscope inspect`: validates a scenario (or every scenario of a data set) and prints a
//! summary, as text or JSON.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use vadscope::sequence::inspect;

/// Options of `vadscope inspect`.
#[derive(Debug, Args)]
pub struct InspectArgs {
    /// A scenario folder or a data-set root holding `Scenario_*` folders.
    path: PathBuf,
    /// Print the report as JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// Runs `vadscope inspect`. The exit status is non-zero when a scenario cannot be opened
/// (no readable RGB frame), after the full report has been printed.
pub fn run(args: InspectArgs) -> anyhow::Result<ExitCode> {
    let report = inspect(&args.path)?;
    if args.json {
        println!("{}", report.to_json());
    } else {
        print!("{report}");
    }
    Ok(
        if report.failed.is_empty() && !report.scenarios.is_empty() {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        },
    )
}
