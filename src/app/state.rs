//! The viewer's core, GUI-free: the open data set, the current scenario and frame,
//! playback, the analyst's settings, fused scores and live metrics for the scenario and the
//! data set, ranked failure cases with their tags, the background scoring job and the log.
//! The egui layer only reads this state and sends it [`Action`]s and setting changes, so
//! everything here is testable without a display.

use std::path::{Path, PathBuf};

use crate::annotate::{Edge, IntervalId, Rect, TrackId};
use crate::eval::anomaly_events;
use crate::export::ExportProgress;
use crate::render::{DashboardOptions, ViewSettings as RenderSettings};
use crate::score::{FusionParams, ObjectMaps, ScoreProgress, reference_threshold};
use crate::sequence::FrameId;

use super::analysis::{DatasetMetrics, ScenarioAnalysis};
use super::dataset::{Dataset, ScoreStatus, Scores};
use super::error::AppError;
use super::export_job::{ExportChoice, ExportEvent, ExportJob, ExportRequest};
use super::failures::{
    FailureCase, FailureRow, FailureTags, TAGS_FILE, failures_csv, rank, scenario_failures,
    write_atomically,
};
use super::jobs::{JobEvent, ScoringJob, ScoringSetup};
use super::labeling::{Labeling, ScenarioLabels};
use super::playback::Playback;
use super::settings::{Overlay, Reference, ThresholdMode, ViewMode, ViewSettings};

/// Something the analyst asks for (by key, click or button).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// Start or stop playback.
    TogglePlay,
    /// Move by this many frames.
    Step(i64),
    /// Go to the first frame.
    First,
    /// Go to the last frame.
    Last,
    /// Go to the onset of the previous anomaly event.
    PreviousEvent,
    /// Go to the onset of the next anomaly event.
    NextEvent,
    /// Go to this frame.
    Seek(usize),
    /// Open this scenario of the data set.
    SelectScenario(usize),
    /// Move this many scenarios up or down the list.
    StepScenario(i64),
    /// Switch the main view.
    SetView(ViewMode),
    /// Turn an overlay on or off.
    ToggleOverlay(Overlay),
    /// Jump to this failure case (index into [`AppState::failures`]).
    JumpToFailure(usize),
    /// Jump to the next (+1) or previous (−1) failure case.
    StepFailure(i64),
    /// Select the object with this track id (or none).
    SelectObject(Option<u64>),
    /// Stop the scoring job.
    CancelScoring,
    /// Stop the export job.
    CancelExport,
    /// Show or hide the help overlay.
    ToggleHelp,
    /// Turn the labeling mode on or off (opens the current scenario's labels).
    ToggleLabeling,
    /// Labeling: mark the cursor as the start of a new interval.
    StartInterval,
    /// Labeling: end the marked interval at the cursor (adds it).
    EndInterval,
    /// Labeling: move the interval edge nearest to the cursor to the cursor.
    MoveNearestEdge,
    /// Labeling: tag the current range (mark to cursor, else the selected failure run in
    /// this scenario, else the cursor's frame) with the tag text.
    TagRange,
    /// Labeling: undo the last edit.
    Undo,
    /// Labeling: redo the last undone edit.
    Redo,
    /// Labeling: move an interval's edge to a frame (timeline drag).
    SetIntervalEdge {
        /// The interval.
        interval: IntervalId,
        /// Which edge.
        edge: Edge,
        /// Where to.
        frame: usize,
    },
    /// Labeling: add a box at the cursor's frame (drawn on the frame, frame pixels).
    AddBox(Rect),
    /// Labeling: move or resize a box at the cursor's frame (a keyframe there).
    SetBox {
        /// The box's track.
        track: TrackId,
        /// Its new rectangle.
        rect: Rect,
    },
    /// Labeling: select a box (or none).
    SelectBox(Option<TrackId>),
    /// Labeling: delete the selected box from the cursor's frame on.
    DeleteSelectedBox,
}

/// How serious a log entry is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogLevel {
    /// Progress and results.
    Info,
    /// Something could not be used, the rest goes on.
    Warning,
    /// Something failed.
    Error,
}

/// One message of the log panel.
#[derive(Debug, Clone, PartialEq)]
pub struct LogEntry {
    /// How serious.
    pub level: LogLevel,
    /// What happened, naming the file involved.
    pub message: String,
}

/// Log entries kept (older ones are dropped).
const LOG_CAPACITY: usize = 500;

/// Decoded-frame cache of the scenario on screen: about 200 frames of 768×512, so scrubbing
/// back and forth near the cursor decodes nothing twice.
pub const CURRENT_FRAME_CACHE: usize = 256 << 20;

