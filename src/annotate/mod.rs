//! The analyst's labels of a scenario: anomaly intervals, box tracks (keyframes, linear
//! interpolation, an `outside` flag), failure-case tags on frame ranges and notes on
//! frames; undo and redo; crash-safe saving; import and export formats.
//!
//! The scenario's ground truth (`sequence`: frame labels, `BBOX_2D` boxes) is the starting
//! point; the labels are kept in vadscope's folder of the scenario
//! ([`crate::sequence::Scenario::cache_dir`]), never in its source files. Frame index is the
//! key everywhere; the AnoVox frame ids are kept beside it for exports.
//!
//! Entry points:
//! - [`Editor`]: what the viewer holds. [`Editor::apply`] an [`Edit`], [`Editor::undo`],
//!   [`Editor::redo`]; queries on [`Editor::labels`] ([`LabelSet::intervals_at`],
//!   [`LabelSet::boxes_at`], [`LabelSet::nearest_edge`]) and [`Editor::lane`] (one
//!   [`LaneCell`] per frame) are cheap enough for every redraw.
//! - Saving: every edit goes to `labels.journal` (fsynced by a background writer; with
//!   [`SaveMode::Durable`] before `apply` returns, with [`SaveMode::Background`] before
//!   [`Editor::flush`] returns); [`Editor::compact`] writes `labels.json` atomically.
//!   Opening replays the journal records newer than `labels.json`; damaged files are
//!   reported, copied aside and everything readable is kept.
//! - [`export_labels`] / [`import_labels`] with a [`LabelFormat`].

mod document;
mod edit;
mod editor;
mod error;
mod formats;
mod ground_truth;
mod journal;
mod labels;
mod lane;
mod tracks;
mod writer;

pub use document::{FORMAT_NAME, FORMAT_VERSION};
pub use edit::Edit;
pub use editor::{Editor, SaveMode};
pub use error::AnnotateError;
pub use formats::{ExportSummary, Import, LabelFormat, export_labels, import_labels};
pub use ground_truth::{DEFAULT_CLASS, ground_truth_labels, intervals_from_flags, scenario_class};
pub use journal::{JournalRecord, Step, read_journal};
pub use labels::{
    Edge, EdgeRef, FailureTag, FrameBox, Interval, IntervalId, Keyframe, LabelSet, Origin, Rect,
    TagId, Track, TrackId,
};
pub use lane::{LabelLane, LaneCell};
pub use tracks::{boxes_by_frame, tracks_from_boxes};
pub use writer::{JOURNAL_FILE, LABELS_FILE};
