//! `vadscope render`: writes the views of a scenario's frames as PNG files (and animated
//! GIFs), scoring the scenario first when it has no current score cache.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;

use anyhow::Context;
use clap::{Args, ValueEnum};
use image::RgbaImage;
use vadscope::export::{self, FileNaming, FrameRenderer, FrameView, FramesExport, export_frames};
use vadscope::render::{self, Colormap, TimelineOptions, ViewSettings};
use vadscope::score::{FlowSource, ScoreCache};
use vadscope::sequence::Scenario;
use vadscope::synth::parse_size;

use super::score_cache::{ScoreArgs, current_cache};

/// Options of `vadscope render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The scenario folder.
    scenario: PathBuf,
    /// Frames to render, as START..END (END excluded) or one index (default: all).
    #[arg(long, value_name = "START..END", value_parser = parse_frames)]
    frames: Option<Range<usize>>,
    /// Views to write (comma-separated).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "dashboard")]
    view: Vec<ViewArg>,
    /// Colormap of heatmaps, error maps and boxes: turbo, viridis, inferno or jet.
    #[arg(long, default_value = "turbo")]
    colormap: Colormap,
    /// Scale the heatmap per frame (labelled) instead of the model's reference range.
    #[arg(long)]
    auto_range: bool,
    /// Image size as WIDTHxHEIGHT (default: per view).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Folder to write the images into (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Also write one animated GIF per frame view (10 frames/s).
    #[arg(long)]
    gif: bool,
    #[command(flatten)]
    scores: ScoreArgs,
}

/// The views `vadscope render` can write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ViewArg {
    /// Every view of one frame in one image.
    Dashboard,
    /// The frame with heatmap, boxes, truth contour and caption.
    Frame,
    /// Actual vs predicted frame and patches.
    Pred,
    /// Flow vs reconstruction.
    Flow,
    /// The score timeline of the scenario (one image).
    Timeline,
    /// ROC chart and score histogram of the scenario (one image each).
    Roc,
}

impl ViewArg {
    /// The per-frame view this is, if it is one.
    fn frame_view(self) -> Option<FrameView> {
        match self {
            Self::Dashboard => Some(FrameView::Dashboard),
            Self::Frame => Some(FrameView::Frame),
            Self::Pred => Some(FrameView::Pred),
            Self::Flow => Some(FrameView::Flow),
            Self::Timeline | Self::Roc => None,
        }
    }
}

/// Parses `A..B` (B excluded) or a single frame index `A`.
pub fn parse_frames(text: &str) -> Result<Range<usize>, String> {
    let bad =
        |e: std::num::ParseIntError| format!("{text:?}: {e} (expected START..END or one index)");
    match text.split_once("..") {
        Some((a, b)) => {
            let (a, b) = (
                a.trim().parse::<usize>().map_err(bad)?,
                b.trim().parse::<usize>().map_err(bad)?,
            );
            if b <= a {
                return Err(format!("{text:?}: END must be greater than START"));
            }
            Ok(a..b)
        }
        None => {
            let a = text.trim().parse::<usize>().map_err(bad)?;
            Ok(a..a + 1)
        }
    }
}

/// The frames of `range` clipped to the scenario, with an error when nothing is left.
pub fn frames_in(
    scenario: &Scenario,
    range: Option<&Range<usize>>,
) -> anyhow::Result<Range<usize>> {
    Ok(export::frames_in(scenario, range)?)
}

/// Writes `image` as PNG at `path`.
pub fn save_png(image: &RgbaImage, path: &Path) -> anyhow::Result<()> {
    Ok(export::write_png(image, path)?)
}

/// The view settings of `args`.
pub fn settings_of(scores: &ScoreArgs, colormap: Colormap, auto_range: bool) -> ViewSettings {
    ViewSettings {
        weights: scores.fusion_weights(),
        threshold: scores.decision_threshold(),
        colormap,
        auto_range,
        median_kernel: scores.median_kernel,
    }
}

/// Opens the scenario and its current score cache (scoring first when needed).
pub fn open_scored(
    path: &Path,
    scores: &ScoreArgs,
) -> anyhow::Result<(Scenario, ScoreCache, PathBuf)> {
    let scenario =
        Scenario::open(path).with_context(|| format!("cannot open scenario {}", path.display()))?;
    let (cache, model) = current_cache(&scenario, scores)?;
    Ok((scenario, cache, model))
}

/// Runs `vadscope render`.
pub fn run(args: RenderArgs) -> anyhow::Result<ExitCode> {
    let (scenario, cache, _) = open_scored(&args.scenario, &args.scores)?;
    let frames = frames_in(&scenario, args.frames.as_ref())?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let settings = settings_of(&args.scores, args.colormap, args.auto_range);
    let renderer = FrameRenderer::new(
        &scenario,
        &cache,
        &scenario.frame_labels().flags,
        settings,
        FlowSource::default(),
    );
    let (series, settings) = (renderer.series(), renderer.settings());
    let windowed = args.frames.is_some();
    let evaluation = renderer.evaluation();
    let mut written = 0usize;

    for view in args
        .view
        .iter()
        .copied()
        .filter(|v| v.frame_view().is_none())
    {
        match view {
            ViewArg::Timeline => {
                let timeline_options = TimelineOptions {
                    window: windowed.then(|| frames.clone()),
                    ..TimelineOptions::default()
                };
                let input = series.timeline(&[], Some(settings.threshold), None);
                let image =
                    render::timeline(&input, &timeline_options, args.size.unwrap_or((1200, 360)));
                save_png(&image, &args.out.join("timeline.png"))?;
                written += 1;
            }
            _ => {
                let size = args.size.unwrap_or((520, 420));
                save_png(
                    &render::roc_chart(&evaluation, size),
                    &args.out.join("roc.png"),
                )?;
                save_png(
                    &render::histogram(&evaluation, size),
                    &args.out.join("histogram.png"),
                )?;
                written += 2;
            }
        }
    }

    let views: Vec<FrameView> = args.view.iter().filter_map(|v| v.frame_view()).collect();
    if !views.is_empty() {
        let request = FramesExport {
            out: args.out.clone(),
            frames: frames.clone(),
            views,
            size: args.size,
            png: true,
            gif: args.gif,
            naming: FileNaming::ByView,
        };
        let summary = export_frames(&renderer, &request, &mut |_| {}, &AtomicBool::new(false))?;
        written += summary.files.len();
    }
    println!("wrote {written} files to {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}
