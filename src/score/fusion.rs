//! Fusion of cached per-object errors into frame scores and pixel heatmaps for any weights:
//! pure functions over a [`ScoreTable`] (and the maps of one frame), cheap enough to redo on
//! every slider move.
//!
//! **Frame scores** (spec §6, Part A.7): object score
//! s = w_r·(S_r − μ_r)/σ_r + w_p·(S_p − μ_p)/σ_p with the model's training statistics; a
//! frame scores the maximum over its objects, a frame without objects the score of a
//! zero-error object, w_r·(−μ_r/σ_r) + w_p·(−μ_p/σ_p). A zero σ contributes 0 (see
//! [`crate::model::ScoreStats::z`]). A model that keeps tail tables
//! ([`crate::model::ScoreScale::TailSurprisal`]) replaces each z-score by the tail surprisal
//! of the error among the training cubes, s = w_r·t_r(S_r) + w_p·t_p(S_p). For metrics, the first `clip_hist` frames of a
//! scenario are dropped and the rest median-filtered ([`metric_frames`]).
//!
//! **Pixel heatmaps** (spec §7.2, Part A.6): per object,
//! w_r_p·(E_r − m_r)/IQR_r + w_p_p·(E_p − m_p)/IQR_p on its channel-averaged 32×32 error
//! maps (robust scaling is affine, so scaling the channel mean equals the channel mean of
//! the scaled elements), with the median and IQR of a reference set: the model's training
//! cubes (default), the scenario being scored, or, for comparison with the reference code,
//! the object's own batch of 128 cubes. Each box gets its own map, resized bilinearly
//! (OpenCV `INTER_LINEAR` sampling) into the box's pixels — columns ⌈x1⌉…⌈x2⌉−1 and rows
//! ⌈y1⌉…⌈y2⌉−1 clipped to the image, exactly what the cube saw —, pixels outside every box
//! score 0 and overlapping boxes take the maximum. [`PixelReferenceMode::ReferenceBatches`]
//! also reproduces the reference's quirk: every box of a frame shows the map of the frame's
//! last object, written box after box (later boxes overwrite).

use serde::{Deserialize, Serialize};

use crate::box_crop;
use crate::eval::{RobustStats, median_filter};
use crate::model::{ObjectStatistics, ScoreStats, ScoreTails, TrainingStats, band_of};

use super::ScoreError;
use super::cache::{ObjectMaps, ObjectScore, PixelReference, ScoreTable};

/// The four fusion weights.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FusionWeights {
    /// Frame level: weight of the flow-reconstruction z-score.
    pub w_r: f64,
    /// Frame level: weight of the frame-prediction z-score.
    pub w_p: f64,
    /// Pixel level: weight of the robust-scaled flow error map.
    pub w_r_p: f64,
    /// Pixel level: weight of the robust-scaled frame error map.
    pub w_p_p: f64,
}

impl FusionWeights {
    /// HF²-VAD_AD as its paper's text states it: 10 / 0.1 at both levels (vadscope's default).
    pub const PAPER_TEXT: Self = Self {
        w_r: 10.0,
        w_p: 0.1,
        w_r_p: 10.0,
        w_p_p: 0.1,
    };
    /// HF²-VAD_AD as its committed `finetune_cfg.yaml` says: 0.1 / 10 at both levels.
    pub const AD_CODE: Self = Self {
        w_r: 0.1,
        w_p: 10.0,
        w_r_p: 0.1,
        w_p_p: 10.0,
    };
    /// The original HF²-VAD's 1 / 0.1 (it has no pixel level; the same pair is used there).
    pub const ORIGINAL: Self = Self {
        w_r: 1.0,
        w_p: 0.1,
        w_r_p: 1.0,
        w_p_p: 0.1,
    };

