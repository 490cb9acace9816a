//! The cheap side of the score cache, measured where the viewer repeats it:
//!
//! * re-fusing the frame scores of 100,000 frames (3 objects each) for new weights, median
//!   filter, and AUROC / AP / FPR95 — target ≤ 16 ms (one frame time) —, and the fusion
//!   alone and without the filter, to show where the time goes;
//! * the same over 500 scenarios of 200 frames through `evaluate_dataset` (per-scenario
//!   filter, micro and macro AUROC, rows by domain × weather);
//! * composing one full-resolution 768×512 heatmap from a frame's maps — target ≤ 5 ms —
//!   and the same including reading the maps from the cache file;
//! * opening the cache of a 10,000-frame scenario (3 objects per frame, 460 MB of maps).
//!
//! Run: `CARGO_PROFILE_DEV_OPT_LEVEL=3 cargo bench --profile dev --bench score_fusion`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use vadscope::eval::{RobustStats, ScoreMetrics};
use vadscope::model::{PixelStats, ScoreStats, TrainingStats};
use vadscope::score::{
    CacheKey, CacheWriter, FrameEntry, FrameMetricOptions, FrameState, FusionWeights, Heatmap,
    HeatmapScratch, ModelKey, ObjectMaps, ObjectScore, PixelReference, PixelReferenceMode,
    ScenarioScores, ScoreCache, ScoreMeta, ScoreTable, compose_heatmap, evaluate_dataset,
    frame_scores_into, metric_frames,
};
use vadscope::sequence::{Domain, FrameId, Weather};

const PATCH: usize = 32;

/// A small LCG keeps the bench free of extra dependencies.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn pixel(median: f64, q25: f64, q75: f64) -> PixelStats {
    PixelStats {
        median,
        q25,
        q75,
        iqr: q75 - q25,
        sampled: 1,
        total: 1,
    }
}

/// A table of `frames` frames with `per_frame` objects (every 50th frame empty), anomalies
/// in 20 % of the frames raising S_r; returns the table and the labels.
fn synthetic_table(frames: usize, per_frame: usize, seed: u64) -> (ScoreTable, Vec<bool>) {
    let mut rng = Lcg(seed);
    let labels: Vec<bool> = (0..frames).map(|i| (i / 50) % 5 == 4).collect();
    let mut entries = Vec::with_capacity(frames);
    let mut objects = Vec::with_capacity(frames * per_frame);
    for (i, &anomalous) in labels.iter().enumerate() {
        let count = if i % 50 == 7 { 0 } else { per_frame };
        entries.push(FrameEntry {
            id: FrameId(i as u64),
            state: if count == 0 {
                FrameState::NoBoxes
            } else {
                FrameState::Scored
            },
            first_object: objects.len() as u32,
            objects: count as u32,
        });
        for k in 0..count {
            let x = 100.0 + 200.0 * k as f32;
            objects.push(ObjectScore {
                frame: i as u32,
                track_id: k as u64,
                class: 14,
                bbox: [x, 200.0, x + 73.0, 254.0],
                confidence: 1.0,
                s_r: (20_000.0 * (0.5 + rng.next()) * if anomalous { 1.6 } else { 1.0 }) as f32,
                s_p: (14.0 * (0.5 + rng.next())) as f32,
            });
        }
    }
    let robust = |m: f64| RobustStats {
        median: m,
        q25: 0.5 * m,
        q75: 2.0 * m,
    };
    let batches = (0..objects.len().div_ceil(128))
        .map(|_| PixelReference {
            flow: robust(2.5),
            frame: robust(1.5e-3),
        })
        .collect();
    let table = ScoreTable {
        meta: ScoreMeta {
            key: CacheKey {
                scenario: "bench".into(),
                model: ModelKey(1),
                boxes: "gt".into(),
                flow: "stored".into(),
            },
            frame_width: 768,
            frame_height: 512,
            patch: PATCH as u32,
            clip_hist: 4,
            frame_ids_hash: 0,
            training: TrainingStats {
                cubes: 142_339,
                flow_score: ScoreStats {
                    mean: 20_192.7,
                    std: 87_763.3,
                },
                frame_score: ScoreStats {
                    mean: 14.10,
                    std: 28.58,
                },
                flow_pixel: pixel(2.5, 1.0, 5.0),
                frame_pixel: pixel(1.5e-3, 5e-4, 3e-3),
                bands: Vec::new(),
                tails: None,
            },
            scenario_pixels: PixelReference {
                flow: robust(2.5),
                frame: robust(1.5e-3),
            },
            batch_size: 128,
        },
        frames: entries,
        objects,
        batches,
    };
    (table, labels)
}

fn synthetic_maps(rng: &mut Lcg) -> ObjectMaps {
    let area = PATCH * PATCH;
    ObjectMaps {
        flow_error: (0..area).map(|_| (5.0 * rng.next()) as f32).collect(),
        frame_error: (0..area).map(|_| (3e-3 * rng.next()) as f32).collect(),
        predicted: (0..3 * area).map(|_| (255.0 * rng.next()) as u8).collect(),
        recon_flow: (0..2 * area)
            .map(|_| (8.0 * rng.next() - 4.0) as f32)
            .collect(),
    }
}

