//! Per-frame views of a scenario as files: [`FrameRenderer`] draws the views of one frame
//! with `render` from the scenario and its score cache; [`export_frames`] writes them for a
//! frame range as PNG files and/or one animated GIF per view, reporting progress and
//! stopping between frames when cancelled.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use image::RgbaImage;

use crate::atomic_file::remove_stale_temporaries;
use crate::render::{
    DashboardInput, DashboardOptions, DrawSettings, FrameScene, FrameView, Provenance, ScoreLabels,
    TimelineInput, draw_frame_view,
};
use crate::score::{FlowProvider, FlowSource, PixelReferenceMode, ScoreCache, ScoreSeries};
use crate::sequence::Scenario;

use super::ExportError;
use super::files::{GifWriter, write_png};

/// Draws the views of a scenario's frames: the scenario, its score cache, the fused score
/// series and the view settings and options, as `vadscope render` and the viewer use them.
pub struct FrameRenderer<'a> {
    scenario: &'a Scenario,
    cache: &'a ScoreCache,
    series: ScoreSeries,
    settings: DrawSettings,
    options: DashboardOptions,
    flow: FlowSource,
}

impl<'a> FrameRenderer<'a> {
    /// A renderer fusing `cache` with `settings` against the per-frame anomaly flags
    /// `labels` (the ground truth, or the analyst's labels), drawing with `settings`'
    /// options ([`DrawSettings::options`]); flow is read from `flow`.
    pub fn new(
        scenario: &'a Scenario,
        cache: &'a ScoreCache,
        labels: &[bool],
        settings: DrawSettings,
        flow: FlowSource,
    ) -> Self {
        let options = settings.options(cache.table());
        Self::with_options(scenario, cache, labels, settings, options, flow)
    }

    /// The same with view options of the caller's (the viewer's overlays and opacity).
    pub fn with_options(
        scenario: &'a Scenario,
        cache: &'a ScoreCache,
        labels: &[bool],
        settings: DrawSettings,
        options: DashboardOptions,
        flow: FlowSource,
    ) -> Self {
        let series = ScoreSeries::compute(
            cache.table(),
            labels,
            &settings.fusion.weights,
            settings.fusion.median_kernel,
        );
        Self {
            scenario,
            cache,
            series,
            settings,
            options,
            flow,
        }
    }

    /// The fused score series.
    pub fn series(&self) -> &ScoreSeries {
        &self.series
    }

    /// The view settings.
    pub fn settings(&self) -> &DrawSettings {
        &self.settings
    }

    /// The view options.
    pub fn options(&self) -> &DashboardOptions {
        &self.options
    }

    /// The scenario.
    pub fn scenario(&self) -> &Scenario {
        self.scenario
    }

    /// The score cache.
    pub fn cache(&self) -> &ScoreCache {
        self.cache
    }

    /// Where the scores came from, for the header of `scores.csv`: this vadscope, the
    /// scenario, the checkpoint `model` the cache was scored with, the box and flow
    /// sources, the weights, filter and threshold.
    pub fn provenance(&self, model: &Path) -> Provenance {
        let key = &self.cache.table().meta.key;
        Provenance {
            version: env!("CARGO_PKG_VERSION").to_string(),
            scenario: self.scenario.name().to_string(),
            model: model.display().to_string(),
            model_hash: key.model.0,
            boxes: key.boxes.clone(),
            flow: key.flow.clone(),
            weights: self.settings.fusion.weights,
            median_kernel: self.settings.fusion.median_kernel,
            threshold: self.settings.threshold,
        }
    }