/// Decoded-frame cache of every other scenario of the data set: enough for the failure
/// panel's thumbnails to be drawn without decoding on every repaint, small enough that a
/// data set of hundreds of scenarios stays within a few GiB at worst.
pub const BACKGROUND_FRAME_CACHE: usize = 8 << 20;

/// One object of the current frame as the inspector shows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectInfo {
    /// Position among the frame's objects (and its maps).
    pub index: usize,
    /// Track id.
    pub track_id: u64,
    /// Semantic class.
    pub class: u16,
    /// Box [x1, y1, x2, y2] in pixels.
    pub bbox: [f32; 4],
    /// Flow-reconstruction error S_r.
    pub s_r: f32,
    /// Frame-prediction error S_p.
    pub s_p: f32,
    /// z-score of S_r under the training statistics.
    pub z_r: f64,
    /// z-score of S_p.
    pub z_p: f64,
    /// Fused object score w_r·z_r + w_p·z_p.
    pub score: f64,
}

/// The current frame's numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameInfo {
    /// Frame index.
    pub index: usize,
    /// AnoVox frame id.
    pub id: Option<FrameId>,
    /// Ground-truth flag.
    pub anomalous: bool,
    /// Raw fused score.
    pub raw: Option<f64>,
    /// Median-filtered score (NaN in the frames the model cannot score).
    pub filtered: Option<f64>,
}

/// The viewer's state.
#[derive(Debug)]
pub struct AppState {
    dataset: Option<Dataset>,
    current: usize,
    playback: Playback,
    settings: ViewSettings,
    analyses: Vec<Option<ScenarioAnalysis>>,
    metrics: DatasetMetrics,
    threshold: f64,
    failures: Vec<FailureCase>,
    failure_cursor: Option<usize>,
    tags: Vec<FailureTags>,
    selected_track: Option<u64>,
    log: Vec<LogEntry>,
    job: Option<ScoringJob>,
    setup: ScoringSetup,
    show_help: bool,
    labeling: Labeling,
    export: Option<ExportJob>,
    export_progress: Option<ExportProgress>,
}

impl AppState {
    /// An empty viewer that will score with `setup`.
    pub fn new(setup: ScoringSetup, settings: ViewSettings) -> Self {
        Self {
            dataset: None,
            current: 0,
            playback: Playback::new(0, 10.0),
            settings,
            analyses: Vec::new(),
            metrics: DatasetMetrics::default(),
            threshold: 0.0,
            failures: Vec::new(),
            failure_cursor: None,
            tags: Vec::new(),
            selected_track: None,
            log: Vec::new(),
            job: None,
            setup,
            show_help: false,
            labeling: Labeling::new(0),
            export: None,
            export_progress: None,
        }
    }

    /// Opens a scenario or data-set root and starts scoring what has no scores. On error
    /// the previous data set stays open and the error is logged; returns whether it opened.
    pub fn open(&mut self, path: &Path) -> bool {
        match Dataset::open(path) {
            Ok(dataset) => {
                self.log(
                    LogLevel::Info,
                    format!(
                        "opened {} ({} scenarios)",
                        path.display(),
                        dataset.scenarios.len()
                    ),
                );
                for entry in &dataset.scenarios {
                    if let Some(error) = &entry.error {
                        self.log(LogLevel::Error, error.clone());
                    }
                }
                self.set_dataset(dataset);
                self.start_scoring();
                true
            }
            Err(e) => {
                self.log(
                    LogLevel::Error,
                    format!("cannot open {}: {e}", path.display()),
                );
                false
            }
        }
    }

    /// Replaces the data set (no scoring is started) and shows its first scenario.
    pub fn set_dataset(&mut self, dataset: Dataset) {
        self.job = None;
        self.tags = dataset
            .scenarios
            .iter()
            .map(|entry| {
                let Some(scenario) = &entry.scenario else {
                    return FailureTags::default();
                };
                let loaded = scenario
                    .cache_dir()
                    .map_err(AppError::from)
                    .and_then(|dir| FailureTags::load(&dir.join(TAGS_FILE)));
                loaded.unwrap_or_else(|e| {
                    self.log.push(LogEntry {
                        level: LogLevel::Warning,
                        message: format!("failure tags of {} not read: {e}", entry.name),
                    });
                    FailureTags::default()
                })
            })
            .collect();
        let active = self.labeling.active;
        self.labeling = Labeling::new(dataset.len());
        self.labeling.active = active;
        self.dataset = Some(dataset);
        self.failure_cursor = None;
        if self.settings.reference == Reference::AnalystLabels {
            self.open_all_labels();
        }
        self.select_scenario(0);
        self.refuse();
    }