    /// The presets of the weights panel, with their names.
    pub const PRESETS: [(&'static str, Self); 3] = [
        ("HF²-VAD_AD paper text (10 / 0.1)", Self::PAPER_TEXT),
        ("HF²-VAD_AD code (0.1 / 10)", Self::AD_CODE),
        ("HF²-VAD original (1 / 0.1)", Self::ORIGINAL),
    ];
}

impl Default for FusionWeights {
    fn default() -> Self {
        Self::PAPER_TEXT
    }
}

/// One affine map (S_r, S_p) ↦ a_r·S_r + a_p·S_p + c.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Affine {
    a_r: f64,
    a_p: f64,
    c: f64,
}

impl Affine {
    fn new(flow: &ScoreStats, frame: &ScoreStats, weights: &FusionWeights) -> Self {
        let slope = |w: f64, s: &ScoreStats| if s.std > 0.0 { w / s.std } else { 0.0 };
        Self {
            a_r: slope(weights.w_r, flow),
            a_p: slope(weights.w_p, frame),
            c: weights.w_r * flow.z(0.0) + weights.w_p * frame.z(0.0),
        }
    }
}

/// The weighted sum of tail surprisals w_r·t_r(S_r) + w_p·t_p(S_p).
#[derive(Debug, Clone, PartialEq)]
struct TailSum {
    tails: ScoreTails,
    w_r: f64,
    w_p: f64,
}

/// One set of training statistics as a map (S_r, S_p) ↦ object score.
#[derive(Debug, Clone, PartialEq)]
enum ObjectMap {
    /// z-scores: affine in (S_r, S_p).
    Affine(Affine),
    /// Tail surprisals.
    Tail(TailSum),
}

impl ObjectMap {
    fn new(statistics: ObjectStatistics<'_>, weights: &FusionWeights) -> Self {
        match statistics.tails {
            Some(tails) => Self::Tail(TailSum {
                tails: tails.clone(),
                w_r: weights.w_r,
                w_p: weights.w_p,
            }),
            None => Self::Affine(Affine::new(statistics.flow, statistics.frame, weights)),
        }
    }

    fn score(&self, s_r: f64, s_p: f64) -> f64 {
        match self {
            Self::Affine(map) => map.a_r * s_r + map.a_p * s_p + map.c,
            Self::Tail(sum) => {
                let (t_r, t_p) = sum.tails.surprisals(s_r, s_p);
                sum.w_r * t_r + sum.w_p * t_p
            }
        }
    }
}

/// The object score `w_r·z(S_r) + w_p·z(S_p)` (or the tail surprisals' sum, for a model
/// that keeps tail tables), with the training statistics of the object's band of the image
/// when the model has them ([`TrainingStats::bands`]), else with the global ones.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameFusion {
    global: ObjectMap,
    /// One map per band, left to right (empty without bands).
    bands: Vec<ObjectMap>,
    frame_width: u32,
}

impl FrameFusion {
    /// The fusion of `weights` under the model's training statistics, for frames
    /// `frame_width` pixels wide.
    pub fn new(stats: &TrainingStats, weights: &FusionWeights, frame_width: u32) -> Self {
        let n = stats.bands.len();
        let bands = (0..n)
            .map(|b| ObjectMap::new(stats.statistics_at((b as f32 + 0.5) / n as f32), weights))
            .collect();
        Self {
            global: ObjectMap::new(stats.global(), weights),
            bands,
            frame_width,
        }
    }

    /// The fusion of `weights` for the objects of `table`.
    pub fn of_table(table: &ScoreTable, weights: &FusionWeights) -> Self {
        Self::new(&table.meta.training, weights, table.meta.frame_width)
    }

    /// The score of `object`.
    pub fn object_score(&self, object: &ObjectScore) -> f64 {
        let map = if self.bands.is_empty() {
            &self.global
        } else {
            let centre = object.centre_fraction(self.frame_width);
            &self.bands[band_of(centre, self.bands.len())]
        };
        map.score(f64::from(object.s_r), f64::from(object.s_p))
    }

