//! The error type of the viewer's core: every variant names the file or folder involved and
//! says what is wrong, so that the log panel can show it as it is.

use std::path::PathBuf;

use crate::annotate::AnnotateError;
use crate::model::ModelError;
use crate::score::ScoreError;
use crate::sequence::SequenceError;

/// Everything that can go wrong opening data, scoring it or saving the analyst's work.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// A scenario or data set could not be read.
    #[error(transparent)]
    Sequence(#[from] SequenceError),
    /// Scores could not be produced, read or fused.
    #[error(transparent)]
    Score(#[from] ScoreError),
    /// The model could not be found or loaded.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The operating system refused to read or write a file.
    #[error("{path}: {source}")]
    Io {
        /// File or folder involved.
        path: PathBuf,
        /// Underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A file of the viewer's own (layout, tags) is not what it should be.
    #[error("{path}: {problem}")]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong, in words.
        problem: String,
    },
    /// The analyst's labels could not be opened, edited or saved.
    #[error(transparent)]
    Labels(#[from] AnnotateError),
    /// A labeling request does not fit the labels (nothing was changed).
    #[error("{0}")]
    Labeling(String),
    /// An export could not be written.
    #[error("{0}")]
    Export(String),
    /// A view could not be gathered for drawing (frame, maps or flow unreadable).
    #[error("{0}")]
    View(String),
    /// The window could not be opened (no display, no graphics adapter).
    #[error("cannot open the viewer window: {0}")]
    Window(String),
}

impl From<crate::atomic_file::WriteError> for AppError {
    fn from(e: crate::atomic_file::WriteError) -> Self {
        Self::io(e.path, e.source)
    }
}

impl AppError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}
