//! Pixel-level ROC metrics of the heatmaps against the anomaly masks ([`PixelRoc`],
//! [`add_scenario_pixels`]).
//!
//! Pixel metrics run on the full-resolution grid and, like frame metrics, skip the first
//! `clip_hist` frames (the AD code keeps them and works at 192×128). Every pixel counts;
//! to keep memory bounded the scores are merged into bins of relative width 2⁻¹⁵ (ties
//! within a bin count as equal scores), which moves AUROC and AP by far less than their
//! printed precision.

use std::collections::HashMap;

use image::GrayImage;

use crate::eval::{MetricsError, RocCurve, RocPoint};
use crate::sequence::Scenario;

use super::ScoreError;
use super::cache::ScoreCache;
use super::fusion::{FusionWeights, Heatmap, HeatmapScratch, PixelReferenceMode, compose_heatmap};

/// Pixel scores and labels merged into score bins, for a ROC curve over any number of
/// pixels.
#[derive(Debug, Clone, Default)]
pub struct PixelRoc {
    /// (anomalous, normal) pixels per score bin.
    bins: HashMap<u32, (u64, u64)>,
    /// Pixels scored exactly 0 (outside every box): anomalous, normal.
    zero: (u64, u64),
}

/// Bits dropped from a score's order-preserving key: bins of relative width 2⁻¹⁵.
const BIN_SHIFT: u32 = 8;

/// A key that orders like the score (negative scores below positive ones).
fn bin_of(score: f32) -> u32 {
    let bits = (score + 0.0).to_bits();
    let ordered = if bits & 0x8000_0000 != 0 {
        !bits
    } else {
        bits | 0x8000_0000
    };
    ordered >> BIN_SHIFT
}

/// The smallest score of bin `bin` (the threshold it stands for).
fn bin_floor(bin: u32) -> f64 {
    let ordered = bin << BIN_SHIFT;
    let bits = if ordered & 0x8000_0000 != 0 {
        ordered & 0x7fff_ffff
    } else {
        !ordered
    };
    f64::from(f32::from_bits(bits))
}

impl PixelRoc {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the pixels of one heatmap against its mask (non-zero = anomalous); both must
    /// have the same size.
    pub fn add(&mut self, heatmap: &Heatmap, mask: &GrayImage) -> Result<(), ScoreError> {
        if mask.dimensions() != (heatmap.width, heatmap.height) {
            return Err(ScoreError::Invalid(format!(
                "heatmap {}×{} and anomaly mask {}×{} differ in size",
                heatmap.width,
                heatmap.height,
                mask.width(),
                mask.height()
            )));
        }
        for (&score, &m) in heatmap.values.iter().zip(mask.as_raw()) {
            let anomalous = m != 0;
            let counts = if score == 0.0 {
                &mut self.zero
            } else if score.is_nan() {
                continue;
            } else {
                self.bins.entry(bin_of(score)).or_default()
            };
            if anomalous {
                counts.0 += 1;
            } else {
                counts.1 += 1;
            }
        }
        Ok(())
    }

    /// Adds the counts of `other`.
    pub fn merge(&mut self, other: &PixelRoc) {
        for (bin, (p, n)) in &other.bins {
            let c = self.bins.entry(*bin).or_default();
            c.0 += p;
            c.1 += n;
        }
        self.zero.0 += other.zero.0;
        self.zero.1 += other.zero.1;
    }

    /// The ROC curve, one point per non-empty bin from the highest scores down.
    pub fn curve(&self) -> Result<RocCurve, MetricsError> {
        let mut bins: Vec<(u32, (u64, u64))> = self.bins.iter().map(|(k, v)| (*k, *v)).collect();
        if self.zero.0 + self.zero.1 > 0 {
            let zero_bin = bin_of(0.0);
            match bins.iter_mut().find(|(k, _)| *k == zero_bin) {
                Some((_, c)) => {
                    c.0 += self.zero.0;
                    c.1 += self.zero.1;
                }
                None => bins.push((zero_bin, self.zero)),
            }
        }
        bins.sort_unstable_by_key(|b| std::cmp::Reverse(b.0));
        let positives: u64 = bins.iter().map(|(_, c)| c.0).sum();
        let negatives: u64 = bins.iter().map(|(_, c)| c.1).sum();
        if positives == 0 || negatives == 0 {
            return Err(MetricsError::SingleClass {
                count: (positives + negatives) as usize,
                positive: positives > 0,
            });
        }
        let mut points = Vec::with_capacity(bins.len() + 1);
        points.push(RocPoint {
            threshold: f64::INFINITY,
            tp: 0,
            fp: 0,
        });
        let (mut tp, mut fp) = (0, 0);
        for (bin, (p, n)) in bins {
            tp += p;
            fp += n;
            points.push(RocPoint {
                threshold: bin_floor(bin),
                tp,
                fp,
            });
        }
        Ok(RocCurve {
            points,
            positives,
            negatives,
        })
    }
}

/// Adds the full-resolution heatmaps of every frame of `cache` from frame `skip_first` on
/// to `roc`, against the scenario's anomaly masks. Frames without a mask are skipped;
/// returns how many frames were added.
pub fn add_scenario_pixels(
    roc: &mut PixelRoc,
    scenario: &Scenario,
    cache: &ScoreCache,
    weights: &FusionWeights,
    mode: PixelReferenceMode,
    skip_first: usize,
) -> Result<usize, ScoreError> {
    add_scenario_pixels_each(
        std::slice::from_mut(roc),
        scenario,
        cache,
        std::slice::from_ref(weights),
        mode,
        skip_first,
    )
}

/// [`add_scenario_pixels`] for several weights at once: the heatmaps of `weights[k]` go to
/// `rocs[k]`. Each frame's mask and maps are read once for all of them (what a weight
/// study needs).
pub fn add_scenario_pixels_each(
    rocs: &mut [PixelRoc],
    scenario: &Scenario,
    cache: &ScoreCache,
    weights: &[FusionWeights],
    mode: PixelReferenceMode,
    skip_first: usize,
) -> Result<usize, ScoreError> {
    if rocs.len() != weights.len() {
        return Err(ScoreError::Invalid(format!(
            "{} pixel accumulators for {} weights",
            rocs.len(),
            weights.len()
        )));
    }
    let table = cache.table();
    let mut heatmap = Heatmap::new(table.meta.frame_width, table.meta.frame_height);
    let mut scratch = HeatmapScratch::default();
    let mut added = 0;
    for i in skip_first..table.frames.len() {
        let Some(mask) = scenario.anomaly_mask(i)? else {
            continue;
        };
        let maps = cache.frame_maps(i)?;
        for (roc, w) in rocs.iter_mut().zip(weights) {
            compose_heatmap(table, i, &maps, w, mode, &mut heatmap, &mut scratch)?;
            roc.add(&heatmap, &mask)?;
        }
        added += 1;
    }
    Ok(added)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_preserve_order_and_floors_lie_below_their_scores() {
        let values = [-3.0f32, -1e-3, 0.0, 1e-6, 0.5, 1.0, 7.25, 1e6];
        for w in values.windows(2) {
            assert!(bin_of(w[0]) < bin_of(w[1]), "{} vs {}", w[0], w[1]);
        }
        for v in values {
            let floor = bin_floor(bin_of(v));
            assert!(floor <= f64::from(v) + 1e-12, "{v}: floor {floor}");
            assert!((f64::from(v) - floor).abs() <= f64::from(v).abs() * 1e-4 + 1e-30);
        }
        assert_eq!(bin_of(-0.0), bin_of(0.0));
    }
}
