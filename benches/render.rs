//! Render speed: the dashboard of one 768×512 frame (target ≤ 30 ms) and the timeline of
//! 100,000 frames (target ≤ 10 ms), on generated inputs.

use criterion::{Criterion, criterion_group, criterion_main};
use image::{Rgb, RgbImage};
use vadscope::render::{
    self, Caption, DashboardInput, DashboardOptions, FrameViewInput, SceneObject, ScoreLabels,
    TimelineInput, TimelineOptions,
};
use vadscope::score::{FusionWeights, Heatmap, ObjectMaps};
use vadscope::sequence::FlowField;

const W: u32 = 768;
const H: u32 = 512;

fn series(n: usize) -> (Vec<f64>, Vec<f64>, Vec<bool>) {
    let truth: Vec<bool> = (0..n).map(|i| (i / 997) % 5 == 2).collect();
    let fused: Vec<f64> = (0..n)
        .map(|i| 10.0 + 5.0 * (i as f64 / 13.0).sin() + if truth[i] { 30.0 } else { 0.0 })
        .collect();
    let filtered = vadscope::eval::median_filter(&fused, 17);
    (fused, filtered, truth)
}

fn bench_timeline(c: &mut Criterion) {
    let (fused, filtered, truth) = series(100_000);
    let z: Vec<f64> = fused.iter().map(|v| v / 10.0).collect();
    let labels: Vec<Option<bool>> = truth.iter().map(|&t| Some(t)).collect();
    let input = TimelineInput {
        fused: &fused,
        filtered: &filtered,
        z_r: &z,
        z_p: &z,
        surprisals: false,
        truth: &truth,
        labels: &labels,
        threshold: Some(30.0),
        cursor: Some(50_000),
    };
    let options = TimelineOptions::default();
    c.bench_function("timeline 100k frames 1200x360", |b| {
        b.iter(|| render::timeline(&input, &options, (1200, 360)))
    });
}

fn bench_dashboard(c: &mut Criterion) {
    let frame = RgbImage::from_fn(W, H, |x, y| Rgb([(x % 256) as u8, (y % 256) as u8, 90]));
    let boxes = [
        [100.0, 260.0, 220.0, 340.0],
        [330.0, 250.0, 430.0, 320.0],
        [500.0, 270.0, 640.0, 360.0],
        [20.0, 280.0, 90.0, 330.0],
    ];
    let area = 32 * 32;
    let maps: Vec<ObjectMaps> = (0..boxes.len())
        .map(|k| ObjectMaps {
            flow_error: (0..area)
                .map(|i| (i % 32) as f32 * 0.01 * (k + 1) as f32)
                .collect(),
            frame_error: (0..area).map(|i| (i / 32) as f32 * 0.001).collect(),
            predicted: (0..3 * area).map(|i| (i % 251) as u8).collect(),
            recon_flow: (0..2 * area).map(|i| (i % 7) as f32 - 3.0).collect(),
        })
        .collect();
    let objects: Vec<SceneObject<'_>> = boxes
        .iter()
        .enumerate()
        .map(|(k, b)| SceneObject {
            bbox: *b,
            track_id: k as u64,
            score: Some(10.0 * k as f64),
            maps: Some(&maps[k]),
        })
        .collect();
    let mut heat = Heatmap::new(W, H);
    for (i, v) in heat.values.iter_mut().enumerate() {
        *v = (i % 97) as f32;
    }
    let flow = FlowField {
        width: W,
        height: H,
        uv: (0..2 * W * H).map(|i| (i % 11) as f32 - 5.0).collect(),
        valid: None,
    };
    let (fused, filtered, truth) = series(200);
    let caption = Caption {
        scenario: "bench".into(),
        index: 100,
        frame_id: Some(100),
        frame_score: Some(filtered[100]),
        threshold: Some(30.0),
        weights: Some(FusionWeights::default()),
        truth: Some(truth[100]),
    };
    let input = DashboardInput {
        frame: FrameViewInput {
            frame: &frame,
            objects: &objects,
            heatmap: Some(&heat),
            anomaly_mask: None,
            caption: Some(&caption),
        },
        flow: Some(&flow),
        timeline: TimelineInput {
            fused: &fused,
            filtered: &filtered,
            truth: &truth,
            threshold: Some(30.0),
            cursor: Some(100),
            ..TimelineInput::default()
        },
        evaluation: Some(ScoreLabels {
            scores: &filtered,
            labels: &truth,
            threshold: Some(30.0),
        }),
    };
    let options = DashboardOptions::default();
    c.bench_function("dashboard 768x512 frame at 1600x1000", |b| {
        b.iter(|| render::dashboard(&input, &options, (1600, 1000)))
    });
}

criterion_group!(benches, bench_timeline, bench_dashboard);
criterion_main!(benches);
