//! `ModelConfig`: every size of the HF²-VAD networks, the presets (`paper`, `compact`,
//! `parity`) and the input conventions (colour order, flow units) a set of weights expects.
//!
//! The config travels inside every checkpoint, so a model can always be rebuilt from its file.

use serde::{Deserialize, Serialize};

use super::box_filter::BoxFilter;
use super::error::ModelError;

/// Number of colour channels of a frame.
pub const IMG_CHANNELS: usize = 3;
/// Number of channels of one optical flow (u, v).
pub const FLOW_CHANNELS: usize = 2;

/// How the decoder of ML-MemAE-SC merges an encoder feature into an upsampled one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SkipOp {
    /// No skip connection at this level.
    None,
    /// Concatenate `[encoder feature, upsampled]` on channels.
    Concat,
}

/// Channel order of the frames a model was trained on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ColorOrder {
    /// Red, green, blue (vadscope's convention).
    Rgb,
    /// Blue, green, red (the reference code reads frames with OpenCV).
    Bgr,
}

/// Units of the flow values a model was trained on.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FlowUnits {
    /// Displacements in pixels of the frame the flow belongs to (vadscope's convention).
    NativePixels,
    /// Displacements in pixels of the P×P patch: native u is multiplied by P / (crop width)
    /// and native v by P / (crop height) of each cube, so a box's motion reads the same
    /// whatever its size in the image (vadscope's option beyond the paper; the reference
    /// keeps native pixels). The factors depend on the box, so they are applied where the
    /// cube is cut ([`super::stc`]); [`FlowUnits::factors`] is (1, 1) for this variant.
    Patch,
    /// Displacements in pixels of a frame `width` pixels wide: native u and v are multiplied
    /// by `width` / the frame's width, so a model trained on frames of one width reads the
    /// same motion in frames of another (vadscope's option beyond the paper: native pixels
    /// halve with the resolution). The factor depends on the frame, so, as for
    /// [`FlowUnits::Patch`], it is applied where the cube is cut and [`FlowUnits::factors`]
    /// is (1, 1).
    FrameWidth {
        /// The width the flows are rescaled to, normally the training frames'.
        width: u32,
    },
    /// Displacements in pixels of a resized grid: native u is multiplied by `x` and native v
    /// by `y` before the model sees them. The reference leaves FlowNet2 flows in its input
    /// grid (e.g. 1024×640 for 768×512 CARLA frames: x = 4/3, y = 5/4).
    Scaled {
        /// Factor applied to the horizontal component.
        x: f32,
        /// Factor applied to the vertical component.
        y: f32,
    },
}

impl FlowUnits {
    /// Whether a model trained on flows in `self` may be continued as one in `to` without
    /// retraining: only native pixels named frame-width units, which leaves the cubes of
    /// frames as wide as the reference width as they were.
    pub fn relabels_as(self, to: FlowUnits) -> bool {
        matches!(
            (self, to),
            (FlowUnits::NativePixels, FlowUnits::FrameWidth { .. })
        )
    }

    /// The (u, v) factors that turn native-pixel flows into the model's units.
    pub fn factors(&self) -> [f32; 2] {
        match self {
            FlowUnits::NativePixels | FlowUnits::Patch | FlowUnits::FrameWidth { .. } => [1.0, 1.0],
            FlowUnits::Scaled { x, y } => [*x, *y],
        }
    }
}

/// What the inputs of a set of weights look like. Frames are always in [0, 1]; flow stored at
/// frame i is the motion from frame i−1 to frame i, (u, v) = (right, down).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InputConventions {
    /// Channel order of the frames.
    pub color_order: ColorOrder,
    /// Units of the flow values.
    pub flow_units: FlowUnits,
}

impl InputConventions {
    /// vadscope's own convention: RGB frames, flows in native pixels.
    pub fn vadscope() -> Self {
        Self {
            color_order: ColorOrder::Rgb,
            flow_units: FlowUnits::NativePixels,
        }
    }

