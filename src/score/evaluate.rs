//! Evaluation over scored scenarios: frame-level metrics by box source and by domain ×
//! weather ([`evaluate_dataset`], [`evaluate_table`] with a [`Grouping`]: the paper's
//! Table 2), the weight study ([`sweep_weights`] over [`sweep_grid`]: Table 3) and box IoU
//! of the scored boxes against the ground truth. Pixel-level metrics live in
//! [`super::pixel_roc`]; [`super::table`] renders the rows.
//!
//! Frame AUROC is micro (all metric frames of a group concatenated, as the reference);
//! macro (mean of per-scenario AUROCs, scenarios with a single class skipped) is reported
//! beside it. FPR95 is read at the first threshold whose TPR reaches 0.95; the AD code's
//! "closest to 0.95" variant is reported too.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::eval::{MetricsError, ScoreMetrics, macro_auroc};
use crate::sequence::{BoxRecord, Domain, Scenario, Weather};

use super::ScoreError;
use super::boxes::BoxMatchStats;
use super::cache::{ModelKey, ScoreCache, ScoreTable};
use super::fusion::{FrameFusion, FrameMetricOptions, FusionWeights, frame_scores, metric_frames};
use super::objects::is_anomalous_object;
use super::pixel_roc::PixelRoc;
use super::run::ScoreRequest;

/// One scored scenario as evaluation sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioScores {
    /// Scenario name.
    pub name: String,
    /// Road environment.
    pub domain: Domain,
    /// Weather.
    pub weather: Weather,
    /// Box source label (rows are grouped by it).
    pub box_source: String,
    /// Per-frame anomaly flags.
    pub labels: Vec<bool>,
    /// The cached scores.
    pub table: ScoreTable,
    /// Scored boxes against the ground truth, when computed.
    pub boxes: Option<BoxMatchStats>,
}

impl ScenarioScores {
    /// Gathers labels, metadata and (with `iou_threshold`) the box agreement of the cached
    /// objects' boxes with the ground truth of `scenario`.
    pub fn from_table(
        scenario: &Scenario,
        box_source: impl Into<String>,
        table: ScoreTable,
        iou_threshold: Option<f32>,
    ) -> Result<Self, ScoreError> {
        let labels = scenario.frame_labels().flags.clone();
        if labels.len() != table.frames.len() {
            return Err(ScoreError::Invalid(format!(
                "{}: {} frame labels but the score table has {} frames",
                scenario.root().display(),
                labels.len(),
                table.frames.len()
            )));
        }
        let boxes = match iou_threshold {
            Some(threshold) => Some(scored_box_agreement(scenario, &table, threshold)?),
            None => None,
        };
        let meta = scenario.meta();
        Ok(Self {
            name: scenario.name().to_string(),
            domain: meta.domain,
            weather: meta.weather,
            box_source: box_source.into(),
            labels,
            table,
            boxes,
        })
    }
}

impl ScenarioScores {
    /// The scores of `scenario` for `request` and `model` from its score cache, with box
    /// agreement at `iou_threshold`; `Ok(None)` when the scenario has not been scored so.
    /// The rows of [`evaluate_dataset`] are grouped by [`super::BoxSource::label`].
    pub fn from_cache(
        scenario: &Scenario,
        request: &ScoreRequest,
        model: ModelKey,
        iou_threshold: Option<f32>,
    ) -> Result<Option<Self>, ScoreError> {
        let key = request.key(scenario, model)?;
        let Some(cache) = ScoreCache::lookup(scenario, &key)? else {
            return Ok(None);
        };
        Self::from_table(
            scenario,
            request.boxes.label(),
            cache.into_table(),
            iou_threshold,
        )
        .map(Some)
    }
}

