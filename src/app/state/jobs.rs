//! The background jobs as the state sees them: starting the scoring and export jobs,
//! polling their events every frame (scores arriving, progress, failures, cancels) and
//! waiting for them (tests and headless use).

use std::path::PathBuf;

use crate::export::ExportProgress;
use crate::score::ScoreProgress;

use crate::app::dataset::{ScoreStatus, Scores};
use crate::app::export_job::{ExportChoice, ExportEvent, ExportJob, ExportRequest};
use crate::app::jobs::{JobEvent, ScoringJob, ScoringSetup};

use super::AppState;
use super::log::{LogEntry, LogLevel};

impl AppState {
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

    pub(super) fn poll_export(&mut self) -> bool {
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

    pub(super) fn poll_scoring(&mut self) -> bool {
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

    pub(super) fn take_event(&mut self, event: JobEvent) -> bool {
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

    /// The scoring setup.
    pub fn scoring_setup(&self) -> &ScoringSetup {
        &self.setup
    }
}
