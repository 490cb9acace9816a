//! Training of HF²-VAD_AD: the three stages of the reference (ML-MemAE-SC on the last flow;
//! the CVAE with ML-MemAE-SC frozen; everything fine-tuned), over sets of spatio-temporal
//! cubes, with seeded and resumable runs, model selection on held-out normal cubes (never on
//! test AUROC) and the training statistics the scores are normalised with.

pub mod config;
pub mod cubes;
pub mod error;
mod model_files;
pub mod scenarios;
pub mod stages;

pub use config::{LrSchedule, StageConfig, TrainConfig};
pub use cubes::CubeSet;
pub use error::TrainError;
pub use stages::{StageSummary, TrainEvent, TrainReport, train, train_from_checkpoint};