/// Agreement of the boxes that were scored (the cache's objects) with the ground truth of
/// `scenario`, frame by frame.
pub fn scored_box_agreement(
    scenario: &Scenario,
    table: &ScoreTable,
    iou_threshold: f32,
) -> Result<BoxMatchStats, ScoreError> {
    let mut stats = BoxMatchStats::new(iou_threshold);
    for i in 0..table.frames.len() {
        let id = table.frames[i].id;
        let scored: Vec<BoxRecord> = table
            .frame_objects(i)
            .iter()
            .map(|o| o.box_record(id))
            .collect();
        stats.add_frame(&scenario.boxes(i)?, &scored);
    }
    Ok(stats)
}

/// How often the object that sets an anomaly frame's score is the anomalous one: the
/// question an analyst asks first of a detection ("did it fire on the right car?").
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct TopObjectHits {
    /// Anomaly frames (after the skipped first frames) whose top-scoring object overlaps a
    /// ground-truth box flagged anomalous (IoU ≥ 0.5, or the same track id).
    pub hits: usize,
    /// Anomaly frames (after the skipped first frames) that have scored objects.
    pub frames: usize,
}

impl TopObjectHits {
    /// Adds the counts of `other`.
    pub fn merge(&mut self, other: TopObjectHits) {
        self.hits += other.hits;
        self.frames += other.frames;
    }

    /// `hits / frames`, `None` without anomaly frames.
    pub fn rate(&self) -> Option<f64> {
        (self.frames > 0).then(|| self.hits as f64 / self.frames as f64)
    }
}

/// Counts, over the anomaly frames of `scenario` from `skip_first` on, whether the
/// object with the highest fused score under `weights` is the anomalous one.
pub fn top_object_hits(
    scenario: &Scenario,
    table: &ScoreTable,
    weights: &FusionWeights,
    skip_first: usize,
) -> Result<TopObjectHits, ScoreError> {
    let fusion = FrameFusion::of_table(table, weights);
    let labels = &scenario.frame_labels().flags;
    let mut out = TopObjectHits::default();
    for (i, _) in labels
        .iter()
        .enumerate()
        .skip(skip_first)
        .filter(|(_, a)| **a)
    {
        let objects = table.frame_objects(i);
        let Some(top) = fusion.top_object(objects).map(|k| &objects[k]) else {
            continue;
        };
        out.frames += 1;
        let scored = top.box_record(table.frames[i].id);
        out.hits += usize::from(is_anomalous_object(top, &scored, &scenario.boxes(i)?));
    }
    Ok(out)
}

/// One row of the evaluation table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EvalRow {
    /// Box source label.
    pub box_source: String,
    /// Domain of the group; `None` = all domains.
    pub domain: Option<Domain>,
    /// Weather of the group; `None` = all weathers.
    pub weather: Option<Weather>,
    /// Scenarios in the group.
    pub scenarios: usize,
    /// Frames entering the metrics (after the skipped first frames).
    pub frames: usize,
    /// Anomalous ones among them.
    pub anomalous_frames: usize,
    /// Micro AUROC, AP, FPR95 etc.; `None` when the group has a single class.
    pub metrics: Option<ScoreMetrics>,
    /// Macro AUROC: mean over scenarios with both classes.
    pub auroc_macro: Option<f64>,
    /// Scenarios that entered the macro AUROC.
    pub macro_scenarios: usize,
    /// Pixel-level AUROC, AP, FPR95 etc. over the group's heatmaps; `None` when pixels were
    /// not evaluated or hold a single class.
    pub pixel: Option<ScoreMetrics>,
    /// Mean IoU of the ground-truth boxes with the scored boxes.
    pub mean_iou: Option<f64>,
    /// Ground-truth boxes found at the IoU threshold.
    pub box_recall: Option<f64>,
}

/// Which conditions split a box source's scenarios into rows of their own, after the row
/// over all of them. Both together give one row per domain × weather pair present.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Grouping {
    /// Split by road environment.
    pub domain: bool,
    /// Split by weather.
    pub weather: bool,
}

