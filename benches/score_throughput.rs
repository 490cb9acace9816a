//! Scoring throughput in frames per second on the sample scenarios (`sample_sequences/`,
//! 384×256, about 25 ground-truth boxes per frame, no stored flow): boxes, DIS flow at the
//! `medium` preset, cubes, the `compact` model and the score cache, exactly as
//! `vadscope score` runs them, over the first frames of each scenario.
//!
//! The model is the `compact` preset with random weights: the same architecture and cost as
//! the bundled checkpoint, so the figure does not wait for (or depend on) trained weights.
//! Criterion reports the throughput in elements/s, one element per frame.
//!
//! Run: `cargo bench --bench score_throughput` (dependencies are optimised in every
//! profile; `--profile dev` with `CARGO_PROFILE_DEV_OPT_LEVEL=3` avoids a release build).

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use burn::tensor::Device;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use vadscope::model::stc::CubeGeometry;
use vadscope::model::{
    CheckpointMeta, Detector, Hf2Vad, ModelConfig, NoiseRng, PixelStats, ScoreStats, TrainingStats,
};
use vadscope::score::{
    BoxProvider, BoxSource, FlowSource, ModelKey, ScenarioCubes, ScoreRequest, ScoringPlan,
    run_scoring,
};
use vadscope::sequence::Scenario;

/// Frames scored per iteration (from the first frame, whose cubes are padded like any
/// scenario start).
const FRAMES: usize = 8;

fn pixel(median: f64) -> PixelStats {
    PixelStats {
        median,
        q25: 0.5 * median,
        q75: 2.0 * median,
        iqr: 1.5 * median,
        sampled: 1,
        total: 1,
    }
}

fn compact_detector() -> Detector {
    let config = ModelConfig::compact();
    let device = Device::flex();
    let model = Hf2Vad::new(&config, &device, &mut NoiseRng::new(1)).expect("model");
    let meta = CheckpointMeta {
        config,
        stats: Some(TrainingStats {
            cubes: 1,
            flow_score: ScoreStats {
                mean: 1000.0,
                std: 500.0,
            },
            frame_score: ScoreStats {
                mean: 10.0,
                std: 5.0,
            },
            flow_pixel: pixel(0.1),
            frame_pixel: pixel(0.01),
            bands: Vec::new(),
            tails: None,
        }),
        note: None,
    };
    Detector::new(model, meta, &device).expect("detector")
}

fn bench_scoring(c: &mut Criterion) {
    let samples = Path::new(env!("CARGO_MANIFEST_DIR")).join("sample_sequences");
    let detector = compact_detector();
    let config = detector.config().clone();
    let out = tempfile::tempdir().expect("temp dir");
    let mut group = c.benchmark_group("score_sample_frames");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(60))
        .throughput(Throughput::Elements(FRAMES as u64));
    let mut folders: Vec<_> = std::fs::read_dir(&samples)
        .expect("sample_sequences/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.join("RGB_IMG").is_dir())
        .collect();
    folders.sort();
    for folder in folders {
        let scenario = Scenario::open(&folder).expect("sample scenario");
        let request = ScoreRequest::new(BoxSource::GroundTruth, FlowSource::default());
        let key = request.key(&scenario, ModelKey(0)).expect("key");
        let path = key.path_in(out.path());
        let plan = ScoringPlan {
            scenario_root: folder.clone(),
            key,
            frame_ids: (0..FRAMES).filter_map(|i| scenario.frame_id(i)).collect(),
            frame_size: scenario.resolution(),
            batch_size: request.batch_size,
            pixel_sample: 1 << 16,
        };
        group.bench_function(scenario.name(), |b| {
            b.iter(|| {
                let mut boxes = BoxProvider::new(&scenario, &request.boxes).expect("boxes");
                let mut cubes =
                    ScenarioCubes::new(&scenario, request.flow, CubeGeometry::of(&config));
                run_scoring(
                    &plan,
                    &mut boxes,
                    &mut cubes,
                    &detector,
                    &path,
                    &mut |_| {},
                    &AtomicBool::new(false),
                )
                .expect("scoring")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_scoring);
criterion_main!(benches);
