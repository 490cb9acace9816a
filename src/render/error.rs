//! The error type of the `render` module: gathering a frame's data from a scenario and its
//! score cache can fail; drawing itself cannot.

use crate::score::ScoreError;
use crate::sequence::SequenceError;

/// What can go wrong gathering the data of a view.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Reading the scenario failed (frame, mask, flow).
    #[error(transparent)]
    Sequence(#[from] SequenceError),
    /// Reading the score cache or fusing its scores failed.
    #[error(transparent)]
    Score(#[from] ScoreError),
    /// The frame index lies outside the scenario.
    #[error("{scenario}: frame {index} does not exist (the scenario has {frames} frames)")]
    NoSuchFrame {
        /// Scenario name.
        scenario: String,
        /// The requested frame index.
        index: usize,
        /// Frames in the scenario.
        frames: usize,
    },
}
