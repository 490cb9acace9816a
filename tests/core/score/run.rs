//! The scoring run with hand-made cubes: what lands in the cache, progress, cancellation,
//! bad inputs, the real detector behind the `CubeScorer` seam, and evaluation of the
//! result (frame table, box IoU, pixel ROC).

use std::cell::Cell;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};

use burn::tensor::Device;
use image::{GrayImage, Luma};
use vadscope::eval::{RocCurve, ScoreMetrics};
use vadscope::model::stc::Cube;
use vadscope::model::{
    CheckpointMeta, CubeResult, Detector, Hf2Vad, ModelConfig, ModelError, NoiseRng, TrainingStats,
};
use vadscope::score::{
    BoxMatchStats, BoxSource, CacheKey, CubeScorer, FlowSource, FrameMetricOptions, FrameState,
    FusionWeights, Heatmap, ModelKey, PixelReferenceMode, PixelRoc, ScenarioScores, ScoreCache,
    ScoreError, ScoreProgress, ScoreRequest, ScoringPlan, add_scenario_pixels, evaluate_dataset,
    format_eval_table, run_scoring, score_scenario_with,
};
use vadscope::sequence::{
    BoxRecord, Domain, FrameId, FrameRecord, Scenario, ScenarioMeta, Weather,
};

use crate::support::scenario::{ScenarioBuilder, square_box, square_record, square_scenario};
use crate::support::score::{object, table, training_stats};

const P: usize = 4;
const T: usize = 2;
const AREA: usize = P * P;

/// A stand-in model: reconstructs every flow as 0 and predicts every pixel as 0, so the
/// flow error is flow² and the frame error the last frame².
struct ZeroModel {
    stats: Option<TrainingStats>,
}

impl CubeScorer for ZeroModel {
    fn patch_size(&self) -> usize {
        P
    }
    fn clip_hist(&self) -> usize {
        T
    }
    fn training_stats(&self) -> Option<TrainingStats> {
        self.stats.clone()
    }
    fn score(&self, frames: &[f32], flows: &[f32]) -> Result<Vec<CubeResult>, ModelError> {
        let frame_len = 3 * (T + 1) * AREA;
        let flow_len = 2 * T * AREA;
        Ok(frames
            .chunks(frame_len)
            .zip(flows.chunks(flow_len))
            .map(|(fr, fl)| {
                let flow_error: Vec<f32> = fl.iter().map(|v| v * v).collect();
                let frame_error: Vec<f32> = fr[3 * T * AREA..].iter().map(|v| v * v).collect();
                CubeResult {
                    recon_flows: vec![0.0; flow_len],
                    predicted_frame: vec![0.5; 3 * AREA],
                    s_r: flow_error.iter().sum(),
                    s_p: frame_error.iter().sum(),
                    flow_error,
                    frame_error,
                }
            })
            .collect())
    }
}

fn bbox(x: f32) -> BoxRecord {
    BoxRecord {
        frame: FrameId(0),
        track_id: x as u64,
        x1: x,
        y1: 0.0,
        x2: x + 4.0,
        y2: 4.0,
        class: 14,
        score: 0.5,
        anomalous: false,
    }
}

/// A cube whose flows are all `flow` and whose frames are all `frame`.
fn cube(b: BoxRecord, flow: f32, frame: u8) -> Cube {
    Cube {
        box_index: 0,
        frames: vec![frame; 3 * (T + 1) * AREA],
        flows: vec![flow; 2 * T * AREA],
        flow_scale: [1.0, 1.0],
        bbox: b,
    }
}

fn plan(dir: &std::path::Path, frames: usize, batch_size: usize) -> (ScoringPlan, PathBuf) {
    let key = CacheKey {
        scenario: "hand".into(),
        model: ModelKey(1),
        boxes: "gt".into(),
        flow: "stored".into(),
    };
    let path = key.path_in(dir);
    (
        ScoringPlan {
            scenario_root: dir.to_path_buf(),
            key,
            frame_ids: (0..frames as u64).map(FrameId).collect(),
            frame_size: (32, 8),
            batch_size,
            pixel_sample: 10_000,
        },
        path,
    )
}

