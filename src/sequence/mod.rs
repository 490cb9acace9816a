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

pub mod boxes;
mod csv_table;
pub mod depth;
pub mod error;
pub mod flow_file;
pub mod images;
pub mod keyvalue;
pub mod labels;
pub mod layout;
pub mod meta;
pub mod palette;
pub mod py_literal;
pub mod types;
pub mod writer;

pub use error::SequenceError;
pub use flow_file::FlowField;
pub use types::*;
pub use writer::ScenarioWriter;
