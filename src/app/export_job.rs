//! The export job: on its own thread, it writes the chosen view of a frame range of the
//! current scenario as PNG files and/or an animated GIF, and `scores.csv`, through the same
//! library code as `vadscope render` and `vadscope export` ([`crate::export`]), reporting
//! progress over a channel; cancelling stops it between frames.

use std::ops::Range;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::Sender;

use crate::export::{
    ExportError, ExportProgress, FileNaming, FrameRenderer, FrameView, FramesExport, export_frames,
    write_scores_csv,
};
use crate::model::bundled_model;
use crate::render::{DashboardOptions, DrawSettings};
use crate::score::{CacheKey, FlowSource, ScoreCache};
use crate::sequence::Scenario;

use super::background::BackgroundThread;

/// What the analyst asks to export (the export dialog's choices).
#[derive(Debug, Clone, PartialEq)]
pub struct ExportChoice {
    /// Frame indices to write.
    pub frames: Range<usize>,
    /// The view written per frame.
    pub view: FrameView,
    /// One PNG per frame.
    pub png: bool,
    /// One animated GIF of the frames (`<view>.gif`).
    pub gif: bool,
    /// `scores.csv` of the whole scenario with its provenance header.
    pub scores_csv: bool,
    /// The folder to write into (created if missing).
    pub out: PathBuf,
}

/// Everything the job thread needs, owned (it opens the scenario and cache itself).
#[derive(Debug, Clone)]
pub struct ExportRequest {
    /// The scenario folder.
    pub scenario: PathBuf,
    /// The score cache to open.
    pub key: CacheKey,
    /// The checkpoint the scores came from (`None`: the bundled model), for provenance.
    pub model: Option<PathBuf>,
    /// The per-frame anomaly flags the scores are measured against.
    pub labels: Vec<bool>,
    /// Weights, threshold, filter and colormap, as the viewer shows them.
    pub settings: DrawSettings,
    /// View options, as the viewer shows them (overlays, opacity).
    pub options: DashboardOptions,
    /// Where flow is read from.
    pub flow: FlowSource,
    /// What to write.
    pub choice: ExportChoice,
}

/// What the export job reports.
#[derive(Debug)]
pub enum ExportEvent {
    /// Frames written so far.
    Progress(ExportProgress),
    /// The export ended: the files written, or why it stopped.
    Finished(Result<Vec<PathBuf>, String>),
}

/// A running (or finished) export.
#[derive(Debug)]
pub struct ExportJob {
    thread: BackgroundThread<ExportEvent>,
    out: PathBuf,
}

impl ExportJob {
    /// Starts writing `request`.
    pub fn start(request: ExportRequest) -> Self {
        let out = request.choice.out.clone();
        let thread = BackgroundThread::spawn("vadscope-export", move |sender, cancel| {
            let result = run(&request, sender, cancel).map_err(|e| e.to_string());
            let _ = sender.send(ExportEvent::Finished(result));
        });
        Self { thread, out }
    }

    /// The events that have arrived since the last call (never blocks).
    pub fn poll(&mut self) -> Vec<ExportEvent> {
        self.thread.poll()
    }

    /// Asks the job to stop before its next frame.
    pub fn cancel(&self) {
        self.thread.cancel();
    }

    /// The folder being written.
    pub fn out(&self) -> &std::path::Path {
        &self.out
    }
}

fn run(
    request: &ExportRequest,
    events: &Sender<ExportEvent>,
    cancel: &AtomicBool,
) -> Result<Vec<PathBuf>, ExportError> {
    let scenario = Scenario::open(&request.scenario)?;
    let cache =
        ScoreCache::lookup(&scenario, &request.key)?.ok_or_else(|| ExportError::NoScores {
            scenario: request.scenario.clone(),
        })?;
    let renderer = FrameRenderer::with_options(
        &scenario,
        &cache,
        &request.labels,
        request.settings,
        request.options.clone(),
        request.flow,
    );
    let choice = &request.choice;
    std::fs::create_dir_all(&choice.out).map_err(|e| ExportError::io(&choice.out, e))?;
    let mut files = Vec::new();
    if choice.scores_csv {
        let model = request
            .model
            .clone()
            .or_else(|| bundled_model().ok())
            .unwrap_or_default();
        let path = choice.out.join("scores.csv");
        write_scores_csv(
            &path,
            cache.table(),
            renderer.series(),
            &renderer.provenance(&model),
        )?;
        files.push(path);
    }
    if choice.png || choice.gif {
        let frames = crate::export::frames_in(&scenario, Some(&choice.frames))?;
        let export = FramesExport {
            out: choice.out.clone(),
            frames,
            views: vec![choice.view],
            size: None,
            png: choice.png,
            gif: choice.gif,
            naming: FileNaming::ByView,
        };
        let mut report = |p: ExportProgress| {
            let _ = events.send(ExportEvent::Progress(p));
        };
        files.extend(export_frames(&renderer, &export, &mut report, cancel)?.files);
    }
    Ok(files)
}