    /// The reference code's convention (BGR frames); the flow scale depends on the data set
    /// and is left at native pixels unless the caller knows it.
    pub fn reference(flow_units: FlowUnits) -> Self {
        Self {
            color_order: ColorOrder::Bgr,
            flow_units,
        }
    }
}

/// Every size of ML-MemAE-SC and the CVAE (spec Part B §3 and §4), plus the input
/// conventions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelConfig {
    /// Preset name this config came from (free text for edited configs).
    pub preset: String,
    /// Side of the square cube patches (32 in the reference).
    pub patch_size: usize,
    /// Number of past frames the CVAE sees (t = 4). The cube holds `clip_hist + 1` frames.
    pub clip_hist: usize,
    /// Number of flows in a cube (4); each is reconstructed separately by ML-MemAE-SC. The
    /// reference reconstructs `clip_hist` flows and feeds `num_flows` to the CVAE, so the two
    /// must agree.
    pub num_flows: usize,
    /// Width of the first ML-MemAE-SC level; levels double it (×2, ×4, ×8).
    pub feature_root: usize,
    /// Slots per memory module.
    pub num_slots: usize,
    /// Hard-shrinkage threshold λ on the memory attention (reference: 1/num_slots).
    pub shrink_thres: f64,
    /// Which levels carry a memory: index 1 = 16×16, 2 = 8×8, 3 = 4×4 (for a 32×32 patch).
    /// Index 0 has no memory module in the reference and is ignored, as there.
    pub mem_usage: [bool; 4],
    /// Skip connections of the decoder levels, top (full resolution) first.
    pub skip_ops: [SkipOp; 3],
    /// Width of the first CVAE encoder stage.
    pub nf_start: usize,
    /// Widest CVAE stage, also the latent channel count.
    pub nf_max: usize,
    /// Dropout probability inside every CVAE residual block.
    pub dropout: f64,
    /// What the weights expect as input.
    pub conventions: InputConventions,
    /// Which boxes are scored and trained on. Recorded so that scoring filters exactly as
    /// training did; absent in older checkpoints, which keep every box (the default).
    #[serde(default)]
    pub box_filter: BoxFilter,
    /// ML-MemAE-SC reconstructs the cube's `num_flows` flows jointly (2·t channels in and
    /// out), so a change of motion across the cube is part of what it learns; the
    /// reference (`false`, the default) reconstructs each flow on its own.
    #[serde(default)]
    pub joint_flows: bool,
    /// Equal vertical bands of the image whose objects get training score moments of their
    /// own ([`super::TrainingStats::bands`], by the box centre): an object is then scored
    /// against the normal objects *at its place*. 1 (the reference, and the default of older
    /// checkpoints) keeps one global z-score.
    #[serde(default = "one_band")]
    pub score_bands: usize,
    /// How an object's S_r and S_p are made comparable before the fusion weights multiply
    /// them ([`ScoreScale`]). Absent in older checkpoints, which z-score (the reference).
    #[serde(default)]
    pub score_scale: ScoreScale,
}

/// How an object's S_r and S_p are normalised before fusion.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScoreScale {
    /// (S − μ) / σ with the training moments (the reference).
    #[default]
    ZScore,
    /// −ln P(S' ≥ S) over the training cubes' scores ([`super::score_tail`]): how rare an
    /// error this large is among normal objects, robust to S_r's heavy tail.
    TailSurprisal,
}

/// The reference's single, global score statistic.
fn one_band() -> usize {
    1
}

/// Most score bands a model may use.
pub const MAX_SCORE_BANDS: usize = 16;

