//! Helpers of the `app` tests and the `app` benchmark: tiny generated data sets, a tiny
//! random checkpoint with plausible training statistics, synthetic score tables, and the
//! viewer in a headless egui_kittest harness with a pointer-drag gesture. It uses no other
//! helper module, since the benchmark includes this file on its own.

// The benchmark uses only part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use burn::tensor::Device;
use egui_kittest::Harness;
use vadscope::app::{
    AppState, Dataset, Layout, ScenarioEntry, ScoringSetup, ViewSettings, ViewerApp,
};
use vadscope::eval::RobustStats;
use vadscope::model::{
    CheckpointMeta, Hf2Vad, InputConventions, ModelConfig, NoiseRng, PixelStats, ScoreStats,
    TrainingStats, save_checkpoint,
};
use vadscope::score::{
    BoxSource, CacheKey, FlowSource, FrameEntry, FrameState, ModelKey, ObjectScore, PixelReference,
    ScoreMeta, ScoreRequest, ScoreTable,
};
use vadscope::sequence::labels::write_frame_labels;
use vadscope::sequence::{Domain, FrameId, Modality, Weather};
use vadscope::synth::{ScenarioKind, ScenarioSpec, generate_scenario_without};

/// Frames of each generated scenario.
pub const FRAMES: u32 = 16;
/// Frames labelled anomalous in the city scenario.
pub const ANOMALY: std::ops::RangeInclusive<u64> = 8..=13;

/// Training statistics of the tiny model: S_r ~ (2, 1), S_p ~ (0.5, 0.25).
pub fn training_stats() -> TrainingStats {
    let pixel = PixelStats {
        median: 0.01,
        q25: 0.001,
        q75: 0.05,
        iqr: 0.049,
        sampled: 1000,
        total: 1000,
    };
    TrainingStats {
        cubes: 1000,
        flow_score: ScoreStats {
            mean: 2.0,
            std: 1.0,
        },
        frame_score: ScoreStats {
            mean: 0.5,
            std: 0.25,
        },
        flow_pixel: pixel,
        frame_pixel: pixel,
        bands: Vec::new(),
        tails: None,
    }
}

/// A tiny randomly initialised checkpoint at `dir/tiny.safetensors`: the parity network's
/// widths on 16×16 patches with two past frames, vadscope's input conventions.
pub fn tiny_checkpoint(dir: &Path) -> PathBuf {
    let config = ModelConfig {
        patch_size: 16,
        clip_hist: 2,
        num_flows: 2,
        num_slots: 8,
        shrink_thres: 1.0 / 8.0,
        conventions: InputConventions::vadscope(),
        ..ModelConfig::parity()
    };
    let device = Device::flex();
    let model = Hf2Vad::new(&config, &device, &mut NoiseRng::new(5)).expect("model");
    let path = dir.join("tiny.safetensors");
    let meta = CheckpointMeta {
        config,
        stats: Some(training_stats()),
        note: Some("random weights for the viewer tests".into()),
    };
    save_checkpoint(&path, &model, &meta).expect("save checkpoint");
    path
}

/// A data set of two generated 96×64 scenarios of [`FRAMES`] frames with their exact flow,
/// under `dir/data`: city driving in sun whose `frame_labels.csv` is rewritten to mark
/// [`ANOMALY`] anomalous (a generated sudden braking needs 80 frames, too many to score
/// quickly), and normal highway driving in rain.
pub fn generate_dataset(dir: &Path) -> PathBuf {
    let root = dir.join("data");
    for (domain, weather, seed) in [
        (Domain::City, Weather::Sun, 3),
        (Domain::Highway, Weather::Rain, 4),
    ] {
        let mut spec = ScenarioSpec::new(ScenarioKind::Normal, domain, weather, seed);
        spec.frames = FRAMES;
        spec.width = 96;
        spec.height = 64;
        let folder =
            generate_scenario_without(&spec, &root, &[Modality::Depth], |_| {}).expect("generate");
        if domain == Domain::City {
            let labels: Vec<(FrameId, bool)> = (0..u64::from(FRAMES))
                .map(|k| (FrameId(k), ANOMALY.contains(&k)))
                .collect();
            write_frame_labels(&folder.join("frame_labels.csv"), &labels).expect("labels");
        }
    }
    root
}

