//! `vadscope export`: writes every frame annotated (frame view: heatmap, boxes, truth
//! contour, caption) and `scores.csv` with a provenance header, scoring first when the
//! scenario has no current score cache; with `--labels`, the analyst's labels in standard
//! formats as well (or only them, with `--labels-only`, which needs no scoring).

use std::ops::Range;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;

use anyhow::Context;
use clap::Args;
use vadscope::annotate::{LabelFormat, export_labels};
use vadscope::export::{
    FileNaming, FrameRenderer, FrameView, FramesExport, export_frames, write_scores_csv,
};
use vadscope::render::Colormap;
use vadscope::score::FlowSource;
use vadscope::sequence::Scenario;
use vadscope::synth::parse_size;

use super::labels::{open_editor, parse_format};
use super::render::{frames_in, open_scored, parse_frames, settings_of};
use super::score_cache::ScoreArgs;

/// Options of `vadscope export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The scenario folder.
    scenario: PathBuf,
    /// Folder to write `frames/` and `scores.csv` into (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Frames to write as images, START..END (END excluded) or one index (default: all);
    /// `scores.csv` always has every frame.
    #[arg(long, value_name = "START..END", value_parser = parse_frames)]
    frames: Option<Range<usize>>,
    /// Colormap of heatmaps and boxes: turbo, viridis, inferno or jet.
    #[arg(long, default_value = "turbo")]
    colormap: Colormap,
    /// Scale the heatmap per frame (labelled) instead of the model's reference range.
    #[arg(long)]
    auto_range: bool,
    /// Image size as WIDTHxHEIGHT (default: the frame 1:1 with caption and colour bar).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<(u32, u32)>,
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
    #[command(flatten)]
    scores: ScoreArgs,
}

/// Runs `vadscope export`.
pub fn run(args: ExportArgs) -> anyhow::Result<ExitCode> {
    if args.labels_only {
        let scenario = Scenario::open(&args.scenario)?;
        let written = write_labels(&scenario, &args.labels, &args.out)?;
        println!("wrote {written} label files to {}", args.out.display());
        return Ok(ExitCode::SUCCESS);
    }
    let (scenario, cache, model) = open_scored(&args.scenario, &args.scores)?;
    let settings = settings_of(&args.scores, args.colormap, args.auto_range);
    let renderer = FrameRenderer::new(
        &scenario,
        &cache,
        &scenario.frame_labels().flags,
        settings,
        FlowSource::default(),
    );
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let provenance = renderer.provenance(&model);
    let frames = if args.no_frames {
        None
    } else {
        Some(frames_in(&scenario, args.frames.as_ref())?)
    };
    write_scores_csv(
        &args.out.join("scores.csv"),
        cache.table(),
        renderer.series(),
        &provenance,
    )?;
    let mut written = 1;
    if let Some(frames) = frames {
        let request = FramesExport {
            out: args.out.clone(),
            frames,
            views: vec![FrameView::Frame],
            size: args.size,
            png: true,
            gif: false,
            naming: FileNaming::FramesFolder,
        };
        let summary = export_frames(&renderer, &request, &mut |_| {}, &AtomicBool::new(false))?;
        written += summary.files.len();
    }
    written += write_labels(&scenario, &args.labels, &args.out)?;
    println!("wrote {written} files to {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}

/// Writes the scenario's labels in each of `formats` into `out/labels/` under the format's
/// default file name; returns the number of files written.
fn write_labels(
    scenario: &Scenario,
    formats: &[LabelFormat],
    out: &std::path::Path,
) -> anyhow::Result<usize> {
    if formats.is_empty() {
        return Ok(0);
    }
    let editor = open_editor(scenario)?;
    let dir = out.join("labels");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut files = 0;
    for &format in formats {
        let path = dir.join(format.default_file_name());
        let summary = export_labels(scenario, editor.labels(), format, &path)?;
        println!("{format}: {} rows to {}", summary.records, path.display());
        files += summary.files;
    }
    Ok(files)
}
