//! Reading and writing AnoVox-style scenarios.
//!
//! This module owns everything on disk that describes a driving scenario: the frame index
//! (keyed by AnoVox/CARLA frame id), lazily decoded camera frames, semantic, instance and
//! depth images, pixel anomaly masks, per-frame anomaly flags, 2D boxes, optical flow files,
//! the ACTION/ANOMALY key-value CSVs and scenario metadata, plus a validation report and a
//! writer for the benchmark layout. It knows nothing of the model or the GUI.
//!
//! Frame *index* (0-based position in the sorted frame list) is the primary key everywhere;
//! the AnoVox frame id ([`FrameId`]) is kept beside it and never derived from time.
//!
//! Entry points:
//! - [`Scenario::open`] opens one scenario folder (benchmark or generator layout) and gives
//!   lazy, cached access by frame index: [`Scenario::rgb`], [`Scenario::semantic`],
//!   [`Scenario::instance`], [`Scenario::depth_m`], [`Scenario::anomaly_mask`],
//!   [`Scenario::flow`], [`Scenario::action`], [`Scenario::anomaly_state`],
//!   [`Scenario::boxes`], [`Scenario::detections`], [`Scenario::frame_labels`],
//!   [`Scenario::cache_dir`], and [`Scenario::validate`] for a [`ValidationReport`].
//! - [`discover_scenarios`] lists the scenarios under a dataset root; [`inspect()`] opens,
//!   summarises and validates all of them for `vadscope inspect` (text or JSON).
//! - [`ScenarioWriter`] writes the benchmark layout (thread-safe `write_frame`).
//! - File formats on their own: [`flow_file`] (KITTI PNG, `.flo`, `.npy`), [`depth`],
//!   [`images`], [`keyvalue`], [`boxes`], [`labels`], [`meta`], [`palette`].

pub mod boxes;
pub mod cache;
mod csv_table;
pub mod depth;
pub mod detections;
pub mod discovery;
pub mod error;
pub mod flow_file;
pub mod images;
pub mod index;
pub mod inspect;
pub mod keyvalue;
pub mod labels;
pub mod layout;
pub mod meta;
pub mod palette;
pub mod problem;
pub mod py_literal;
pub mod scenario;
pub mod types;
pub mod vadscope_dir;
pub mod validate;
pub mod writer;

pub use discovery::discover_scenarios;
pub use error::SequenceError;
pub use flow_file::FlowField;
pub use index::FrameIndex;
pub use inspect::{InspectReport, ScenarioSummary, inspect};
pub use labels::{FrameLabels, LabelSource};
pub use problem::FileProblem;
pub use scenario::{BoxSource, Scenario, ScenarioOptions};
pub use types::*;
pub use validate::ValidationReport;
pub use writer::ScenarioWriter;
