//! The error type of the `score` module: every variant names the file (or the scenario and
//! frame) involved and says what is wrong.

use std::path::{Path, PathBuf};

use crate::flow::FlowError;
use crate::model::ModelError;
use crate::sequence::SequenceError;

/// Everything that can go wrong producing, storing, reading or evaluating scores.
#[derive(Debug, thiserror::Error)]
pub enum ScoreError {
    /// Reading the scenario failed (frames, boxes, flows, metadata).
    #[error(transparent)]
    Sequence(#[from] SequenceError),
    /// The operating system refused to read or write a file.
    #[error("{path}: {source}")]
    Io {
        /// File or folder involved.
        path: PathBuf,
        /// Underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A score cache is truncated, corrupt, of another version or of another scenario.
    #[error("score cache {path}: {problem}")]
    Cache {
        /// The cache file.
        path: PathBuf,
        /// What is wrong, in words.
        problem: String,
    },
    /// The model could not be loaded.
    #[error(transparent)]
    LoadModel(#[from] ModelError),
    /// The model failed on the cubes of a frame.
    #[error("{scenario}, frame {frame}: {source}")]
    Model {
        /// Scenario folder.
        scenario: PathBuf,
        /// Frame index whose cubes were being scored (the first of the batch).
        frame: usize,
        /// What the model said.
        #[source]
        source: ModelError,
    },
    /// A flow could not be read or estimated (the error names the scenario and frame).
    #[error(transparent)]
    Flow(#[from] FlowError),
    /// The model has no training statistics, so its scores cannot be z-scored.
    #[error(
        "model has no training statistics: scores cannot be normalised (compute them with `vadscope train` first)"
    )]
    NoTrainingStats,
    /// Inputs that do not fit together (a request, a hand-built table).
    #[error("{0}")]
    Invalid(String),
    /// The caller asked the scoring run to stop; nothing was written.
    #[error("scoring of {scenario} was cancelled; no cache was written")]
    Cancelled {
        /// Scenario folder.
        scenario: PathBuf,
    },
}

impl From<crate::atomic_file::WriteError> for ScoreError {
    fn from(e: crate::atomic_file::WriteError) -> Self {
        Self::io(e.path, e.source)
    }
}

impl ScoreError {
    /// Wraps an I/O error with the path it happened on.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// A problem with the score cache at `path`.
    pub fn cache(path: &Path, problem: impl Into<String>) -> Self {
        Self::Cache {
            path: path.to_path_buf(),
            problem: problem.into(),
        }
    }
}
