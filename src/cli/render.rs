//! `vadscope render`: writes the views of a scenario's frames as PNG files (and animated
//! GIFs), scoring the scenario first when it has no current score cache.

use std::process::ExitCode;
use std::sync::atomic::AtomicBool;

use clap::{Args, ValueEnum};
use vadscope::export::{FileNaming, FrameRenderer, FrameView, FramesExport, export_frames};
use vadscope::render::{self, TimelineInput, TimelineOptions};
use vadscope::score::FlowSource;

use super::scenario_views::{ScenarioViewArgs, save_png};

/// Options of `vadscope render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    // The scenario, the frames, how they are drawn, the scores and the output folder.
    #[command(flatten)]
    target: ScenarioViewArgs,
    /// Views to write (comma-separated).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "dashboard")]
    view: Vec<ViewArg>,
    /// Also write one animated GIF per frame view (10 frames/s).
    #[arg(long)]
    gif: bool,
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

/// Runs `vadscope render`.
pub fn run(args: RenderArgs) -> anyhow::Result<ExitCode> {
    let target = &args.target;
    let (scenario, cache, _) = target.open_scored()?;
    let frames = target.frames_in(&scenario)?;
    let out = target.create_out("")?;
    let renderer = FrameRenderer::new(
        &scenario,
        &cache,
        &scenario.frame_labels().flags,
        target.settings(),
        FlowSource::default(),
    );
    let (series, settings) = (renderer.series(), renderer.settings());
    let windowed = target.frames.is_some();
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
                let input = TimelineInput::of_series(series, &[], Some(settings.threshold), None);
                let image = render::timeline(
                    &input,
                    &timeline_options,
                    target.size.unwrap_or((1200, 360)),
                );
                save_png(&image, &out.join("timeline.png"))?;
                written += 1;
            }
            _ => {
                let size = target.size.unwrap_or((520, 420));
                save_png(&render::roc_chart(&evaluation, size), &out.join("roc.png"))?;
                save_png(
                    &render::histogram(&evaluation, size),
                    &out.join("histogram.png"),
                )?;
                written += 2;
            }
        }
    }

    let views: Vec<FrameView> = args.view.iter().filter_map(|v| v.frame_view()).collect();
    if !views.is_empty() {
        let request = FramesExport {
            out: out.clone(),
            frames,
            views,
            size: target.size,
            png: true,
            gif: args.gif,
            naming: FileNaming::ByView,
        };
        let summary = export_frames(&renderer, &request, &mut |_| {}, &AtomicBool::new(false))?;
        written += summary.files.len();
    }
    println!("wrote {written} files to {}", out.display());
    Ok(ExitCode::SUCCESS)
}
