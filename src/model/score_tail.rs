//! Tail surprisal of a score under its training distribution: −ln P(S ≥ s) over the normal
//! training cubes, from a table of the distribution's upper quantiles kept with the model.
//!
//! Beyond the reference, which z-scores S_r and S_p with their training mean and standard
//! deviation: S_r is heavy-tailed (its standard deviation is four times its mean on the
//! training cubes, set by a few close, fast objects), so its z-score compresses every object
//! but the most extreme into a narrow band, and the moments themselves move with the few
//! cubes that make the tail. The surprisal asks "how rare is an error this large among
//! normal objects" instead: it is 0 for an error at or below the training minimum, ln 2 at
//! the median, and grows by ln 10 for each decade of rarity, up to ln(2(n + 1)) at the
//! largest of n training errors. Beyond that it grows with the log of the ratio to the
//! largest, so errors past everything seen in training keep their order.

use serde::{Deserialize, Serialize};

use super::stats::quantile_sorted;

/// Quantile levels a table keeps: enough that interpolating between them matches the exact
/// empirical surprisal to well within the spread of a validation set's scores.
pub const TAIL_LEVELS: usize = 256;

/// Upper quantiles of one score over the training cubes, at upper-tail probabilities spaced
/// geometrically from 1 down to 1 / (2(n + 1)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TailTable {
    /// The score at each level, non-decreasing.
    pub values: Vec<f64>,
    /// −ln of each level's upper-tail probability, increasing from 0.
    pub surprisal: Vec<f64>,
}

impl TailTable {
    /// The table of `scores` (any order); `None` for no scores or a non-finite one.
    pub fn of(scores: &[f64]) -> Option<Self> {
        if scores.is_empty() || scores.iter().any(|s| !s.is_finite()) {
            return None;
        }
        let mut sorted = scores.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let rarest = (2.0 * (n as f64 + 1.0)).ln();
        let (mut values, surprisal): (Vec<f64>, Vec<f64>) = (0..TAIL_LEVELS)
            .map(|k| {
                let surprisal = rarest * k as f64 / (TAIL_LEVELS - 1) as f64;
                let below = 1.0 - (-surprisal).exp();
                (quantile_sorted(&sorted, below), surprisal)
            })
            .unzip();
        // The rarest level stands for the largest training score itself (its half-count
        // upper tail), so an error is "past everything seen" exactly when it exceeds it.
        values[TAIL_LEVELS - 1] = sorted[n - 1];
        Some(Self { values, surprisal })
    }

    /// The surprisal of `score`: interpolated linearly between the bracketing levels, 0 at
    /// or below the smallest value, and past the largest the rarest level plus
    /// ln(score / largest).
    pub fn surprisal(&self, score: f64) -> f64 {
        let (Some(&first), Some(&last)) = (self.values.first(), self.values.last()) else {
            return 0.0;
        };
        let rarest = self.surprisal.last().copied().unwrap_or(0.0);
        if score.is_nan() || score <= first {
            return 0.0;
        }
        if score >= last {
            return if last > 0.0 {
                rarest + (score / last).ln()
            } else {
                rarest
            };
        }
        // values[i - 1] ≤ score < values[i], with 0 < i < len.
        let i = self.values.partition_point(|&v| v <= score);
        let (v0, v1) = (self.values[i - 1], self.values[i]);
        let (s0, s1) = (self.surprisal[i - 1], self.surprisal[i]);
        s0 + (s1 - s0) * (score - v0) / (v1 - v0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// −ln of the empirical upper-tail probability with the half-count correction the
    /// table's end points use.
    fn exact_surprisal(sorted: &[f64], score: f64) -> f64 {
        let n = sorted.len() as f64;
        let at_or_below = sorted.partition_point(|&v| v <= score) as f64;
        -((n - at_or_below + 0.5) / (n + 1.0)).ln()
    }

    #[test]
    fn surprisal_follows_the_empirical_tail_of_a_heavy_tailed_sample() {
        // Squares of a spread of values: heavy-tailed like S_r.
        let scores: Vec<f64> = (1..=4000).map(|i| (i as f64 * 0.37).powi(4)).collect();
        let table = TailTable::of(&scores).unwrap();
        assert_eq!(table.values.len(), TAIL_LEVELS);
        assert!(table.values.windows(2).all(|w| w[0] <= w[1]));
        assert!(table.surprisal.windows(2).all(|w| w[0] < w[1]));
        // Linear quantiles and the half-count tail differ by O(1/n) in probability, which
        // shows only in the last few levels.
        for (q, tolerance) in [
            (0.1, 0.03),
            (0.5, 0.03),
            (0.9, 0.03),
            (0.99, 0.03),
            (0.999, 0.2),
        ] {
            let score = scores[(q * scores.len() as f64) as usize];
            let (ours, exact) = (table.surprisal(score), exact_surprisal(&scores, score));
            assert!(
                (ours - exact).abs() < tolerance,
                "q {q}: {ours} against {exact}"
            );
        }
        assert_eq!(table.surprisal(0.0), 0.0);
        let median = table.surprisal(scores[1999]);
        assert!((median - 2.0f64.ln()).abs() < 0.01, "median: {median}");
        let largest = *scores.last().unwrap();
        let rarest = (2.0 * 4001.0f64).ln();
        assert!((table.surprisal(largest) - rarest).abs() < 1e-9);
        assert!((table.surprisal(10.0 * largest) - (rarest + 10.0f64.ln())).abs() < 1e-9);
    }

    #[test]
    fn ties_and_a_single_score_give_a_usable_table() {
        let table = TailTable::of(&[3.0; 10]).unwrap();
        assert_eq!(table.surprisal(2.0), 0.0);
        assert_eq!(table.surprisal(3.0), 0.0);
        assert!(table.surprisal(6.0) > table.surprisal(4.0));
        let one = TailTable::of(&[5.0]).unwrap();
        assert_eq!(one.surprisal(1.0), 0.0);
        assert!((one.surprisal(10.0) - (4.0f64.ln() + 2.0f64.ln())).abs() < 1e-9);
        assert!(TailTable::of(&[]).is_none());
        assert!(TailTable::of(&[1.0, f64::NAN]).is_none());
        assert_eq!(table.surprisal(f64::NAN), 0.0);
    }
}