/// Frame 0: no boxes; 1: one box; 2: two boxes; 3: a box without a cube; 4: one box.
fn boxes_of(i: usize) -> Result<Vec<BoxRecord>, ScoreError> {
    Ok(match i {
        0 => vec![],
        2 => vec![bbox(0.0), bbox(8.0)],
        _ => vec![bbox(4.0 * i as f32)],
    })
}

fn cubes_of(i: usize, boxes: &[BoxRecord]) -> Result<Vec<Cube>, ScoreError> {
    if i == 3 {
        return Ok(Vec::new());
    }
    Ok(boxes
        .iter()
        .enumerate()
        .map(|(k, b)| cube(*b, (i + k) as f32, 255))
        .collect())
}

#[test]
fn the_run_stores_scores_maps_states_and_statistics() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (plan, path) = plan(dir.path(), 5, 2);
    let model = ZeroModel {
        stats: Some(training_stats()),
    };
    let mut seen = Vec::new();
    let cache = run_scoring(
        &plan,
        &mut boxes_of,
        &mut cubes_of,
        &model,
        &path,
        &mut |p: ScoreProgress| seen.push(p),
        &AtomicBool::new(false),
    )
    .expect("run");
    let t = cache.table();
    let states: Vec<FrameState> = t.frames.iter().map(|f| f.state).collect();
    use FrameState::*;
    assert_eq!(states, vec![NoBoxes, Scored, Scored, NoCubes, Scored]);
    assert_eq!(
        t.frames.iter().map(|f| f.objects).collect::<Vec<_>>(),
        vec![0, 1, 2, 0, 1]
    );
    assert_eq!(t.frames[4].id, FrameId(4));
    // Object flows: frame 1 → 1, frame 2 → 2 and 3, frame 4 → 4; S_r = 2T·P²·flow².
    let s_r: Vec<f32> = t.objects.iter().map(|o| o.s_r).collect();
    let n = (2 * T * AREA) as f32;
    assert_eq!(s_r, vec![n, 4.0 * n, 9.0 * n, 16.0 * n]);
    assert_eq!(t.objects[2].bbox, [8.0, 0.0, 12.0, 4.0]);
    assert_eq!(
        (
            t.objects[2].frame,
            t.objects[2].track_id,
            t.objects[2].confidence
        ),
        (2, 8, 0.5)
    );
    assert_eq!(t.meta.training, training_stats());
    assert_eq!(
        (t.meta.patch, t.meta.clip_hist, t.meta.frame_width),
        (P as u32, T as u32, 32)
    );
    assert_eq!(
        t.batches.len(),
        1,
        "4 objects fit one reference batch of 128"
    );
    // Reference batch flow errors: 64 values each of 1, 4, 9, 16 → median 6.5.
    assert_eq!(t.batches[0].flow.median, 6.5);
    assert_eq!(
        t.batches[0].flow.q25, 3.25,
        "NumPy-linear: 1 + 0.75 · (4 − 1)"
    );
    assert_eq!(t.meta.scenario_pixels.flow.median, 6.5);
    assert_eq!(t.meta.scenario_pixels.frame.median, 1.0);

    let maps = cache.frame_maps(2).expect("maps");
    assert_eq!(maps.len(), 2);
    assert!(
        maps[1].flow_error.iter().all(|&v| v == 9.0),
        "channel mean of flow²"
    );
    assert!(maps[1].frame_error.iter().all(|&v| v == 1.0));
    assert!(maps[1].predicted.iter().all(|&v| v == 128), "0.5 → 128");
    assert_eq!(maps[1].recon_flow.len(), 2 * AREA);

    let last = *seen.last().expect("progress");
    assert_eq!(
        last,
        ScoreProgress {
            frames_done: 5,
            frames_total: 5,
            objects: 4
        }
    );
    assert!(
        seen.len() >= 3,
        "a call per batch of 2 and one at the end: {seen:?}"
    );
    assert!(
        seen.windows(2)
            .all(|w| w[0].frames_done <= w[1].frames_done)
    );
    assert_eq!(ScoreCache::open(&path).expect("reopen").table(), t);
}