    /// Starts the background job on every scenario that is pending or failed, the current
    /// one first. Does nothing while a job runs.
    pub fn start_scoring(&mut self) {
        if self.job.is_some() {
            return;
        }
        let Some(dataset) = &mut self.dataset else {
            return;
        };
        let current = self.current;
        let mut todo: Vec<(usize, PathBuf)> = dataset
            .scenarios
            .iter()
            .enumerate()
            .filter(|(_, e)| {
                e.scenario.is_some()
                    && matches!(e.status, ScoreStatus::Pending | ScoreStatus::Failed(_))
            })
            .map(|(i, e)| (i, e.root.clone()))
            .collect();
        todo.sort_by_key(|(i, _)| *i != current);
        if todo.is_empty() {
            return;
        }
        for (i, _) in &todo {
            dataset.scenarios[*i].status = ScoreStatus::Pending;
        }
        self.job = Some(ScoringJob::start(self.setup.clone(), todo));
    }

    /// Takes in what the scoring and export jobs have reported; returns whether anything
    /// changed.
    pub fn poll_jobs(&mut self) -> bool {
        let exported = self.poll_export();
        exported | self.poll_scoring()
    }

    fn poll_export(&mut self) -> bool {
        let Some(job) = &mut self.export else {
            return false;
        };
        let events = job.poll();
        let out = job.out().display().to_string();
        let changed = !events.is_empty();
        for event in events {
            match event {
                ExportEvent::Progress(p) => self.export_progress = Some(p),
                ExportEvent::Finished(result) => {
                    self.export = None;
                    self.export_progress = None;
                    match result {
                        Ok(files) => self.log(
                            LogLevel::Info,
                            format!("export: {} files written to {out}", files.len()),
                        ),
                        Err(e) => self.log(LogLevel::Error, format!("export to {out}: {e}")),
                    }
                }
            }
        }
        changed
    }

    fn poll_scoring(&mut self) -> bool {
        let Some(job) = &mut self.job else {
            return false;
        };
        let events = job.poll();
        let finished = job.is_finished() && events.is_empty();
        if finished {
            self.job = None;
        }
        let mut rescored = false;
        let changed = !events.is_empty();
        for event in events {
            rescored |= self.take_event(event);
        }
        if rescored {
            self.refuse();
        }
        changed || finished
    }

    fn take_event(&mut self, event: JobEvent) -> bool {
        let Some(dataset) = &mut self.dataset else {
            return false;
        };
        let (message, rescored) = match event {
            JobEvent::Progress { scenario, progress } => {
                if let Some(e) = dataset.scenarios.get_mut(scenario) {
                    e.status = ScoreStatus::Scoring(progress);
                }
                return false;
            }
            JobEvent::Scored {
                scenario,
                cache,
                computed,
            } => {
                let Some(e) = dataset.scenarios.get_mut(scenario) else {
                    return false;
                };
                if cache.table().frames.len() != e.labels.len() {
                    let error = format!(
                        "{}: {} frames scored but {} labels",
                        cache.path().display(),
                        cache.table().frames.len(),
                        e.labels.len()
                    );
                    e.status = ScoreStatus::Failed(error.clone());
                    (
                        LogEntry {
                            level: LogLevel::Error,
                            message: error,
                        },
                        false,
                    )
                } else {
                    let how = if computed {
                        "scored"
                    } else {
                        "scores read from cache"
                    };
                    let message = format!("{}: {how} ({})", e.name, cache.path().display());
                    e.status = ScoreStatus::Ready(Box::new(Scores::Cache(*cache)));
                    (
                        LogEntry {
                            level: LogLevel::Info,
                            message,
                        },
                        true,
                    )
                }
            }
            JobEvent::Failed { scenario, error } => {
                if let Some(e) = dataset.scenarios.get_mut(scenario) {
                    e.status = ScoreStatus::Failed(error.clone());
                }
                (
                    LogEntry {
                        level: LogLevel::Error,
                        message: error,
                    },
                    false,
                )
            }
            JobEvent::Cancelled { unscored } => {
                for i in &unscored {
                    if let Some(e) = dataset.scenarios.get_mut(*i) {
                        e.status = ScoreStatus::Failed("scoring cancelled".into());
                    }
                }
                let message = format!(
                    "scoring cancelled; {} scenarios left unscored",
                    unscored.len()
                );
                (
                    LogEntry {
                        level: LogLevel::Warning,
                        message,
                    },
                    false,
                )
            }
        };
        self.push_log(message);
        rescored
    }

    /// Whether the scoring job runs.
    pub fn is_scoring(&self) -> bool {
        self.job.is_some()
    }

