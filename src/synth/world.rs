//! [`World`]: everything a frame is rendered from (spec, intrinsics, road, scenery, traffic,
//! lighting, texture salts), with the distant backdrop's elevation over azimuth.

use super::lighting::Lighting;
use super::road::Road;
use super::scenery::Scenery;
use super::spec::ScenarioSpec;
use super::texture::value2;
use super::traffic::Traffic;
use crate::sequence::{CameraIntrinsics, Domain};

/// Everything a frame is rendered from.
pub struct World {
    /// The spec it was built from.
    pub spec: ScenarioSpec,
    /// Camera intrinsics.
    pub intrinsics: CameraIntrinsics,
    /// Road.
    pub road: Road,
    /// Static objects.
    pub scenery: Scenery,
    /// Simulated traffic.
    pub traffic: Traffic,
    /// Condition.
    pub lighting: Lighting,
    /// Texture salts.
    pub ground_salt: u32,
    /// Cloud texture salt.
    pub cloud_salt: u32,
    /// Skyline / hills elevation (tangent) over azimuth, [`BACKDROP_SAMPLES`] samples over
    /// [-π, π).
    pub backdrop: Vec<f32>,
    /// Label the lead as agent car (114) / anomaly (100), as AnoVox does in sudden-braking
    /// scenarios.
    pub labels_lead_as_agent: bool,
}

/// Azimuth samples of the backdrop table.
pub const BACKDROP_SAMPLES: usize = 4096;

impl World {
    /// Backdrop elevation (tangent) at world azimuth `az` (radians), linearly interpolated.
    #[inline]
    pub fn backdrop_at(&self, az: f32) -> f32 {
        let n = BACKDROP_SAMPLES as f32;
        let x = (az + std::f32::consts::PI) / std::f32::consts::TAU * n;
        let i = (x.max(0.0) as usize) % BACKDROP_SAMPLES;
        let f = (x - i as f32).clamp(0.0, 1.0);
        let a = self.backdrop[i];
        let b = self.backdrop[(i + 1) % BACKDROP_SAMPLES];
        a + (b - a) * f
    }
}

/// Largest value [`backdrop_height`] returns.
pub const BACKDROP_MAX: f32 = 0.09;

/// Tangent of the elevation of the distant skyline (city) or hills (highway) at world
/// azimuth `az`.
pub fn backdrop_height(domain: Domain, az: f32, salt: u32) -> f32 {
    match domain {
        Domain::Highway => {
            let x = az * 9.0;
            0.012 + 0.05 * value2(x, 0.5, salt) + 0.02 * value2(x * 3.1, 1.5, salt ^ 7)
        }
        _ => {
            let bin = (az * 60.0).floor();
            let u = super::rng::unit1(bin as i32, salt);
            if u < 0.3 { 0.0 } else { 0.01 + 0.07 * u * u }
        }
    }
}
