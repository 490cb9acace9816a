//! Scenario I/O speed at AnoVox's 768×512: writing a frame with every modality, opening and
//! validating a 200-frame scenario, and decoding one frame's RGB, semantic and flow images.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use image::{GrayImage, Luma, Rgb, RgbImage};
use vadscope::sequence::{
    BoxRecord, FlowField, FrameId, FrameRecord, KeyValues, Scenario, ScenarioMeta, ScenarioOptions,
    ScenarioWriter,
};

const W: u32 = 768;
const H: u32 = 512;

/// A frame resembling a rendered road scene: smooth gradients, a few flat regions and mild
/// deterministic texture, so PNG compression sees realistic redundancy.
fn synthetic_frame(id: u64) -> FrameRecord {
    let texture = |x: u32, y: u32| ((x.wrapping_mul(7919) ^ y.wrapping_mul(104_729)) % 9) as u8;
    let horizon = H / 3;
    let rgb = RgbImage::from_fn(W, H, |x, y| {
        let t = texture(x + id as u32, y);
        if y < horizon {
            Rgb([110 + (y / 8) as u8, 150 + (y / 8) as u8, 200 + t])
        } else {
            let g = 70 + ((y - horizon) / 6) as u8 + t;
            Rgb([g, g, g + 5])
        }
    });
    let in_car = |x: u32, y: u32| (300..460).contains(&x) && (220..330).contains(&y);
    let semantic = GrayImage::from_fn(W, H, |x, y| {
        Luma([if in_car(x, y) {
            14
        } else if y < horizon {
            11
        } else {
            1
        }])
    });
    let instance = RgbImage::from_fn(W, H, |x, y| {
        if in_car(x, y) {
            Rgb([14, 42, 1])
        } else {
            Rgb([semantic.get_pixel(x, y).0[0], 0, 0])
        }
    });
    let depth_m = (0..W * H)
        .map(|i| {
            let y = i / W;
            if y <= horizon {
                1000.0
            } else {
                1.8 * 384.0 / (y - horizon) as f32
            }
        })
        .collect();
    let flow = FlowField {
        width: W,
        height: H,
        uv: (0..W * H)
            .flat_map(|i| {
                let (x, y) = ((i % W) as f32, (i / W) as f32);
                [(x - 384.0) * 0.02, (y - 170.0).max(0.0) * 0.03]
            })
            .collect(),
        valid: None,
    };
    let mut action = KeyValues::default();
    action.push("frame_id", id);
    action.push("speed", 72.0);
    action.push("brake", 0.0);
    FrameRecord {
        id: FrameId(id),
        rgb,
        semantic: Some(semantic),
        instance: Some(instance),
        depth_m: Some(depth_m),
        flow: Some(flow),
        action: Some(action.clone()),
        anomaly: Some(action),
        boxes: vec![BoxRecord {
            frame: FrameId(id),
            track_id: 42 + 256,
            x1: 300.0,
            y1: 220.0,
            x2: 460.0,
            y2: 330.0,
            class: 14,
            score: 1.0,
            anomalous: false,
        }],
        anomalous: Some(false),
    }
}

fn bench_write_frame(c: &mut Criterion) {
    let root = tempfile::tempdir().expect("temp dir");
    let writer = ScenarioWriter::create(
        &root.path().join("Scenario_bench"),
        &ScenarioMeta::default(),
    )
    .expect("writer");
    let template = synthetic_frame(0);
    let mut next_id = 0u64;
    let mut group = c.benchmark_group("sequence_write");
    group.sample_size(20);
    group.bench_function("write_frame_768x512_all_modalities", |b| {
        b.iter(|| {
            let frame = FrameRecord {
                id: FrameId(next_id),
                ..template.clone()
            };
            next_id += 1;
            writer.write_frame(black_box(&frame)).expect("writes");
        })
    });
    group.finish();
}

/// Frames in the scenario the read benchmarks open (one AnoVox scenario).
const SCENARIO_FRAMES: u64 = 200;

fn bench_read(c: &mut Criterion) {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = root.path().join("Scenario_read");
    let writer = ScenarioWriter::create(&dir, &ScenarioMeta::default()).expect("writer");
    let template = synthetic_frame(0);
    for id in 0..SCENARIO_FRAMES {
        let frame = FrameRecord {
            id: FrameId(id),
            ..template.clone()
        };
        writer.write_frame(&frame).expect("writes");
    }
    writer.finish().expect("finishes");

    let mut group = c.benchmark_group("sequence_read");
    group.sample_size(20);
    group.bench_function("open_scenario_200_frames", |b| {
        b.iter(|| Scenario::open(black_box(&dir)).expect("opens"))
    });
    let scenario = Scenario::open(&dir).expect("opens");
    group.bench_function("validate_scenario_200_frames", |b| {
        b.iter(|| scenario.validate().expect("validates"))
    });
    // A zero budget stores nothing, so every call below decodes from disk.
    let uncached = Scenario::open_with(
        &dir,
        ScenarioOptions {
            cache_budget_bytes: 0,
            ..ScenarioOptions::default()
        },
    )
    .expect("opens");
    group.bench_function("decode_rgb_768x512", |b| {
        b.iter(|| uncached.rgb(black_box(7)).expect("rgb"))
    });
    group.bench_function("decode_semantic_768x512", |b| {
        b.iter(|| uncached.semantic(black_box(7)).expect("semantic"))
    });
    group.bench_function("decode_flow_kitti_768x512", |b| {
        b.iter(|| uncached.flow(black_box(7)).expect("flow"))
    });
    group.bench_function("rgb_cache_hit", |b| {
        scenario.rgb(7).expect("warm");
        b.iter(|| scenario.rgb(black_box(7)).expect("rgb"))
    });
    group.finish();
}

criterion_group!(benches, bench_write_frame, bench_read);
criterion_main!(benches);