impl Grouping {
    /// Only the row over all scenarios of each box source.
    pub const NONE: Self = Self {
        domain: false,
        weather: false,
    };
    /// One row per domain × weather pair, as the paper's Table 2.
    pub const DOMAIN_WEATHER: Self = Self {
        domain: true,
        weather: true,
    };

    /// The group of a scenario under this grouping (`None` = not split on that key).
    fn key_of(self, item: &Prepared) -> (Option<Domain>, Option<Weather>) {
        (
            self.domain.then_some(item.domain),
            self.weather.then_some(item.weather),
        )
    }
}

fn condition_order(domain: Option<Domain>, weather: Option<Weather>) -> (u8, u8) {
    let d = match domain {
        None => 0,
        Some(Domain::City) => 1,
        Some(Domain::Highway) => 2,
        Some(Domain::Unknown) => 3,
    };
    let w = match weather {
        None => 0,
        Some(Weather::Sun) => 1,
        Some(Weather::Rain) => 2,
        Some(Weather::Fog) => 3,
        Some(Weather::Night) => 4,
        Some(Weather::Unknown) => 5,
    };
    (d, w)
}

/// One scenario ready for the metrics: its fused, filtered scores and labels, its box
/// agreement, and its pixel counts when pixels are evaluated.
struct Prepared<'a> {
    source: &'a str,
    domain: Domain,
    weather: Weather,
    scores: Vec<f64>,
    labels: Vec<bool>,
    boxes: Option<&'a BoxMatchStats>,
    pixels: Option<&'a PixelRoc>,
}

/// One scenario's raw frame scores from a scorer other than the model's fusion (a
/// [`super::Baseline`]), with what evaluation needs to place them in a table.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameSeries {
    /// Scenario name.
    pub name: String,
    /// Road environment.
    pub domain: Domain,
    /// Weather.
    pub weather: Weather,
    /// Row label (rows are grouped by it).
    pub source: String,
    /// Per-frame anomaly flags.
    pub labels: Vec<bool>,
    /// Raw frame scores, one per frame.
    pub raw: Vec<f64>,
    /// Frames dropped at the start unless the options say otherwise (the model's
    /// `clip_hist`, so baselines and model are measured on the same frames).
    pub skip_first: usize,
}

fn group_row(
    box_source: &str,
    condition: (Option<Domain>, Option<Weather>),
    members: &[&Prepared],
) -> Result<EvalRow, ScoreError> {
    let scores: Vec<f64> = members
        .iter()
        .flat_map(|m| m.scores.iter().copied())
        .collect();
    let labels: Vec<bool> = members
        .iter()
        .flat_map(|m| m.labels.iter().copied())
        .collect();
    let invalid = |e: MetricsError| ScoreError::Invalid(format!("{box_source}: {e}"));
    let metrics = match ScoreMetrics::compute(&scores, &labels) {
        Ok(m) => Some(m),
        Err(MetricsError::SingleClass { .. }) => None,
        Err(e) => return Err(invalid(e)),
    };
    let per_scenario = members
        .iter()
        .map(|m| (m.scores.as_slice(), m.labels.as_slice()));
    let macro_result = macro_auroc(per_scenario).map_err(invalid)?;
    let mut boxes: Option<BoxMatchStats> = None;
    let mut pixels: Option<PixelRoc> = None;
    for m in members {
        if let Some(b) = m.boxes {
            boxes
                .get_or_insert_with(|| BoxMatchStats::new(b.iou_threshold))
                .merge(b);
        }
        if let Some(p) = m.pixels {
            pixels.get_or_insert_with(PixelRoc::new).merge(p);
        }
    }
    let pixel = match pixels.map(|p| p.curve()) {
        None | Some(Err(MetricsError::SingleClass { .. })) => None,
        Some(Ok(curve)) => Some(curve.metrics()),
        Some(Err(e)) => return Err(invalid(e)),
    };
    Ok(EvalRow {
        box_source: box_source.to_string(),
        domain: condition.0,
        weather: condition.1,
        scenarios: members.len(),
        frames: labels.len(),
        anomalous_frames: labels.iter().filter(|&&l| l).count(),
        metrics,
        auroc_macro: macro_result.map(|(a, _)| a),
        macro_scenarios: macro_result.map_or(0, |(_, n)| n),
        pixel,
        mean_iou: boxes.and_then(|b| b.mean_iou()),
        box_recall: boxes.and_then(|b| b.recall()),
    })
}

