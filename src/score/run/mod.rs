//! The scoring run: boxes → cubes → model in batches → score cache, with a progress
//! callback and a cancellation flag.
//!
//! The run is written against three small seams (in `seams.rs`): [`FrameBoxes`],
//! [`CubeSource`] and [`CubeScorer`]. [`run_scoring`] writes a cache file;
//! [`score_table`] keeps the scalar table in memory.
//!
//! Per object the cache keeps S_r, S_p, the channel-averaged error maps, the predicted
//! patch and the reconstructed last flow; per frame whether it had boxes and cubes. While
//! scoring, the run also gathers the pixel statistics of the scenario (a reservoir sample
//! of every per-element error, the "scenario" pixel reference) and the median and quartiles
//! of each batch of [`REFERENCE_BATCH`] consecutive objects' full error tensors (the
//! reference code's per-batch pixel scaling). Batches follow object order (frame by frame)
//! within the scenario; the reference batches its whole concatenated test set instead.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use crate::eval::{RobustStats, quantile_linear};
use crate::flow::FlowSource;
use crate::model::stc::{Cube, CubeGeometry};
use crate::model::{Detector, ModelError, StatsAccumulator};
use crate::sequence::{FrameId, Scenario};

use super::ScoreError;
use super::boxes::{BoxProvider, BoxSource};
use super::cache::{
    CacheKey, CacheWriter, FrameEntry, FrameState, ModelKey, ObjectMaps, ObjectScore,
    PixelReference, REFERENCE_BATCH, ScoreCache, ScoreMeta, ScoreTable, frame_ids_hash,
};

mod seams;

pub use seams::{CubeScorer, CubeSource, FrameBoxes, ScenarioCubes};

/// How far a run has come.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScoreProgress {
    /// Frames whose cubes have been scored.
    pub frames_done: usize,
    /// Frames in the scenario.
    pub frames_total: usize,
    /// Objects scored so far.
    pub objects: usize,
}

/// Everything a run needs to know about the scenario and the output.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoringPlan {
    /// The scenario folder (for messages).
    pub scenario_root: PathBuf,
    /// Key of the cache to write.
    pub key: CacheKey,
    /// Frame ids by frame index.
    pub frame_ids: Vec<FrameId>,
    /// Frame width and height.
    pub frame_size: (u32, u32),
    /// Cubes sent to the model at once.
    pub batch_size: usize,
    /// Per-element errors kept for the scenario's pixel statistics (reservoir sample).
    pub pixel_sample: usize,
}

impl ScoringPlan {
    /// The plan for every frame of `scenario`, written under `key`.
    pub fn of_scenario(
        scenario: &Scenario,
        key: CacheKey,
        batch_size: usize,
        pixel_sample: usize,
    ) -> Self {
        Self {
            scenario_root: scenario.root().to_path_buf(),
            key,
            frame_ids: (0..scenario.len())
                .filter_map(|i| scenario.frame_id(i))
                .collect(),
            frame_size: scenario.resolution(),
            batch_size,
            pixel_sample,
        }
    }
}

/// What to score a scenario with, besides the model.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreRequest {
    /// The boxes of the objects.
    pub boxes: BoxSource,
    /// The flows of the cubes.
    pub flow: FlowSource,
    /// Cubes sent to the model at once (default 128, the reference's test batch).
    pub batch_size: usize,
}

impl ScoreRequest {
    /// A request with the default batch size.
    pub fn new(boxes: BoxSource, flow: FlowSource) -> Self {
        Self {
            boxes,
            flow,
            batch_size: REFERENCE_BATCH,
        }
    }

    /// The cache key of this request for `scenario` and `model`.
    pub fn key(&self, scenario: &Scenario, model: ModelKey) -> Result<CacheKey, ScoreError> {
        Ok(CacheKey {
            scenario: scenario.name().to_string(),
            model,
            boxes: self.boxes.key()?,
            flow: self.flow.key(),
        })
    }
}

/// Default reservoir size of the scenario's pixel statistics (per error kind).
pub const DEFAULT_PIXEL_SAMPLE: usize = 1 << 20;

/// Scores `scenario` with cubes from `cubes` and writes its cache (see
/// [`ScoreRequest::key`] for where). Returns the opened cache.
pub fn score_scenario_with(
    scenario: &Scenario,
    scorer: &dyn CubeScorer,
    model: ModelKey,
    request: &ScoreRequest,
    cubes: &mut dyn CubeSource,
    progress: &mut dyn FnMut(ScoreProgress),
    cancel: &AtomicBool,
) -> Result<ScoreCache, ScoreError> {
    let key = request.key(scenario, model)?;
    let path = key.path_in(&scenario.cache_dir()?);
    let plan = ScoringPlan::of_scenario(scenario, key, request.batch_size, DEFAULT_PIXEL_SAMPLE);
    let mut boxes = BoxProvider::new(scenario, &request.boxes)?;
    run_scoring(&plan, &mut boxes, cubes, scorer, &path, progress, cancel)
}

