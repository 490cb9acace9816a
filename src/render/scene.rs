//! What the views show of one frame, gathered from a scenario and its score cache
//! ([`FrameScene`]: image, scored objects and their maps, heatmap, mask, flow), and the
//! fusion, threshold and colours every view of a scenario is drawn with ([`DrawSettings`]). The numbers
//! (the score series, the reference threshold) are `score`'s.

use std::sync::Arc;

use image::{GrayImage, RgbImage};

use crate::score::{
    FlowProvider, FrameFusion, FusionParams, FusionWeights, Heatmap, HeatmapScratch, ObjectMaps,
    ObjectScore, PixelReferenceMode, ScoreCache, ScoreError, ScoreSeries, ScoreTable,
    compose_heatmap, reference_threshold,
};
use crate::sequence::{FlowField, FrameId, Scenario};

use super::colormap::Colormap;
use super::dashboard::DashboardOptions;
use super::error::RenderError;
use super::frame_view::{Caption, FrameViewInput, HeatRange, REFERENCE_RANGE_IQR};
use super::overlay::{SceneObject, ScoreScale};
use crate::model::PixelStats;

/// Everything the views show of one frame.
#[derive(Debug, Clone)]
pub struct FrameScene {
    /// Frame index.
    pub index: usize,
    /// AnoVox frame id.
    pub frame_id: Option<FrameId>,
    /// The camera frame.
    pub frame: Arc<RgbImage>,
    /// Its scored objects.
    pub objects: Vec<ObjectScore>,
    /// Fused score of each object.
    pub scores: Vec<f64>,
    /// The maps of each object.
    pub maps: Vec<ObjectMaps>,
    /// The full-resolution pixel heatmap (`None` without scored objects).
    pub heatmap: Option<Heatmap>,
    /// The ground-truth anomaly mask.
    pub mask: Option<Arc<GrayImage>>,
    /// The flow leading into the frame.
    pub flow: Option<Arc<FlowField>>,
}

impl FrameScene {
    /// Gathers frame `index` of `scenario` scored in `cache`, fused with `weights`, pixel
    /// maps scaled by `mode`, flow from `flows` (none when `None`).
    pub fn load(
        scenario: &Scenario,
        cache: &ScoreCache,
        index: usize,
        weights: &FusionWeights,
        mode: PixelReferenceMode,
        flows: Option<&mut FlowProvider<'_>>,
    ) -> Result<Self, RenderError> {
        if index >= scenario.len() {
            return Err(RenderError::NoSuchFrame {
                scenario: scenario.name().to_string(),
                index,
                frames: scenario.len(),
            });
        }
        let table = cache.table();
        let frame = scenario.rgb(index)?;
        let objects = table.frame_objects(index).to_vec();
        let maps = if objects.is_empty() {
            Vec::new()
        } else {
            cache.frame_maps(index)?
        };
        let fusion = FrameFusion::of_table(table, weights);
        let scores = objects.iter().map(|o| fusion.object_score(o)).collect();
        let heatmap = if objects.is_empty() {
            None
        } else {
            let (w, h) = frame.dimensions();
            let mut heat = Heatmap::new(w, h);
            compose_heatmap(
                table,
                index,
                &maps,
                weights,
                mode,
                &mut heat,
                &mut HeatmapScratch::default(),
            )?;
            Some(heat)
        };
        let flow = match flows {
            Some(provider) => provider.flow(index).map_err(ScoreError::from)?,
            None => None,
        };
        Ok(Self {
            index,
            frame_id: scenario.frame_id(index),
            frame,
            objects,
            scores,
            maps,
            heatmap,
            mask: scenario.anomaly_mask(index)?,
            flow,
        })
    }

    /// The caption of this frame in `scenario` with `settings`.
    pub fn caption(
        &self,
        scenario: &str,
        series: &ScoreSeries,
        settings: &DrawSettings,
    ) -> Caption {
        let score = series
            .filtered
            .get(self.index)
            .copied()
            .filter(|v| v.is_finite())
            .or_else(|| series.fused.get(self.index).copied());
        Caption {
            scenario: scenario.to_string(),
            index: self.index,
            frame_id: self.frame_id.map(|id| id.0),
            frame_score: score,
            threshold: Some(settings.threshold),
            weights: Some(settings.fusion.weights),
            truth: series.truth.get(self.index).copied(),
        }
    }

    /// The frame view's input: this frame with `objects` (from [`Self::scene_objects`]),
    /// its heatmap, truth mask and `caption`.
    pub fn frame_input<'a>(
        &'a self,
        objects: &'a [SceneObject<'a>],
        caption: Option<&'a Caption>,
    ) -> FrameViewInput<'a> {
        FrameViewInput {
            frame: &self.frame,
            objects,
            heatmap: self.heatmap.as_ref(),
            anomaly_mask: self.mask.as_deref(),
            caption,
        }
    }

    /// The objects as the views take them.
    pub fn scene_objects(&self) -> Vec<SceneObject<'_>> {
        self.objects
            .iter()
            .enumerate()
            .map(|(k, o)| SceneObject {
                bbox: o.bbox,
                track_id: o.track_id,
                score: self.scores.get(k).copied(),
                maps: self.maps.get(k),
            })
            .collect()
    }
}

/// What every view of a scenario is drawn with: the scores' fusion and threshold (the
/// viewer's from its `app::ViewSettings`, the CLI's from its options) and the colours.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawSettings {
    /// Fusion weights and median filter of the frame scores.
    pub fusion: FusionParams,
    /// Decision threshold on the filtered frame score.
    pub threshold: f64,
    /// Colormap of heatmaps, error maps and boxes.
    pub colormap: Colormap,
    /// Heatmap range per frame instead of the model's reference range.
    pub auto_range: bool,
}

impl Default for DrawSettings {
    fn default() -> Self {
        let weights = FusionWeights::default();
        Self {
            fusion: FusionParams {
                weights,
                median_kernel: 17,
            },
            threshold: reference_threshold(&weights),
            colormap: Colormap::default(),
            auto_range: false,
        }
    }
}

/// The error range of the reference statistics `p`: 0 to [`REFERENCE_RANGE_IQR`] IQRs
/// above the median (`None` when that is not positive).
pub fn reference_error_range(p: &PixelStats) -> Option<(f32, f32)> {
    let high = (p.median + f64::from(REFERENCE_RANGE_IQR) * p.iqr) as f32;
    (high.is_finite() && high > 0.0).then_some((0.0, high))
}

impl DrawSettings {
    /// The options of every view for scores of `table` (ranges from its model's training
    /// statistics).
    pub fn options(&self, table: &ScoreTable) -> DashboardOptions {
        let mut options = DashboardOptions::default();
        let scale = ScoreScale::around(self.threshold);
        options.frame.colormap = self.colormap;
        options.frame.range = if self.auto_range {
            HeatRange::AutoPerFrame
        } else {
            HeatRange::reference(&self.fusion.weights)
        };
        options.frame.box_scale = scale;
        options.pred.colormap = self.colormap;
        options.pred.box_scale = scale;
        options.pred.error_range = reference_error_range(&table.meta.training.frame_pixel);
        options.flow.colormap = self.colormap;
        options.flow.box_scale = scale;
        options.flow.error_range = reference_error_range(&table.meta.training.flow_pixel);
        options
    }
}
