//! Helpers of the score tests (and of the annotate tests' scenario): hand-built score
//! tables and small scenarios with a moving square, written on the fly.

use std::path::{Path, PathBuf};

use image::{Rgb, RgbImage};
use vadscope::eval::RobustStats;
use vadscope::model::{PixelStats, ScoreStats, TrainingStats};
use vadscope::score::{
    CacheKey, FrameEntry, FrameState, ModelKey, ObjectMaps, ObjectScore, PixelReference, ScoreMeta,
    ScoreTable,
};
use vadscope::sequence::{BoxRecord, FrameId, FrameRecord, ScenarioMeta, ScenarioWriter};

/// Pixel statistics with the given median and quartiles.
pub fn pixel_stats(median: f64, q25: f64, q75: f64) -> PixelStats {
    PixelStats {
        median,
        q25,
        q75,
        iqr: q75 - q25,
        sampled: 100,
        total: 100,
    }
}

/// Training statistics: S_r ~ (10, 2), S_p ~ (1, 0.5); flow pixels median 1, IQR 2; frame
/// pixels median 0.1, IQR 0.5.
pub fn training_stats() -> TrainingStats {
    TrainingStats {
        cubes: 1000,
        flow_score: ScoreStats {
            mean: 10.0,
            std: 2.0,
        },
        frame_score: ScoreStats {
            mean: 1.0,
            std: 0.5,
        },
        flow_pixel: pixel_stats(1.0, 0.5, 2.5),
        frame_pixel: pixel_stats(0.1, 0.0, 0.5),
    }
}

/// Robust statistics from median and quartiles.
pub fn robust(median: f64, q25: f64, q75: f64) -> RobustStats {
    RobustStats { median, q25, q75 }
}

/// A box [x1, y1, x2, y2] with scores.
pub fn object(bbox: [f32; 4], s_r: f32, s_p: f32) -> (BoxRecord, f32, f32) {
    (
        BoxRecord {
            frame: FrameId(0),
            track_id: 1,
            x1: bbox[0],
            y1: bbox[1],
            x2: bbox[2],
            y2: bbox[3],
            class: 14,
            score: 1.0,
            anomalous: false,
        },
        s_r,
        s_p,
    )
}

/// A table of `frames` (each a list of objects; an empty list is a frame without boxes),
/// frames of `width`×`height`, patch 8, clip_hist `clip_hist`, reference batches of
/// `batch_size` with statistics `batch_stats(k)`.
pub fn table(
    frames: &[Vec<(BoxRecord, f32, f32)>],
    size: (u32, u32),
    clip_hist: u32,
    batch_size: u32,
) -> ScoreTable {
    let mut entries = Vec::new();
    let mut objects = Vec::new();
    for (i, objs) in frames.iter().enumerate() {
        entries.push(FrameEntry {
            id: FrameId(100 + i as u64),
            state: if objs.is_empty() {
                FrameState::NoBoxes
            } else {
                FrameState::Scored
            },
            first_object: objects.len() as u32,
            objects: objs.len() as u32,
        });
        for (b, s_r, s_p) in objs {
            objects.push(ObjectScore {
                frame: i as u32,
                track_id: b.track_id,
                class: b.class,
                bbox: [b.x1, b.y1, b.x2, b.y2],
                confidence: b.score,
                s_r: *s_r,
                s_p: *s_p,
            });
        }
    }
    let batches = (0..objects.len().div_ceil(batch_size as usize))
        .map(|k| PixelReference {
            flow: robust(k as f64, k as f64 - 1.0, k as f64 + 1.0),
            frame: robust(0.0, 0.0, 1.0),
        })
        .collect();
    ScoreTable {
        meta: ScoreMeta {
            key: CacheKey {
                scenario: "hand-built".into(),
                model: ModelKey(7),
                boxes: "gt".into(),
                flow: "stored".into(),
            },
            frame_width: size.0,
            frame_height: size.1,
            patch: 8,
            clip_hist,
            frame_ids_hash: 0,
            training: training_stats(),
            scenario_pixels: PixelReference {
                flow: robust(2.0, 1.0, 5.0),
                frame: robust(0.0, 0.0, 1.0),
            },
            batch_size,
        },
        frames: entries,
        objects,
        batches,
    }
}

/// 8×8 maps with constant flow and frame errors.
pub fn constant_maps(flow: f32, frame: f32) -> ObjectMaps {
    ObjectMaps {
        flow_error: vec![flow; 64],
        frame_error: vec![frame; 64],
        predicted: vec![128; 192],
        recon_flow: vec![0.5; 128],
    }
}

/// Width of the moving-square scenario's frames.
pub const SQUARE_W: u32 = 96;
/// Height of the moving-square scenario's frames.
pub const SQUARE_H: u32 = 64;
/// Side of the square.
pub const SQUARE: u32 = 16;

/// Left edge of the square in frame `k`: 8 + 4k, top edge 24.
pub fn square_x(k: u64) -> u32 {
    8 + 4 * k as u32
}

/// Frame `k` of the moving square: a square with vertical stripes 5 px wide (so that its
/// inside changes as it moves, as a textured car does) on a dark, faintly textured
/// background.
pub fn square_frame(k: u64) -> RgbImage {
    let x0 = square_x(k);
    RgbImage::from_fn(SQUARE_W, SQUARE_H, |x, y| {
        if (x0..x0 + SQUARE).contains(&x) && (24..24 + SQUARE).contains(&y) {
            if ((x - x0) / 5).is_multiple_of(2) {
                Rgb([220, 200, 180])
            } else {
                Rgb([120, 110, 100])
            }
        } else {
            let t = ((x * 7 + y * 13) % 5) as u8;
            Rgb([40 + t, 45 + t, 50 + t])
        }
    })
}

/// The ground-truth box of the square in frame `k`.
pub fn square_box(k: u64) -> BoxRecord {
    let x0 = square_x(k) as f32;
    BoxRecord {
        frame: FrameId(k),
        track_id: 5,
        x1: x0,
        y1: 24.0,
        x2: x0 + SQUARE as f32,
        y2: 24.0 + SQUARE as f32,
        class: 14,
        score: 1.0,
        anomalous: k >= 4,
    }
}

/// Writes `frames` frames of the moving square (ground-truth boxes, labels: anomalous from
/// frame 4 on) into `dir`.
pub fn write_square_scenario(dir: &Path, frames: u64, meta: &ScenarioMeta) -> PathBuf {
    let writer = ScenarioWriter::create(dir, meta).expect("create writer");
    for k in 0..frames {
        writer
            .write_frame(&FrameRecord {
                id: FrameId(k),
                rgb: square_frame(k),
                semantic: None,
                instance: None,
                depth_m: None,
                flow: None,
                action: None,
                anomaly: None,
                boxes: vec![square_box(k)],
                anomalous: Some(k >= 4),
            })
            .expect("write frame");
    }
    writer.finish().expect("finish")
}