    /// The index in `objects` of the object with the highest score (the last of equal ones),
    /// `None` for no objects: the object that sets a frame's score.
    pub fn top_object(&self, objects: &[ObjectScore]) -> Option<usize> {
        (0..objects.len()).max_by(|&a, &b| {
            self.object_score(&objects[a])
                .total_cmp(&self.object_score(&objects[b]))
        })
    }

    /// The score of a frame without objects: a zero-error object under the global
    /// statistics.
    pub fn empty_frame_score(&self) -> f64 {
        self.global.score(0.0, 0.0)
    }
}

/// Raw frame scores of a table (one per frame, unfiltered), written into `out`.
pub fn frame_scores_into(table: &ScoreTable, weights: &FusionWeights, out: &mut Vec<f64>) {
    let fusion = FrameFusion::of_table(table, weights);
    out.clear();
    out.reserve(table.frames.len());
    for f in &table.frames {
        let start = f.first_object as usize;
        let objects = table
            .objects
            .get(start..start + f.objects as usize)
            .unwrap_or(&[]);
        let score = objects
            .iter()
            .map(|o| fusion.object_score(o))
            .reduce(f64::max)
            .unwrap_or_else(|| fusion.empty_frame_score());
        out.push(score);
    }
}

/// Raw frame scores of a table (one per frame, unfiltered).
pub fn frame_scores(table: &ScoreTable, weights: &FusionWeights) -> Vec<f64> {
    let mut out = Vec::new();
    frame_scores_into(table, weights, &mut out);
    out
}

/// How frame scores become metric inputs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrameMetricOptions {
    /// Median-filter kernel (SciPy `medfilt`, zero-padded); 0 or 1 = no filter. The
    /// reference uses 17.
    pub median_kernel: usize,
    /// Frames dropped at the start of each scenario; `None` = the model's `clip_hist`.
    pub skip_first: Option<usize>,
}

impl Default for FrameMetricOptions {
    fn default() -> Self {
        Self {
            median_kernel: 17,
            skip_first: None,
        }
    }
}

/// The scores and labels of one scenario as they enter the metrics: the first frames
/// dropped, then the median filter (the reference's order). `labels` must have one flag
/// per frame.
pub fn metric_frames(
    raw: &[f64],
    labels: &[bool],
    skip_first: usize,
    median_kernel: usize,
) -> Result<(Vec<f64>, Vec<bool>), ScoreError> {
    if raw.len() != labels.len() {
        return Err(ScoreError::Invalid(format!(
            "{} frame scores but {} frame labels",
            raw.len(),
            labels.len()
        )));
    }
    let skip = skip_first.min(raw.len());
    Ok((
        median_filter(&raw[skip..], median_kernel),
        labels[skip..].to_vec(),
    ))
}

/// Which statistics robust-scale the pixel error maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PixelReferenceMode {
    /// Median / IQR of the model's training cubes (vadscope's default).
    #[default]
    Training,
    /// Median / IQR over the scored scenario's objects.
    Scenario,
    /// The reference code: each object's batch of 128 cubes, and the last object's map in
    /// every box of a frame.
    ReferenceBatches,
}

/// A pixel score map on a grid of `width`×`height`, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Heatmap {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// One score per pixel.
    pub values: Vec<f32>,
}

impl Heatmap {
    /// An all-zero map.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            values: vec![0.0; width as usize * height as usize],
        }
    }

    /// The score at (x, y).
    pub fn at(&self, x: u32, y: u32) -> f32 {
        self.values[y as usize * self.width as usize + x as usize]
    }
}

/// The pixel map of one object as an affine function of its two error maps.
#[derive(Debug, Clone, Copy)]
struct PixelAffine {
    a_flow: f32,
    a_frame: f32,
    c: f32,
}

