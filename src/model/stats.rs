//! Training statistics stored with a model: mean and population std of the per-cube scores
//! S_r and S_p (for the frame-level z-scores, spec §6) and median / quartiles of the per-pixel
//! squared errors (for the pixel-level robust scaling, spec Part A.6), plus their accumulator.
//!
//! Beyond the reference, the score moments can also be kept per vertical band of the image
//! ([`TrainingStats::bands`], by the box centre's column): objects beside the road (parked
//! and oncoming cars) have much larger flow errors in normal driving than the car ahead, so
//! one global z-score lets them set every normal frame's score; a z-score against the
//! objects of the same band asks "unusual *for an object there*" instead. The scores can
//! also be kept as tail tables ([`ScoreTails`], [`super::score_tail`]), which score an
//! object by how rare its error is among the training cubes instead of by its z-score.

use serde::{Deserialize, Serialize};

use super::rng::NoiseRng;
use super::score_tail::TailTable;

/// Mean and population standard deviation (ddof 0) of one score: the same statistic the
/// evaluation z-scores with, so both share one definition.
pub type ScoreStats = crate::eval::MeanStd;

/// Robust location and spread of the per-pixel squared errors, taken over all elements of
/// the error tensors together (as the reference robust-scales whole error tensors).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PixelStats {
    /// Median.
    pub median: f64,
    /// First quartile.
    pub q25: f64,
    /// Third quartile.
    pub q75: f64,
    /// Interquartile range q75 − q25.
    pub iqr: f64,
    /// How many values the quantiles were computed from (a uniform sample of all of them).
    pub sampled: u64,
    /// How many values there were in total.
    pub total: u64,
}

/// Tail tables of S_r and S_p over a set of training cubes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScoreTails {
    /// S_r's table.
    pub flow: TailTable,
    /// S_p's table.
    pub frame: TailTable,
}

impl ScoreTails {
    /// The tables of paired S_r and S_p values; `None` for none (or a non-finite one).
    pub fn of(flow_scores: &[f64], frame_scores: &[f64]) -> Option<Self> {
        Some(Self {
            flow: TailTable::of(flow_scores)?,
            frame: TailTable::of(frame_scores)?,
        })
    }

    /// The tail surprisals of S_r and S_p.
    pub fn surprisals(&self, s_r: f64, s_p: f64) -> (f64, f64) {
        (self.flow.surprisal(s_r), self.frame.surprisal(s_p))
    }
}

/// S_r and S_p moments of the training cubes whose box centre lies in one band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BandStats {
    /// Training cubes in the band.
    pub cubes: u64,
    /// S_r of those cubes.
    pub flow_score: ScoreStats,
    /// S_p of those cubes.
    pub frame_score: ScoreStats,
    /// Tail tables of those cubes' scores, when the model scores by tail surprisal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tails: Option<ScoreTails>,
}

/// The band (of `bands` equal vertical bands of the image) holding a box centre at
/// `centre_x`, a fraction of the frame width; centres outside [0, 1) fall in the end bands.
pub fn band_of(centre_x: f32, bands: usize) -> usize {
    let bands = bands.max(1);
    ((centre_x * bands as f32).floor().max(0.0) as usize).min(bands - 1)
}

/// Everything the scoring needs from the training data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainingStats {
    /// Number of training cubes.
    pub cubes: u64,
    /// S_r: per-cube sum of squared flow-reconstruction errors.
    pub flow_score: ScoreStats,
    /// S_p: per-cube sum of squared frame-prediction errors.
    pub frame_score: ScoreStats,
    /// Per-element squared flow errors (all flow channels).
    pub flow_pixel: PixelStats,
    /// Per-element squared frame errors (all colour channels).
    pub frame_pixel: PixelStats,
    /// S_r/S_p moments per vertical band of the image, left to right (empty: the global
    /// moments above apply everywhere, as in the reference). A band with fewer than
    /// [`MIN_BAND_CUBES`] training cubes keeps the global moments.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bands: Vec<BandStats>,
    /// Tail tables of all training cubes' scores (`None`: objects are z-scored, as in the
    /// reference). When present, every band with its own moments has its own tables too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tails: Option<ScoreTails>,
}