/// Upper bounds on the sizes a config may ask for. A checkpoint's config comes from a file
/// that may not be ours: these refuse one that would make the model's construction allocate
/// without bound (the paper's sizes are 32, 4, 32, 2,000 and 64, far inside).
pub const MAX_PATCH_SIZE: usize = 256;
/// Most past frames (and flows) a cube may hold.
pub const MAX_CLIP_HIST: usize = 16;
/// Most base features of ML-MemAE-SC, and of the CVAE's first stage.
pub const MAX_FEATURES: usize = 1024;
/// Most memory slots per level.
pub const MAX_SLOTS: usize = 65_536;
/// Most trainable parameters (1 GB of `f32`).
pub const MAX_PARAMETERS: usize = 250_000_000;

impl ModelConfig {
    /// The reference configuration, spec Part B exactly (69.2 M parameters, ≈2.1 GMAC per
    /// cube).
    pub fn paper() -> Self {
        Self {
            preset: "paper".into(),
            patch_size: 32,
            clip_hist: 4,
            num_flows: 4,
            feature_root: 32,
            num_slots: 2000,
            shrink_thres: 1.0 / 2000.0,
            mem_usage: [false, true, true, true],
            skip_ops: [SkipOp::None, SkipOp::Concat, SkipOp::Concat],
            nf_start: 64,
            nf_max: 128,
            dropout: 0.1,
            conventions: InputConventions::vadscope(),
            box_filter: BoxFilter::KEEP_ALL,
            joint_flows: false,
            score_bands: 1,
            score_scale: ScoreScale::ZScore,
        }
    }

    /// The bundled CPU model: same architecture, narrower.
    ///
    /// * `feature_root` 16 (paper 32): ML-MemAE-SC convolutions cost a quarter, and the
    ///   memory slots (whole feature maps) become half as long.
    /// * `num_slots` 500 (paper 2000), λ = 1/500 as the reference pairs λ with 1/slots: the
    ///   memories hold 500 × 14,336 values = 7.2 M parameters instead of 57.3 M, which is what
    ///   keeps the file small (the slots are 83 % of the paper model).
    /// * `nf_start`/`nf_max` 32/64 (paper 64/128): the CVAE costs about a quarter.
    ///
    /// Result: ≈ 9.9 M parameters (≈ 40 MB in f32, under the 60 MB budget) and ≈ 0.47 GMAC per
    /// cube (paper 2.12), which is what makes the three training stages fit a 2-core CPU.
    pub fn compact() -> Self {
        Self {
            preset: "compact".into(),
            feature_root: 16,
            num_slots: 500,
            shrink_thres: 1.0 / 500.0,
            nf_start: 32,
            nf_max: 64,
            ..Self::paper()
        }
    }

    /// The small configuration of the parity fixtures (`shared/parity/README.md` §2):
    /// feature_root 8, 16 slots, λ = 1/16, nf 16/32, reference (BGR) conventions.
    pub fn parity() -> Self {
        Self {
            preset: "parity".into(),
            feature_root: 8,
            num_slots: 16,
            shrink_thres: 1.0 / 16.0,
            nf_start: 16,
            nf_max: 32,
            conventions: InputConventions::reference(FlowUnits::NativePixels),
            ..Self::paper()
        }
    }

    /// Looks a preset up by name (`paper`, `compact`, `parity`).
    pub fn preset(name: &str) -> Result<Self, ModelError> {
        match name {
            "paper" => Ok(Self::paper()),
            "compact" => Ok(Self::compact()),
            "parity" => Ok(Self::parity()),
            other => Err(ModelError::InvalidConfig(format!(
                "unknown preset '{other}' (known: paper, compact, parity)"
            ))),
        }
    }

    /// Number of CVAE resolution stages: 1 + round(log2(patch)) − 2 (4 for 32×32).
    pub fn n_stages(&self) -> usize {
        (self.patch_size as f64).log2().round() as usize - 1
    }

    /// Number of frame channels in a cube: `(clip_hist + 1) · 3`.
    pub fn cube_frame_channels(&self) -> usize {
        (self.clip_hist + 1) * IMG_CHANNELS
    }