impl PixelAffine {
    fn new(reference: &PixelReference, weights: &FusionWeights) -> Self {
        // RobustStats::scale divides by 1 when the IQR is 0; the same convention here.
        let inverse = |r: &RobustStats| {
            let iqr = r.iqr();
            if iqr > 0.0 { 1.0 / iqr } else { 1.0 }
        };
        let (fl, fr) = (inverse(&reference.flow), inverse(&reference.frame));
        Self {
            a_flow: (weights.w_r_p * fl) as f32,
            a_frame: (weights.w_p_p * fr) as f32,
            c: (-weights.w_r_p * reference.flow.median * fl
                - weights.w_p_p * reference.frame.median * fr) as f32,
        }
    }

    fn map(&self, maps: &ObjectMaps, out: &mut Vec<f32>) {
        out.clear();
        out.extend(
            maps.flow_error
                .iter()
                .zip(&maps.frame_error)
                .map(|(&r, &p)| self.a_flow * r + self.a_frame * p + self.c),
        );
    }
}

/// The `INTER_LINEAR` taps ([`crate::box_crop::taps`]) for `out` destination pixels
/// sampled from `len` source pixels, into `taps`.
fn linear_taps(len: usize, out: usize, taps: &mut Vec<(usize, usize, f32)>) {
    taps.clear();
    taps.extend((0..out).map(|d| box_crop::taps(d, len as u32, out)));
}

/// Pixel range [start, end) of a box side after the cube's rounding
/// ([`crate::box_crop::crop_range`]), as indices.
fn pixel_span(lo: f32, hi: f32, size: u32) -> Option<(usize, usize)> {
    box_crop::crop_range(lo, hi, size).map(|(start, end)| (start as usize, end as usize))
}

/// Reusable buffers of heatmap composition (keeps the per-frame path allocation-free).
#[derive(Debug, Default)]
pub struct HeatmapScratch {
    patch_map: Vec<f32>,
    x_taps: Vec<(usize, usize, f32)>,
    y_taps: Vec<(usize, usize, f32)>,
}

/// Columns [x0, x1) and rows [y0, y1) of a box on the heatmap grid.
type PixelSpan = ((usize, usize), (usize, usize));

/// Resizes the `patch`×`patch` map bilinearly into `span` of a row-major grid of `width`
/// columns, taking the maximum with what is there (`take_max`) or overwriting it.
#[allow(clippy::too_many_arguments)]
fn paint_box(
    values: &mut [f32],
    width: usize,
    span: PixelSpan,
    patch: usize,
    patch_map: &[f32],
    x_taps: &mut Vec<(usize, usize, f32)>,
    y_taps: &mut Vec<(usize, usize, f32)>,
    take_max: bool,
) {
    let ((x0, x1), (y0, y1)) = span;
    linear_taps(patch, x1 - x0, x_taps);
    linear_taps(patch, y1 - y0, y_taps);
    for (dy, &(ya, yb, wy)) in y_taps.iter().enumerate() {
        let row_a = &patch_map[ya * patch..(ya + 1) * patch];
        let row_b = &patch_map[yb * patch..(yb + 1) * patch];
        let row = &mut values[(y0 + dy) * width + x0..(y0 + dy) * width + x1];
        for (cell, &(xa, xb, wx)) in row.iter_mut().zip(x_taps.iter()) {
            let top = row_a[xa] + (row_a[xb] - row_a[xa]) * wx;
            let bottom = row_b[xa] + (row_b[xb] - row_b[xa]) * wx;
            let v = top + (bottom - top) * wy;
            *cell = if take_max { cell.max(v) } else { v };
        }
    }
}

