//! Fused frame scores and live metrics: for the current weights, each scored scenario's
//! score series (`score`'s [`ScoreSeries`]: raw and median-filtered frame scores, z-scores,
//! the series the timeline draws), its ROC metrics and detection latencies, and the same
//! over the whole data set (micro and macro AUROC). Pure functions of the score tables,
//! labels and settings, redone on every change of weights, filter or threshold.

use crate::eval::{DetectionOutcome, RocCurve, ScoreMetrics, detection_outcomes, macro_auroc};
use crate::score::{FusionParams, ScoreSeries, ScoreTable};

/// One scored scenario under the current parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioAnalysis {
    /// The score series: raw (`fused`) and median-filtered (`filtered`, NaN for the first
    /// `skip` frames, which the model cannot score and metrics leave out) frame scores and
    /// the z-scores of each frame's top object.
    pub series: ScoreSeries,
    /// ROC curve of the metric frames; `None` when they hold a single class.
    pub roc: Option<RocCurve>,
    /// Metrics of the metric frames; `None` when they hold a single class.
    pub metrics: Option<ScoreMetrics>,
    /// Every anomaly event with its detection latency at the threshold of the last
    /// [`Self::detect`].
    pub outcomes: Vec<DetectionOutcome>,
}

impl ScenarioAnalysis {
    /// Fuses `table` with `params` against `labels` (one flag per frame of the table);
    /// detections are left for [`Self::detect`].
    pub fn fuse(table: &ScoreTable, labels: &[bool], params: &FusionParams) -> Self {
        let series = ScoreSeries::compute(table, labels, &params.weights, params.median_kernel);
        let (scores, flags) = metric_frames(&series, labels);
        let roc = RocCurve::compute(scores, flags).ok();
        let metrics = roc.as_ref().map(RocCurve::metrics);
        Self {
            series,
            roc,
            metrics,
            outcomes: Vec::new(),
        }
    }

    /// Finds every anomaly event of `labels` and its detection latency at `threshold`.
    pub fn detect(&mut self, labels: &[bool], threshold: f64) {
        let n = self.series.filtered.len().min(labels.len());
        self.outcomes = detection_outcomes(&self.series.filtered[..n], &labels[..n], threshold);
    }

    /// Mean latency (frames) of the detected events.
    pub fn mean_latency(&self) -> Option<f64> {
        mean_latency(&self.outcomes)
    }

    /// Number of events detected at the threshold.
    pub fn detected(&self) -> usize {
        self.outcomes
            .iter()
            .filter(|o| o.latency_frames.is_some())
            .count()
    }
}

/// The frames that enter the metrics: filtered scores and labels after the first `skip`.
pub fn metric_frames<'a>(series: &'a ScoreSeries, labels: &'a [bool]) -> (&'a [f64], &'a [bool]) {
    let n = series.filtered.len().min(labels.len());
    let skip = series.skip.min(n);
    (&series.filtered[skip..n], &labels[skip..n])
}

/// Mean latency (frames) of the detected events of `outcomes`.
fn mean_latency<'a>(outcomes: impl IntoIterator<Item = &'a DetectionOutcome>) -> Option<f64> {
    let (sum, count) = outcomes
        .into_iter()
        .filter_map(|o| o.latency_frames)
        .fold((0usize, 0usize), |(s, c), l| (s + l, c + 1));
    (count > 0).then(|| sum as f64 / count as f64)
}

/// Metrics over every scored scenario of the data set.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DatasetMetrics {
    /// Scenarios that have scores.
    pub scenarios: usize,
    /// Metric frames over them.
    pub frames: usize,
    /// ROC of all metric frames concatenated; `None` when they hold a single class.
    pub roc: Option<RocCurve>,
    /// Micro metrics (all metric frames concatenated).
    pub micro: Option<ScoreMetrics>,
    /// Macro AUROC (mean over scenarios with both classes) and the scenarios it averages.
    pub macro_auroc: Option<(f64, usize)>,
    /// Anomaly events over all scenarios.
    pub events: usize,
    /// Events detected at the threshold.
    pub detected: usize,
    /// Mean latency (frames) of the detected events.
    pub mean_latency: Option<f64>,
}

impl DatasetMetrics {
    /// ROC metrics over `scenarios`, each an analysis with the labels it was fused against;
    /// detections are left for [`Self::detect`].
    pub fn compute<'a>(
        scenarios: impl IntoIterator<Item = (&'a ScenarioAnalysis, &'a [bool])>,
    ) -> Self {
        let mut count = 0;
        let mut scores = Vec::new();
        let mut labels = Vec::new();
        let mut groups = Vec::new();
        for (analysis, flags) in scenarios {
            let (s, l) = metric_frames(&analysis.series, flags);
            scores.extend_from_slice(s);
            labels.extend_from_slice(l);
            groups.push((s, l));
            count += 1;
        }
        let roc = RocCurve::compute(&scores, &labels).ok();
        Self {
            scenarios: count,
            frames: scores.len(),
            micro: roc.as_ref().map(RocCurve::metrics),
            roc,
            macro_auroc: macro_auroc(groups).ok().flatten(),
            ..Self::default()
        }
    }

    /// Sums the detections of `scenarios` (after their [`ScenarioAnalysis::detect`]).
    pub fn detect<'a>(&mut self, scenarios: impl IntoIterator<Item = &'a ScenarioAnalysis>) {
        let outcomes: Vec<&DetectionOutcome> =
            scenarios.into_iter().flat_map(|a| &a.outcomes).collect();
        self.events = outcomes.len();
        self.detected = outcomes
            .iter()
            .filter(|o| o.latency_frames.is_some())
            .count();
        self.mean_latency = mean_latency(outcomes);
    }
}