#[test]
fn cancelling_stops_the_run_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (plan, path) = plan(dir.path(), 5, 1);
    let model = ZeroModel {
        stats: Some(training_stats()),
    };
    let cancel = AtomicBool::new(false);
    let calls = Cell::new(0);
    let result = run_scoring(
        &plan,
        &mut boxes_of,
        &mut cubes_of,
        &model,
        &path,
        &mut |_| {
            calls.set(calls.get() + 1);
            cancel.store(true, Ordering::Relaxed);
        },
        &cancel,
    );
    assert!(
        matches!(result, Err(ScoreError::Cancelled { .. })),
        "{result:?}"
    );
    assert_eq!(calls.get(), 1, "stopped after the first batch");
    assert!(!path.exists());
    let left: Vec<_> = std::fs::read_dir(path.parent().expect("dir"))
        .expect("list")
        .filter_map(Result::ok)
        .collect();
    assert!(left.is_empty(), "temporary file removed: {left:?}");
}

#[test]
fn missing_statistics_and_wrong_cube_sizes_are_errors() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (plan, path) = plan(dir.path(), 5, 2);
    let never = AtomicBool::new(false);
    let result = run_scoring(
        &plan,
        &mut boxes_of,
        &mut cubes_of,
        &ZeroModel { stats: None },
        &path,
        &mut |_| {},
        &never,
    );
    assert!(
        matches!(result, Err(ScoreError::NoTrainingStats)),
        "{result:?}"
    );

    let model = ZeroModel {
        stats: Some(training_stats()),
    };
    let mut short = |_: usize, boxes: &[BoxRecord]| -> Result<Vec<Cube>, ScoreError> {
        Ok(boxes
            .iter()
            .map(|b| Cube {
                box_index: 0,
                frames: vec![0; 5],
                flows: vec![],
                flow_scale: [1.0, 1.0],
                bbox: *b,
            })
            .collect())
    };
    let error = run_scoring(
        &plan,
        &mut boxes_of,
        &mut short,
        &model,
        &path,
        &mut |_| {},
        &never,
    )
    .expect_err("bad cube")
    .to_string();
    assert!(
        error.contains("frame 1") && error.contains("5 frame bytes"),
        "{error}"
    );
    assert!(!path.exists());
}

fn detector_with_stats() -> Detector {
    let config = ModelConfig::parity();
    let device = Device::flex();
    let model = Hf2Vad::new(&config, &device, &mut NoiseRng::new(3)).expect("model");
    let meta = CheckpointMeta {
        config,
        stats: Some(training_stats()),
        note: None,
    };
    Detector::new(model, meta, &device).expect("detector")
}

