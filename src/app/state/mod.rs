//! The viewer's core, GUI-free: the open data set, the current scenario and frame,
//! playback, the analyst's settings, fused scores and live metrics for the scenario and the
//! data set, ranked failure cases with their tags, the background scoring job and the log.
//! The egui layer only reads this state and sends it [`Action`]s and setting changes, so
//! everything here is testable without a display.
//!
//! Split the way rerun splits its `App`: this file holds the state, opening a data set and
//! [`AppState::apply`]; `jobs` polls the scoring and export jobs, `refresh` re-fuses after
//! a change of settings and switches the scenario on screen, `labeling` drives the
//! labeling mode, `failures` the failure cases and their tags, `frame` the current frame's
//! numbers, `log` the log panel. Each adds methods to [`AppState`].

use std::path::Path;

use crate::eval::anomaly_events;
use crate::export::ExportProgress;

use super::action::Action;
use super::analysis::{DatasetMetrics, ScenarioAnalysis};
use super::dataset::Dataset;
use super::error::AppError;
use super::export_job::ExportJob;
use super::failures::{FailureCase, FailureTags, TAGS_FILE};
use super::jobs::{ScoringJob, ScoringSetup};
use super::labeling::Labeling;
use super::playback::Playback;
use super::settings::{Reference, ViewSettings};

mod failures;
mod frame;
mod jobs;
mod labeling;
mod log;
mod refresh;

pub use frame::{FrameInfo, ObjectInfo};
pub use log::{LogEntry, LogLevel};
pub use refresh::{BACKGROUND_FRAME_CACHE, CURRENT_FRAME_CACHE};

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

    /// Whether the help overlay is shown.
    pub fn show_help(&self) -> bool {
        self.show_help
    }
}
