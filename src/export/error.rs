//! The error type of `export`: every variant names the file or scenario involved.

use std::path::PathBuf;

use crate::render::RenderError;
use crate::score::ScoreError;
use crate::sequence::SequenceError;

/// What can go wrong writing an export.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// A frame's data could not be gathered (frame, maps or flow unreadable).
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The scenario could not be opened.
    #[error(transparent)]
    Sequence(#[from] SequenceError),
    /// The score cache could not be opened.
    #[error(transparent)]
    Score(#[from] ScoreError),
    /// The scenario has no current score cache to export from.
    #[error("{scenario}: no current score cache; score the scenario first")]
    NoScores {
        /// The scenario folder.
        scenario: PathBuf,
    },
    /// A file or folder could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// An image could not be encoded or written.
    #[error("cannot write {path}: {source}")]
    Image {
        /// The file.
        path: PathBuf,
        /// Underlying image error.
        #[source]
        source: image::ImageError,
    },
    /// The requested frames are not in the scenario.
    #[error("{scenario}: no frame in {start}..{end} (the scenario has {frames} frames)")]
    NoFrames {
        /// The scenario folder.
        scenario: PathBuf,
        /// First requested frame.
        start: usize,
        /// End of the requested frames (excluded).
        end: usize,
        /// Frames in the scenario.
        frames: usize,
    },
    /// The export was cancelled; the files written so far are complete.
    #[error("export cancelled after {written} files")]
    Cancelled {
        /// Files completely written before the cancel.
        written: usize,
    },
}

impl From<crate::atomic_file::WriteError> for ExportError {
    fn from(e: crate::atomic_file::WriteError) -> Self {
        Self::io(e.path, e.source)
    }
}

impl ExportError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}