/// Fewest training cubes a band needs for moments of its own.
pub const MIN_BAND_CUBES: u64 = 30;

impl TrainingStats {
    /// The band of an object whose box centre lies at `centre_x` (a fraction of the frame
    /// width), if the model has bands and that one has enough cubes for its own statistics.
    pub fn band_at(&self, centre_x: f32) -> Option<&BandStats> {
        self.bands
            .get(band_of(centre_x, self.bands.len()))
            .filter(|band| band.cubes >= MIN_BAND_CUBES)
    }

    /// The statistics of all training cubes.
    pub fn global(&self) -> ObjectStatistics<'_> {
        ObjectStatistics {
            flow: &self.flow_score,
            frame: &self.frame_score,
            tails: self.tails.as_ref(),
        }
    }

    /// The statistics that normalise an object whose box centre lies at `centre_x` (a
    /// fraction of the frame width): its band's when it has its own, else the global ones.
    pub fn statistics_at(&self, centre_x: f32) -> ObjectStatistics<'_> {
        match self.band_at(centre_x) {
            Some(band) => ObjectStatistics {
                flow: &band.flow_score,
                frame: &band.frame_score,
                tails: band.tails.as_ref(),
            },
            None => self.global(),
        }
    }

    /// The letter the viewer names normalised scores with: `t` for tail surprisals, `z` for
    /// z-scores.
    pub fn component_symbol(&self) -> &'static str {
        if self.tails.is_some() { "t" } else { "z" }
    }
}

/// The training statistics one object is normalised against (its band's or the global
/// ones): S_r and S_p moments, and their tail tables when the model scores by tail
/// surprisal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectStatistics<'a> {
    /// S_r moments.
    pub flow: &'a ScoreStats,
    /// S_p moments.
    pub frame: &'a ScoreStats,
    /// Tail tables of S_r and S_p, if kept.
    pub tails: Option<&'a ScoreTails>,
}

impl ObjectStatistics<'_> {
    /// The normalised (S_r, S_p), what the fusion weights multiply: their tail surprisals
    /// when there are tail tables, else their z-scores.
    pub fn normalise(&self, s_r: f64, s_p: f64) -> (f64, f64) {
        match self.tails {
            Some(tails) => tails.surprisals(s_r, s_p),
            None => (self.flow.z(s_r), self.frame.z(s_p)),
        }
    }
}

/// Reservoir sample of a stream of values (Vitter's algorithm R), for quantiles of streams
/// too large to hold (the paper set has ~1.2 billion flow-error values).
#[derive(Debug, Clone)]
struct Reservoir {
    capacity: usize,
    seen: u64,
    values: Vec<f32>,
}

impl Reservoir {
    fn new(capacity: usize) -> Self {
        Self {
            capacity,
            seen: 0,
            values: Vec::with_capacity(capacity.min(1 << 20)),
        }
    }

    fn push_all(&mut self, values: &[f32], rng: &mut NoiseRng) {
        for &v in values {
            self.seen += 1;
            if self.values.len() < self.capacity {
                self.values.push(v);
            } else {
                let j = (rng.next_u64() % self.seen) as usize;
                if j < self.capacity {
                    self.values[j] = v;
                }
            }
        }
    }

    fn stats(mut self) -> PixelStats {
        self.values.sort_unstable_by(f32::total_cmp);
        let q = |p: f64| quantile_sorted(&self.values, p);
        let (q25, median, q75) = (q(0.25), q(0.5), q(0.75));
        PixelStats {
            median,
            q25,
            q75,
            iqr: q75 - q25,
            sampled: self.values.len() as u64,
            total: self.seen,
        }
    }
}

