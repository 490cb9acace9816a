//! The command line: argument parsing (clap) and one thin module per subcommand. Each
//! subcommand turns its arguments into library calls and prints the result; errors are
//! reported with their whole cause chain and a non-zero exit status.

mod eval;
mod export;
mod flow;
mod generate;
mod inspect;
mod labels;
mod render;
mod scenario_views;
mod score;
mod score_cache;
mod train;
mod view;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// vadscope: view, score and label video anomaly detection in driving scenarios.
///
/// With no subcommand, opens the viewer on the bundled sample scenarios.
#[derive(Debug, Parser)]
#[command(name = "vadscope", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Open the desktop viewer on a scenario or data set (the default command).
    View(view::ViewArgs),
    /// Generate synthetic AnoVox-style driving scenarios with exact ground truth.
    Generate(generate::GenerateArgs),
    /// Validate a scenario or data set and print a summary.
    Inspect(inspect::InspectArgs),
    /// Score scenarios with the model into their score caches (`.vadscope/scores/`).
    Score(score::ScoreArgs),
    /// Score what is not cached yet and print the paper's tables (Table 2, `--sweep`: 3).
    Eval(eval::EvalArgs),
    /// Compute dense optical flow (DIS) for frames without it; evaluate it against stored flow.
    Flow(flow::FlowArgs),
    /// Open, import, export or show a scenario's labels (crash-safe, undoable).
    Labels(labels::LabelsArgs),
    /// Render views of a scenario's frames (dashboard, frame, pred, flow, timeline, roc) to PNG.
    Render(render::RenderArgs),
    /// Write annotated frames and scores.csv (with provenance) of a scenario.
    Export(export::ExportArgs),
    /// Train HF²-VAD_AD (three stages) on normal driving scenarios.
    // Boxed: its many options would make every command as large as it.
    Train(Box<train::TrainArgs>),
}

/// Parses the command line, runs the subcommand and maps its outcome to an exit status.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        None => view::run_view(view::ViewArgs::default()),
        Some(Command::View(args)) => view::run_view(args),
        Some(Command::Generate(args)) => generate::run(args),
        Some(Command::Inspect(args)) => inspect::run(args),
        Some(Command::Flow(args)) => flow::run(args),
        Some(Command::Train(args)) => train::run(*args),
        Some(Command::Score(args)) => score::run(args),
        Some(Command::Eval(args)) => eval::run(args),
        Some(Command::Render(args)) => render::run(args),
        Some(Command::Export(args)) => export::run(args),
        Some(Command::Labels(args)) => labels::run(args),
    };
    match outcome {
        Ok(code) => code,
        Err(error) => {
            eprintln!("error: {}", describe(&error));
            ExitCode::FAILURE
        }
    }
}

/// The error with its causes, each said once: a cause whose text the message so far already
/// holds (the library's messages often end with their source's) is not repeated.
fn describe(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let said = cause.to_string();
        if text.contains(&said) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&said);
    }
    text
}
