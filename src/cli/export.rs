//! `vadscope export`: writes every frame annotated (frame view: heatmap, boxes, truth
//! contour, caption) and `scores.csv` with a provenance header, scoring first when the
//! scenario has no current score cache; with `--labels`, the analyst's labels in standard
//! formats as well (or only them, with `--labels-only`, which needs no scoring).

use std::process::ExitCode;
use std::sync::atomic::AtomicBool;

use clap::Args;
use vadscope::annotate::{LabelFormat, export_labels};
use vadscope::export::{
    FileNaming, FrameRenderer, FrameView, FramesExport, export_frames, write_scores_csv,
};
use vadscope::score::FlowSource;
use vadscope::sequence::Scenario;

use super::labels::{open_editor, parse_format};
use super::scenario_views::ScenarioViewArgs;

/// Options of `vadscope export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    // The scenario, the frames written as images (`scores.csv` always has every frame), how
    // they are drawn, the scores, and the folder that receives `frames/` and `scores.csv`.
    #[command(flatten)]
    target: ScenarioViewArgs,
    /// Write only `scores.csv`.
    #[arg(long)]
    no_frames: bool,
    /// Also write the analyst's labels (the ground truth with every edit made in the viewer
    /// or with `vadscope labels`) into `DIR/labels/`, in these formats: frame-labels,
    /// boxes-csv, mot, coco, yolo, intervals-csv (comma-separated).
    #[arg(long, value_name = "F,...", value_delimiter = ',', value_parser = parse_format)]
    labels: Vec<LabelFormat>,
    /// Write only the `--labels` files: no frames, no `scores.csv`, no scoring.
    #[arg(long, requires = "labels")]
    labels_only: bool,
}

/// Runs `vadscope export`.
pub fn run(args: ExportArgs) -> anyhow::Result<ExitCode> {
    let target = &args.target;
    if args.labels_only {
        let scenario = Scenario::open(&target.scenario)?;
        let written = write_labels(&scenario, &args.labels, target)?;
        println!("wrote {written} label files to {}", target.out.display());
        return Ok(ExitCode::SUCCESS);
    }
    let (scenario, cache, model) = target.open_scored()?;
    let renderer = FrameRenderer::new(
        &scenario,
        &cache,
        &scenario.frame_labels().flags,
        target.settings(),
        FlowSource::default(),
    );
    let out = target.create_out("")?;
    let frames = if args.no_frames {
        None
    } else {
        Some(target.frames_in(&scenario)?)
    };
    write_scores_csv(
        &out.join("scores.csv"),
        cache.table(),
        renderer.series(),
        &renderer.provenance(&model),
    )?;
    let mut written = 1;
    if let Some(frames) = frames {
        let request = FramesExport {
            out: out.clone(),
            frames,
            views: vec![FrameView::Frame],
            size: target.size,
            png: true,
            gif: false,
            naming: FileNaming::FramesFolder,
        };
        let summary = export_frames(&renderer, &request, &mut |_| {}, &AtomicBool::new(false))?;
        written += summary.files.len();
    }
    written += write_labels(&scenario, &args.labels, target)?;
    println!("wrote {written} files to {}", out.display());
    Ok(ExitCode::SUCCESS)
}

/// Writes the scenario's labels in each of `formats` into `labels/` below `--out` under the
/// format's default file name; returns the number of files written.
fn write_labels(
    scenario: &Scenario,
    formats: &[LabelFormat],
    target: &ScenarioViewArgs,
) -> anyhow::Result<usize> {
    if formats.is_empty() {
        return Ok(0);
    }
    let editor = open_editor(scenario)?;
    let dir = target.create_out("labels")?;
    let mut files = 0;
    for &format in formats {
        let path = dir.join(format.default_file_name());
        let summary = export_labels(scenario, editor.labels(), format, &path)?;
        println!("{format}: {} rows to {}", summary.records, path.display());
        files += summary.files;
    }
    Ok(files)
}
