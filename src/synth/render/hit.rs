//! What a ray meets: the nearest surface ([`Hit`]), and what a ray of an image row shares
//! with its neighbours ([`PlaneHits`], [`GroundHint`]).

use crate::synth::keys::KEY_SKY;
use crate::synth::math::V3;

/// The nearest surface along a ray.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Ray parameter = depth along the optical axis (infinite for sky and backdrop).
    pub t: f32,
    /// Object key.
    pub key: u32,
    /// Index of the primitive in the frame's list (`u32::MAX` for ground, sky, backdrop).
    pub prim: u32,
    /// Part index for vehicles (wheels are `WHEEL_PART + k`), 1 for a kerb face, 0 otherwise.
    pub part: u8,
    /// Hit point: object-local for primitives, (s, d, z) for the ground, the ray direction
    /// for sky and backdrop.
    pub local: V3,
    /// Surface normal: object-local for primitives, world for the ground.
    pub normal: V3,
}

/// Part index offset of wheels.
pub const WHEEL_PART: u8 = 64;

impl Hit {
    /// The sky in direction `dir`.
    pub(super) fn sky(dir: V3) -> Self {
        Hit {
            t: f32::INFINITY,
            key: KEY_SKY,
            prim: u32::MAX,
            part: 0,
            local: dir,
            normal: V3::default(),
        }
    }
}

/// Ray parameters at which a camera ray meets the road plane and the raised-sidewalk plane
/// (infinite for rays that do not descend).
#[derive(Debug, Clone, Copy)]
pub struct PlaneHits {
    /// Where the ray meets the road plane.
    pub(super) floor: f32,
    /// Where the ray meets the raised-sidewalk plane.
    pub(super) raised: f32,
}

/// Where a nearby ray of the same image row met the ground: the start of the next ray's
/// Frenet inversion.
#[derive(Debug, Clone, Copy)]
pub struct GroundHint {
    /// Expected arc length of the next ray's ground point.
    pub s: f32,
    /// Whether the nearby ray landed on the raised sidewalk level.
    pub raised: bool,
}
