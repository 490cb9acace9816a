//! Training of HF²-VAD_AD: the three stages of the reference (ML-MemAE-SC on the last flow;
//! the CVAE with ML-MemAE-SC frozen; everything fine-tuned), over sets of spatio-temporal
//! cubes, with seeded and resumable runs, model selection on held-out normal cubes or on
//! validation scenarios with anomalies (never on test data), optional averaging of the late
//! epochs' weights and the training statistics the scores are normalised with.

pub mod averaging;
pub mod config;
pub mod cubes;
pub mod error;
mod measure;
mod model_files;
pub mod progress;
mod run_state;
pub mod scenarios;
pub mod selection;
pub mod stages;

pub use averaging::WeightAveraging;
pub use config::{LrSchedule, StageConfig, TrainConfig};
pub use cubes::CubeSet;
pub use error::TrainError;
pub use progress::{StageSummary, TrainEvent, TrainReport};
pub use selection::{AnomalySelection, EpochJudge};
pub use stages::{train, train_from_checkpoint, train_judged};
