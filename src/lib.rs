//! vadscope: a viewer, labeling tool and HF²-VAD_AD runtime for video anomaly detection in
//! autonomous driving.
//!
//! The library is GUI-free below `app`; see `ARCHITECTURE.md` for the module map and the
//! one-way data flow.

pub mod annotate;
#[cfg(feature = "viewer")]
pub mod app;
pub mod atomic_file;
pub mod box_crop;
pub mod cpu_guard;
pub mod eval;
pub mod export;
pub mod flow;
pub mod fnv;
pub mod model;
pub mod render;
pub mod score;
pub mod sequence;
pub mod synth;
pub mod train;