    /// Number of flow channels in a cube: `num_flows · 2`.
    pub fn cube_flow_channels(&self) -> usize {
        self.num_flows * FLOW_CHANNELS
    }

    /// Channels of one ML-MemAE-SC pass: all of a cube's flows when they are reconstructed
    /// jointly, else one flow's two.
    pub fn memae_channels(&self) -> usize {
        if self.joint_flows {
            self.cube_flow_channels()
        } else {
            FLOW_CHANNELS
        }
    }

    /// Width of CVAE encoder stage `s` (1-based): `min(nf_start · 2^(s−1), nf_max)`.
    pub fn stage_width(&self, stage: usize) -> usize {
        let mut nf = self.nf_start;
        for _ in 1..stage {
            nf = (2 * nf).min(self.nf_max);
        }
        nf
    }

    /// Slot dimension of the memory at `level` (1 = 16×16 for a 32 patch, 2, 3): the whole
    /// flattened feature map.
    pub fn slot_dim(&self, level: usize) -> usize {
        let side = self.patch_size >> level;
        self.feature_root * (1 << level) * side * side
    }

    /// Checks that the sizes describe a network the reference architecture can build.
    pub fn validate(&self) -> Result<(), ModelError> {
        let bad = |msg: String| Err(ModelError::InvalidConfig(msg));
        if !self.patch_size.is_power_of_two() || self.patch_size < 16 {
            return bad(format!(
                "patch_size {} must be a power of two >= 16 (three stride-2 levels and two \
                 latent scales)",
                self.patch_size
            ));
        }
        for (name, value, limit) in [
            ("patch_size", self.patch_size, MAX_PATCH_SIZE),
            ("clip_hist", self.clip_hist, MAX_CLIP_HIST),
            ("feature_root", self.feature_root, MAX_FEATURES),
            ("nf_start", self.nf_start, MAX_FEATURES),
            ("num_slots", self.num_slots, MAX_SLOTS),
        ] {
            if value > limit {
                return bad(format!("{name} {value} exceeds the limit of {limit}"));
            }
        }
        if self.clip_hist == 0 || self.num_flows != self.clip_hist {
            return bad(format!(
                "num_flows ({}) must equal clip_hist ({}) and be positive: the reference \
                 reconstructs clip_hist flows and feeds num_flows to the CVAE",
                self.num_flows, self.clip_hist
            ));
        }
        if self.feature_root == 0 || self.num_slots == 0 {
            return bad("feature_root and num_slots must be positive".into());
        }
        if !(self.shrink_thres >= 0.0 && self.shrink_thres < 1.0) {
            return bad(format!(
                "shrink_thres {} must be in [0, 1)",
                self.shrink_thres
            ));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return bad(format!("dropout {} must be in [0, 1)", self.dropout));
        }
        if self.nf_start == 0 || self.nf_max != 2 * self.nf_start {
            return bad(format!(
                "nf_max ({}) must be 2·nf_start ({}): the decoder's last stage has nf_max/2 \
                 channels and takes the first encoder stage as skip input",
                self.nf_max, self.nf_start
            ));
        }
        if self.stage_width(self.n_stages()) != self.nf_max {
            return bad("the deepest CVAE stage must reach nf_max".into());
        }
        if let FlowUnits::Scaled { x, y } = self.conventions.flow_units
            && !(x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0)
        {
            return bad(format!("flow scale factors ({x}, {y}) must be positive"));
        }
        if self.conventions.flow_units == (FlowUnits::FrameWidth { width: 0 }) {
            return bad("the flows' reference frame width must be positive".into());
        }
        // Within the limits above the count cannot overflow.
        let parameters = self.parameter_count();
        if parameters > MAX_PARAMETERS {
            return bad(format!(
                "{parameters} parameters exceed the limit of {MAX_PARAMETERS}"
            ));
        }
        self.box_filter.validate()?;
        if !(1..=MAX_SCORE_BANDS).contains(&self.score_bands) {
            return bad(format!(
                "score_bands {} must lie in 1..={MAX_SCORE_BANDS}",
                self.score_bands
            ));
        }
        Ok(())
    }