    /// The scenario being scored and how far it has come.
    pub fn scoring_progress(&self) -> Option<(usize, ScoreProgress)> {
        self.dataset
            .as_ref()?
            .scenarios
            .iter()
            .enumerate()
            .find_map(|(i, e)| match e.status {
                ScoreStatus::Scoring(p) => Some((i, p)),
                _ => None,
            })
    }

    /// Scenarios waiting for the job (pending, not being scored).
    pub fn scoring_queue(&self) -> usize {
        if self.job.is_none() {
            return 0;
        }
        self.dataset.as_ref().map_or(0, |d| {
            d.scenarios
                .iter()
                .filter(|e| e.scenario.is_some() && matches!(e.status, ScoreStatus::Pending))
                .count()
        })
    }

    /// Waits (blocking) until the scoring job has finished and takes in its results;
    /// for tests and benchmarks, never called by the GUI.
    pub fn wait_for_scoring(&mut self) {
        while self.job.is_some() {
            if !self.poll_jobs() {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
        }
    }

    /// Starts exporting `choice` from the current scenario in the background (as the
    /// viewer shows it: weights, threshold, overlays, reference labels); returns whether it
    /// started. Needs the scenario's score cache; one export runs at a time.
    pub fn start_export(&mut self, choice: ExportChoice) -> bool {
        if self.export.is_some() {
            self.log(LogLevel::Warning, "an export is running already");
            return false;
        }
        let Some(entry) = self.entry() else {
            return false;
        };
        let Some(cache) = entry.scores().and_then(|s| s.cache()) else {
            let message = format!("{}: nothing to export before it is scored", entry.name);
            self.log(LogLevel::Warning, message);
            return false;
        };
        if choice.out.as_os_str().is_empty() {
            self.log(LogLevel::Warning, "export: choose a folder first");
            return false;
        }
        let request = ExportRequest {
            scenario: entry.root.clone(),
            key: cache.table().meta.key.clone(),
            model: self.setup.model.clone(),
            labels: self.reference_labels().to_vec(),
            settings: self.render_settings(),
            options: self.dashboard_options(),
            flow: self.setup.request.flow,
            choice,
        };
        self.log(
            LogLevel::Info,
            format!("exporting to {}", request.choice.out.display()),
        );
        self.export = Some(ExportJob::start(request));
        self.export_progress = None;
        true
    }

    /// Whether an export runs.
    pub fn is_exporting(&self) -> bool {
        self.export.is_some()
    }

    /// How far the running export has come (`None` before its first frame).
    pub fn export_progress(&self) -> Option<ExportProgress> {
        self.export_progress
    }

    /// Waits (blocking) until the export has finished and takes in its result; for tests,
    /// never called by the GUI.
    pub fn wait_for_export(&mut self) {
        while self.export.is_some() {
            if !self.poll_export() {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
        }
    }

    /// The settings `render` draws with: the analyst's weights, filter and colormap and the
    /// threshold in effect.
    pub fn render_settings(&self) -> RenderSettings {
        let settings = &self.settings;
        RenderSettings {
            weights: settings.weights,
            threshold: self.threshold,
            colormap: settings.colormap,
            auto_range: false,
            median_kernel: settings.median_kernel,
        }
    }

    /// The view options `vadscope render` would use for these settings (ranges from the
    /// model's training statistics when scored), with the analyst's overlays and opacity;
    /// while labeling, the analyst's boxes replace the scored ones (drawn by the UI).
    pub fn dashboard_options(&self) -> DashboardOptions {
        let settings = &self.settings;
        let mut options = match self.entry().and_then(|e| e.scores()) {
            Some(scores) => self.render_settings().options(scores.table()),
            None => DashboardOptions::default(),
        };
        let o = &settings.overlays;
        options.frame.heatmap = o.heatmap;
        options.frame.boxes = o.boxes && !self.labeling.active;
        options.frame.mask = o.mask;
        options.frame.caption = o.caption;
        options.frame.opacity = settings.opacity;
        options
    }

    /// Applies an action.
    pub fn apply(&mut self, action: Action) {
        match action {
            Action::TogglePlay => self.playback.toggle(),
            Action::Step(delta) => self.playback.step(delta),
            Action::First => self.playback.seek(0),
            Action::Last => self.playback.seek(usize::MAX),
            Action::PreviousEvent | Action::NextEvent => {
                let frame = self.playback.frame();
                let events = anomaly_events(self.reference_labels());
                let target = if action == Action::NextEvent {
                    events.iter().find(|e| e.start > frame).map(|e| e.start)
                } else {
                    events
                        .iter()
                        .rev()
                        .find(|e| e.start < frame)
                        .map(|e| e.start)
                };
                if let Some(target) = target {
                    self.playback.seek(target);
                }
            }
            Action::Seek(frame) => self.playback.seek(frame),
            Action::SelectScenario(index) => self.select_scenario(index),
            Action::StepScenario(delta) => {
                let len = self.dataset.as_ref().map_or(0, Dataset::len);
                if len > 0 {
                    let target = (self.current as i64 + delta).clamp(0, len as i64 - 1);
                    self.select_scenario(target as usize);
                }
            }
            Action::SetView(view) => self.settings.view = view,
            Action::ToggleOverlay(overlay) => self.settings.overlays.toggle(overlay),
            Action::JumpToFailure(index) => self.jump_to_failure(index),
            Action::StepFailure(delta) => {
                if !self.failures.is_empty() {
                    let len = self.failures.len() as i64;
                    let next = match self.failure_cursor {
                        Some(c) => (c as i64 + delta).rem_euclid(len),
                        None if delta < 0 => len - 1,
                        None => 0,
                    };
                    self.jump_to_failure(next as usize);
                }
            }
            Action::SelectObject(track) => {
                self.selected_track = track;
                if track.is_none() {
                    self.labeling.selected_box = None;
                }
            }
            Action::CancelScoring => {
                if let Some(job) = &self.job {
                    job.cancel();
                }
            }
            Action::CancelExport => {
                if let Some(job) = &self.export {
                    job.cancel();
                }
            }
            Action::ToggleHelp => self.show_help = !self.show_help,
            Action::ToggleLabeling => {
                self.labeling.active = !self.labeling.active;
                if self.labeling.active {
                    self.open_labels(self.current);
                }
            }
            Action::StartInterval
            | Action::EndInterval
            | Action::MoveNearestEdge
            | Action::TagRange
            | Action::Undo
            | Action::Redo
            | Action::SetIntervalEdge { .. }
            | Action::AddBox(_)
            | Action::SetBox { .. }
            | Action::SelectBox(_)
            | Action::DeleteSelectedBox => self.label(action),
        }
    }

    /// Opens the labels of scenario `index` unless open, logging what opening found wrong
    /// (damaged files are named and copied aside); returns whether they are open.
    fn open_labels(&mut self, index: usize) -> bool {
        if self.labeling.is_open(index) {
            return true;
        }
        let Some(entry) = self.dataset.as_ref().and_then(|d| d.scenarios.get(index)) else {
            return false;
        };
        let Some(scenario) = &entry.scenario else {
            let message = format!("{}: no scenario on disk, nothing to label", entry.name);
            self.log(LogLevel::Warning, message);
            return false;
        };
        let name = entry.name.clone();
        match ScenarioLabels::open(scenario) {
            Ok((labels, report)) => {
                for problem in report.problems {
                    self.log(LogLevel::Error, format!("labels of {name}: {problem}"));
                }
                for copy in report.set_aside {
                    self.log(
                        LogLevel::Warning,
                        format!("the damaged label file was kept as {}", copy.display()),
                    );
                }
                let dir = labels
                    .editor()
                    .dir()
                    .map_or_else(String::new, |d| d.display().to_string());
                self.log(LogLevel::Info, format!("labels of {name} open ({dir})"));
                self.labeling.insert(index, labels);
                true
            }
            Err(e) => {
                self.log(LogLevel::Error, format!("labels of {name} not opened: {e}"));
                false
            }
        }
    }

    /// Opens every scenario's labels (for the analyst-labels reference).
    fn open_all_labels(&mut self) {
        let len = self.dataset.as_ref().map_or(0, Dataset::len);
        for index in 0..len {
            let on_disk = self
                .dataset
                .as_ref()
                .is_some_and(|d| d.scenarios[index].scenario.is_some());
            if on_disk {
                self.open_labels(index);
            }
        }
    }

    /// Carries out a labeling action on the current scenario; what fails is logged.
    fn label(&mut self, action: Action) {
        if !self.labeling.active {
            self.log(
                LogLevel::Warning,
                "labeling is off: press L (or View > Labeling mode) first",
            );
            return;
        }
        if !self.open_labels(self.current) {
            return;
        }
        let frame = self.frame();
        let range = self.tag_range();
        let (result, changed) = self.labeling.perform(self.current, action, frame, range);
        match result {
            Ok(Some(message)) => self.log(LogLevel::Info, message),
            Ok(None) => {}
            Err(e) => self.log(LogLevel::Warning, format!("labeling: {e}")),
        }
        if changed && self.settings.reference == Reference::AnalystLabels {
            self.refuse();
        }
    }

    /// The frames "tag range" tags: mark to cursor, else the selected failure run when it
    /// is in this scenario, else the cursor's frame.
    fn tag_range(&self) -> (usize, usize) {
        let frame = self.frame();
        if let Some(mark) = self.labeling.mark {
            return (mark.min(frame), mark.max(frame));
        }
        self.failure_cursor
            .and_then(|c| self.failures.get(c))
            .filter(|c| c.scenario == self.current)
            .map_or((frame, frame), |c| (c.start, c.end))
    }

    fn jump_to_failure(&mut self, index: usize) {
        let Some(case) = self.failures.get(index).cloned() else {
            return;
        };
        self.failure_cursor = Some(index);
        if case.scenario != self.current {
            self.select_scenario(case.scenario);
        }
        self.playback.seek(case.focus);
    }

    fn select_scenario(&mut self, index: usize) {
        let Some(dataset) = &self.dataset else {
            return;
        };
        let index = index.min(dataset.len().saturating_sub(1));
        let entry = dataset.scenarios.get(index);
        let frames = entry.map_or(0, |e| e.frames);
        let fps = entry
            .and_then(|e| e.scenario.as_ref())
            .map_or(10.0, |s| f64::from(s.meta().fps));
        let keep_frame = index == self.current && self.playback.len() == frames;
        // One budget for the scenario on screen, a small one for the rest: memory stays
        // bounded by the data set's size, not by how many scenarios were visited.
        for (i, entry) in dataset.scenarios.iter().enumerate() {
            if let Some(scenario) = &entry.scenario {
                scenario.set_cache_budget(if i == index {
                    CURRENT_FRAME_CACHE
                } else {
                    BACKGROUND_FRAME_CACHE
                });
            }
        }
        self.current = index;
        if !keep_frame {
            self.playback = Playback::new(frames, fps);
            self.selected_track = None;
            self.labeling.mark = None;
            self.labeling.selected_box = None;
        }
        if self.labeling.active {
            self.open_labels(index);
        }
    }

    /// Replaces the settings, re-fusing when weights, filter or threshold changed.
    pub fn set_settings(&mut self, settings: ViewSettings) {
        let refuse = settings.weights != self.settings.weights
            || settings.median_kernel != self.settings.median_kernel
            || settings.threshold_mode != self.settings.threshold_mode
            || settings.manual_threshold != self.settings.manual_threshold
            || settings.late_after != self.settings.late_after
            || settings.reference != self.settings.reference;
        let analyst = settings.reference == Reference::AnalystLabels
            && self.settings.reference != Reference::AnalystLabels;
        self.settings = settings;
        if analyst {
            self.open_all_labels();
        }
        if refuse {
            self.refuse();
        }
    }

    /// Re-fuses every scored scenario and recomputes metrics, threshold and failure cases.
    pub fn refuse(&mut self) {
        let Some(dataset) = &self.dataset else {
            self.analyses.clear();
            self.metrics = DatasetMetrics::default();
            self.failures.clear();
            return;
        };
        let params = FusionParams {
            weights: self.settings.weights,
            median_kernel: self.settings.median_kernel,
        };
        let analyst = self.settings.reference == Reference::AnalystLabels;
        let labeling = &self.labeling;
        let reference = |i: usize, e: &super::dataset::ScenarioEntry| -> Vec<bool> {
            labeling
                .flags(i, e.labels.len())
                .filter(|_| analyst)
                .unwrap_or(&e.labels)
                .to_vec()
        };
        let references: Vec<Vec<bool>> = dataset
            .scenarios
            .iter()
            .enumerate()
            .map(|(i, e)| reference(i, e))
            .collect();
        self.analyses = dataset
            .scenarios
            .iter()
            .zip(&references)
            .map(|(e, labels)| {
                e.scores()
                    .map(|s| ScenarioAnalysis::fuse(s.table(), labels, &params))
            })
            .collect();
        let scored = || {
            self.analyses
                .iter()
                .zip(&references)
                .filter_map(|(a, l)| a.as_ref().map(|a| (a, l.as_slice())))
        };
        self.metrics = DatasetMetrics::compute(scored());
        let reference = reference_threshold(&self.settings.weights);
        self.threshold = match self.settings.threshold_mode {
            ThresholdMode::Reference => reference,
            ThresholdMode::F1Max => self
                .metrics
                .micro
                .map(|m| m.f1_threshold)
                .filter(|t| t.is_finite())
                .unwrap_or(reference),
            ThresholdMode::Manual => self.settings.manual_threshold,
        };
        let mut failures = Vec::new();
        for (i, (analysis, labels)) in self.analyses.iter_mut().zip(&references).enumerate() {
            if let Some(analysis) = analysis {
                analysis.detect(labels, self.threshold);
                failures.extend(scenario_failures(
                    i,
                    analysis,
                    labels,
                    self.threshold,
                    self.settings.late_after,
                ));
            }
        }
        self.metrics.detect(self.analyses.iter().flatten());
        rank(&mut failures);
        let previous = self
            .failure_cursor
            .and_then(|c| self.failures.get(c))
            .map(|c| (c.scenario, c.tag_key()));
        self.failure_cursor = previous.and_then(|(s, key)| {
            failures
                .iter()
                .position(|c| c.scenario == s && c.tag_key() == key)
        });
        self.failures = failures;
    }

    /// The open data set.
    pub fn dataset(&self) -> Option<&Dataset> {
        self.dataset.as_ref()
    }

    /// Index of the current scenario.
    pub fn current_scenario(&self) -> usize {
        self.current
    }

    /// The current scenario's entry.
    pub fn entry(&self) -> Option<&super::dataset::ScenarioEntry> {
        self.dataset.as_ref()?.scenarios.get(self.current)
    }

    /// The current scenario's ground-truth flags (empty when none is open).
    pub fn labels(&self) -> &[bool] {
        self.entry().map_or(&[], |e| e.labels.as_slice())
    }

    /// The per-frame flags the metrics of the current scenario are measured against: the
    /// analyst's intervals under [`Reference::AnalystLabels`] (when the labels are open),
    /// else the ground truth.
    pub fn reference_labels(&self) -> &[bool] {
        let truth = self.labels();
        match self.settings.reference {
            Reference::AnalystLabels => self
                .labeling
                .flags(self.current, truth.len())
                .unwrap_or(truth),
            Reference::GroundTruth => truth,
        }
    }

    /// The labeling mode: whether it is on, the mark, the selected box, the tag text.
    pub fn labeling(&self) -> &Labeling {
        &self.labeling
    }

    /// Whether the labeling mode is on.
    pub fn is_labeling(&self) -> bool {
        self.labeling.active
    }

    /// The tag text "tag range" uses, to edit.
    pub fn tag_text_mut(&mut self) -> &mut String {
        &mut self.labeling.tag_text
    }

    /// The current scenario's labels, when open.
    pub fn current_labels(&self) -> Option<&ScenarioLabels> {
        self.labeling.get(self.current)
    }

    /// Playback of the current scenario.
    pub fn playback(&self) -> &Playback {
        &self.playback
    }

    /// Lets `seconds` of wall time pass for playback; returns whether the frame changed.
    pub fn advance(&mut self, seconds: f64) -> bool {
        self.playback.advance(seconds)
    }

    /// The current frame index.
    pub fn frame(&self) -> usize {
        self.playback.frame()
    }

    /// The analyst's settings.
    pub fn settings(&self) -> &ViewSettings {
        &self.settings
    }

    /// The threshold in effect (see [`ThresholdMode`]).
    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    /// The analysis of scenario `index` (when it has scores).
    pub fn analysis(&self, index: usize) -> Option<&ScenarioAnalysis> {
        self.analyses.get(index)?.as_ref()
    }

    /// The analysis of the current scenario.
    pub fn current_analysis(&self) -> Option<&ScenarioAnalysis> {
        self.analysis(self.current)
    }

    /// Metrics over the whole data set.
    pub fn dataset_metrics(&self) -> &DatasetMetrics {
        &self.metrics
    }

    /// Failure cases of every scored scenario, ranked within each kind.
    pub fn failures(&self) -> &[FailureCase] {
        &self.failures
    }

    /// The failure case last jumped to.
    pub fn failure_cursor(&self) -> Option<usize> {
        self.failure_cursor
    }

    /// The tag of failure case `index`.
    pub fn failure_tag(&self, index: usize) -> Option<&str> {
        let case = self.failures.get(index)?;
        self.tags.get(case.scenario)?.get(&case.tag_key())
    }

    /// Tags failure case `index` (an empty text removes the tag) and saves the scenario's
    /// tags; a failed save is logged and the tag kept in memory.
    pub fn set_failure_tag(&mut self, index: usize, tag: &str) {
        let Some(case) = self.failures.get(index) else {
            return;
        };
        let (scenario, key) = (case.scenario, case.tag_key());
        let Some(tags) = self.tags.get_mut(scenario) else {
            return;
        };
        tags.set(key, tag);
        let path = self
            .dataset
            .as_ref()
            .and_then(|d| d.scenarios.get(scenario))
            .and_then(|e| e.scenario.as_ref())
            .map(|s| s.cache_dir().map(|d| d.join(TAGS_FILE)));
        let saved = match path {
            Some(Ok(path)) => tags.save(&path),
            Some(Err(e)) => Err(e.into()),
            None => Ok(()),
        };
        if let Err(e) = saved {
            self.log(LogLevel::Error, format!("failure tags not saved: {e}"));
        }
    }

    /// The failure cases as CSV (see [`super::failures::FAILURE_CSV_HEADER`]).
    pub fn failures_csv(&self) -> String {
        let Some(dataset) = &self.dataset else {
            return failures_csv(std::iter::empty());
        };
        failures_csv(self.failures.iter().enumerate().map(|(i, case)| {
            let entry = &dataset.scenarios[case.scenario];
            let id = |frame: usize| entry.scenario.as_ref().and_then(|s| s.frame_id(frame));
            FailureRow {
                case,
                scenario: &entry.name,
                ids: [id(case.start), id(case.focus), id(case.end)],
                tag: self.failure_tag(i),
            }
        }))
    }

    /// Writes [`Self::failures_csv`] to `path`.
    pub fn export_failures(&self, path: &Path) -> Result<(), AppError> {
        write_atomically(path, self.failures_csv().as_bytes())
    }

    /// The current frame's numbers.
    pub fn frame_info(&self) -> FrameInfo {
        let index = self.frame();
        let analysis = self.current_analysis();
        FrameInfo {
            index,
            id: self
                .entry()
                .and_then(|e| e.scenario.as_ref())
                .and_then(|s| s.frame_id(index)),
            anomalous: self.labels().get(index).copied().unwrap_or(false),
            raw: analysis.and_then(|a| a.series.fused.get(index).copied()),
            filtered: analysis.and_then(|a| a.series.filtered.get(index).copied()),
        }
    }

    /// The scored objects of the current frame.
    pub fn frame_objects(&self) -> Vec<ObjectInfo> {
        let Some(scores) = self.entry().and_then(|e| e.scores()) else {
            return Vec::new();
        };
        let table = scores.table();
        if self.frame() >= table.frames.len() {
            return Vec::new();
        }
        let stats = &table.meta.training;
        let w = &self.settings.weights;
        table
            .frame_objects(self.frame())
            .iter()
            .enumerate()
            .map(|(index, o)| {
                let z_r = stats.flow_score.z(f64::from(o.s_r));
                let z_p = stats.frame_score.z(f64::from(o.s_p));
                ObjectInfo {
                    index,
                    track_id: o.track_id,
                    class: o.class,
                    bbox: o.bbox,
                    s_r: o.s_r,
                    s_p: o.s_p,
                    z_r,
                    z_p,
                    score: w.w_r * z_r + w.w_p * z_p,
                }
            })
            .collect()
    }

    /// The maps of the current frame's objects, in object order; `None` when the scores
    /// have no maps on disk. Read errors are returned (the caller logs them).
    pub fn frame_maps(&self) -> Option<Result<Vec<ObjectMaps>, AppError>> {
        let cache = self.entry()?.scores()?.cache()?;
        if self.frame() >= cache.table().frames.len() {
            return None;
        }
        Some(cache.frame_maps(self.frame()).map_err(AppError::from))
    }

    /// The selected object's track id.
    pub fn selected_track(&self) -> Option<u64> {
        self.selected_track
    }

    /// The smallest box of the current frame that holds pixel (x, y).
    pub fn object_at(&self, x: f32, y: f32) -> Option<ObjectInfo> {
        self.frame_objects()
            .into_iter()
            .filter(|o| {
                let [x1, y1, x2, y2] = o.bbox;
                (x1..=x2).contains(&x) && (y1..=y2).contains(&y)
            })
            .min_by(|a, b| area(a.bbox).total_cmp(&area(b.bbox)))
    }

    /// Whether the help overlay is shown.
    pub fn show_help(&self) -> bool {
        self.show_help
    }

    /// The log, oldest first.
    pub fn log_entries(&self) -> &[LogEntry] {
        &self.log
    }

    /// Adds a log entry.
    pub fn log(&mut self, level: LogLevel, message: impl Into<String>) {
        self.push_log(LogEntry {
            level,
            message: message.into(),
        });
    }

    fn push_log(&mut self, entry: LogEntry) {
        if self.log.len() >= LOG_CAPACITY {
            self.log.remove(0);
        }
        self.log.push(entry);
    }

    /// The scoring setup.
    pub fn scoring_setup(&self) -> &ScoringSetup {
        &self.setup
    }
}

fn area(b: [f32; 4]) -> f32 {
    (b[2] - b[0]).max(0.0) * (b[3] - b[1]).max(0.0)
}
