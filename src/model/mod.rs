//! The HF²-VAD_AD model in burn: ML-MemAE-SC, the VUNet CVAE and their combination
//! ([`Hf2Vad`]), their configuration and presets, losses, weight import (parity safetensors,
//! reference PyTorch checkpoints) and vadscope's own checkpoints.
//!
//! The networks follow `shared/design/hf2vad-model.md` Part B layer by layer; vadscope's
//! decisions (Part A) sit on top: deterministic inference with posterior means, RGB frames
//! and native-pixel flows, recorded per checkpoint in [`InputConventions`].

pub mod box_filter;
pub mod bundled;
pub mod checkpoint;
pub mod config;
pub mod error;
pub mod gemm_conv;
pub mod hf2vad;
pub mod inference;
pub mod layers;
pub mod losses;
pub mod memae;
pub mod rng;
pub mod score_tail;
pub mod stats;
pub mod stc;
pub mod vunet;
pub mod weights;

pub use box_filter::BoxFilter;
pub use bundled::{BUNDLED_MODEL_FILE, MODEL_ENV, bundled_model};
pub use checkpoint::{
    Checkpoint, CheckpointMeta, load_checkpoint, read_checkpoint_meta, save_checkpoint,
};
pub use config::{ColorOrder, FlowUnits, InputConventions, ModelConfig, ScoreScale, SkipOp};
pub use error::ModelError;
pub use hf2vad::{Hf2Vad, Hf2VadOutput};
pub use inference::{CubeResult, Detector, InferenceLatents};
pub use memae::{MemAeOutput, MlMemAeSc};
pub use rng::NoiseRng;
pub use score_tail::TailTable;
pub use stats::{
    BandStats, ObjectStatistics, PixelStats, ScoreStats, ScoreTails, StatsAccumulator,
    TrainingStats, band_of,
};
pub use vunet::{Latents, Vunet, VunetOutput};