    /// Number of trainable scalar parameters of the model built from this config (BatchNorm
    /// running statistics excluded, as the spec's counts), computed from the sizes alone.
    pub fn parameter_count(&self) -> usize {
        let fr = self.feature_root;
        let conv = |cin: usize, cout: usize, k: usize| cin * cout * k * k + cout;
        let bn = |c: usize| 2 * c;
        let double = |cin: usize, cout: usize| {
            conv(cin, cout, 3) + bn(cout) + conv(cout, cout, 3) + bn(cout)
        };
        let mut memae = double(self.memae_channels(), fr);
        for level in 1..=3 {
            let (cin, cout) = (fr << (level - 1), fr << level);
            memae += conv(cin, cout, 3) + double(cout, cout);
            if self.mem_usage[level] {
                memae += self.num_slots * self.slot_dim(level);
            }
        }
        for level in (1..=3).rev() {
            let (cin, cout) = (fr << level, fr << (level - 1));
            memae += conv(cin, cout, 3);
            let fused = match self.skip_ops[level - 1] {
                SkipOp::Concat => cin,
                SkipOp::None => cout,
            };
            memae += double(fused, cout);
        }
        memae += conv(fr, self.memae_channels(), 1);

        // NormConv2d: conv weight + bias + weight_g + gamma + beta.
        let nconv = |cin: usize, cout: usize, k: usize| cin * cout * k * k + 4 * cout;
        let block = |c: usize, skip: bool| {
            if skip {
                nconv(2 * c, c, 3) + nconv(c, c, 1)
            } else {
                nconv(c, c, 3)
            }
        };
        let n = self.n_stages();
        let encoder = |nf_in: usize| {
            let mut p = nconv(nf_in, self.nf_start, 1);
            for s in 1..=n {
                if s > 1 {
                    p += nconv(self.stage_width(s - 1), self.stage_width(s), 3);
                }
                p += 2 * block(self.stage_width(s), false);
            }
            p
        };
        let nf = self.nf_max;
        let flows = self.cube_flow_channels();
        let f_phi = encoder(self.clip_hist * IMG_CHANNELS + flows);
        let e_theta = encoder(flows);
        let zc =
            3 * block(nf, true) + nconv(nf, nf, 1) + nconv(nf, 4 * nf, 3) + nconv(2 * nf, nf, 1);
        let bottleneck = nconv(nf, nf, 1)
            + nconv(nf, 4 * nf, 3)
            + 2 * nconv(2 * nf, nf, 1)
            + 4 * block(nf, true)
            + block(nf, false)
            + 3 * block(nf, true)
            + nconv(4 * nf, nf, 1);
        let mut decoder = 0;
        let mut width = nf;
        for stage in (1..=n - 2).rev() {
            let out = if stage == 1 { width / 2 } else { width };
            decoder += nconv(width, 4 * out, 3) + 2 * block(out, true);
            width = out;
        }
        decoder += nconv(width, IMG_CHANNELS, 1);
        memae + f_phi + e_theta + zc + bottleneck + decoder
    }
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self::compact()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_preset_has_the_spec_parameter_count() {
        let paper = ModelConfig::paper();
        paper.validate().expect("paper config is valid");
        assert_eq!(paper.n_stages(), 4);
        // Spec §8: ML-MemAE-SC 60,252,578 + CVAE 8,990,668.
        assert_eq!(paper.parameter_count(), 69_243_246);
    }

    #[test]
    fn compact_preset_fits_the_size_budget() {
        let compact = ModelConfig::compact();
        compact.validate().expect("compact config is valid");
        let megabytes = compact.parameter_count() as f64 * 4.0 / 1e6;
        assert!(megabytes <= 60.0, "compact model is {megabytes:.1} MB");
    }