    /// The evaluation frames (after the ones the model cannot score) at the threshold.
    pub fn evaluation(&self) -> ScoreLabels<'_> {
        let skip = self.series.skip.min(self.series.len());
        ScoreLabels {
            scores: &self.series.filtered[skip..],
            labels: &self.series.truth[skip..],
            threshold: Some(self.settings.threshold),
        }
    }

    /// A flow reader for [`Self::draw`].
    pub fn flows(&self) -> FlowProvider<'a> {
        FlowProvider::new(self.scenario, self.flow)
    }

    /// Draws `views` of frame `index`, each at `size` or its default size; `flows` is
    /// needed for views that show flow ([`FrameView::needs_flow`]).
    pub fn draw(
        &self,
        index: usize,
        views: &[FrameView],
        size: Option<(u32, u32)>,
        flows: Option<&mut FlowProvider<'_>>,
    ) -> Result<Vec<RgbaImage>, ExportError> {
        let flows = flows.filter(|_| views.iter().any(|v| v.needs_flow()));
        let scene = FrameScene::load(
            self.scenario,
            self.cache,
            index,
            &self.settings.fusion.weights,
            PixelReferenceMode::Training,
            flows,
        )?;
        let objects = scene.scene_objects();
        let caption = scene.caption(self.scenario.name(), &self.series, &self.settings);
        let input = DashboardInput {
            frame: scene.frame_input(&objects, Some(&caption)),
            flow: scene.flow.as_deref(),
            timeline: TimelineInput::of_series(
                &self.series,
                &[],
                Some(self.settings.threshold),
                Some(index),
            ),
            evaluation: Some(self.evaluation()),
        };
        let dims = scene.frame.dimensions();
        Ok(views
            .iter()
            .map(|&view| {
                let size = size.unwrap_or_else(|| view.default_size(dims, &self.options));
                draw_frame_view(view, &input, &self.options, size)
            })
            .collect())
    }
}

/// Where the PNG files of an export go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileNaming {
    /// `<out>/<view>_<index>.png` (`vadscope render`).
    ByView,
    /// `<out>/frames/<view>_<index>.png` (`vadscope export`).
    FramesFolder,
}

/// What [`export_frames`] writes.
#[derive(Debug, Clone, PartialEq)]
pub struct FramesExport {
    /// The folder to write into (created if missing).
    pub out: PathBuf,
    /// Frame indices to write.
    pub frames: Range<usize>,
    /// The views, each written per frame.
    pub views: Vec<FrameView>,
    /// Image size; `None` = each view's default size.
    pub size: Option<(u32, u32)>,
    /// Write one PNG per view and frame.
    pub png: bool,
    /// Write one animated GIF per view (`<out>/<view>.gif`).
    pub gif: bool,
    /// Where the PNG files go.
    pub naming: FileNaming,
}

/// How far an export has come.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExportProgress {
    /// Frames written.
    pub frames_done: usize,
    /// Frames to write.
    pub frames_total: usize,
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ExportSummary {
    /// Every file written, in order.
    pub files: Vec<PathBuf>,
}

/// Writes the views of `request.frames` as PNG files and/or GIFs, calling `progress` after
/// each frame and stopping before the next one once `cancel` is set (the GIFs written so
/// far are complete files with the frames up to there).
pub fn export_frames(
    renderer: &FrameRenderer<'_>,
    request: &FramesExport,
    progress: &mut dyn FnMut(ExportProgress),
    cancel: &AtomicBool,
) -> Result<ExportSummary, ExportError> {
    let png_dir = match request.naming {
        FileNaming::ByView => request.out.clone(),
        FileNaming::FramesFolder => request.out.join("frames"),
    };
    for dir in [&request.out, &png_dir] {
        std::fs::create_dir_all(dir).map_err(|e| ExportError::io(dir, e))?;
        // What an export killed mid-file left behind.
        remove_stale_temporaries(dir);
    }
    let mut summary = ExportSummary::default();
    let mut gifs = Vec::new();
    if request.gif {
        for view in &request.views {
            gifs.push(GifWriter::create(
                &request.out.join(format!("{}.gif", view.name())),
            )?);
        }
    }
    let mut flows = renderer.flows();
    let total = request.frames.len();
    let mut cancelled = false;
    for (done, index) in request.frames.clone().enumerate() {
        if cancel.load(Ordering::Relaxed) {
            cancelled = true;
            break;
        }
        let images = renderer.draw(index, &request.views, request.size, Some(&mut flows))?;
        for (k, (view, image)) in request.views.iter().zip(&images).enumerate() {
            if request.png {
                let path = png_path(&png_dir, *view, index);
                write_png(image, &path)?;
                summary.files.push(path);
            }
            if let Some(gif) = gifs.get_mut(k) {
                gif.push(image)?;
            }
        }
        progress(ExportProgress {
            frames_done: done + 1,
            frames_total: total,
        });
    }
    for gif in gifs {
        summary.files.push(gif.path().to_path_buf());
        gif.finish()?;
    }
    if cancelled {
        return Err(ExportError::Cancelled {
            written: summary.files.len(),
        });
    }
    Ok(summary)
}

fn png_path(dir: &Path, view: FrameView, index: usize) -> PathBuf {
    dir.join(format!("{}_{index:05}.png", view.name()))
}
