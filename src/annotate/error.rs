//! The error type of the `annotate` module: every variant names the file (or the edit)
//! involved and says what is wrong.

use std::path::{Path, PathBuf};

use crate::sequence::SequenceError;

/// Everything that can go wrong editing, saving, loading, importing or exporting labels.
#[derive(Debug, thiserror::Error)]
pub enum AnnotateError {
    /// Reading the scenario (frames, ground truth) failed.
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
    /// An edit does not fit the labels it is applied to (unknown id, frame out of range,
    /// empty interval, ...). Nothing was changed.
    #[error("invalid edit: {0}")]
    InvalidEdit(String),
    /// A label file, journal or imported file is malformed at a line.
    #[error("{path}:{line}: {problem}")]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong with that line.
        problem: String,
    },
    /// A file as a whole cannot be used.
    #[error("{path}: {problem}")]
    File {
        /// The file or folder.
        path: PathBuf,
        /// What is wrong, in words.
        problem: String,
    },
    /// The labels are open for editing in another process (a viewer or `vadscope
    /// labels`); nothing was read or changed.
    #[error(
        "{path}: these labels are being edited by another vadscope process (a viewer or \
         `vadscope labels`); close them there first"
    )]
    Busy {
        /// The locked journal.
        path: PathBuf,
    },
    /// The background journal writer failed or is gone; the edits are applied in memory
    /// and kept for the next attempt.
    #[error("saving labels to {path} failed: {problem}")]
    Save {
        /// The journal or label file being written.
        path: PathBuf,
        /// What went wrong, in words.
        problem: String,
    },
}

impl From<crate::atomic_file::WriteError> for AnnotateError {
    fn from(e: crate::atomic_file::WriteError) -> Self {
        Self::io(e.path, e.source)
    }
}

impl AnnotateError {
    /// Wraps an I/O error with the path it happened on.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// An invalid edit, with the reason.
    pub fn invalid(reason: impl Into<String>) -> Self {
        Self::InvalidEdit(reason.into())
    }

    /// A malformed line of `path`.
    pub fn line(path: &Path, line: usize, problem: impl Into<String>) -> Self {
        Self::Line {
            path: path.to_path_buf(),
            line,
            problem: problem.into(),
        }
    }

    /// A problem with `path` as a whole.
    pub fn file(path: &Path, problem: impl Into<String>) -> Self {
        Self::File {
            path: path.to_path_buf(),
            problem: problem.into(),
        }
    }
}
