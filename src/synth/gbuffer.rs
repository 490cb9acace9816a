//! [`GBuffer`]: the per-pixel geometry of a frame (object key, depth, surface point), which
//! ray casting fills and the next frame's flow, post-processing and labels read.

use super::math::V3;

/// Per-pixel geometry of a frame, kept for the next frame's flow.
#[derive(Debug, Clone)]
pub struct GBuffer {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Object key per pixel.
    pub key: Vec<u32>,
    /// Depth along the optical axis (infinite for sky and backdrop).
    pub depth: Vec<f32>,
    /// Surface point: vehicle-local for vehicles, world for everything static, the ray
    /// direction for sky and backdrop.
    pub point: Vec<V3>,
}
