//! `vadscope view` (and `vadscope` with no subcommand): opens the desktop viewer on a
//! scenario or data set, by default the bundled sample scenarios and the bundled model.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, ValueEnum};
use vadscope::app::{Layout, ScoringSetup, ViewerOptions, run};
use vadscope::score::{BoxSource, FlowSource, MotionParams, ScoreRequest};

/// Where the object boxes come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum Boxes {
    /// The scenario's ground-truth boxes.
    #[default]
    Gt,
    /// Detector-free motion boxes from frame differences.
    Motion,
}

/// Options of `vadscope view`.
#[derive(Debug, Default, Args)]
pub struct ViewArgs {
    /// A scenario folder or a data-set root holding `Scenario_*` folders (default: the
    /// bundled `sample_sequences/`).
    path: Option<PathBuf>,
    /// The checkpoint to score with (default: the bundled model).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Where the object boxes come from.
    #[arg(long, value_enum, default_value_t)]
    boxes: Boxes,
    /// The layout file (panels, settings, recent data sets); default: the user's config
    /// folder.
    #[arg(long)]
    layout: Option<PathBuf>,
}

/// The bundled sample scenarios: `sample_sequences/` in the working folder, else in the
/// source tree.
fn sample_sequences() -> PathBuf {
    let here = Path::new("sample_sequences");
    if here.is_dir() {
        here.to_path_buf()
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("sample_sequences")
    }
}

/// Runs the viewer until its window is closed.
pub fn run_view(args: ViewArgs) -> anyhow::Result<ExitCode> {
    let boxes = match args.boxes {
        Boxes::Gt => BoxSource::GroundTruth,
        Boxes::Motion => BoxSource::Motion(MotionParams::default()),
    };
    let options = ViewerOptions {
        path: Some(args.path.unwrap_or_else(sample_sequences)),
        setup: ScoringSetup {
            model: args.model,
            request: ScoreRequest::new(boxes, FlowSource::default()),
        },
        layout_file: args.layout.or_else(Layout::default_path),
    };
    run(options).context("the viewer stopped")?;
    Ok(ExitCode::SUCCESS)
}
