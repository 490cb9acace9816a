//! The per-frame score series of one scenario for given fusion parameters ([`ScoreSeries`]:
//! fused, median-filtered, the z-scores of each frame's top object, truth), and the default
//! decision threshold ([`reference_threshold`]). What the timeline draws, the captions
//! print, `scores.csv` stores and the viewer's metrics measure.

use crate::eval::median_filter;

use super::cache::ScoreTable;
use super::fusion::{FrameFusion, FusionWeights, frame_scores};

/// How frame scores are fused and filtered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FusionParams {
    /// The fusion weights.
    pub weights: FusionWeights,
    /// Median-filter kernel (0 or 1 = none).
    pub median_kernel: usize,
}

/// Training standard deviations above the mean, in both errors, of the object whose fused
/// score is the default threshold ([`reference_threshold`]).
pub const REFERENCE_THRESHOLD_SIGMA: f64 = 3.0;

/// The default decision threshold on the (filtered) frame score for `weights`: the fused
/// score of an object whose S_r and S_p both lie [`REFERENCE_THRESHOLD_SIGMA`] training
/// standard deviations above their training means. It needs no labels.
pub fn reference_threshold(weights: &FusionWeights) -> f64 {
    REFERENCE_THRESHOLD_SIGMA * (weights.w_r + weights.w_p)
}

/// The per-frame score series of one scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreSeries {
    /// Raw fused frame score per frame.
    pub fused: Vec<f64>,
    /// The metric input: the first `skip` frames NaN (left out), the rest median-filtered.
    pub filtered: Vec<f64>,
    /// z(S_r) of each frame's top object (NaN without objects).
    pub z_r: Vec<f64>,
    /// z(S_p) of each frame's top object (NaN without objects).
    pub z_p: Vec<f64>,
    /// Whether `z_r` and `z_p` are tail surprisals: the model keeps tail tables
    /// ([`crate::model::ScoreScale::TailSurprisal`]).
    pub surprisals: bool,
    /// Index into [`ScoreTable::objects`] of each frame's top object.
    pub top_object: Vec<Option<usize>>,
    /// Ground truth per frame (false beyond the scenario's labels).
    pub truth: Vec<bool>,
    /// Frames left out at the start (the model's `clip_hist`).
    pub skip: usize,
}

impl ScoreSeries {
    /// The series of `table` for `weights`, filtered with `median_kernel` after the first
    /// `clip_hist` frames as the metrics do; `truth` holds the ground-truth flags.
    pub fn compute(
        table: &ScoreTable,
        truth: &[bool],
        weights: &FusionWeights,
        median_kernel: usize,
    ) -> Self {
        let fused = frame_scores(table, weights);
        let n = fused.len();
        let skip = (table.meta.clip_hist as usize).min(n);
        let mut filtered = vec![f64::NAN; skip];
        filtered.extend(median_filter(&fused[skip..], median_kernel));
        let fusion = FrameFusion::of_table(table, weights);
        let stats = &table.meta.training;
        let mut z_r = vec![f64::NAN; n];
        let mut z_p = vec![f64::NAN; n];
        let mut top_object = vec![None; n];
        for i in 0..n {
            let first = table.frames[i].first_object as usize;
            let best = table
                .frame_objects(i)
                .iter()
                .enumerate()
                .map(|(k, o)| (k, fusion.object_score(o)))
                .fold(None, |best: Option<(usize, f64)>, cur| match best {
                    Some(b) if b.1 >= cur.1 => Some(b),
                    _ => Some(cur),
                });
            if let Some((k, _)) = best {
                let o = &table.objects[first + k];
                (z_r[i], z_p[i]) = o.z_scores(stats, table.meta.frame_width);
                top_object[i] = Some(first + k);
            }
        }
        let truth = (0..n)
            .map(|i| truth.get(i).copied().unwrap_or(false))
            .collect();
        Self {
            fused,
            filtered,
            z_r,
            z_p,
            surprisals: stats.tails.is_some(),
            top_object,
            truth,
            skip,
        }
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.fused.len()
    }

    /// Whether there is no frame.
    pub fn is_empty(&self) -> bool {
        self.fused.is_empty()
    }
}