#[test]
fn a_real_detector_scores_a_scenario_through_the_seams() {
    let dir = tempfile::tempdir().expect("tempdir");
    let meta = ScenarioMeta {
        domain: Domain::Highway,
        weather: Weather::Rain,
        ..ScenarioMeta::default()
    };
    let root = square_scenario(6)
        .meta(meta)
        .write(&dir.path().join("scenario"));
    let scenario = Scenario::open(&root).expect("open");
    let detector = detector_with_stats();
    let p = detector.config().patch_size;
    let t = detector.config().clip_hist;
    // Hand-made cubes of the right size: grey frames, flow = frame index.
    let mut cubes = |i: usize, boxes: &[BoxRecord]| -> Result<Vec<Cube>, ScoreError> {
        Ok(boxes
            .iter()
            .map(|b| Cube {
                box_index: 0,
                frames: vec![100; 3 * (t + 1) * p * p],
                flows: vec![i as f32; 2 * t * p * p],
                flow_scale: [1.0, 1.0],
                bbox: *b,
            })
            .collect())
    };
    let request = ScoreRequest::new(BoxSource::GroundTruth, FlowSource::Stored);
    let cache = score_scenario_with(
        &scenario,
        &detector,
        ModelKey(42),
        &request,
        &mut cubes,
        &mut |_| {},
        &AtomicBool::new(false),
    )
    .expect("score");
    let key = request.key(&scenario, ModelKey(42)).expect("key");
    assert_eq!(
        cache.path(),
        key.path_in(&scenario.cache_dir().expect("dir"))
    );
    let found = ScoreCache::lookup(&scenario, &key)
        .expect("lookup")
        .expect("present");
    let table = found.table();
    assert_eq!(table.objects.len(), 6);
    assert!(
        table
            .objects
            .iter()
            .all(|o| o.s_r.is_finite() && o.s_p > 0.0)
    );
    assert!(
        table.objects[5].s_r > table.objects[1].s_r,
        "larger flows reconstruct worse"
    );
    assert_eq!(table.objects[3].bbox, {
        let b = square_box(3);
        [b.x1, b.y1, b.x2, b.y2]
    });

    // Evaluation: labels from the scenario (anomalous from frame 4), IoU of GT boxes is 1.
    let scores = ScenarioScores::from_cache(&scenario, &request, ModelKey(42), Some(0.5))
        .expect("scores")
        .expect("scored");
    assert_eq!(&scores.table, table);
    assert_eq!(scores.box_source, "ground truth");
    let unscored = ScoreRequest::new(BoxSource::Detections, FlowSource::Stored);
    assert!(
        ScenarioScores::from_cache(&scenario, &unscored, ModelKey(42), None)
            .expect("lookup")
            .is_none()
    );
    assert_eq!(scores.labels, vec![false, false, false, false, true, true]);
    assert_eq!(
        (scores.domain, scores.weather),
        (Domain::Highway, Weather::Rain)
    );
    let boxes = scores.boxes.expect("box stats");
    assert_eq!((boxes.mean_iou(), boxes.recall()), (Some(1.0), Some(1.0)));
    let items = [scores];
    let rows = evaluate_dataset(
        &items,
        &FusionWeights::ORIGINAL,
        &FrameMetricOptions {
            median_kernel: 0,
            skip_first: None,
        },
    )
    .expect("evaluate");
    assert_eq!(rows.len(), 2, "all + highway/rain");
    assert_eq!(
        rows[0].frames,
        6 - t,
        "the first clip_hist frames are dropped"
    );
    assert!(
        rows[0].metrics.is_none(),
        "frames 4 and 5 are both anomalous"
    );
    let rows = evaluate_dataset(
        &items,
        &FusionWeights::ORIGINAL,
        &FrameMetricOptions {
            median_kernel: 3,
            skip_first: Some(2),
        },
    )
    .expect("evaluate");
    assert_eq!((rows[0].frames, rows[0].anomalous_frames), (4, 2));
    assert!(rows[0].metrics.is_some());
}

fn scored(
    name: &str,
    source: &str,
    domain: Domain,
    weather: Weather,
    scores: &[f32],
    labels: &[bool],
) -> ScenarioScores {
    let frames: Vec<Vec<_>> = scores
        .iter()
        .map(|&s| vec![object([0.0, 0.0, 4.0, 4.0], s, 1.0)])
        .collect();
    let mut boxes = BoxMatchStats::new(0.5);
    boxes.add_frame(&[bbox(0.0)], &[bbox(2.0)]);
    ScenarioScores {
        name: name.into(),
        domain,
        weather,
        box_source: source.into(),
        labels: labels.to_vec(),
        table: table(&frames, (32, 8), 1, 128),
        boxes: Some(boxes),
    }
}