    #[test]
    fn configs_that_would_allocate_without_bound_are_refused() {
        let refused = |edit: &dyn Fn(&mut ModelConfig), needle: &str| {
            let mut c = ModelConfig::paper();
            edit(&mut c);
            match c.validate() {
                Err(ModelError::InvalidConfig(m)) => assert!(m.contains(needle), "{m}"),
                other => panic!("{needle}: {other:?}"),
            }
        };
        refused(&|c| c.patch_size = 1 << 20, "patch_size 1048576 exceeds");
        refused(&|c| c.num_slots = usize::MAX, "num_slots");
        refused(&|c| c.feature_root = 1 << 40, "feature_root");
        refused(&|c| (c.clip_hist, c.num_flows) = (1000, 1000), "clip_hist");
        // Each size within its limit, together too many parameters.
        refused(
            &|c| (c.patch_size, c.feature_root, c.num_slots) = (256, 512, 65_536),
            "parameters exceed",
        );
    }

    #[test]
    fn invalid_configs_are_rejected_with_a_reason() {
        let mut c = ModelConfig::paper();
        c.nf_max = 96;
        assert!(matches!(c.validate(), Err(ModelError::InvalidConfig(m)) if m.contains("nf_max")));
        let mut c = ModelConfig::paper();
        c.patch_size = 24;
        assert!(c.validate().is_err());
        let mut c = ModelConfig::paper();
        c.num_flows = 3;
        assert!(c.validate().is_err());
        assert!(ModelConfig::preset("huge").is_err());
    }

    #[test]
    fn options_beyond_the_paper_round_trip_and_older_configs_read_as_the_reference() {
        let mut c = ModelConfig::compact();
        c.conventions.flow_units = FlowUnits::Patch;
        c.box_filter = BoxFilter {
            min_area_fraction: 0.0025,
            drop_truncated: true,
        };
        c.joint_flows = true;
        c.score_bands = 5;
        c.score_scale = ScoreScale::TailSurprisal;
        let back: ModelConfig =
            serde_json::from_str(&serde_json::to_string(&c).expect("serialise")).expect("parse");
        assert_eq!(back, c);
        // A config written before these fields existed reads as the reference behaviour.
        let mut old = serde_json::to_value(ModelConfig::compact()).expect("value");
        let object = old.as_object_mut().expect("object");
        object.remove("box_filter");
        object.remove("joint_flows");
        object.remove("score_bands");
        object.remove("score_scale");
        let old: ModelConfig = serde_json::from_value(old).expect("parse old");
        assert_eq!(old, ModelConfig::compact());
        assert_eq!(old.box_filter, BoxFilter::KEEP_ALL);
        assert!(!old.joint_flows);
        assert_eq!(old.score_bands, 1);
        assert_eq!(old.score_scale, ScoreScale::ZScore);
        let mut bad = ModelConfig::compact();
        bad.score_bands = 0;
        assert!(bad.validate().is_err());
    }

    #[test]
    fn joint_flows_widen_only_the_flow_autoencoders_ends() {
        let mut joint = ModelConfig::compact();
        joint.joint_flows = true;
        joint.validate().expect("valid");
        let fr = joint.feature_root;
        let extra_in = 6 * fr * 9; // first conv: 6 more input channels, 3×3
        let extra_out = 6 * fr + 6; // 1×1 output conv: 6 more outputs and biases
        assert_eq!(
            joint.parameter_count(),
            ModelConfig::compact().parameter_count() + extra_in + extra_out
        );
    }

    #[test]
    fn config_round_trips_through_json() {
        let mut c = ModelConfig::compact();
        c.conventions = InputConventions::reference(FlowUnits::Scaled {
            x: 4.0 / 3.0,
            y: 1.25,
        });
        let json = serde_json::to_string(&c).expect("serialise");
        let back: ModelConfig = serde_json::from_str(&json).expect("parse");
        assert_eq!(back, c);
    }
}
