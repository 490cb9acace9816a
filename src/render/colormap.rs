//! Colormaps for heatmaps, error maps and score-coloured boxes: turbo, viridis, inferno and
//! jet, each a function from a value in [0, 1] to an RGB colour.
//!
//! Turbo uses Anton Mikhailov's published degree-5 polynomial fit (Google AI blog, 2019),
//! which follows the tabulated map closely in the middle but ends somewhat lighter (about
//! 0.1 off at 0 and 1); viridis and inferno use Matt Zucker's published degree-6 polynomial
//! fits of matplotlib's maps, within a few levels of the tables; jet is the classic
//! piecewise-linear map.

use std::fmt;
use std::str::FromStr;

/// A colormap from [0, 1] to RGB.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Colormap {
    /// Google's turbo: dark blue → cyan → green → yellow → red → dark red (the default).
    #[default]
    Turbo,
    /// matplotlib's viridis: dark purple → teal → yellow (perceptually uniform).
    Viridis,
    /// matplotlib's inferno: black → purple → orange → pale yellow (perceptually uniform).
    Inferno,
    /// The classic jet: dark blue → cyan → yellow → dark red.
    Jet,
}

/// Turbo's polynomial coefficients per channel, degree 0 to 5.
const TURBO: [[f32; 6]; 3] = [
    [
        0.135_721_38,
        4.615_392_6,
        -42.660_323,
        132.131_08,
        -152.942_39,
        59.286_38,
    ],
    [
        0.091_402_61,
        2.194_188_4,
        4.842_966_6,
        -14.185_033,
        4.277_298_6,
        2.829_566,
    ],
    [
        0.106_673_3,
        12.641_946,
        -60.582_047,
        110.362_77,
        -89.903_11,
        27.348_25,
    ],
];

#[allow(clippy::excessive_precision)]
/// Viridis' polynomial coefficients per degree 0 to 6, (r, g, b) each.
const VIRIDIS: [[f32; 3]; 7] = [
    [0.277_727_33, 0.005_407_344_5, 0.334_099_8],
    [0.105_093_04, 1.404_613_5, 1.384_590_2],
    [-0.330_861_83, 0.214_847_56, 0.095_095_16],
    [-4.634_230_4, -5.799_101, -19.332_441],
    [6.228_27, 14.179_933, 56.690_553],
    [4.776_385, -13.745_145, -65.353_03],
    [-5.435_456, 4.645_852_6, 26.312_435],
];

#[allow(clippy::excessive_precision)]
/// Inferno's polynomial coefficients per degree 0 to 6, (r, g, b) each.
const INFERNO: [[f32; 3]; 7] = [
    [0.000_218_940_37, 0.001_651_004_6, -0.019_480_899],
    [0.106_513_42, 0.563_956_4, 3.932_712_4],
    [11.602_493, -3.972_854, -15.942_394],
    [-41.703_995, 17.436_399, 44.354_145],
    [77.162_94, -33.402_36, -81.807_31],
    [-71.319_43, 32.626_064, 73.209_52],
    [25.131_126, -12.242_669, -23.070_325],
];

impl Colormap {
    /// Every colormap, in the order of the GUI's menu.
    pub const ALL: [Colormap; 4] = [Self::Turbo, Self::Viridis, Self::Inferno, Self::Jet];

    /// The name used on the command line and in menus.
    pub fn name(self) -> &'static str {
        match self {
            Self::Turbo => "turbo",
            Self::Viridis => "viridis",
            Self::Inferno => "inferno",
            Self::Jet => "jet",
        }
    }

    /// The colour of `value` in [0, 1]; values outside are clamped, NaN counts as 0.
    pub fn colorize(self, value: f32) -> [u8; 3] {
        let t = if value.is_nan() {
            0.0
        } else {
            value.clamp(0.0, 1.0)
        };
        let rgb = match self {
            Self::Turbo => {
                let mut out = [0.0f32; 3];
                for (c, coeffs) in TURBO.iter().enumerate() {
                    out[c] = coeffs.iter().rev().fold(0.0, |acc, &k| acc * t + k);
                }
                out
            }
            Self::Viridis => polynomial3(&VIRIDIS, t),
            Self::Inferno => polynomial3(&INFERNO, t),
            Self::Jet => {
                let ramp = |centre: f32| (1.5 - (4.0 * t - centre).abs()).clamp(0.0, 1.0);
                [ramp(3.0), ramp(2.0), ramp(1.0)]
            }
        };
        rgb.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
    }

    /// A 256-entry lookup table of the map (entry k is the colour of k / 255).
    pub fn lut(self) -> [[u8; 3]; 256] {
        let mut out = [[0u8; 3]; 256];
        for (k, entry) in out.iter_mut().enumerate() {
            *entry = self.colorize(k as f32 / 255.0);
        }
        out
    }
}

/// Evaluates a polynomial with (r, g, b) coefficients per degree at `t` (Horner).
fn polynomial3(coeffs: &[[f32; 3]; 7], t: f32) -> [f32; 3] {
    let mut out = [0.0f32; 3];
    for c in 0..3 {
        out[c] = coeffs.iter().rev().fold(0.0, |acc, k| acc * t + k[c]);
    }
    out
}

impl fmt::Display for Colormap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A colormap name that is not one of [`Colormap::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown colormap {0:?} (expected turbo, viridis, inferno or jet)")]
pub struct UnknownColormap(pub String);

impl FromStr for Colormap {
    type Err = UnknownColormap;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownColormap(s.to_string()))
    }
}