#[test]
fn the_dataset_table_groups_by_box_source_and_condition() {
    let l = [false, false, false, true, true, false];
    let items = [
        scored(
            "a",
            "gt",
            Domain::City,
            Weather::Sun,
            &[0.0, 1.0, 2.0, 9.0, 8.0, 3.0],
            &l,
        ),
        scored(
            "b",
            "gt",
            Domain::Highway,
            Weather::Fog,
            &[0.0, 5.0, 6.0, 4.0, 3.0, 2.0],
            &l,
        ),
        scored(
            "c",
            "gt",
            Domain::City,
            Weather::Sun,
            &[0.0; 6],
            &[false; 6],
        ),
        scored(
            "a",
            "motion",
            Domain::City,
            Weather::Sun,
            &[0.0, 1.0, 2.0, 9.0, 8.0, 3.0],
            &l,
        ),
    ];
    let options = FrameMetricOptions {
        median_kernel: 0,
        skip_first: None,
    };
    let rows = evaluate_dataset(&items, &FusionWeights::ORIGINAL, &options).expect("evaluate");
    let names: Vec<(String, Option<Domain>, Option<Weather>, usize)> = rows
        .iter()
        .map(|r| (r.box_source.clone(), r.domain, r.weather, r.scenarios))
        .collect();
    assert_eq!(
        names,
        vec![
            ("gt".into(), None, None, 3),
            ("gt".into(), Some(Domain::City), Some(Weather::Sun), 2),
            ("gt".into(), Some(Domain::Highway), Some(Weather::Fog), 1),
            ("motion".into(), None, None, 1),
            ("motion".into(), Some(Domain::City), Some(Weather::Sun), 1),
        ]
    );
    // Frame 0 of each scenario is dropped (clip_hist 1).
    assert_eq!((rows[0].frames, rows[0].anomalous_frames), (15, 4));
    let city = rows[1].metrics.expect("both classes");
    assert_eq!(
        city.auroc, 1.0,
        "scenario a separates perfectly; c adds only normal zeros"
    );
    assert_eq!(rows[2].metrics.expect("both classes").auroc, 1.0 / 3.0);
    assert_eq!(rows[0].macro_scenarios, 2, "c has a single class");
    assert!((rows[0].auroc_macro.expect("macro") - (1.0 + 1.0 / 3.0) / 2.0).abs() < 1e-12);
    // Micro over the concatenation of a, b and c, as the metric functions compute it.
    let frame_scores: Vec<f64> = [
        [1.0, 2.0, 9.0, 8.0, 3.0],
        [5.0, 6.0, 4.0, 3.0, 2.0],
        [0.0; 5],
    ]
    .iter()
    .flatten()
    .map(|s| (s - 10.0) / 2.0 + 0.1 * 0.0)
    .collect();
    let labels: Vec<bool> = [&l[1..], &l[1..], &[false; 5][..]].concat();
    let expected = ScoreMetrics::compute(&frame_scores, &labels).expect("metrics");
    assert!((rows[0].metrics.expect("m").auroc - expected.auroc).abs() < 1e-12);
    let iou = f64::from(vadscope::score::box_iou(&bbox(0.0), &bbox(2.0)));
    assert!((rows[0].mean_iou.expect("iou") - iou).abs() < 1e-9);
    assert_eq!(rows[0].box_recall, Some(0.0), "IoU 1/3 is below 0.5");
    let text = format_eval_table(&rows);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 6, "{text}");
    assert!(
        lines[0].starts_with("box source") && lines[0].contains("FPR95"),
        "{text}"
    );
    assert!(
        lines[2].starts_with("gt") && lines[2].contains("city") && lines[2].contains("100.0"),
        "{text}"
    );
    let single =
        evaluate_dataset(&items[2..3], &FusionWeights::ORIGINAL, &options).expect("evaluate");
    assert!(single[0].metrics.is_none(), "a single class has no ROC");
}

