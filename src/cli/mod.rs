//! The command line: argument parsing (clap) and one thin module per subcommand. Each
//! subcommand turns its arguments into library calls and prints the result; errors are
//! reported with their whole cause chain and a non-zero exit status.

mod export;
mod flow;
mod generate;
mod inspect;
mod labels;
mod render;
mod score_cache;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// vadscope: view, score and label video anomaly detection in driving scenarios.
#[derive(Debug, Parser)]
#[command(name = "vadscope", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Generate synthetic AnoVox-style driving scenarios with exact ground truth.
    Generate(generate::GenerateArgs),
    /// Validate a scenario or data set and print a summary.
    Inspect(inspect::InspectArgs),
    /// Compute dense optical flow (DIS) for frames without it; evaluate it against stored flow.
    Flow(flow::FlowArgs),
    /// Open, import, export or show a scenario's labels (crash-safe, undoable).
    Labels(labels::LabelsArgs),
    /// Render views of a scenario's frames (dashboard, frame, pred, flow, timeline, roc) to PNG.
    Render(render::RenderArgs),
    /// Write annotated frames and scores.csv (with provenance) of a scenario.
    Export(export::ExportArgs),
}

/// Parses the command line, runs the subcommand and maps its outcome to an exit status.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Generate(args) => generate::run(args),
        Command::Inspect(args) => inspect::run(args),
        Command::Flow(args) => flow::run(args),
        Command::Labels(args) => labels::run(args),
        Command::Render(args) => render::run(args),
        Command::Export(args) => export::run(args),
    };
    match outcome {
        Ok(code) => code,
        Err(error) => {
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
