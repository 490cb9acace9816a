//! What a score cache holds, in memory: per-frame states, per-object scores and error
//! maps, the model's training statistics and the scenario's pixel statistics
//! ([`ScoreTable`], [`ObjectMaps`]).

use serde::Serialize;

use crate::eval::RobustStats;
use crate::model::{PixelStats, TrainingStats};
use crate::sequence::{BoxRecord, FrameId};

use super::key::CacheKey;

/// Cubes per batch of the reference's pixel-level robust scaling (spec §7.2).
pub const REFERENCE_BATCH: usize = 128;

/// Whether and why a frame has scored objects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum FrameState {
    /// At least one object was scored.
    Scored,
    /// The box source gave no box.
    NoBoxes,
    /// Boxes were given but none had a non-empty crop inside the image.
    NoCubes,
}

impl FrameState {
    pub(super) fn code(self) -> u8 {
        match self {
            Self::Scored => 0,
            Self::NoBoxes => 1,
            Self::NoCubes => 2,
        }
    }

    pub(super) fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Self::Scored),
            1 => Some(Self::NoBoxes),
            2 => Some(Self::NoCubes),
            _ => None,
        }
    }
}

/// One frame of a score table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrameEntry {
    /// AnoVox frame id.
    pub id: FrameId,
    /// Whether it has objects.
    pub state: FrameState,
    /// Index of its first object in [`ScoreTable::objects`].
    pub first_object: u32,
    /// Number of its objects (contiguous from `first_object`).
    pub objects: u32,
}

/// The scalar record of one scored object.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ObjectScore {
    /// Frame index.
    pub frame: u32,
    /// Track id of its box (0 when the source has none).
    pub track_id: u64,
    /// Class of its box.
    pub class: u16,
    /// The box, [x1, y1, x2, y2] in frame pixels (x2/y2 exclusive).
    pub bbox: [f32; 4],
    /// Confidence of its box (1 for ground truth).
    pub confidence: f32,
    /// S_r: summed squared flow-reconstruction error (model units).
    pub s_r: f32,
    /// S_p: summed squared frame-prediction error.
    pub s_p: f32,
}

impl ObjectScore {
    /// The box centre's column as a fraction of a frame `frame_width` pixels wide (what
    /// picks the object's score band, [`TrainingStats::statistics_at`]).
    pub fn centre_fraction(&self, frame_width: u32) -> f32 {
        0.5 * (self.bbox[0] + self.bbox[2]) / frame_width.max(1) as f32
    }

    /// z(S_r) and z(S_p) of the object under `stats` (their tail surprisals for a model
    /// that keeps tail tables, [`crate::model::ObjectStatistics::normalise`]): against the
    /// training objects of its band of the image when the model has bands, else all of them.
    pub fn z_scores(&self, stats: &TrainingStats, frame_width: u32) -> (f64, f64) {
        stats
            .statistics_at(self.centre_fraction(frame_width))
            .normalise(f64::from(self.s_r), f64::from(self.s_p))
    }

    /// The object's box as a [`BoxRecord`] of frame `frame` (not flagged anomalous).
    pub fn box_record(&self, frame: FrameId) -> BoxRecord {
        BoxRecord {
            frame,
            track_id: self.track_id,
            x1: self.bbox[0],
            y1: self.bbox[1],
            x2: self.bbox[2],
            y2: self.bbox[3],
            class: self.class,
            score: self.confidence,
            anomalous: false,
        }
    }
}

/// The per-pixel data of one scored object, each plane P×P row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectMaps {
    /// Squared flow-reconstruction error, mean over the flow channels (P² values).
    pub flow_error: Vec<f32>,
    /// Squared frame-prediction error, mean over R, G, B (P² values).
    pub frame_error: Vec<f32>,
    /// Predicted patch, planar RGB bytes (3·P² values).
    pub predicted: Vec<u8>,
    /// Reconstructed last flow, planar u then v, native pixels (2·P² values).
    pub recon_flow: Vec<f32>,
}

impl ObjectMaps {
    /// All-zero maps for patches of `patch`×`patch`.
    pub fn zeros(patch: usize) -> Self {
        let area = patch * patch;
        Self {
            flow_error: vec![0.0; area],
            frame_error: vec![0.0; area],
            predicted: vec![0; 3 * area],
            recon_flow: vec![0.0; 2 * area],
        }
    }