/// Scores `scenario` with `detector`: boxes from `request.boxes`, cubes cut by `model::stc`
/// with flows from `request.flow`, the model in batches of `request.batch_size`; writes
/// the cache at [`ScoreRequest::key`]'s path in the scenario's cache folder and returns it
/// opened. `progress` is called after every batch, `cancel` stops the run (nothing is
/// written).
pub fn score_scenario(
    scenario: &Scenario,
    detector: &Detector,
    model: ModelKey,
    request: &ScoreRequest,
    progress: &mut dyn FnMut(ScoreProgress),
    cancel: &AtomicBool,
) -> Result<ScoreCache, ScoreError> {
    let geometry = CubeGeometry::of(detector.config());
    let mut cubes = ScenarioCubes::new(scenario, request.flow, geometry);
    score_scenario_with(
        scenario, detector, model, request, &mut cubes, progress, cancel,
    )
}

/// Quartiles of `values` (NumPy linear interpolation) by selection, without a full sort.
fn robust_of(values: &mut [f32]) -> RobustStats {
    if values.is_empty() {
        return RobustStats {
            median: 0.0,
            q25: 0.0,
            q75: 0.0,
        };
    }
    let n = values.len();
    let mut at = |q: f64| {
        let pos = q * (n - 1) as f64;
        let lo = pos.floor() as usize;
        let (_, &mut a, right) = values.select_nth_unstable_by(lo, f32::total_cmp);
        let b = right.iter().copied().min_by(f32::total_cmp).unwrap_or(a);
        quantile_linear(&[f64::from(a), f64::from(b)], pos - lo as f64)
    };
    RobustStats {
        q25: at(0.25),
        median: at(0.5),
        q75: at(0.75),
    }
}

/// Accumulates the per-element errors of one reference batch.
#[derive(Default)]
struct BatchErrors {
    objects: usize,
    flow: Vec<f32>,
    frame: Vec<f32>,
}

impl BatchErrors {
    fn finish(&mut self) -> PixelReference {
        let stats = PixelReference {
            flow: robust_of(&mut self.flow),
            frame: robust_of(&mut self.frame),
        };
        self.objects = 0;
        self.flow.clear();
        self.frame.clear();
        stats
    }
}

/// Mean over `channels` planes of `area` values.
fn channel_mean(values: &[f32], channels: usize, area: usize) -> Vec<f32> {
    let mut out = vec![0f32; area];
    for plane in values.chunks_exact(area).take(channels) {
        for (o, v) in out.iter_mut().zip(plane) {
            *o += v;
        }
    }
    let inv = 1.0 / channels.max(1) as f32;
    out.iter_mut().for_each(|v| *v *= inv);
    out
}

/// Where a scoring run puts each object's maps.
trait MapSink {
    /// Takes the maps of the next object; `maps` builds them, so a sink that keeps none
    /// never pays for them.
    fn push(&mut self, maps: impl FnOnce() -> ObjectMaps) -> Result<(), ScoreError>;
}

impl MapSink for CacheWriter {
    fn push(&mut self, maps: impl FnOnce() -> ObjectMaps) -> Result<(), ScoreError> {
        self.push_maps(&maps())
    }
}

/// Keeps no maps: the run of an in-memory table.
struct NoMaps;

impl MapSink for NoMaps {
    fn push(&mut self, _: impl FnOnce() -> ObjectMaps) -> Result<(), ScoreError> {
        Ok(())
    }
}

/// The state of a run between batches.
struct Run<'a, S> {
    plan: &'a ScoringPlan,
    scorer: &'a dyn CubeScorer,
    /// Where the per-object maps go.
    maps: S,
    patch: usize,
    clip_hist: usize,
    objects: Vec<ObjectScore>,
    batches: Vec<PixelReference>,
    batch: BatchErrors,
    scenario_pixels: StatsAccumulator,
    pending: Vec<(usize, Cube)>,
}

