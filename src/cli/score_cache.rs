//! What `render` and `export` share: the options that choose the scores (model, boxes,
//! weights, threshold) and getting a current score cache for them, scoring first (with a
//! progress bar) when there is none.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use vadscope::model::{Detector, bundled_model};
use vadscope::render::reference_threshold;
use vadscope::score::{
    BoxSource, FlowSource, FusionWeights, ModelKey, MotionParams, ScoreCache, ScoreRequest,
    score_scenario,
};
use vadscope::sequence::Scenario;

/// Options that choose which scores a view shows.
#[derive(Debug, Args)]
pub struct ScoreArgs {
    /// Checkpoint to score with (default: the bundled model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Boxes of the scored objects: ground truth or detector-free motion boxes.
    #[arg(long, value_enum, default_value_t = BoxArg::Gt)]
    pub boxes: BoxArg,
    /// Fusion weights as w_r,w_p,w_r_p,w_p_p (frame level, then pixel level).
    #[arg(long, value_name = "WR,WP,WRP,WPP", conflicts_with = "preset", value_parser = parse_weights)]
    pub weights: Option<FusionWeights>,
    /// A weights preset (default: paper-text, 10 / 0.1).
    #[arg(long, value_enum)]
    pub preset: Option<PresetArg>,
    /// Decision threshold on the filtered frame score (default: the score of an object 3
    /// training standard deviations above the mean in both errors).
    #[arg(long)]
    pub threshold: Option<f64>,
    /// Median-filter kernel of the filtered score (odd; 1 = none).
    #[arg(long, default_value_t = 17)]
    pub median_kernel: usize,
}

/// Box sources offered on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BoxArg {
    /// The scenario's ground-truth boxes.
    Gt,
    /// Detector-free boxes from frame differences.
    Motion,
}

/// Weight presets offered on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PresetArg {
    /// HF²-VAD_AD paper text: 10 / 0.1.
    PaperText,
    /// HF²-VAD_AD committed config: 0.1 / 10 (`paper-code` works too).
    #[value(alias = "paper-code")]
    AdCode,
    /// Original HF²-VAD: 1 / 0.1.
    Original,
}

/// Parses `--weights`: four finite numbers w_r,w_p,w_r_p,w_p_p (also `vadscope eval`'s).
pub fn parse_weights(text: &str) -> Result<FusionWeights, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{text:?}: {e}"))?;
    match values[..] {
        [w_r, w_p, w_r_p, w_p_p] if values.iter().all(|v| v.is_finite()) => Ok(FusionWeights {
            w_r,
            w_p,
            w_r_p,
            w_p_p,
        }),
        _ => Err(format!(
            "{text:?}: expected four numbers w_r,w_p,w_r_p,w_p_p"
        )),
    }
}

impl PresetArg {
    /// The weights of this preset.
    pub fn weights(self) -> FusionWeights {
        match self {
            Self::PaperText => FusionWeights::PAPER_TEXT,
            Self::AdCode => FusionWeights::AD_CODE,
            Self::Original => FusionWeights::ORIGINAL,
        }
    }
}

impl ScoreArgs {
    /// The fusion weights asked for.
    pub fn fusion_weights(&self) -> FusionWeights {
        self.weights
            .or(self.preset.map(PresetArg::weights))
            .unwrap_or_default()
    }

    /// The decision threshold asked for.
    pub fn decision_threshold(&self) -> f64 {
        self.threshold
            .unwrap_or_else(|| reference_threshold(&self.fusion_weights()))
    }

    /// The box source asked for.
    pub fn box_source(&self) -> BoxSource {
        match self.boxes {
            BoxArg::Gt => BoxSource::GroundTruth,
            BoxArg::Motion => BoxSource::Motion(MotionParams::default()),
        }
    }

    /// The checkpoint to use.
    pub fn model_path(&self) -> anyhow::Result<PathBuf> {
        match &self.model {
            Some(path) if path.is_file() => Ok(path.clone()),
            Some(path) => bail!("model {} does not exist", path.display()),
            None => Ok(bundled_model()?),
        }
    }
}

/// A current score cache of `scenario` for `args`, and the checkpoint it came from.
pub fn current_cache(
    scenario: &Scenario,
    args: &ScoreArgs,
) -> anyhow::Result<(ScoreCache, PathBuf)> {
    let model = args.model_path()?;
    let key = ModelKey::of_checkpoint(&model)?;
    let request = ScoreRequest::new(args.box_source(), FlowSource::default());
    let cache_key = request.key(scenario, key)?;
    if let Some(cache) = ScoreCache::lookup(scenario, &cache_key)? {
        return Ok((cache, model));
    }
    let detector = Detector::from_checkpoint(&model)
        .with_context(|| format!("loading model {}", model.display()))?;
    let bar = ProgressBar::new(scenario.len() as u64).with_style(
        ProgressStyle::with_template(
            "{prefix:>12} [{bar:40}] {pos}/{len} frames ({per_sec}, eta {eta}) {msg}",
        )
        .expect("static progress template")
        .progress_chars("=> "),
    );
    bar.set_prefix("scoring");
    let cancel = AtomicBool::new(false);
    let cache = score_scenario(
        scenario,
        &detector,
        key,
        &request,
        &mut |p| {
            bar.set_position(p.frames_done as u64);
            bar.set_message(format!("{} objects", p.objects));
        },
        &cancel,
    )
    .with_context(|| format!("scoring {}", scenario.root().display()))?;
    bar.finish_and_clear();
    Ok((cache, model))
}
