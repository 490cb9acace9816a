//! The error type of the `sequence` module: every variant names the file and the problem.

use std::path::PathBuf;

/// An error from reading or writing scenario data. Every variant carries the path of the
/// file (or folder) involved so that a user can find and fix it.
#[derive(Debug, thiserror::Error)]
pub enum SequenceError {
    /// The operating system refused to read or write a file.
    #[error("{path}: {source}")]
    Io {
        /// File or folder involved.
        path: PathBuf,
        /// Underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// An image file could not be decoded.
    #[error("{path}: cannot decode image: {message}")]
    Image {
        /// Image file.
        path: PathBuf,
        /// What the decoder said.
        message: String,
    },
    /// A file was read but its content is not what the format requires.
    #[error("{path}: {problem}")]
    Format {
        /// File whose content is wrong.
        path: PathBuf,
        /// What is wrong, in words.
        problem: String,
    },
    /// A line of a text file (CSV, key-value) is malformed.
    #[error("{path}:{line}: {problem}")]
    Line {
        /// Text file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong with that line.
        problem: String,
    },
    /// A folder holds no scenario (no RGB frames, or no `Scenario_*` folders).
    #[error("{path}: {problem}")]
    NotAScenario {
        /// Folder that was opened.
        path: PathBuf,
        /// Why it is not a scenario.
        problem: String,
    },
}

impl SequenceError {
    /// Wraps an I/O error with the path it happened on.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// A content problem in `path`.
    pub fn format(path: impl Into<PathBuf>, problem: impl Into<String>) -> Self {
        Self::Format {
            path: path.into(),
            problem: problem.into(),
        }
    }

    /// A problem with line `line` (1-based) of `path`.
    pub fn line(path: impl Into<PathBuf>, line: usize, problem: impl Into<String>) -> Self {
        Self::Line {
            path: path.into(),
            line,
            problem: problem.into(),
        }
    }
}

impl Clone for SequenceError {
    /// Clones the error; an I/O source is rebuilt from its kind and message, because
    /// `std::io::Error` itself cannot be cloned. Lets lazily loaded files report the same
    /// error on every access.
    fn clone(&self) -> Self {
        match self {
            Self::Io { path, source } => Self::Io {
                path: path.clone(),
                source: std::io::Error::new(source.kind(), source.to_string()),
            },
            Self::Image { path, message } => Self::Image {
                path: path.clone(),
                message: message.clone(),
            },
            Self::Format { path, problem } => Self::Format {
                path: path.clone(),
                problem: problem.clone(),
            },
            Self::Line {
                path,
                line,
                problem,
            } => Self::Line {
                path: path.clone(),
                line: *line,
                problem: problem.clone(),
            },
            Self::NotAScenario { path, problem } => Self::NotAScenario {
                path: path.clone(),
                problem: problem.clone(),
            },
        }
    }
}

impl SequenceError {
    /// The problem in words, without the path (which [`SequenceError::path`] gives).
    pub fn problem(&self) -> String {
        match self {
            Self::Io { source, .. } => source.to_string(),
            Self::Image { message, .. } => format!("cannot decode image: {message}"),
            Self::Format { problem, .. } | Self::NotAScenario { problem, .. } => problem.clone(),
            Self::Line { line, problem, .. } => format!("line {line}: {problem}"),
        }
    }

    /// The file or folder the error is about.
    pub fn path(&self) -> &std::path::Path {
        match self {
            Self::Io { path, .. }
            | Self::Image { path, .. }
            | Self::Format { path, .. }
            | Self::Line { path, .. }
            | Self::NotAScenario { path, .. } => path,
        }
    }
}
