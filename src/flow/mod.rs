//! Dense optical flow estimation and flow colouring.
//!
//! The estimator is DIS (Dense Inverse Search, Kroeger et al., ECCV 2016) with DeepFlow's
//! variational refinement, structured like OpenCV's `DISOpticalFlow` so that its presets
//! (`ultrafast`, `fast`, `medium`, plus `quality` = medium at full resolution) compare one to
//! one. Per pyramid level, coarse to fine:
//!
//! 1. a 2×2 area pyramid of both frames (luminance, `f32`);
//! 2. inverse-compositional Gauss–Newton search of every patch of a sparse grid, with
//!    spatial propagation between neighbours, mean normalisation and an optional temporal
//!    candidate ([`inverse_search`]);
//! 3. densification by photometric-error-weighted averaging of overlapping patches
//!    ([`densify`]);
//! 4. variational refinement by fixed-point and red-black SOR iterations ([`variational`]).
//!
//! The flow of the finest processed level is up-sampled bilinearly to full resolution.
//! Work is spread with rayon over a fixed partition, so the result does not depend on the
//! number of threads.
//!
//! [`cache`] fills a scenario's on-disk flow cache and [`evaluate`] scores cached flows
//! against a scenario's ground truth.
//!
//! Also here: the Middlebury colour coding ([`colorize_flow`]) and accuracy metrics
//! ([`endpoint_error`], [`box_endpoint_error`]). The module knows nothing of the model or the
//! GUI; its only dependency inside the crate is the shared [`FlowField`] type.

pub mod cache;
mod colorize;
mod densify;
mod dis;
mod error;
pub mod evaluate;
mod grid;
mod inverse_search;
mod metrics;
mod params;
mod plane;
mod simd;
pub mod source;
mod variational;

pub use colorize::{
    FlowColorRange, auto_range, color_wheel_legend, colorize_flow, colorize_flow_rgba, flow_color,
};
pub use dis::DisFlow;
pub use error::FlowError;
pub use metrics::{EndpointError, PixelBox, box_endpoint_error, crop_resize_flow, endpoint_error};
pub use params::{DisParams, DisPreset, SUPPORTED_PATCH_SIZES};
pub use plane::FlowFrame;
pub use source::{FlowProvider, FlowSource};

pub use crate::sequence::FlowField;
