//! The error type of the `flow` module.

use std::path::PathBuf;

/// Why a flow could not be estimated, compared or stored.
///
/// Estimation errors describe the offending input (sizes, parameters); file errors name the
/// file involved.
#[derive(Debug, thiserror::Error)]
pub enum FlowError {
    /// The two frames of a pair do not have the same size.
    #[error(
        "frame size mismatch: previous frame is {prev_width}×{prev_height}, next frame is {next_width}×{next_height}"
    )]
    FrameSizeMismatch {
        /// Width of the previous frame.
        prev_width: u32,
        /// Height of the previous frame.
        prev_height: u32,
        /// Width of the next frame.
        next_width: u32,
        /// Height of the next frame.
        next_height: u32,
    },
    /// The frames are smaller than one search patch, so no flow can be estimated.
    #[error(
        "frames of {width}×{height} are smaller than one {patch_size}×{patch_size} search patch"
    )]
    FrameTooSmall {
        /// Frame width.
        width: u32,
        /// Frame height.
        height: u32,
        /// Patch size of the estimator.
        patch_size: u32,
    },
    /// Two flow fields that must share a grid do not (e.g. an estimate and its ground truth,
    /// or a temporal prior and the frames).
    #[error("{what}: expected a {expected_width}×{expected_height} flow, got {width}×{height}")]
    FlowSizeMismatch {
        /// Which flow was wrong, in words.
        what: &'static str,
        /// Expected width.
        expected_width: u32,
        /// Expected height.
        expected_height: u32,
        /// Actual width.
        width: u32,
        /// Actual height.
        height: u32,
    },
    /// A flow field's buffers do not match its declared size.
    #[error("malformed flow field: {problem}")]
    MalformedFlow {
        /// What is inconsistent, in words.
        problem: String,
    },
    /// A parameter set is unusable (e.g. zero patch size or a stride larger than the patch).
    #[error("invalid DIS parameters: {problem}")]
    InvalidParams {
        /// What is wrong, in words.
        problem: String,
    },
    /// A box given to a patch metric does not overlap the flow field.
    #[error("box ({x1}, {y1})–({x2}, {y2}) covers no pixel of a {width}×{height} flow")]
    EmptyBox {
        /// Left edge.
        x1: f32,
        /// Top edge.
        y1: f32,
        /// Right edge (exclusive).
        x2: f32,
        /// Bottom edge (exclusive).
        y2: f32,
        /// Flow width.
        width: u32,
        /// Flow height.
        height: u32,
    },
    /// Estimating the flow into one frame of a scenario failed.
    #[error("{scenario}: frame {index}: {source}")]
    Frame {
        /// The scenario folder.
        scenario: PathBuf,
        /// Index of the frame the flow leads into.
        index: usize,
        /// What went wrong.
        #[source]
        source: Box<FlowError>,
    },
    /// Reading scenario data failed (the error names the file).
    #[error(transparent)]
    Sequence(#[from] crate::sequence::SequenceError),
    /// Reading or writing a file failed.
    #[error("{path}: {problem}")]
    File {
        /// The file involved.
        path: PathBuf,
        /// What went wrong, in words.
        problem: String,
    },
}
