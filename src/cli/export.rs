//! `vadscope export`: writes every frame annotated (frame view: heatmap, boxes, truth
//! contour, caption) and `scores.csv` with a provenance header, scoring first when the
//! scenario has no current score cache; with `--labels`, the analyst's labels in standard
//! formats as well (or only them, with `--labels-only`, which needs no scoring).

use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use vadscope::annotate::{LabelFormat, export_labels};
use vadscope::render::{self, FrameScene, Provenance, ScoreSeries, scores_csv};
use vadscope::score::PixelReferenceMode;
use vadscope::sequence::Scenario;

use super::labels::{open_editor, parse_format};
use super::scenario_views::{ScenarioViewArgs, save_png};

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
    let settings = target.settings();
    let table = cache.table();
    let series = ScoreSeries::compute(
        table,
        &scenario.frame_labels().flags,
        &settings.weights,
        settings.median_kernel,
    );
    let out = target.create_out("")?;
    let provenance = Provenance {
        version: env!("CARGO_PKG_VERSION").to_string(),
        scenario: scenario.name().to_string(),
        model: model.display().to_string(),
        model_hash: table.meta.key.model.0,
        boxes: table.meta.key.boxes.clone(),
        flow: table.meta.key.flow.clone(),
        weights: settings.weights,
        median_kernel: settings.median_kernel,
        threshold: settings.threshold,
    };
    let frames = if args.no_frames {
        None
    } else {
        Some(target.frames_in(&scenario)?)
    };
    let csv_path = out.join("scores.csv");
    std::fs::write(&csv_path, scores_csv(table, &series, &provenance))
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let mut written = 1;
    if let Some(frames) = frames {
        let dir = target.create_out("frames")?;
        let options = settings.options(table).frame;
        let name = scenario.name().to_string();
        for index in frames {
            let scene = FrameScene::load(
                &scenario,
                &cache,
                index,
                &settings.weights,
                PixelReferenceMode::Training,
                None,
            )?;
            let objects = scene.scene_objects();
            let caption = scene.caption(&name, &series, &settings);
            let input = scene.frame_input(&objects, Some(&caption));
            let size = target
                .size
                .unwrap_or_else(|| render::natural_size(scene.frame.dimensions(), &options));
            save_png(
                &render::frame_view(&input, &options, size),
                &dir.join(format!("frame_{index:05}.png")),
            )?;
            written += 1;
        }
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
