//! Errors of the model module: invalid configs, bad inputs, unreadable weight files.

use std::path::PathBuf;

/// Everything that can go wrong building, loading, saving or running a model.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The config describes a network the architecture cannot build.
    #[error("invalid model config: {0}")]
    InvalidConfig(String),
    /// Input tensors have the wrong size or hold non-finite values.
    #[error("invalid model input: {0}")]
    InvalidInput(String),
    /// A weight or checkpoint file could not be read or does not fit the model.
    #[error("cannot load weights from {path}: {reason}")]
    Load {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        reason: String,
    },
    /// A checkpoint could not be written.
    #[error("cannot save checkpoint to {path}: {reason}")]
    Save {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        reason: String,
    },
    /// A cube could not be built from a scenario.
    #[error("cannot build cube: {0}")]
    Cube(String),
}

impl ModelError {
    /// A load error for `path`.
    pub fn load(path: impl Into<PathBuf>, reason: impl ToString) -> Self {
        Self::Load {
            path: path.into(),
            reason: reason.to_string(),
        }
    }

    /// A save error for `path`.
    pub fn save(path: impl Into<PathBuf>, reason: impl ToString) -> Self {
        Self::Save {
            path: path.into(),
            reason: reason.to_string(),
        }
    }
}
