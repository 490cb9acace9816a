//! The ROC and precision-recall curve of a scored, labelled set, and the scalar metrics read
//! off it (AUROC, average precision, FPR95, F1-max).
//!
//! One descending sort of the scores gives the cumulative true/false positive counts at every
//! distinct threshold; every metric is then a single pass over those points. That keeps
//! re-evaluation of 100,000 frames far below one frame time, which the viewer relies on when
//! the analyst moves a weight slider.

use rayon::slice::ParallelSliceMut;

/// Why a metric cannot be computed for a set of scores and labels.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MetricsError {
    /// Scores and labels differ in length.
    #[error("{scores} scores but {labels} labels")]
    LengthMismatch {
        /// Number of scores.
        scores: usize,
        /// Number of labels.
        labels: usize,
    },
    /// A score is NaN, which has no place in an ordering.
    #[error("score {index} is NaN")]
    NotANumber {
        /// Position of the NaN.
        index: usize,
    },
    /// All labels are equal, so one of TPR and FPR is undefined.
    #[error("all {count} labels are {}: ROC metrics need both classes", if *positive { "anomalous" } else { "normal" })]
    SingleClass {
        /// Number of samples.
        count: usize,
        /// The one class present.
        positive: bool,
    },
}

/// One point of a ROC curve: predicting "anomalous" for every score `>= threshold`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RocPoint {
    /// Decision threshold (`+inf` for the initial point that predicts nothing).
    pub threshold: f64,
    /// True positives at this threshold.
    pub tp: u64,
    /// False positives at this threshold.
    pub fp: u64,
}

/// A ROC curve with one point per distinct score, from the strictest threshold down.
#[derive(Debug, Clone, PartialEq)]
pub struct RocCurve {
    /// Points in order of decreasing threshold; the first is (`+inf`, 0, 0).
    pub points: Vec<RocPoint>,
    /// Number of positive (anomalous) samples.
    pub positives: u64,
    /// Number of negative (normal) samples.
    pub negatives: u64,
}

/// The scalar metrics of one scored set.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ScoreMetrics {
    /// Area under the ROC curve.
    pub auroc: f64,
    /// Average precision (area under the precision-recall curve, step-wise as scikit-learn).
    pub average_precision: f64,
    /// FPR at the first (strictest) threshold whose TPR reaches 0.95.
    pub fpr95: f64,
    /// Threshold at which `fpr95` is reached.
    pub fpr95_threshold: f64,
    /// FPR at the ROC point whose TPR is closest to 0.95 (the HF²-VAD_AD code's variant).
    pub fpr95_closest: f64,
    /// Best F1 score over all thresholds.
    pub f1_max: f64,
    /// Threshold at which `f1_max` is reached.
    pub f1_threshold: f64,
}

impl RocCurve {
    /// Computes the full ROC curve (scikit-learn `roc_curve(..., drop_intermediate=False)`).
    pub fn compute(scores: &[f64], labels: &[bool]) -> Result<Self, MetricsError> {
        if scores.len() != labels.len() {
            return Err(MetricsError::LengthMismatch {
                scores: scores.len(),
                labels: labels.len(),
            });
        }
        if let Some(index) = scores.iter().position(|s| s.is_nan()) {
            return Err(MetricsError::NotANumber { index });
        }
        let positives = labels.iter().filter(|&&l| l).count() as u64;
        let negatives = labels.len() as u64 - positives;
        if positives == 0 || negatives == 0 {
            return Err(MetricsError::SingleClass {
                count: labels.len(),
                positive: positives > 0,
            });
        }
        // Sorting integer keys that order like `f64::total_cmp` is cheaper than comparing
        // floats; ties may come out in any order because the points are taken at the last
        // sample of each distinct score. Both cores halve the sort, the bulk of a
        // re-evaluation.
        let mut keyed: Vec<(i64, bool)> = scores
            .iter()
            .map(|s| total_order_key(*s))
            .zip(labels.iter().copied())
            .collect();
        keyed.par_sort_unstable_by(|a, b| b.0.cmp(&a.0));
        let order: Vec<(f64, bool)> = keyed
            .into_iter()
            .map(|(key, label)| (score_of_key(key), label))
            .collect();

        let mut points = Vec::with_capacity(order.len() + 1);
        points.push(RocPoint {
            threshold: f64::INFINITY,
            tp: 0,
            fp: 0,
        });
        let (mut tp, mut fp) = (0u64, 0u64);
        for (i, &(score, label)) in order.iter().enumerate() {
            if label {
                tp += 1;
            } else {
                fp += 1;
            }
            let last_of_its_value = order.get(i + 1).is_none_or(|next| next.0 != score);
            if last_of_its_value {
                points.push(RocPoint {
                    threshold: score,
                    tp,
                    fp,
                });
            }
        }
        Ok(Self {
            points,
            positives,
            negatives,
        })
    }

    /// True positive rate of point `i`.
    pub fn tpr(&self, i: usize) -> f64 {
        self.points[i].tp as f64 / self.positives as f64
    }

    /// False positive rate of point `i`.
    pub fn fpr(&self, i: usize) -> f64 {
        self.points[i].fp as f64 / self.negatives as f64
    }