impl<S: MapSink> Run<'_, S> {
    /// Scores the first `count` pending cubes (all when fewer are pending).
    fn flush(&mut self, count: usize) -> Result<(), ScoreError> {
        let count = count.min(self.pending.len());
        if count == 0 {
            return Ok(());
        }
        let batch: Vec<(usize, Cube)> = self.pending.drain(..count).collect();
        let first_frame = batch[0].0;
        let frames: Vec<f32> = batch
            .iter()
            .flat_map(|(_, c)| c.frames.iter().map(|&b| f32::from(b) / 255.0))
            .collect();
        let flows: Vec<f32> = batch
            .iter()
            .flat_map(|(_, c)| c.flows.iter().copied())
            .collect();
        let model_error = |source| ScoreError::Model {
            scenario: self.plan.scenario_root.clone(),
            frame: first_frame,
            source,
        };
        let results = self.scorer.score(&frames, &flows).map_err(model_error)?;
        if results.len() != batch.len() {
            return Err(model_error(ModelError::InvalidInput(format!(
                "{} results for {} cubes",
                results.len(),
                batch.len()
            ))));
        }
        let area = self.patch * self.patch;
        let t = self.clip_hist;
        for ((frame, cube), r) in batch.into_iter().zip(results) {
            let sizes = [
                (r.recon_flows.len(), 2 * t * area),
                (r.predicted_frame.len(), 3 * area),
                (r.flow_error.len(), 2 * t * area),
                (r.frame_error.len(), 3 * area),
            ];
            if sizes.iter().any(|(have, want)| have != want) {
                return Err(ScoreError::Model {
                    scenario: self.plan.scenario_root.clone(),
                    frame,
                    source: ModelError::InvalidInput(format!(
                        "model output sizes {sizes:?} (have, want) do not fit {}×{} patches",
                        self.patch, self.patch
                    )),
                });
            }
            self.maps.push(|| ObjectMaps {
                flow_error: channel_mean(&r.flow_error, 2 * t, area),
                frame_error: channel_mean(&r.frame_error, 3, area),
                predicted: r
                    .predicted_frame
                    .iter()
                    .map(|&v| (v * 255.0).round().clamp(0.0, 255.0) as u8)
                    .collect(),
                // Back to native pixels, so the view compares it with the stored flow.
                recon_flow: r.recon_flows[2 * (t - 1) * area..]
                    .chunks(area)
                    .zip(cube.flow_scale)
                    .flat_map(|(plane, scale)| plane.iter().map(move |v| v / scale))
                    .collect(),
            })?;
            self.scenario_pixels
                .push(r.s_r, r.s_p, &r.flow_error, &r.frame_error);
            self.batch.flow.extend_from_slice(&r.flow_error);
            self.batch.frame.extend_from_slice(&r.frame_error);
            self.batch.objects += 1;
            if self.batch.objects == REFERENCE_BATCH {
                self.batches.push(self.batch.finish());
            }
            let b = cube.bbox;
            self.objects.push(ObjectScore {
                frame: frame as u32,
                track_id: b.track_id,
                class: b.class,
                bbox: [b.x1, b.y1, b.x2, b.y2],
                confidence: b.score,
                s_r: r.s_r,
                s_p: r.s_p,
            });
        }
        Ok(())
    }
}

/// Runs the model over every frame of `plan` and writes the cache at `path` (atomically;
/// nothing is written on error or cancellation). `progress` is called after every model
/// batch and at the end; `cancel` is checked before every frame and batch.
pub fn run_scoring(
    plan: &ScoringPlan,
    boxes: &mut dyn FrameBoxes,
    cubes: &mut dyn CubeSource,
    scorer: &dyn CubeScorer,
    path: &Path,
    progress: &mut dyn FnMut(ScoreProgress),
    cancel: &AtomicBool,
) -> Result<ScoreCache, ScoreError> {
    let create = |patch| CacheWriter::create(path, patch);
    let (table, writer) = score_objects(plan, boxes, cubes, scorer, create, progress, cancel)?;
    let written = writer.finish(&table)?;
    ScoreCache::open(&written)
}

/// As [`run_scoring`], but in memory: the scalar table alone, no maps, no file. For
/// callers that only need frame scores (model selection during training).
pub fn score_table(
    plan: &ScoringPlan,
    boxes: &mut dyn FrameBoxes,
    cubes: &mut dyn CubeSource,
    scorer: &dyn CubeScorer,
    cancel: &AtomicBool,
) -> Result<ScoreTable, ScoreError> {
    let no_maps = |_| Ok(NoMaps);
    score_objects(plan, boxes, cubes, scorer, no_maps, &mut |_| {}, cancel).map(|(table, _)| table)
}

