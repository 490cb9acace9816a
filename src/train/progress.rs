//! What a training run tells its caller: [`TrainEvent`]s while it runs (stage starts,
//! steps, finished epochs with their losses and ratings, the final statistics), a
//! [`StageSummary`] per stage (also kept in the run's `state.json`) and the
//! [`TrainReport`] at the end.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::model::TrainingStats;

/// Progress reported to the caller.
#[derive(Debug, Clone, PartialEq)]
pub enum TrainEvent {
    /// A stage begins (or resumes) at `first_epoch`.
    StageStarted {
        /// Stage number (1–3).
        stage: usize,
        /// First epoch that will run (0-based; > 0 after a resume).
        first_epoch: usize,
        /// Total epochs of the stage.
        epochs: usize,
        /// Optimiser steps per epoch.
        steps_per_epoch: usize,
    },
    /// One optimiser step finished.
    Step {
        /// Stage number.
        stage: usize,
        /// Epoch (0-based).
        epoch: usize,
        /// Step within the epoch (0-based).
        step: usize,
        /// Total loss of the batch.
        loss: f64,
    },
    /// An epoch finished and was checkpointed.
    EpochDone {
        /// Stage number.
        stage: usize,
        /// Epoch (0-based).
        epoch: usize,
        /// Mean training loss of the epoch.
        train_loss: f64,
        /// Mean validation loss (None without validation cubes).
        val_loss: Option<f64>,
        /// The judge's rating of this epoch's candidate, when anomaly selection judged it.
        rating: Option<f64>,
        /// Epochs averaged into this epoch's candidate (the losses and rating are its):
        /// 0 when it is the epoch's own weights.
        averaged: usize,
        /// Learning rate used.
        lr: f64,
        /// Whether this epoch is the best of the stage so far.
        best: bool,
    },
    /// The training statistics were computed.
    StatsDone(Box<TrainingStats>),
}

/// Outcome of one stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageSummary {
    /// Epochs run.
    pub epochs: usize,
    /// Epoch whose model was kept (0-based).
    pub best_epoch: usize,
    /// Epochs averaged into the kept model, ending at `best_epoch` (0: its own weights).
    #[serde(default)]
    pub best_averaged: usize,
    /// Its selection value, lowest kept: its validation loss (training loss when there was
    /// no validation data), or with anomaly selection minus its rating.
    pub best_loss: f64,
    /// The judge's rating of the kept epoch, with anomaly selection.
    #[serde(default)]
    pub best_rating: Option<f64>,
    /// Mean training loss of the last epoch.
    pub last_train_loss: f64,
}

/// Outcome of a whole training run.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainReport {
    /// The final checkpoint (`model.safetensors` in the output folder).
    pub checkpoint: PathBuf,
    /// Training statistics stored in it.
    pub stats: TrainingStats,
    /// Per-stage outcomes (None for a stage with 0 epochs).
    pub stages: [Option<StageSummary>; 3],
    /// Cubes used for training and for validation.
    pub split: (usize, usize),
}
