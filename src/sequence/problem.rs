//! [`FileProblem`]: a file and what is wrong with it, as discovery, label reading,
//! validation and inspection report the problems that are not fatal.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::error::SequenceError;

/// A file and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct FileProblem {
    /// The file (or folder).
    pub path: PathBuf,
    /// The problem, in words.
    pub problem: String,
}

impl FileProblem {
    /// A problem with `path`.
    pub fn new(path: &Path, problem: impl Into<String>) -> Self {
        Self {
            path: path.to_path_buf(),
            problem: problem.into(),
        }
    }

    /// The file and problem of an error.
    pub fn from_error(error: &SequenceError) -> Self {
        Self::new(error.path(), error.problem())
    }
}

impl std::fmt::Display for FileProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.problem)
    }
}
