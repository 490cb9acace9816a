//! The background scoring job: on its own thread, for each scenario in turn, it opens the
//! scenario's score cache for the model, box source and flow source, or scores the scenario
//! with `score::Scorer` when there is none, and reports progress and results over a
//! channel. The UI polls the channel every frame, so it never waits; cancelling sets a flag
//! that the scoring run checks between batches (nothing half-done is written).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;

use crate::model::bundled_model;
use crate::score::{CacheLookup, ScoreCache, ScoreError, ScoreProgress, ScoreRequest, Scorer};
use crate::sequence::Scenario;

use super::background::BackgroundThread;
use super::error::AppError;

/// Which model scores, and with which boxes and flows.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoringSetup {
    /// The checkpoint; `None` = the bundled model ([`bundled_model`]).
    pub model: Option<PathBuf>,
    /// Box and flow source and batch size.
    pub request: ScoreRequest,
}

/// What the job reports.
#[derive(Debug)]
pub enum JobEvent {
    /// Scenario `scenario` (index in the data set) is being scored.
    Progress {
        /// Scenario index.
        scenario: usize,
        /// How far it has come.
        progress: ScoreProgress,
    },
    /// Scenario `scenario` has scores (from its cache, or freshly computed).
    Scored {
        /// Scenario index.
        scenario: usize,
        /// The opened cache.
        cache: Box<ScoreCache>,
        /// Whether it was computed now (rather than found on disk).
        computed: bool,
    },
    /// Scenario `scenario` could not be scored.
    Failed {
        /// Scenario index.
        scenario: usize,
        /// Why, naming the file involved.
        error: String,
    },
    /// The job stopped because it was cancelled; the scenarios it had not finished are
    /// listed.
    Cancelled {
        /// Scenario indices left unscored.
        unscored: Vec<usize>,
    },
}

/// A running (or finished) scoring job.
#[derive(Debug)]
pub struct ScoringJob {
    thread: BackgroundThread<JobEvent>,
}

impl ScoringJob {
    /// Starts scoring `scenarios` (data-set index and folder), in the given order.
    pub fn start(setup: ScoringSetup, scenarios: Vec<(usize, PathBuf)>) -> Self {
        let thread = BackgroundThread::spawn("vadscope-scoring", move |sender, cancel| {
            run_job(&setup, &scenarios, sender, cancel)
        });
        Self { thread }
    }

    /// The events that have arrived since the last call (never blocks).
    pub fn poll(&mut self) -> Vec<JobEvent> {
        self.thread.poll()
    }

    /// Whether the job's thread has ended (all its events may still wait in [`Self::poll`]).
    pub fn is_finished(&self) -> bool {
        self.thread.is_finished()
    }

    /// Asks the job to stop after the current batch.
    pub fn cancel(&self) {
        self.thread.cancel();
    }

    /// Whether cancelling has been asked for.
    pub fn is_cancelling(&self) -> bool {
        self.thread.is_cancelling()
    }
}

fn run_job(
    setup: &ScoringSetup,
    scenarios: &[(usize, PathBuf)],
    events: &Sender<JobEvent>,
    cancel: &AtomicBool,
) {
    let fail_all = |error: String| {
        for (index, _) in scenarios {
            let _ = events.send(JobEvent::Failed {
                scenario: *index,
                error: error.clone(),
            });
        }
    };
    let path = match setup.model.clone().map_or_else(bundled_model, Ok) {
        Ok(path) => path,
        Err(e) => return fail_all(e.to_string()),
    };
    let mut scorer = match Scorer::new(path) {
        Ok(scorer) => scorer,
        Err(e) => return fail_all(e.to_string()),
    };
    for (position, (index, root)) in scenarios.iter().enumerate() {
        if cancel.load(Ordering::Relaxed) {
            let unscored = scenarios[position..].iter().map(|(i, _)| *i).collect();
            let _ = events.send(JobEvent::Cancelled { unscored });
            return;
        }
        let event = match score_one(*index, root, setup, &mut scorer, events, cancel) {
            Ok((cache, computed)) => JobEvent::Scored {
                scenario: *index,
                cache: Box::new(cache),
                computed,
            },
            Err(AppError::Score(ScoreError::Cancelled { .. })) => {
                let unscored = scenarios[position..].iter().map(|(i, _)| *i).collect();
                let _ = events.send(JobEvent::Cancelled { unscored });
                return;
            }
            Err(e) => JobEvent::Failed {
                scenario: *index,
                error: e.to_string(),
            },
        };
        if events.send(event).is_err() {
            return;
        }
    }
}

fn score_one(
    index: usize,
    root: &std::path::Path,
    setup: &ScoringSetup,
    scorer: &mut Scorer,
    events: &Sender<JobEvent>,
    cancel: &AtomicBool,
) -> Result<(ScoreCache, bool), AppError> {
    let scenario = Scenario::open(root)?;
    match scorer.find(&scenario, &setup.request)? {
        CacheLookup::Current(cache) => return Ok((*cache, false)),
        // The viewer reports a cache it cannot use rather than replacing it unasked.
        CacheLookup::Unusable { error, .. } => return Err(error.into()),
        CacheLookup::Missing(_) => {}
    }
    let mut report = |progress: ScoreProgress| {
        let _ = events.send(JobEvent::Progress {
            scenario: index,
            progress,
        });
    };
    let cache = scorer.score(&scenario, &setup.request, &mut report, cancel)?;
    Ok((cache, true))
}
