//! DIS presets and the full parameter set of the estimator.

use serde::{Deserialize, Serialize};

use super::error::FlowError;

/// A named operating point of the DIS estimator.
///
/// `Ultrafast`, `Fast` and `Medium` use the values of OpenCV's presets of the same names so
/// that results can be compared one to one; `Quality` is `Medium` run down to full
/// resolution. Serialised and parsed on the command line as `ultrafast`, `fast`, `medium`,
/// `quality`.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum DisPreset {
    /// Stops at 1/4 resolution, stride 4, 12 search iterations, no variational refinement.
    Ultrafast,
    /// Stops at 1/4 resolution, stride 4, 16 search iterations, variational refinement.
    Fast,
    /// Stops at 1/2 resolution, stride 3, 25 search iterations, variational refinement.
    #[default]
    Medium,
    /// `Medium` continued down to full resolution: about 4× slower, about half the error on
    /// small vehicle boxes.
    Quality,
}

impl DisPreset {
    /// Every preset, fastest first.
    pub const ALL: [DisPreset; 4] = [
        DisPreset::Ultrafast,
        DisPreset::Fast,
        DisPreset::Medium,
        DisPreset::Quality,
    ];

    /// The lowercase name used on the command line, in files and in cache folder names.
    pub fn name(self) -> &'static str {
        match self {
            DisPreset::Ultrafast => "ultrafast",
            DisPreset::Fast => "fast",
            DisPreset::Medium => "medium",
            DisPreset::Quality => "quality",
        }
    }
}

impl std::fmt::Display for DisPreset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for DisPreset {
    type Err = FlowError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        DisPreset::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| FlowError::InvalidParams {
                problem: format!(
                    "unknown preset {s:?} (expected ultrafast, fast, medium or quality)"
                ),
            })
    }
}

/// Patch sizes the search kernels are built for.
pub const SUPPORTED_PATCH_SIZES: [u32; 4] = [4, 8, 12, 16];

/// Every tunable of the DIS estimator. Build one with [`DisParams::from_preset`] and adjust
/// fields as needed; [`DisParams::validate`] checks a hand-made set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DisParams {
    /// Side of the square search patches, in pixels of the pyramid level: 4, 8, 12 or 16.
    pub patch_size: u32,
    /// Distance between neighbouring patch origins on the sparse grid (≤ `patch_size`).
    pub patch_stride: u32,
    /// Finest pyramid level processed (0 = full resolution, 1 = half, ...). The flow of this
    /// level is up-sampled bilinearly to full resolution.
    pub finest_scale: u32,
    /// Gauss–Newton iterations per patch and level, split over the forward and backward pass.
    pub gradient_descent_iterations: u32,
    /// Subtract the patch mean of the residual: makes the search robust to brightness changes.
    pub mean_normalization: bool,
    /// Try the neighbours' vectors as starting points (left/up, then right/down).
    pub spatial_propagation: bool,
    /// Fixed-point iterations of the variational refinement per level; 0 switches it off.
    pub refinement_iterations: u32,
    /// Successive over-relaxation sweeps per fixed-point iteration.
    pub sor_iterations: u32,
    /// SOR relaxation factor (between 1 and 2).
    pub sor_omega: f32,
    /// Weight of the smoothness term of the refinement energy.
    pub alpha: f32,
    /// Weight of the gradient-constancy term.
    pub gamma: f32,
    /// Weight of the brightness-constancy term.
    pub delta: f32,
}

impl DisParams {
    /// The parameters of a preset (OpenCV's values for the three shared names).
    pub fn from_preset(preset: DisPreset) -> Self {
        let base = DisParams {
            patch_size: 8,
            patch_stride: 4,
            finest_scale: 2,
            gradient_descent_iterations: 12,
            mean_normalization: true,
            spatial_propagation: true,
            refinement_iterations: 0,
            sor_iterations: 5,
            sor_omega: 1.6,
            alpha: 20.0,
            gamma: 10.0,
            delta: 5.0,
        };
        match preset {
            DisPreset::Ultrafast => base,
            DisPreset::Fast => DisParams {
                gradient_descent_iterations: 16,
                refinement_iterations: 5,
                ..base
            },
            DisPreset::Medium => DisParams {
                patch_stride: 3,
                finest_scale: 1,
                gradient_descent_iterations: 25,
                refinement_iterations: 5,
                ..base
            },
            DisPreset::Quality => DisParams {
                patch_stride: 3,
                finest_scale: 0,
                gradient_descent_iterations: 25,
                refinement_iterations: 5,
                ..base
            },
        }
    }

    /// Checks that the parameters describe a runnable estimator.
    pub fn validate(&self) -> Result<(), FlowError> {
        let bad = |problem: String| Err(FlowError::InvalidParams { problem });
        if !SUPPORTED_PATCH_SIZES.contains(&self.patch_size) {
            return bad(format!(
                "patch_size {} is not one of {SUPPORTED_PATCH_SIZES:?}",
                self.patch_size
            ));
        }
        if self.patch_stride == 0 || self.patch_stride > self.patch_size {
            return bad(format!(
                "patch_stride {} must be in 1..=patch_size ({})",
                self.patch_stride, self.patch_size
            ));
        }
        if self.finest_scale > 16 {
            return bad(format!(
                "finest_scale {} is larger than 16",
                self.finest_scale
            ));
        }
        if !(self.sor_omega > 0.0 && self.sor_omega < 2.0) {
            return bad(format!("sor_omega {} must lie in (0, 2)", self.sor_omega));
        }
        for (name, value) in [
            ("alpha", self.alpha),
            ("gamma", self.gamma),
            ("delta", self.delta),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return bad(format!("{name} {value} must be finite and non-negative"));
            }
        }
        Ok(())
    }
}

impl Default for DisParams {
    fn default() -> Self {
        Self::from_preset(DisPreset::default())
    }
}
