//! Conditions: sun, rain, fog and night as lighting, sky, haze and exposure parameters.

use super::math::{Rgb, V3};
use super::rng::Rng;
use crate::sequence::Weather;

/// How a frame is lit and what the atmosphere looks like.
#[derive(Debug, Clone, Copy)]
pub struct Lighting {
    /// The condition.
    pub weather: Weather,
    /// Unit vector towards the sun.
    pub sun_dir: V3,
    /// Direct sun irradiance (zero under overcast or at night).
    pub sun: Rgb,
    /// Sky light from above.
    pub sky_ambient: Rgb,
    /// Light bounced from the ground (lights downward-facing surfaces).
    pub ground_ambient: Rgb,
    /// Sky radiance at the zenith.
    pub zenith: Rgb,
    /// Sky radiance at the horizon.
    pub horizon: Rgb,
    /// Colour of haze / fog.
    pub haze: Rgb,
    /// Distance (m) over which haze closes to 1/e.
    pub haze_distance: f32,
    /// Exposure multiplier before tone mapping.
    pub exposure: f32,
    /// 0 dry … 1 soaked road.
    pub wetness: f32,
    /// Cloud cover 0 … 1.
    pub clouds: f32,
    /// Night: street lamps and headlights on, lit windows.
    pub night: bool,
    /// Rain streaks drawn over the image.
    pub rain: bool,
    /// Colour saturation loss 0 … 1.
    pub desaturate: f32,
}

impl Lighting {
    /// The lighting of a condition, with small seeded variations.
    pub fn new(weather: Weather, rng: &mut Rng) -> Self {
        let azimuth = rng.range(-std::f32::consts::PI, std::f32::consts::PI);
        let elevation = rng.range(28.0f32, 60.0).to_radians();
        let sun_dir = V3::new(
            elevation.cos() * azimuth.cos(),
            elevation.cos() * azimuth.sin(),
            elevation.sin(),
        );
        let base = Lighting {
            weather,
            sun_dir,
            sun: Rgb::new(3.1, 2.9, 2.6),
            sky_ambient: Rgb::new(0.42, 0.5, 0.68),
            ground_ambient: Rgb::new(0.12, 0.11, 0.1),
            zenith: Rgb::new(0.16, 0.32, 0.85),
            horizon: Rgb::new(0.72, 0.82, 0.98),
            haze: Rgb::new(0.68, 0.76, 0.9),
            haze_distance: rng.range(900.0, 1500.0),
            exposure: 0.62,
            wetness: 0.0,
            clouds: rng.range(0.1, 0.45),
            night: false,
            rain: false,
            desaturate: 0.0,
        };
        match weather {
            Weather::Rain => Lighting {
                sun: Rgb::BLACK,
                sky_ambient: Rgb::new(0.78, 0.8, 0.84),
                ground_ambient: Rgb::new(0.12, 0.12, 0.12),
                zenith: Rgb::new(0.36, 0.38, 0.42),
                horizon: Rgb::new(0.58, 0.6, 0.63),
                haze: Rgb::new(0.5, 0.52, 0.55),
                haze_distance: rng.range(180.0, 300.0),
                exposure: 0.72,
                wetness: 1.0,
                clouds: 1.0,
                rain: true,
                desaturate: 0.35,
                ..base
            },
            Weather::Fog => Lighting {
                sun: Rgb::new(0.5, 0.5, 0.48),
                sky_ambient: Rgb::new(0.85, 0.87, 0.9),
                ground_ambient: Rgb::new(0.15, 0.15, 0.15),
                zenith: Rgb::new(0.75, 0.77, 0.8),
                horizon: Rgb::new(0.8, 0.82, 0.85),
                haze: Rgb::new(0.8, 0.82, 0.85),
                haze_distance: rng.range(45.0, 75.0),
                exposure: 0.7,
                wetness: 0.25,
                clouds: 1.0,
                desaturate: 0.3,
                ..base
            },
            Weather::Night => Lighting {
                sun: Rgb::BLACK,
                sky_ambient: Rgb::new(0.012, 0.016, 0.03),
                ground_ambient: Rgb::new(0.004, 0.004, 0.005),
                zenith: Rgb::new(0.002, 0.003, 0.008),
                horizon: Rgb::new(0.03, 0.03, 0.04),
                haze: Rgb::new(0.02, 0.02, 0.028),
                haze_distance: rng.range(400.0, 700.0),
                exposure: 2.6,
                wetness: if rng.chance(0.4) { 0.6 } else { 0.0 },
                clouds: rng.range(0.2, 0.8),
                night: true,
                desaturate: 0.1,
                ..base
            },
            _ => base,
        }
    }

    /// Time of day recorded in the metadata.
    pub fn time_of_day(&self) -> &'static str {
        if self.night { "night" } else { "day" }
    }
}