/// The scoring run behind [`run_scoring`] and [`score_table`]: the table, and the sink that
/// took the maps, made by `sink(patch)` once the scorer has been checked.
fn score_objects<S: MapSink>(
    plan: &ScoringPlan,
    boxes: &mut dyn FrameBoxes,
    cubes: &mut dyn CubeSource,
    scorer: &dyn CubeScorer,
    sink: impl FnOnce(usize) -> Result<S, ScoreError>,
    progress: &mut dyn FnMut(ScoreProgress),
    cancel: &AtomicBool,
) -> Result<(ScoreTable, S), ScoreError> {
    let training = scorer.training_stats().ok_or(ScoreError::NoTrainingStats)?;
    let box_filter = scorer.box_filter();
    let patch = scorer.patch_size();
    let clip_hist = scorer.clip_hist();
    if patch == 0 || clip_hist == 0 {
        return Err(ScoreError::Invalid(format!(
            "model with patch {patch} and clip_hist {clip_hist} cannot score cubes"
        )));
    }
    let frame_len = 3 * (clip_hist + 1) * patch * patch;
    let flow_len = 2 * clip_hist * patch * patch;
    let total = plan.frame_ids.len();
    let mut run = Run {
        plan,
        scorer,
        maps: sink(patch)?,
        patch,
        clip_hist,
        objects: Vec::new(),
        batches: Vec::new(),
        batch: BatchErrors::default(),
        scenario_pixels: StatsAccumulator::new(plan.pixel_sample.max(1), 0x5C0E),
        pending: Vec::new(),
    };
    let cancelled = || ScoreError::Cancelled {
        scenario: plan.scenario_root.clone(),
    };
    let mut frames = Vec::with_capacity(total);
    for (index, &id) in plan.frame_ids.iter().enumerate() {
        if cancel.load(Ordering::Relaxed) {
            return Err(cancelled());
        }
        let frame_boxes = box_filter.apply(boxes.boxes(index)?, plan.frame_size);
        let frame_cubes = if frame_boxes.is_empty() {
            Vec::new()
        } else {
            cubes.cubes(index, &frame_boxes)?
        };
        if let Some(bad) = frame_cubes
            .iter()
            .find(|c| c.frames.len() != frame_len || c.flows.len() != flow_len)
        {
            return Err(ScoreError::Invalid(format!(
                "{}, frame {index}: a cube of {} frame bytes and {} flow values; the model needs {frame_len} and {flow_len}",
                plan.scenario_root.display(),
                bad.frames.len(),
                bad.flows.len()
            )));
        }
        let state = match (frame_boxes.is_empty(), frame_cubes.is_empty()) {
            (true, _) => FrameState::NoBoxes,
            (false, true) => FrameState::NoCubes,
            (false, false) => FrameState::Scored,
        };
        let first_object = u32::try_from(run.objects.len() + run.pending.len())
            .map_err(|_| ScoreError::Invalid("more than 2^32 objects in one scenario".into()))?;
        frames.push(FrameEntry {
            id,
            state,
            first_object,
            objects: frame_cubes.len() as u32,
        });
        run.pending
            .extend(frame_cubes.into_iter().map(|c| (index, c)));
        let batch_size = plan.batch_size.max(1);
        while run.pending.len() >= batch_size {
            if cancel.load(Ordering::Relaxed) {
                return Err(cancelled());
            }
            run.flush(batch_size)?;
            progress(ScoreProgress {
                // Frames before the first unscored cube are complete.
                frames_done: run.pending.first().map_or(index + 1, |(frame, _)| *frame),
                frames_total: total,
                objects: run.objects.len(),
            });
        }
    }
    if cancel.load(Ordering::Relaxed) {
        return Err(cancelled());
    }
    let rest = run.pending.len();
    run.flush(rest)?;
    if run.batch.objects > 0 {
        let last = run.batch.finish();
        run.batches.push(last);
    }
    let pixels = run.scenario_pixels.finish();
    let scenario_pixels = if pixels.cubes > 0 {
        PixelReference::of_training(&pixels)
    } else {
        PixelReference::of_training(&training)
    };
    let table = ScoreTable {
        meta: ScoreMeta {
            key: plan.key.clone(),
            frame_width: plan.frame_size.0,
            frame_height: plan.frame_size.1,
            patch: patch as u32,
            clip_hist: clip_hist as u32,
            frame_ids_hash: frame_ids_hash(plan.frame_ids.iter().copied()),
            training,
            scenario_pixels,
            batch_size: REFERENCE_BATCH as u32,
        },
        frames,
        objects: run.objects,
        batches: run.batches,
    };
    progress(ScoreProgress {
        frames_done: total,
        frames_total: total,
        objects: table.objects.len(),
    });
    Ok((table, run.maps))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selection_quartiles_match_sorted_quantiles() {
        let mut v: Vec<f32> = [7.0, 1.0, 4.0, 3.0, 9.0, 2.0, 8.0].to_vec();
        let r = robust_of(&mut v);
        let sorted = [1.0, 2.0, 3.0, 4.0, 7.0, 8.0, 9.0];
        assert_eq!(r.median, quantile_linear(&sorted, 0.5));
        assert_eq!(r.q25, quantile_linear(&sorted, 0.25));
        assert_eq!(r.q75, quantile_linear(&sorted, 0.75));
        let mut even = vec![4.0f32, 1.0, 3.0, 2.0];
        assert_eq!(robust_of(&mut even).median, 2.5);
    }

    #[test]
    fn channel_mean_averages_planes() {
        let v = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        assert_eq!(channel_mean(&v, 3, 2), vec![3.0, 4.0]);
    }
}