#[test]
fn pixel_roc_matches_the_exact_curve_and_reads_scenario_masks() {
    let mut h = Heatmap::new(4, 2);
    h.values = vec![0.0, 0.0, 3.0, -1.0, 0.5, 3.0, 2.0, 0.0];
    let mask = GrayImage::from_raw(4, 2, vec![0, 255, 255, 0, 0, 255, 0, 0]).expect("mask");
    let mut roc = PixelRoc::new();
    roc.add(&h, &mask).expect("same size");
    let exact = RocCurve::compute(
        &h.values.iter().map(|&v| f64::from(v)).collect::<Vec<_>>(),
        &mask.as_raw().iter().map(|&m| m != 0).collect::<Vec<_>>(),
    )
    .expect("exact");
    let binned = roc.curve().expect("curve");
    assert_eq!(binned.auroc(), exact.auroc());
    assert_eq!(binned.average_precision(), exact.average_precision());
    assert_eq!(binned.points.len(), exact.points.len());
    let mut twice = PixelRoc::new();
    twice.merge(&roc);
    twice.merge(&roc);
    assert_eq!(twice.curve().expect("curve").positives, 6);
    assert!(roc.add(&Heatmap::new(3, 2), &mask).is_err());

    // A scenario whose semantic images mark the square as the anomaly from frame 4 on.
    let dir = tempfile::tempdir().expect("tempdir");
    let root = square_scenario(6).write(&dir.path().join("s"));
    let semantic = root.join("SEMANTIC_IMG");
    std::fs::create_dir_all(&semantic).expect("mkdir");
    for k in 0..6u64 {
        let b = square_box(k);
        let img = GrayImage::from_fn(96, 64, |x, y| {
            let inside =
                (b.x1 as u32..b.x2 as u32).contains(&x) && (b.y1 as u32..b.y2 as u32).contains(&y);
            Luma([if inside && k >= 4 { 100 } else { 1 }])
        });
        img.save(semantic.join(format!("SEMANTIC_IMG_{k}.png")))
            .expect("save");
    }
    let scenario = Scenario::open(&root).expect("open");
    let (mut plan, _) = plan(dir.path(), 6, 4);
    plan.frame_size = (96, 64);
    let path = dir.path().join("pixels.vsc");
    let model = ZeroModel {
        stats: Some(training_stats()),
    };
    let mut gt =
        |i: usize| -> Result<Vec<BoxRecord>, ScoreError> { Ok(vec![square_box(i as u64)]) };
    // Larger flows (worse reconstruction) in the anomalous frames.
    let mut cubes = |i: usize, boxes: &[BoxRecord]| -> Result<Vec<Cube>, ScoreError> {
        Ok(boxes
            .iter()
            .map(|b| cube(*b, if i >= 4 { 3.0 } else { 1.0 }, 0))
            .collect())
    };
    let cache = run_scoring(
        &plan,
        &mut gt,
        &mut cubes,
        &model,
        &path,
        &mut |_| {},
        &AtomicBool::new(false),
    )
    .expect("run");
    let mut roc = PixelRoc::new();
    let frames = add_scenario_pixels(
        &mut roc,
        &scenario,
        &cache,
        &FusionWeights::PAPER_TEXT,
        PixelReferenceMode::Training,
        2,
    )
    .expect("pixels");
    assert_eq!(frames, 4);
    let curve = roc.curve().expect("curve");
    assert_eq!(curve.positives, 2 * 256);
    assert_eq!(curve.negatives, 4 * 96 * 64 - 2 * 256);
    assert_eq!(curve.auroc(), 1.0, "the anomalous squares score highest");
}