/// The evaluation table with the paper's Table 2 rows: per box source (in order of first
/// appearance) a row over all its scenarios, followed by one row per domain × weather
/// present. See [`evaluate_table`] for other groupings and pixel metrics.
pub fn evaluate_dataset(
    items: &[ScenarioScores],
    weights: &FusionWeights,
    options: &FrameMetricOptions,
) -> Result<Vec<EvalRow>, ScoreError> {
    evaluate_table(items, None, weights, options, Grouping::DOMAIN_WEATHER)
}

/// The evaluation table: per box source (in order of first appearance) a row over all its
/// scenarios, followed by one row per group of `grouping` present (in the order city,
/// highway and sun, rain, fog, night). `pixels`, when given, holds one [`PixelRoc`] per
/// item (computed with the same weights, see [`add_scenario_pixels`]) and fills the rows'
/// pixel metrics.
pub fn evaluate_table(
    items: &[ScenarioScores],
    pixels: Option<&[PixelRoc]>,
    weights: &FusionWeights,
    options: &FrameMetricOptions,
    grouping: Grouping,
) -> Result<Vec<EvalRow>, ScoreError> {
    if let Some(p) = pixels
        && p.len() != items.len()
    {
        return Err(ScoreError::Invalid(format!(
            "{} pixel counts for {} scenarios",
            p.len(),
            items.len()
        )));
    }
    // Scenarios are fused and filtered independently: spread them over the cores.
    let prepared = items
        .par_iter()
        .enumerate()
        .map(|(k, item)| {
            let raw = frame_scores(&item.table, weights);
            let skip = options
                .skip_first
                .unwrap_or(item.table.meta.clip_hist as usize);
            let (scores, labels) =
                metric_frames(&raw, &item.labels, skip, options.median_kernel)
                    .map_err(|e| ScoreError::Invalid(format!("{}: {e}", item.name)))?;
            Ok(Prepared {
                source: &item.box_source,
                domain: item.domain,
                weather: item.weather,
                scores,
                labels,
                boxes: item.boxes.as_ref(),
                pixels: pixels.map(|p| &p[k]),
            })
        })
        .collect::<Result<Vec<_>, ScoreError>>()?;
    grouped_rows(&prepared, grouping)
}

/// The table of other scorers' frame scores ([`FrameSeries`], e.g. baselines): the rows of
/// [`evaluate_table`] (a row per source over all its scenarios, then one per group of
/// `grouping`), filtered and skipped by `options` as the model's scores are.
pub fn evaluate_series(
    series: &[FrameSeries],
    options: &FrameMetricOptions,
    grouping: Grouping,
) -> Result<Vec<EvalRow>, ScoreError> {
    let prepared = series
        .iter()
        .map(|item| {
            let skip = options.skip_first.unwrap_or(item.skip_first);
            let (scores, labels) =
                metric_frames(&item.raw, &item.labels, skip, options.median_kernel)
                    .map_err(|e| ScoreError::Invalid(format!("{}: {e}", item.name)))?;
            Ok(Prepared {
                source: &item.source,
                domain: item.domain,
                weather: item.weather,
                scores,
                labels,
                boxes: None,
                pixels: None,
            })
        })
        .collect::<Result<Vec<_>, ScoreError>>()?;
    grouped_rows(&prepared, grouping)
}