    pub(super) fn check(&self, patch: usize) -> Result<(), String> {
        let area = patch * patch;
        let sizes = [
            ("flow error", self.flow_error.len(), area),
            ("frame error", self.frame_error.len(), area),
            ("predicted patch", self.predicted.len(), 3 * area),
            ("reconstructed flow", self.recon_flow.len(), 2 * area),
        ];
        match sizes.iter().find(|(_, len, want)| len != want) {
            Some((name, len, want)) => Err(format!("{name} has {len} values, expected {want}")),
            None => Ok(()),
        }
    }
}

/// Bytes of one object's map block for `patch`×`patch` patches.
pub fn map_stride(patch: usize) -> usize {
    15 * patch * patch
}

/// Robust statistics of the two per-pixel error kinds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PixelReference {
    /// Per-element squared flow errors.
    pub flow: RobustStats,
    /// Per-element squared frame errors.
    pub frame: RobustStats,
}

impl PixelReference {
    /// The pixel statistics stored with a model's training statistics.
    pub fn of_training(stats: &TrainingStats) -> Self {
        let robust = |p: &PixelStats| RobustStats {
            median: p.median,
            q25: p.q25,
            q75: p.q75,
        };
        Self {
            flow: robust(&stats.flow_pixel),
            frame: robust(&stats.frame_pixel),
        }
    }
}

/// Everything of a score cache except the maps.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScoreMeta {
    /// What the scores were computed from.
    pub key: CacheKey,
    /// Frame width in pixels.
    pub frame_width: u32,
    /// Frame height in pixels.
    pub frame_height: u32,
    /// Patch side P of the cubes.
    pub patch: u32,
    /// Past frames per cube; the first `clip_hist` frames are excluded from metrics.
    pub clip_hist: u32,
    /// Hash of the scenario's frame ids ([`super::frame_ids_hash`]).
    pub frame_ids_hash: u64,
    /// The model's training statistics (z-scores, default pixel reference).
    pub training: TrainingStats,
    /// Pixel statistics over this scenario's scored objects (the "scenario" reference).
    pub scenario_pixels: PixelReference,
    /// Objects per batch of the reference's per-batch pixel scaling.
    pub batch_size: u32,
}

/// The scalar part of a score cache: what frame fusion needs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScoreTable {
    /// Key, sizes and statistics.
    pub meta: ScoreMeta,
    /// One entry per frame index.
    pub frames: Vec<FrameEntry>,
    /// Every scored object, grouped by frame in frame order.
    pub objects: Vec<ObjectScore>,
    /// Pixel statistics per reference batch of `meta.batch_size` consecutive objects.
    pub batches: Vec<PixelReference>,
}

impl ScoreTable {
    /// The objects of frame `index` (empty outside the table).
    pub fn frame_objects(&self, index: usize) -> &[ObjectScore] {
        let Some(f) = self.frames.get(index) else {
            return &[];
        };
        let start = f.first_object as usize;
        self.objects
            .get(start..start + f.objects as usize)
            .unwrap_or(&[])
    }

    /// Frames with `frames` in order and objects grouped by them, checking that they fit
    /// together (contiguous, in frame order, batch statistics present).
    pub fn validate(&self) -> Result<(), String> {
        let mut next = 0u64;
        for (i, f) in self.frames.iter().enumerate() {
            if u64::from(f.first_object) != next {
                return Err(format!(
                    "frame {i} starts at object {} but object {next} is next",
                    f.first_object
                ));
            }
            if (f.objects > 0) != (f.state == FrameState::Scored) {
                return Err(format!(
                    "frame {i} has {} objects but state {:?}",
                    f.objects, f.state
                ));
            }
            next += u64::from(f.objects);
        }
        if next != self.objects.len() as u64 {
            return Err(format!(
                "frames hold {next} objects but the table has {}",
                self.objects.len()
            ));
        }
        if let Some((k, o)) = self
            .frames
            .iter()
            .enumerate()
            .flat_map(|(i, f)| {
                let start = f.first_object as usize;
                (start..start + f.objects as usize).map(move |k| (k, i))
            })
            .map(|(k, i)| (k, (self.objects[k].frame as usize, i)))
            .find(|(_, (stored, expected))| stored != expected)
        {
            return Err(format!(
                "object {k} names frame {} but lies in frame {}",
                o.0, o.1
            ));
        }
        let batch = self.meta.batch_size.max(1) as usize;
        if self.batches.len() != self.objects.len().div_ceil(batch) {
            return Err(format!(
                "{} reference batches for {} objects in batches of {batch}",
                self.batches.len(),
                self.objects.len()
            ));
        }
        Ok(())
    }
}
