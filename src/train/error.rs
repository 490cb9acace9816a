//! Errors of the training module.

use std::path::PathBuf;

use crate::model::ModelError;

/// Everything that can go wrong while preparing data or training.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// A model-level failure (config, checkpoint, weights).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A file was read but its content is wrong.
    #[error("{path}: {reason}")]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The training data cannot be used.
    #[error("training data: {0}")]
    Data(String),
    /// The training settings cannot be used.
    #[error("training config: {0}")]
    Config(String),
    /// Model selection failed: the judge could not rate an epoch.
    #[error("model selection: {0}")]
    Selection(String),
}

impl From<crate::atomic_file::WriteError> for TrainError {
    fn from(e: crate::atomic_file::WriteError) -> Self {
        Self::io(e.path, e.source)
    }
}

impl TrainError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: impl Into<std::io::Error>) -> Self {
        Self::Io {
            path: path.into(),
            source: source.into(),
        }
    }

    /// A content error in `path`.
    pub fn file(path: impl Into<PathBuf>, reason: impl ToString) -> Self {
        Self::File {
            path: path.into(),
            reason: reason.to_string(),
        }
    }
}
