//! Helpers of the integration tests, one home for the five test binaries (`core`, `cli`,
//! `app`, `parity`, `synth`). A binary that needs them includes this module one way,
//! `#[path = "../support/mod.rs"] mod support;`, and its tests reach the helpers as
//! `crate::support::<area>::…`. Everything here works on small data generated on the fly.

// Each binary uses only part of the helpers; the rest would be reported as dead code there.
#![allow(dead_code)]

pub mod annotate;
pub mod app;
pub mod cli;
pub mod flow;
pub mod model;
pub mod render;
pub mod scenario;
pub mod score;
pub mod sequence;
