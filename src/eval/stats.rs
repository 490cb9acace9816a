//! Summary statistics used to normalise anomaly scores: mean and population standard
//! deviation for z-scores, and median / inter-quartile range for robust scaling.

use serde::{Deserialize, Serialize};

/// Mean and population standard deviation (ddof = 0, as NumPy's `np.std`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MeanStd {
    /// Arithmetic mean.
    pub mean: f64,
    /// Population standard deviation.
    pub std: f64,
}

impl MeanStd {
    /// Statistics of `values` (two-pass, for accuracy); `None` for an empty slice.
    pub fn of(values: &[f64]) -> Option<Self> {
        if values.is_empty() {
            return None;
        }
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
        Some(Self {
            mean,
            std: var.sqrt(),
        })
    }

    /// `(value − mean) / std`; a zero std (constant training errors) scores 0 rather than
    /// infinity so one degenerate statistic cannot swamp the fused score.
    pub fn z(&self, value: f64) -> f64 {
        if self.std > 0.0 {
            (value - self.mean) / self.std
        } else {
            0.0
        }
    }
}

/// Median and quartiles (NumPy's default "linear" quantiles) for robust scaling.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobustStats {
    /// Median (50th percentile).
    pub median: f64,
    /// 25th percentile.
    pub q25: f64,
    /// 75th percentile.
    pub q75: f64,
}

impl RobustStats {
    /// Statistics of `values` (NaNs are ignored); `None` when nothing is left.
    pub fn of(values: &[f64]) -> Option<Self> {
        let mut sorted: Vec<f64> = values.iter().copied().filter(|v| !v.is_nan()).collect();
        if sorted.is_empty() {
            return None;
        }
        sorted.sort_unstable_by(f64::total_cmp);
        Some(Self {
            median: quantile_linear(&sorted, 0.5),
            q25: quantile_linear(&sorted, 0.25),
            q75: quantile_linear(&sorted, 0.75),
        })
    }

    /// Inter-quartile range q75 − q25.
    pub fn iqr(&self) -> f64 {
        self.q75 - self.q25
    }

    /// `(value − median) / iqr`; a zero IQR scales by 1 so constant maps stay finite.
    pub fn scale(&self, value: f64) -> f64 {
        let iqr = self.iqr();
        (value - self.median) / if iqr > 0.0 { iqr } else { 1.0 }
    }
}

/// The `q`-quantile of an ascending, non-empty slice with linear interpolation between
/// order statistics (NumPy `np.quantile(..., method="linear")`).
pub fn quantile_linear(sorted: &[f64], q: f64) -> f64 {
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    let frac = pos - lo as f64;
    sorted[lo] + (sorted[hi] - sorted[lo]) * frac
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate_like_numpy() {
        let v = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile_linear(&v, 0.5), 2.5);
        assert_eq!(quantile_linear(&v, 0.25), 1.75);
        assert_eq!(quantile_linear(&v, 0.75), 3.25);
    }

    #[test]
    fn degenerate_statistics_stay_finite() {
        let s = MeanStd::of(&[3.0, 3.0]).unwrap();
        assert_eq!(s.z(10.0), 0.0);
        let r = RobustStats::of(&[2.0, 2.0, 2.0]).unwrap();
        assert_eq!(r.scale(5.0), 3.0);
        assert!(MeanStd::of(&[]).is_none());
    }
}