    /// The curve without collinear intermediate points, as scikit-learn's default
    /// `drop_intermediate=True`: a point is kept where the curve changes direction, plus the
    /// two ends of the scored points and the initial (+inf) point in front of them. Metrics
    /// are unchanged; plots get lighter.
    pub fn without_intermediate(&self) -> RocCurve {
        let p = &self.points;
        let n = p.len();
        let bends = |i: usize| {
            let d2 = |a: u64, b: u64, c: u64| (c as i128 - b as i128) != (b as i128 - a as i128);
            d2(p[i - 1].fp, p[i].fp, p[i + 1].fp) || d2(p[i - 1].tp, p[i].tp, p[i + 1].tp)
        };
        let points = (0..n)
            .filter(|&i| i <= 1 || i + 1 == n || bends(i))
            .map(|i| p[i])
            .collect();
        RocCurve {
            points,
            positives: self.positives,
            negatives: self.negatives,
        }
    }

    /// Area under the ROC curve by the trapezoidal rule (equals scikit-learn `roc_auc_score`).
    pub fn auroc(&self) -> f64 {
        let twice_area: u128 = self
            .points
            .windows(2)
            .map(|w| (w[1].fp - w[0].fp) as u128 * (w[1].tp + w[0].tp) as u128)
            .sum();
        twice_area as f64 / (2.0 * self.positives as f64 * self.negatives as f64)
    }

    /// Average precision: Σ (R_k − R_{k−1}) · P_k over thresholds from strict to loose
    /// (scikit-learn `average_precision_score`).
    pub fn average_precision(&self) -> f64 {
        self.points
            .windows(2)
            .map(|w| {
                let recall_step = (w[1].tp - w[0].tp) as f64 / self.positives as f64;
                let precision = w[1].tp as f64 / (w[1].tp + w[1].fp) as f64;
                recall_step * precision
            })
            .sum()
    }

    /// Index of the first (strictest) point whose TPR reaches `target`.
    pub fn first_reaching_tpr(&self, target: f64) -> usize {
        (0..self.points.len())
            .find(|&i| self.tpr(i) >= target)
            .unwrap_or(self.points.len() - 1)
    }

    /// Index of the point whose TPR is closest to `target`; the first wins ties.
    pub fn closest_to_tpr(&self, target: f64) -> usize {
        let mut best = 0;
        for i in 1..self.points.len() {
            if (self.tpr(i) - target).abs() < (self.tpr(best) - target).abs() {
                best = i;
            }
        }
        best
    }

    /// Best F1 score and its threshold (ignoring the initial point that predicts nothing).
    pub fn f1_max(&self) -> (f64, f64) {
        self.points[1..]
            .iter()
            .map(|p| {
                let f1 = 2.0 * p.tp as f64 / (self.positives + p.tp + p.fp) as f64;
                (f1, p.threshold)
            })
            .fold((0.0, f64::INFINITY), |best, cur| {
                if cur.0 > best.0 { cur } else { best }
            })
    }

    /// Every scalar metric of this curve.
    pub fn metrics(&self) -> ScoreMetrics {
        let first = self.first_reaching_tpr(0.95);
        let closest = self.closest_to_tpr(0.95);
        let (f1_max, f1_threshold) = self.f1_max();
        ScoreMetrics {
            auroc: self.auroc(),
            average_precision: self.average_precision(),
            fpr95: self.fpr(first),
            fpr95_threshold: self.points[first].threshold,
            fpr95_closest: self.fpr(closest),
            f1_max,
            f1_threshold,
        }
    }
}

impl ScoreMetrics {
    /// Computes every metric of `scores` against `labels`.
    pub fn compute(scores: &[f64], labels: &[bool]) -> Result<Self, MetricsError> {
        Ok(RocCurve::compute(scores, labels)?.metrics())
    }
}

/// An integer that orders like `f64::total_cmp`: negative floats have their magnitude
/// bits flipped so that larger magnitudes sort lower.
fn total_order_key(score: f64) -> i64 {
    let bits = score.to_bits() as i64;
    bits ^ (((bits >> 63) as u64) >> 1) as i64
}

/// The score whose [`total_order_key`] is `key` (the map is its own inverse).
fn score_of_key(key: i64) -> f64 {
    f64::from_bits((key ^ (((key >> 63) as u64) >> 1) as i64) as u64)
}

/// Mean of the per-group AUROCs (macro AUROC), skipping groups with a single class as
/// scikit-learn cannot score them. Returns the mean and the number of groups used, or
/// `None` when no group has both classes.
pub fn macro_auroc<'a>(
    groups: impl IntoIterator<Item = (&'a [f64], &'a [bool])>,
) -> Result<Option<(f64, usize)>, MetricsError> {
    let mut sum = 0.0;
    let mut used = 0;
    for (scores, labels) in groups {
        match RocCurve::compute(scores, labels) {
            Ok(curve) => {
                sum += curve.auroc();
                used += 1;
            }
            Err(MetricsError::SingleClass { .. }) => {}
            Err(e) => return Err(e),
        }
    }
    Ok((used > 0).then(|| (sum / used as f64, used)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_keys_sort_like_total_cmp_and_invert() {
        let scores = [
            f64::NEG_INFINITY,
            -1e300,
            -2.5,
            -f64::MIN_POSITIVE,
            -0.0,
            0.0,
            f64::MIN_POSITIVE,
            3.0,
            1e300,
            f64::INFINITY,
        ];
        for pair in scores.windows(2) {
            assert!(
                total_order_key(pair[0]) < total_order_key(pair[1]),
                "{pair:?}"
            );
        }
        for s in scores {
            assert_eq!(score_of_key(total_order_key(s)).to_bits(), s.to_bits());
        }
    }

    #[test]
    fn negative_scores_rank_below_positive_ones() {
        let curve = RocCurve::compute(&[-3.0, -1.0, 0.5, 2.0], &[false, false, true, true])
            .expect("both classes");
        assert_eq!(curve.auroc(), 1.0);
    }
}
