//! Writing a scenario's views and scores to files, for `vadscope render`, `vadscope export`
//! and the viewer's export dialog alike, so all three write the same pixels and the same
//! `scores.csv`.
//!
//! - [`FrameRenderer`]: a scenario, its score cache, the fused [`ScoreSeries`] and the
//!   view options; draws the [`FrameView`]s of one frame with `render`.
//! - [`export_frames`]: the views of a frame range as PNG files and/or one animated GIF
//!   per view ([`FramesExport`], [`FileNaming`]), with progress and cancellation.
//! - [`write_scores_csv`], [`write_png`], [`GifWriter`], [`frames_in`].
//!
//! [`ScoreSeries`]: crate::score::ScoreSeries

mod error;
mod files;
mod frames;

pub use crate::render::FrameView;
pub use error::ExportError;
pub use files::{GIF_FRAME_MS, GifWriter, frames_in, write_png, write_scores_csv};
pub use frames::{
    ExportProgress, ExportSummary, FileNaming, FrameRenderer, FramesExport, export_frames,
};