/// Quantile `p` of sorted `values` with numpy's default "linear" interpolation; 0 if empty.
pub fn quantile_sorted<T: Copy + Into<f64>>(values: &[T], p: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let pos = p * (values.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let frac = pos - lo as f64;
    let (lo, hi) = (values[lo].into(), values[hi].into());
    lo + (hi - lo) * frac
}

/// Accumulates [`TrainingStats`] over batches of model outputs.
#[derive(Debug, Clone)]
pub struct StatsAccumulator {
    cubes: u64,
    flow_scores: Vec<f64>,
    frame_scores: Vec<f64>,
    /// Band of each pushed cube (empty without bands).
    cube_bands: Vec<usize>,
    bands: usize,
    /// Whether [`Self::finish`] also builds tail tables.
    tails: bool,
    flow_pixels: Reservoir,
    frame_pixels: Reservoir,
    rng: NoiseRng,
}

impl StatsAccumulator {
    /// An empty accumulator keeping at most `pixel_sample` values per error kind for the
    /// quantiles (exact when the data set has fewer).
    pub fn new(pixel_sample: usize, seed: u64) -> Self {
        Self {
            cubes: 0,
            flow_scores: Vec::new(),
            frame_scores: Vec::new(),
            cube_bands: Vec::new(),
            bands: 1,
            tails: false,
            flow_pixels: Reservoir::new(pixel_sample),
            frame_pixels: Reservoir::new(pixel_sample),
            rng: NoiseRng::new(seed),
        }
    }

    /// Also keeps the score moments per each of `bands` vertical bands of the image (1: only
    /// the global moments); cubes then go in with [`Self::push_at`].
    pub fn with_bands(mut self, bands: usize) -> Self {
        self.bands = bands.max(1);
        self
    }

    /// Also keeps tail tables of the scores ([`ScoreTails`]), globally and per band.
    pub fn with_tails(mut self, tails: bool) -> Self {
        self.tails = tails;
        self
    }

    /// Adds one cube whose box centre lies at `centre_x` (a fraction of the frame width).
    pub fn push_at(
        &mut self,
        centre_x: f32,
        s_r: f32,
        s_p: f32,
        flow_error: &[f32],
        frame_error: &[f32],
    ) {
        if self.bands > 1 {
            self.cube_bands.push(band_of(centre_x, self.bands));
        }
        self.push(s_r, s_p, flow_error, frame_error);
    }

    /// Adds one cube: its scores and its per-element squared errors.
    pub fn push(&mut self, s_r: f32, s_p: f32, flow_error: &[f32], frame_error: &[f32]) {
        self.cubes += 1;
        self.flow_scores.push(s_r as f64);
        self.frame_scores.push(s_p as f64);
        self.flow_pixels.push_all(flow_error, &mut self.rng);
        self.frame_pixels.push_all(frame_error, &mut self.rng);
    }

    /// The statistics of everything pushed so far.
    pub fn finish(self) -> TrainingStats {
        // Population moments; none pushed gives 0 and 0.
        let moments = |values: &[f64]| {
            ScoreStats::of(values).unwrap_or(ScoreStats {
                mean: 0.0,
                std: 0.0,
            })
        };
        let bands = if self.bands > 1 && self.cube_bands.len() == self.flow_scores.len() {
            (0..self.bands)
                .map(|band| {
                    let pick = |scores: &[f64]| -> Vec<f64> {
                        scores
                            .iter()
                            .zip(&self.cube_bands)
                            .filter(|(_, b)| **b == band)
                            .map(|(s, _)| *s)
                            .collect()
                    };
                    let (flow, frame) = (pick(&self.flow_scores), pick(&self.frame_scores));
                    BandStats {
                        cubes: flow.len() as u64,
                        flow_score: moments(&flow),
                        frame_score: moments(&frame),
                        tails: self.tails.then(|| ScoreTails::of(&flow, &frame)).flatten(),
                    }
                })
                .collect()
        } else {
            Vec::new()
        };
        TrainingStats {
            cubes: self.cubes,
            flow_score: moments(&self.flow_scores),
            frame_score: moments(&self.frame_scores),
            flow_pixel: self.flow_pixels.stats(),
            frame_pixel: self.frame_pixels.stats(),
            bands,
            tails: self
                .tails
                .then(|| ScoreTails::of(&self.flow_scores, &self.frame_scores))
                .flatten(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_follow_numpy_linear_interpolation() {
        let v = [1.0f32, 2.0, 3.0, 4.0];
        assert!((quantile_sorted(&v, 0.25) - 1.75).abs() < 1e-12);
        assert!((quantile_sorted(&v, 0.5) - 2.5).abs() < 1e-12);
        assert!((quantile_sorted(&v, 0.75) - 3.25).abs() < 1e-12);
    }

    #[test]
    fn accumulator_gives_population_moments_and_exact_small_quantiles() {
        let mut acc = StatsAccumulator::new(1000, 1);
        for (r, p) in [(1.0, 10.0), (2.0, 20.0), (3.0, 30.0), (4.0, 40.0)] {
            acc.push(r, p, &[r, r], &[p]);
        }
        let s = acc.finish();
        assert_eq!(s.cubes, 4);
        assert!((s.flow_score.mean - 2.5).abs() < 1e-12);
        assert!((s.flow_score.std - 1.25f64.sqrt()).abs() < 1e-12);
        assert!((s.frame_score.mean - 25.0).abs() < 1e-12);
        assert_eq!(s.flow_pixel.sampled, 8);
        assert!((s.flow_pixel.median - 2.5).abs() < 1e-12);
        assert!((s.frame_pixel.iqr - 15.0).abs() < 1e-12);
    }

    #[test]
    fn band_moments_are_those_of_the_cubes_centred_in_each_band() {
        let mut acc = StatsAccumulator::new(100, 1).with_bands(3);
        // Left band: S_r 1 and 3; middle: 10, 20, 30 (× 12 so it has enough cubes); right: none.
        for (x, r) in [(0.1, 1.0), (0.2, 3.0)] {
            acc.push_at(x, r, 2.0 * r, &[], &[]);
        }
        for _ in 0..12 {
            for r in [10.0, 20.0, 30.0] {
                acc.push_at(0.5, r, 0.0, &[], &[]);
            }
        }
        let s = acc.finish();
        assert_eq!(s.bands.len(), 3);
        assert_eq!(
            s.bands.iter().map(|b| b.cubes).collect::<Vec<_>>(),
            [2, 36, 0]
        );
        assert!((s.bands[0].flow_score.mean - 2.0).abs() < 1e-12);
        assert!((s.bands[0].frame_score.mean - 4.0).abs() < 1e-12);
        assert!((s.bands[1].flow_score.mean - 20.0).abs() < 1e-12);
        assert!((s.bands[1].flow_score.std - (200.0f64 / 3.0).sqrt()).abs() < 1e-9);
        // The middle band has enough cubes for its own moments; the sparse ones fall back.
        assert_eq!(s.statistics_at(0.5).flow, &s.bands[1].flow_score);
        assert_eq!(s.statistics_at(0.1).flow, &s.flow_score);
        assert_eq!(s.statistics_at(0.9).flow, &s.flow_score);
        assert_eq!(
            (band_of(-0.2, 3), band_of(0.34, 3), band_of(1.0, 3)),
            (0, 1, 2)
        );
    }

    #[test]
    fn reservoir_sample_estimates_quantiles_of_a_long_stream() {
        let mut acc = StatsAccumulator::new(20_000, 7);
        let values: Vec<f32> = (0..200_000).map(|i| i as f32).collect();
        acc.push(0.0, 0.0, &values, &[]);
        let s = acc.finish().flow_pixel;
        assert_eq!(s.total, 200_000);
        assert_eq!(s.sampled, 20_000);
        assert!(
            (s.median / 100_000.0 - 1.0).abs() < 0.02,
            "median {}",
            s.median
        );
    }
}