fn bench_frame_fusion(c: &mut Criterion) {
    let (table, labels) = synthetic_table(100_000, 3, 1);
    let mut raw = Vec::new();
    let mut weights = FusionWeights::PAPER_TEXT;
    c.bench_function(
        "refuse_100k_frames_3_objects (fuse + medfilt17 + AUROC/AP/FPR95)",
        |b| {
            b.iter(|| {
                // A slider move: new weights every iteration.
                weights.w_r = if weights.w_r == 10.0 { 9.5 } else { 10.0 };
                frame_scores_into(black_box(&table), &weights, &mut raw);
                let (scores, kept) = metric_frames(&raw, &labels, 4, 17).expect("lengths");
                let m = ScoreMetrics::compute(&scores, &kept).expect("both classes");
                black_box((m.auroc, m.average_precision, m.fpr95))
            })
        },
    );

    c.bench_function("refuse_100k_frames_3_objects (fuse only)", |b| {
        b.iter(|| {
            frame_scores_into(black_box(&table), &weights, &mut raw);
            black_box(raw[5])
        })
    });
    c.bench_function(
        "refuse_100k_frames_3_objects (fuse + AUROC/AP/FPR95, no filter)",
        |b| {
            b.iter(|| {
                frame_scores_into(black_box(&table), &weights, &mut raw);
                let (scores, kept) = metric_frames(&raw, &labels, 4, 0).expect("lengths");
                let m = ScoreMetrics::compute(&scores, &kept).expect("both classes");
                black_box((m.auroc, m.average_precision, m.fpr95))
            })
        },
    );

    let conditions = [
        (Domain::City, Weather::Sun),
        (Domain::City, Weather::Rain),
        (Domain::Highway, Weather::Fog),
        (Domain::Highway, Weather::Night),
    ];
    let items: Vec<ScenarioScores> = (0..500)
        .map(|s| {
            let (table, labels) = synthetic_table(200, 3, 100 + s as u64);
            let (domain, weather) = conditions[s % 4];
            ScenarioScores {
                name: format!("scenario {s}"),
                domain,
                weather,
                box_source: "ground truth".into(),
                labels,
                table,
                boxes: None,
            }
        })
        .collect();
    let options = FrameMetricOptions::default();
    c.bench_function(
        "evaluate_dataset_500x200_frames (5 rows, micro + macro)",
        |b| {
            b.iter(|| {
                black_box(
                    evaluate_dataset(black_box(&items), &FusionWeights::PAPER_TEXT, &options)
                        .expect("rows"),
                )
            })
        },
    );
}

fn bench_heatmap(c: &mut Criterion) {
    let (mut table, _) = synthetic_table(1, 3, 2);
    // Three boxes: two of the median AnoVox size (73×54) and one close vehicle (240×160),
    // overlapping the second.
    table.objects[1].bbox = [300.0, 220.0, 373.0, 274.0];
    table.objects[2].bbox = [330.0, 240.0, 570.0, 400.0];
    let mut rng = Lcg(3);
    let maps: Vec<ObjectMaps> = (0..3).map(|_| synthetic_maps(&mut rng)).collect();
    let mut heatmap = Heatmap::new(768, 512);
    let mut scratch = HeatmapScratch::default();
    c.bench_function("heatmap_768x512_3_boxes", |b| {
        b.iter(|| {
            compose_heatmap(
                black_box(&table),
                0,
                &maps,
                &FusionWeights::PAPER_TEXT,
                PixelReferenceMode::Training,
                &mut heatmap,
                &mut scratch,
            )
            .expect("compose");
            black_box(heatmap.values[300 * 768 + 400])
        })
    });

    let dir = std::env::temp_dir().join(format!("vadscope-bench-heatmap-{}", std::process::id()));
    let path = dir.join("one.vsc");
    vadscope::score::write_cache(&path, &table, &maps).expect("write");
    let cache = ScoreCache::open(&path).expect("open");
    c.bench_function("heatmap_768x512_3_boxes_with_map_read", |b| {
        b.iter(|| {
            let maps = cache.frame_maps(0).expect("maps");
            compose_heatmap(
                cache.table(),
                0,
                &maps,
                &FusionWeights::PAPER_TEXT,
                PixelReferenceMode::Training,
                &mut heatmap,
                &mut scratch,
            )
            .expect("compose");
            black_box(heatmap.values[300 * 768 + 400])
        })
    });
    drop(cache);
    let _ = std::fs::remove_dir_all(&dir);
}

fn bench_cache_open(c: &mut Criterion) {
    let (table, _) = synthetic_table(10_000, 3, 4);
    let dir = std::env::temp_dir().join(format!("vadscope-bench-cache-{}", std::process::id()));
    let path = dir.join("10k.vsc");
    let mut rng = Lcg(5);
    let maps = synthetic_maps(&mut rng);
    let mut writer = CacheWriter::create(&path, PATCH).expect("create");
    for _ in 0..table.objects.len() {
        writer.push_maps(&maps).expect("push");
    }
    writer.finish(&table).expect("finish");
    c.bench_function("cache_open_10k_frames_30k_objects", |b| {
        b.iter(|| {
            black_box(
                ScoreCache::open(black_box(&path))
                    .expect("open")
                    .table()
                    .objects
                    .len(),
            )
        })
    });
    let cache = ScoreCache::open(&path).expect("open");
    c.bench_function("cache_frame_maps_3_objects", |b| {
        let mut frame = 0;
        b.iter(|| {
            frame = (frame + 7919) % 10_000;
            black_box(cache.frame_maps(frame).expect("maps").len())
        })
    });
    drop(cache);
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench_frame_fusion, bench_heatmap, bench_cache_open);
criterion_main!(benches);
