//! What `render` and `export` share: the options that choose the scores (model, boxes,
//! flow source, weights, threshold) and getting a current score cache for them through
//! `vadscope score`'s [`Scorer`], which scores first (with a progress bar) when there is none.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use vadscope::score::{BoxSource, FusionWeights, ScoreCache, reference_threshold};
use vadscope::sequence::Scenario;

use super::score::{Report, RunArgs, Scorer, parse_box_source};

/// Options that choose which scores a view shows.
#[derive(Debug, Args)]
pub struct ScoreArgs {
    /// Where the boxes of the scored objects come from: `gt` (ground truth), `det` (the
    /// scenario's BBOX_2D_DET), `motion` (detector-free motion boxes), `gt+motion`,
    /// `det+motion`, or a detection file (MOT `.txt`, COCO `.json`, a YOLO folder,
    /// `boxes.csv`).
    #[arg(long, default_value = "gt", value_name = "gt|det|motion|FILE", value_parser = parse_box_source)]
    pub boxes: BoxSource,
    #[command(flatten)]
    pub run: RunArgs,
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
}

/// A current score cache of `scenario` for `args`, and the checkpoint it came from: the
/// cache on disk when it is current, else one scored now (reported on standard error).
pub fn current_cache(
    scenario: &Scenario,
    args: &ScoreArgs,
) -> anyhow::Result<(ScoreCache, PathBuf)> {
    let mut scorer = Scorer::new(&args.run, Report::Stderr)?;
    let cache = scorer.cache_for(scenario, &args.boxes, false)?;
    Ok((cache, scorer.checkpoint().to_path_buf()))
}
