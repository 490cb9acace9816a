//! `vadscope render`: writes the views of a scenario's frames as PNG files (and animated
//! GIFs), scoring the scenario first when it has no current score cache.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, ValueEnum};
use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbaImage};
use vadscope::render::{
    self, DashboardInput, FlowViewInput, FrameScene, PredViewInput, ScoreLabels, ScoreSeries,
    TimelineOptions,
};
use vadscope::score::{FlowProvider, FlowSource, PixelReferenceMode};

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
    fn name(self) -> &'static str {
        match self {
            Self::Dashboard => "dashboard",
            Self::Frame => "frame",
            Self::Pred => "pred",
            Self::Flow => "flow",
            Self::Timeline => "timeline",
            Self::Roc => "roc",
        }
    }

    fn per_frame(self) -> bool {
        matches!(
            self,
            Self::Dashboard | Self::Frame | Self::Pred | Self::Flow
        )
    }
}

/// Runs `vadscope render`.
pub fn run(args: RenderArgs) -> anyhow::Result<ExitCode> {
    let target = &args.target;
    let (scenario, cache, _) = target.open_scored()?;
    let frames = target.frames_in(&scenario)?;
    let out = target.create_out("")?;
    let settings = target.settings();
    let table = cache.table();
    let series = ScoreSeries::compute(
        table,
        &scenario.frame_labels().flags,
        &settings.weights,
        settings.median_kernel,
    );
    let options = settings.options(table);
    let windowed = target.frames.is_some();
    let evaluation = ScoreLabels {
        scores: &series.filtered[series.skip..],
        labels: &series.truth[series.skip..],
        threshold: Some(settings.threshold),
    };
    let mut written = 0usize;

    for view in args.view.iter().copied().filter(|v| !v.per_frame()) {
        match view {
            ViewArg::Timeline => {
                let timeline_options = TimelineOptions {
                    window: windowed.then(|| frames.clone()),
                    ..TimelineOptions::default()
                };
                let input = series.timeline(&[], Some(settings.threshold), None);
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

    let per_frame: Vec<ViewArg> = args
        .view
        .iter()
        .copied()
        .filter(|v| v.per_frame())
        .collect();
    if !per_frame.is_empty() {
        let needs_flow = per_frame
            .iter()
            .any(|v| matches!(v, ViewArg::Dashboard | ViewArg::Flow));
        let mut flows = FlowProvider::new(&scenario, FlowSource::default());
        let mut animations: Vec<Vec<RgbaImage>> = vec![Vec::new(); per_frame.len()];
        let name = scenario.name().to_string();
        for index in frames.clone() {
            let scene = FrameScene::load(
                &scenario,
                &cache,
                index,
                &settings.weights,
                PixelReferenceMode::Training,
                needs_flow.then_some(&mut flows),
            )?;
            let objects = scene.scene_objects();
            let caption = scene.caption(&name, &series, &settings);
            let frame_input = scene.frame_input(&objects, Some(&caption));
            let dims = scene.frame.dimensions();
            for (k, view) in per_frame.iter().enumerate() {
                let image = match view {
                    ViewArg::Frame => {
                        let size = target
                            .size
                            .unwrap_or_else(|| render::natural_size(dims, &options.frame));
                        render::frame_view(&frame_input, &options.frame, size)
                    }
                    ViewArg::Pred => {
                        let input = PredViewInput {
                            frame: &scene.frame,
                            objects: &objects,
                        };
                        render::pred_view(
                            &input,
                            &options.pred,
                            target.size.unwrap_or((2 * dims.0, 2 * dims.1)),
                        )
                    }
                    ViewArg::Flow => {
                        let input = FlowViewInput {
                            frame: &scene.frame,
                            flow: scene.flow.as_deref(),
                            objects: &objects,
                        };
                        render::flow_view(
                            &input,
                            &options.flow,
                            target.size.unwrap_or((3 * dims.0, 2 * dims.1)),
                        )
                    }
                    _ => {
                        let input = DashboardInput {
                            frame: frame_input,
                            flow: scene.flow.as_deref(),
                            timeline: series.timeline(&[], Some(settings.threshold), Some(index)),
                            evaluation: Some(evaluation),
                        };
                        render::dashboard(&input, &options, target.size.unwrap_or((1600, 1000)))
                    }
                };
                save_png(&image, &out.join(format!("{}_{index:05}.png", view.name())))?;
                written += 1;
                if args.gif {
                    animations[k].push(image);
                }
            }
        }
        if args.gif {
            for (view, images) in per_frame.iter().zip(animations) {
                let path = out.join(format!("{}.gif", view.name()));
                write_gif(&images, &path)?;
                written += 1;
            }
        }
    }
    println!("wrote {written} files to {}", out.display());
    Ok(ExitCode::SUCCESS)
}

/// Writes `images` as an endlessly looping GIF at 10 frames/s.
fn write_gif(images: &[RgbaImage], path: &Path) -> anyhow::Result<()> {
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut encoder = GifEncoder::new_with_speed(BufWriter::new(file), 10);
    encoder
        .set_repeat(Repeat::Infinite)
        .with_context(|| format!("cannot write {}", path.display()))?;
    for image in images {
        let frame = Frame::from_parts(image.clone(), 0, 0, Delay::from_numer_denom_ms(100, 1));
        encoder
            .encode_frame(frame)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}