/// The scoring setup of the tests: the tiny checkpoint, ground-truth boxes, stored flow.
pub fn setup(model: &Path) -> ScoringSetup {
    ScoringSetup {
        model: Some(model.to_path_buf()),
        request: ScoreRequest::new(BoxSource::GroundTruth, FlowSource::Stored),
    }
}

/// A viewer state that has opened `root` with `model` and waited for its scores.
pub fn scored_state(root: &Path, model: &Path) -> AppState {
    let mut state = AppState::new(setup(model), ViewSettings::default());
    assert!(state.open(root), "open: {:?}", state.log_entries());
    state.wait_for_scoring();
    state
}

/// A synthetic score table of `frames` frames, one object per frame whose S_r is
/// `s_r(frame)` and S_p `s_p(frame)`, with the tiny model's training statistics and
/// `clip_hist` 4.
pub fn table(frames: usize, s_r: impl Fn(usize) -> f32, s_p: impl Fn(usize) -> f32) -> ScoreTable {
    let robust = |median: f64| RobustStats {
        median,
        q25: 0.0,
        q75: 2.0 * median.max(0.01),
    };
    ScoreTable {
        meta: ScoreMeta {
            key: CacheKey {
                scenario: "synthetic".into(),
                model: ModelKey(1),
                boxes: "gt".into(),
                flow: "stored".into(),
            },
            frame_width: 96,
            frame_height: 64,
            patch: 32,
            clip_hist: 4,
            frame_ids_hash: 0,
            training: training_stats(),
            scenario_pixels: PixelReference {
                flow: robust(0.01),
                frame: robust(0.01),
            },
            batch_size: 128,
        },
        frames: (0..frames)
            .map(|i| FrameEntry {
                id: FrameId(1000 + i as u64),
                state: FrameState::Scored,
                first_object: i as u32,
                objects: 1,
            })
            .collect(),
        objects: (0..frames)
            .map(|i| ObjectScore {
                frame: i as u32,
                track_id: 7,
                class: 14,
                bbox: [10.0, 10.0, 40.0, 30.0],
                confidence: 1.0,
                s_r: s_r(i),
                s_p: s_p(i),
            })
            .collect(),
        batches: Vec::new(),
    }
}

/// A viewer state over in-memory scenarios (no frames on disk), each a table and labels.
pub fn state_of_tables(scenarios: Vec<(&str, ScoreTable, Vec<bool>)>) -> AppState {
    let entries = scenarios
        .into_iter()
        .map(|(name, table, labels)| ScenarioEntry::from_table(name, labels, table))
        .collect();
    let mut state = AppState::new(
        ScoringSetup {
            model: None,
            request: ScoreRequest::new(BoxSource::GroundTruth, FlowSource::Stored),
        },
        ViewSettings::default(),
    );
    state.set_dataset(Dataset::from_entries("in memory", entries));
    state
}

/// The viewer over a scored generated data set (under `dir`), drawn at 1400×900.
pub fn viewer_harness(dir: &Path) -> Harness<'static, ViewerApp> {
    let root = generate_dataset(dir);
    let model = tiny_checkpoint(dir);
    let state = scored_state(&root, &model);
    let app = ViewerApp::with_state(state, Layout::default());
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .wgpu()
        .build_ui_state(|ui, app: &mut ViewerApp| app.show(ui), app);
    harness.run();
    harness
}

/// Presses the primary button at `from`, moves through the middle to `to` and releases.
pub fn drag(h: &mut Harness<'_, ViewerApp>, from: egui::Pos2, to: egui::Pos2) {
    h.hover_at(from);
    h.run();
    h.drag_at(from);
    h.run();
    h.hover_at(from + (to - from) * 0.5);
    h.run();
    h.hover_at(to);
    h.run();
    h.drop_at(to);
    h.run();
}
