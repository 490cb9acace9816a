//! The HF²-VAD_AD model in burn: ML-MemAE-SC, the VUNet CVAE and their combination
//! ([`Hf2Vad`]), their configuration and presets, losses, weight import (parity safetensors,
//! reference PyTorch checkpoints) and vadscope's own checkpoints.
//!
//! The networks follow `shared/design/hf2vad-model.md` Part B layer by layer; vadscope's
//! decisions (Part A) sit on top: deterministic inference with posterior means, RGB frames
//! and native-pixel flows, recorded per checkpoint in [`InputConventions`].

pub mod config;
pub mod error;
pub mod rng;

pub use config::{ColorOrder, FlowUnits, InputConventions, ModelConfig, SkipOp};
pub use error::ModelError;
pub use rng::NoiseRng;
