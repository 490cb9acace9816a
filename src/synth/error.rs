//! The error type of the generator.

use std::path::PathBuf;

use crate::sequence::SequenceError;

/// Why a scenario could not be generated.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// The spec or request asks for something the generator cannot do.
    #[error("invalid scenario spec: {problem}")]
    InvalidSpec {
        /// What is wrong.
        problem: String,
    },
    /// No seeded variant of the scenario satisfied its constraints.
    #[error(
        "scenario {scenario}: no variant satisfied the scenario's constraints (last problem: {problem})"
    )]
    Unsatisfiable {
        /// Scenario name.
        scenario: String,
        /// The problem of the last attempt.
        problem: String,
    },
    /// A scenario folder that exists does not hold what the spec would write.
    #[error("{path} already exists but does not hold this scenario: {problem}")]
    NotTheSame {
        /// Scenario folder.
        path: PathBuf,
        /// The first difference found.
        problem: String,
    },
    /// Writing the scenario failed.
    #[error("writing scenario {path}: {source}")]
    Write {
        /// Scenario folder.
        path: PathBuf,
        /// What the writer reported.
        #[source]
        source: SequenceError,
    },
}
