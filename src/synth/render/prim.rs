//! The primitives of a frame: static objects (panels in pieces) and vehicles, placed
//! camera-relative with the screen bounds they are binned by.

use crate::synth::keys::{KEY_STATIC, KEY_VEHICLE};
use crate::synth::math::V3;

/// What a primitive of a frame is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrimRef {
    /// Index into `Scenery::objects`.
    Static(u32),
    /// Index into `Traffic::vehicles`.
    Vehicle(u32),
}

/// A primitive placed for one frame, in camera-relative coordinates.
#[derive(Debug, Clone, Copy)]
pub struct Prim {
    /// What it is.
    pub what: PrimRef,
    /// Local origin relative to the camera's ground position.
    pub origin: V3,
    /// cos(yaw).
    pub c: f32,
    /// sin(yaw).
    pub s: f32,
    /// Smallest depth of the primitive's bounds (no hit can be nearer).
    pub near: f32,
    /// Screen rectangle of the geometry itself (binning may use a larger one that includes
    /// shadows); rays outside it cannot hit.
    pub rect: [f32; 4],
    /// The camera's ray origin in the primitive's local frame (the same for every ray).
    pub eye: V3,
    /// The part of the object's local x extent this primitive stands for: panels are split
    /// into pieces of at most [`PANEL_PIECE`] so that each piece gets tight screen bounds.
    pub x_range: (f32, f32),
}

/// Longest piece of a panel that is binned as one primitive (m).
pub(super) const PANEL_PIECE: f32 = 4.0;

impl Prim {
    /// Object key for flow and occlusion tests.
    pub fn key(&self) -> u32 {
        match self.what {
            PrimRef::Static(i) => KEY_STATIC + i,
            PrimRef::Vehicle(i) => KEY_VEHICLE | i,
        }
    }
}