/// Composes the pixel heatmap of frame `frame` of `table` into `out` (whose size chooses
/// the grid: the frame size for full resolution, smaller for the reference's 192×128),
/// from `maps`, the maps of that frame's objects in object order.
pub fn compose_heatmap(
    table: &ScoreTable,
    frame: usize,
    maps: &[ObjectMaps],
    weights: &FusionWeights,
    mode: PixelReferenceMode,
    out: &mut Heatmap,
    scratch: &mut HeatmapScratch,
) -> Result<(), ScoreError> {
    let objects = table.frame_objects(frame);
    if objects.len() != maps.len() {
        return Err(ScoreError::Invalid(format!(
            "frame {frame} has {} objects but {} maps were given",
            objects.len(),
            maps.len()
        )));
    }
    let patch = table.meta.patch as usize;
    if let Some(k) = maps
        .iter()
        .position(|m| m.flow_error.len() != patch * patch || m.frame_error.len() != patch * patch)
    {
        return Err(ScoreError::Invalid(format!(
            "maps of object {k} of frame {frame} are not {patch}×{patch}"
        )));
    }
    let (gw, gh) = (out.width, out.height);
    out.values.clear();
    out.values.resize(gw as usize * gh as usize, 0.0);
    let (fw, fh) = (
        table.meta.frame_width.max(1) as f32,
        table.meta.frame_height.max(1) as f32,
    );
    let (sx, sy) = (gw as f32 / fw, gh as f32 / fh);
    let spans: Vec<Option<PixelSpan>> = objects
        .iter()
        .map(|o| {
            let [x1, y1, x2, y2] = o.bbox;
            Some((
                pixel_span(x1 * sx, x2 * sx, gw)?,
                pixel_span(y1 * sy, y2 * sy, gh)?,
            ))
        })
        .collect();
    let width = gw as usize;

    let HeatmapScratch {
        patch_map,
        x_taps,
        y_taps,
    } = scratch;
    match mode {
        PixelReferenceMode::Training | PixelReferenceMode::Scenario => {
            let reference = if mode == PixelReferenceMode::Training {
                PixelReference::of_training(&table.meta.training)
            } else {
                table.meta.scenario_pixels
            };
            let affine = PixelAffine::new(&reference, weights);
            // Covered pixels start at −∞ so that the maximum over boxes is taken whatever
            // the sign of the scaled errors; uncovered pixels stay 0.
            for &((x0, x1), (y0, y1)) in spans.iter().flatten() {
                for y in y0..y1 {
                    out.values[y * width + x0..y * width + x1].fill(f32::NEG_INFINITY);
                }
            }
            for (span, m) in spans.iter().zip(maps) {
                if let Some(span) = span {
                    affine.map(m, patch_map);
                    paint_box(
                        &mut out.values,
                        width,
                        *span,
                        patch,
                        patch_map,
                        x_taps,
                        y_taps,
                        true,
                    );
                }
            }
        }
        PixelReferenceMode::ReferenceBatches => {
            let (Some(last), Some(last_maps)) = (objects.len().checked_sub(1), maps.last()) else {
                return Ok(());
            };
            let object_index = table.frames[frame].first_object as usize + last;
            let batch = object_index / table.meta.batch_size.max(1) as usize;
            let reference = table.batches.get(batch).ok_or_else(|| {
                ScoreError::Invalid(format!(
                    "object {object_index} has no reference batch statistics"
                ))
            })?;
            PixelAffine::new(reference, weights).map(last_maps, patch_map);
            for span in spans.iter().flatten() {
                paint_box(
                    &mut out.values,
                    width,
                    *span,
                    patch,
                    patch_map,
                    x_taps,
                    y_taps,
                    false,
                );
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_match_opencv_positions() {
        let mut t = Vec::new();
        linear_taps(4, 2, &mut t);
        assert_eq!(t, vec![(0, 1, 0.5), (2, 3, 0.5)]);
        linear_taps(2, 4, &mut t);
        assert_eq!(t[0], (0, 1, 0.0));
        assert_eq!(t[1], (0, 1, 0.25));
        assert_eq!(t[3], (1, 1, 0.0));
    }

    #[test]
    fn spans_round_up_and_clip() {
        assert_eq!(pixel_span(10.2, 20.0, 100), Some((11, 20)));
        assert_eq!(pixel_span(-5.0, 3.5, 100), Some((0, 4)));
        assert_eq!(pixel_span(95.0, 130.0, 100), Some((95, 100)));
        assert_eq!(pixel_span(120.0, 130.0, 100), None);
        assert_eq!(pixel_span(f32::NAN, 1.0, 100), None);
    }
}
