//! Which epoch of a stage is kept: by default the one with the lowest loss on held-out
//! normal cubes; with an [`AnomalySelection`], the one an [`EpochJudge`] rates highest — in
//! `vadscope train --select-on`, the frame AUROC on validation scenarios that hold
//! anomalies (`score::ValidationSet`), the number the model is built for.
//!
//! Why a second rule: the normal validation loss of a reconstruction model says how well
//! normal flows are reconstructed, not how far anomalous ones stand out, and on held-out
//! scenarios it is dominated by a few heavy-tailed objects; from one epoch to the next it
//! swings by a third while detection barely moves, so it picks epochs almost at random.
//! Judging a model needs its training statistics (the scores are normalised with them);
//! they are taken from an evenly spaced sample of the training cubes, which the final
//! checkpoint replaces by the statistics over all of them.

use serde::{Deserialize, Serialize};

use crate::model::Detector;

/// Selection of each stage's kept epoch by an [`EpochJudge`] instead of the normal
/// validation loss.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct AnomalySelection {
    /// Judge every n-th epoch (counted from 1) and the last one; the others cannot be
    /// kept. Judging costs about an epoch's inference over the sample and the validation
    /// scenarios, so long runs judge less often.
    pub every: usize,
    /// Training cubes (evenly spaced) that the judged model's statistics come from.
    pub stats_cubes: usize,
    /// Worker threads of a judgement (the sample's statistics and the judge's scoring);
    /// `None`: those of the training steps. Inference gives the same numbers on any number
    /// of threads, so a one-thread run can judge on all cores when nothing else runs.
    #[serde(default)]
    pub threads: Option<usize>,
}

impl AnomalySelection {
    /// Every epoch judged, statistics over 2,048 training cubes.
    pub const EVERY_EPOCH: Self = Self {
        every: 1,
        stats_cubes: 2048,
        threads: None,
    };

    /// Whether epoch `epoch` (0-based) of a stage of `epochs` is judged.
    pub fn judges(&self, epoch: usize, epochs: usize) -> bool {
        (epoch + 1).is_multiple_of(self.every.max(1)) || epoch + 1 == epochs
    }
}

/// Rates the model of an epoch; higher is better. `Send`, since a judgement may run on a
/// thread pool of its own ([`AnomalySelection::threads`]).
pub trait EpochJudge: Send {
    /// What the rating measures, for messages (e.g. "validation frame AUROC").
    fn name(&self) -> &str;
    /// The rating of `detector`: the epoch's model in inference mode, with training
    /// statistics from a sample of the training cubes. An error stops training.
    fn judge(&mut self, detector: &Detector) -> Result<f64, String>;
}

/// The `n` of `indices` at even spacing (all of them when there are no more than `n`).
pub(super) fn evenly_spaced(indices: &[usize], n: usize) -> Vec<usize> {
    let len = indices.len();
    if n >= len {
        return indices.to_vec();
    }
    (0..n).map(|k| indices[k * len / n]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn judged_epochs_are_every_nth_and_the_last() {
        let s = AnomalySelection {
            every: 3,
            stats_cubes: 1,
            threads: None,
        };
        let judged: Vec<usize> = (0..7).filter(|&e| s.judges(e, 7)).collect();
        assert_eq!(judged, vec![2, 5, 6]);
        assert!((0..4).all(|e| AnomalySelection::EVERY_EPOCH.judges(e, 4)));
    }

    #[test]
    fn even_spacing_keeps_the_count_and_order() {
        let idx: Vec<usize> = (10..20).collect();
        assert_eq!(evenly_spaced(&idx, 5), vec![10, 12, 14, 16, 18]);
        assert_eq!(evenly_spaced(&idx, 50), idx);
        assert!(evenly_spaced(&idx, 0).is_empty());
    }
}