/// The square scenario with stored flows (u = 4 inside the square, where it moves).
fn square_with_flow(dir: &std::path::Path, frames: u64) -> PathBuf {
    let frame = |k: u64| {
        let mut flow = vadscope::sequence::FlowField::zeros(96, 64);
        let b = square_box(k);
        for y in b.y1 as u32..b.y2 as u32 {
            for x in b.x1 as u32..b.x2 as u32 {
                flow.uv[2 * (y as usize * 96 + x as usize)] = 4.0;
            }
        }
        FrameRecord {
            flow: (k > 0).then_some(flow),
            ..square_record(k)
        }
    };
    ScenarioBuilder::new()
        .frames((0..frames).map(frame))
        .write(&dir.join("flow-scenario"))
}

#[test]
fn score_scenario_cuts_cubes_with_stc_from_stored_and_estimated_flows() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scenario = Scenario::open(&square_with_flow(dir.path(), 6)).expect("open");
    let detector = detector_with_stats();
    let never = AtomicBool::new(false);
    let stored = ScoreRequest::new(BoxSource::GroundTruth, FlowSource::Stored);
    let cache = vadscope::score::score_scenario(
        &scenario,
        &detector,
        ModelKey(9),
        &stored,
        &mut |_| {},
        &never,
    )
    .expect("score with stored flows");
    let t = cache.table();
    assert_eq!(t.objects.len(), 6);
    assert!(t.frames.iter().all(|f| f.state == FrameState::Scored));
    assert_eq!(t.meta.key.flow, "stored");
    assert!(cache.path().to_string_lossy().contains("stored"));

    // The same scenario with its flows estimated: another cache beside the first.
    let estimated = ScoreRequest::new(
        BoxSource::GroundTruth,
        FlowSource::Estimated(vadscope::flow::DisPreset::Ultrafast),
    );
    let other = vadscope::score::score_scenario(
        &scenario,
        &detector,
        ModelKey(9),
        &estimated,
        &mut |_| {},
        &never,
    )
    .expect("score with estimated flows");
    assert_ne!(other.path(), cache.path());
    assert_eq!(other.table().objects.len(), 6);
    assert_ne!(
        other.table().objects[3].s_r,
        t.objects[3].s_r,
        "other flows, other errors"
    );
}

#[test]
fn score_scenario_reports_missing_flows_and_broken_frames() {
    let dir = tempfile::tempdir().expect("tempdir");
    // No stored flow at all: frame 0 counts as zero motion, frame 1 needs its flow.
    let root = square_scenario(4).write(&dir.path().join("no-flow"));
    let scenario = Scenario::open(&root).expect("open");
    let detector = detector_with_stats();
    let never = AtomicBool::new(false);
    let request = ScoreRequest::new(BoxSource::GroundTruth, FlowSource::Stored);
    let error = vadscope::score::score_scenario(
        &scenario,
        &detector,
        ModelKey(9),
        &request,
        &mut |_| {},
        &never,
    )
    .expect_err("flows missing")
    .to_string();
    assert!(
        error.contains("no flow stored at frame 1") && error.contains("no-flow"),
        "{error}"
    );

    // A frame that cannot be decoded is named by its file.
    std::fs::write(root.join("RGB_IMG").join("RGB_IMG_2.png"), b"not a png").expect("write");
    let scenario = Scenario::open(&root).expect("open");
    let request = ScoreRequest::new(BoxSource::GroundTruth, FlowSource::default());
    let error = vadscope::score::score_scenario(
        &scenario,
        &detector,
        ModelKey(9),
        &request,
        &mut |_| {},
        &never,
    )
    .expect_err("broken frame")
    .to_string();
    assert!(error.contains("RGB_IMG_2.png"), "{error}");
    let request_key = request.key(&scenario, ModelKey(9)).expect("key");
    assert!(
        !request_key
            .path_in(&scenario.cache_dir().expect("dir"))
            .exists()
    );
}