/// Rows per source (in order of first appearance): one over all its scenarios, then one per
/// group of `grouping` present.
fn grouped_rows(prepared: &[Prepared], grouping: Grouping) -> Result<Vec<EvalRow>, ScoreError> {
    let mut sources: Vec<&str> = Vec::new();
    for item in prepared {
        if !sources.contains(&item.source) {
            sources.push(item.source);
        }
    }
    let mut rows = Vec::new();
    for source in sources {
        let members: Vec<&Prepared> = prepared.iter().filter(|p| p.source == source).collect();
        rows.push(group_row(source, (None, None), &members)?);
        if grouping == Grouping::NONE {
            continue;
        }
        let mut conditions: Vec<(Option<Domain>, Option<Weather>)> = Vec::new();
        for m in &members {
            let key = grouping.key_of(m);
            if !conditions.contains(&key) {
                conditions.push(key);
            }
        }
        conditions.sort_by_key(|&(d, w)| condition_order(d, w));
        for condition in conditions {
            let group: Vec<&Prepared> = members
                .iter()
                .filter(|m| grouping.key_of(m) == condition)
                .copied()
                .collect();
            rows.push(group_row(source, condition, &group)?);
        }
    }
    Ok(rows)
}

/// The values each of w_r and w_p takes in the weight study: the grid {0.1, 1, 10}², which
/// holds all three presets (paper text 10 / 0.1, AD code 0.1 / 10, original 1 / 0.1).
pub const SWEEP_VALUES: [f64; 3] = [0.1, 1.0, 10.0];

/// The weight study's grid: every (w_r, w_p) of [`SWEEP_VALUES`], w_r outer, with the same
/// pair at the pixel level (as every preset has).
pub fn sweep_grid() -> Vec<FusionWeights> {
    SWEEP_VALUES
        .iter()
        .flat_map(|&w_r| {
            SWEEP_VALUES.iter().map(move |&w_p| FusionWeights {
                w_r,
                w_p,
                w_r_p: w_r,
                w_p_p: w_p,
            })
        })
        .collect()
}

/// One row of the weight study: the metrics over all scenarios of a box source for one
/// set of weights.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepRow {
    /// The weights of this row.
    pub weights: FusionWeights,
    /// The preset these weights are, if any ([`FusionWeights::PRESETS`]).
    pub preset: Option<&'static str>,
    /// The metrics (always over all domains and weathers).
    pub row: EvalRow,
}

/// The weight study (the paper's Table 3): for every box source, one row per point of
/// `grid` over all its scenarios, box sources in order of first appearance. `pixels`,
/// when given, holds per grid point one [`PixelRoc`] per item, computed with that point's
/// weights.
pub fn sweep_weights(
    items: &[ScenarioScores],
    pixels: Option<&[Vec<PixelRoc>]>,
    grid: &[FusionWeights],
    options: &FrameMetricOptions,
) -> Result<Vec<SweepRow>, ScoreError> {
    if let Some(p) = pixels
        && p.len() != grid.len()
    {
        return Err(ScoreError::Invalid(format!(
            "pixel counts for {} weight points, the grid has {}",
            p.len(),
            grid.len()
        )));
    }
    let mut per_point = Vec::with_capacity(grid.len());
    for (k, weights) in grid.iter().enumerate() {
        let point_pixels = pixels.map(|p| p[k].as_slice());
        per_point.push(evaluate_table(
            items,
            point_pixels,
            weights,
            options,
            Grouping::NONE,
        )?);
    }
    let sources = per_point.first().map_or(0, Vec::len);
    let mut rows = Vec::with_capacity(sources * grid.len());
    for source in 0..sources {
        for (weights, point) in grid.iter().zip(&per_point) {
            rows.push(SweepRow {
                weights: *weights,
                preset: FusionWeights::PRESETS
                    .iter()
                    .find(|(_, p)| p == weights)
                    .map(|(name, _)| *name),
                row: point[source].clone(),
            });
        }
    }
    Ok(rows)
}
