//! Helpers of the score tests: hand-built score tables, their objects and statistics. The
//! scenarios the score tests run on are in [`super::scenario`].

use vadscope::eval::RobustStats;
use vadscope::model::{PixelStats, ScoreStats, TrainingStats};
use vadscope::score::{
    CacheKey, FrameEntry, FrameState, ModelKey, ObjectMaps, ObjectScore, PixelReference, ScoreMeta,
    ScoreTable,
};
use vadscope::sequence::{BoxRecord, FrameId};

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
        bands: Vec::new(),
        tails: None,
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
