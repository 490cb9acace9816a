//! The current frame's numbers and objects, as the inspector and the frame view's hit tests
//! read them.

use crate::score::ObjectMaps;

use crate::app::error::AppError;

use crate::sequence::FrameId;

use super::AppState;

/// One object of the current frame as the inspector shows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectInfo {
    /// Position among the frame's objects (and its maps).
    pub index: usize,
    /// Track id.
    pub track_id: u64,
    /// Semantic class.
    pub class: u16,
    /// Box [x1, y1, x2, y2] in pixels.
    pub bbox: [f32; 4],
    /// Flow-reconstruction error S_r.
    pub s_r: f32,
    /// Frame-prediction error S_p.
    pub s_p: f32,
    /// z-score of S_r under the training statistics (its tail surprisal for a model that
    /// keeps tail tables, [`Self::component_symbol`]).
    pub z_r: f64,
    /// z-score (or tail surprisal) of S_p.
    pub z_p: f64,
    /// Fused object score w_r·z_r + w_p·z_p.
    pub score: f64,
}

/// The current frame's numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameInfo {
    /// Frame index.
    pub index: usize,
    /// AnoVox frame id.
    pub id: Option<FrameId>,
    /// Ground-truth flag.
    pub anomalous: bool,
    /// Raw fused score.
    pub raw: Option<f64>,
    /// Median-filtered score (NaN in the frames the model cannot score).
    pub filtered: Option<f64>,
}

impl AppState {
    /// The current frame's numbers.
    pub fn frame_info(&self) -> FrameInfo {
        let index = self.frame();
        let analysis = self.current_analysis();
        FrameInfo {
            index,
            id: self
                .entry()
                .and_then(|e| e.scenario.as_ref())
                .and_then(|s| s.frame_id(index)),
            anomalous: self.labels().get(index).copied().unwrap_or(false),
            raw: analysis.and_then(|a| a.series.fused.get(index).copied()),
            filtered: analysis.and_then(|a| a.series.filtered.get(index).copied()),
        }
    }

    /// The letter of the current scores' normalised S_r and S_p: `t` (tail surprisal) or
    /// `z` (z-score, also without scores).
    pub fn component_symbol(&self) -> &'static str {
        self.entry()
            .and_then(|e| e.scores())
            .map_or("z", |s| s.table().meta.training.component_symbol())
    }

    /// The scored objects of the current frame.
    pub fn frame_objects(&self) -> Vec<ObjectInfo> {
        let Some(scores) = self.entry().and_then(|e| e.scores()) else {
            return Vec::new();
        };
        let table = scores.table();
        if self.frame() >= table.frames.len() {
            return Vec::new();
        }
        let stats = &table.meta.training;
        let w = &self.settings.weights;
        table
            .frame_objects(self.frame())
            .iter()
            .enumerate()
            .map(|(index, o)| {
                let (z_r, z_p) = o.z_scores(stats, table.meta.frame_width);
                ObjectInfo {
                    index,
                    track_id: o.track_id,
                    class: o.class,
                    bbox: o.bbox,
                    s_r: o.s_r,
                    s_p: o.s_p,
                    z_r,
                    z_p,
                    score: w.w_r * z_r + w.w_p * z_p,
                }
            })
            .collect()
    }

    /// The maps of the current frame's objects, in object order; `None` when the scores
    /// have no maps on disk. Read errors are returned (the caller logs them).
    pub fn frame_maps(&self) -> Option<Result<Vec<ObjectMaps>, AppError>> {
        let cache = self.entry()?.scores()?.cache()?;
        if self.frame() >= cache.table().frames.len() {
            return None;
        }
        Some(cache.frame_maps(self.frame()).map_err(AppError::from))
    }

    /// The selected object's track id.
    pub fn selected_track(&self) -> Option<u64> {
        self.selected_track
    }

    /// The smallest box of the current frame that holds pixel (x, y).
    pub fn object_at(&self, x: f32, y: f32) -> Option<ObjectInfo> {
        self.frame_objects()
            .into_iter()
            .filter(|o| {
                let [x1, y1, x2, y2] = o.bbox;
                (x1..=x2).contains(&x) && (y1..=y2).contains(&y)
            })
            .min_by(|a, b| area(a.bbox).total_cmp(&area(b.bbox)))
    }
}

fn area(b: [f32; 4]) -> f32 {
    (b[2] - b[0]).max(0.0) * (b[3] - b[1]).max(0.0)
}
