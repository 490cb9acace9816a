//! The bridge to `render`: gathers the inputs of the current frame and view from the core
//! state and asks `render` for the images the panels show (main view, object patches, ROC
//! chart, timeline). Nothing here draws; the pixels are render's, the same as
//! `vadscope render` writes.

use image::RgbaImage;

use crate::app::analysis::metric_frames;
use crate::app::error::AppError;
use crate::app::settings::{ViewMode, ViewSettings};
use crate::app::state::AppState;
use crate::render::{
    Caption, DashboardInput, FrameScene, FrameView, FrameViewOptions, PredViewInput, SceneObject,
    ScoreLabels, TimelineInput, draw_frame_view, natural_size, pred_view, roc_chart,
};
use crate::score::{FlowProvider, PixelReferenceMode, ScoreError};

/// What the main view's image depends on: when this is unchanged, the texture is reused.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameKey {
    scenario: usize,
    frame: usize,
    scored: bool,
    selected: Option<u64>,
    settings: ViewSettings,
    threshold: u64,
    labeling: bool,
    size: (u32, u32),
}

impl FrameKey {
    /// The key of the current frame of `state` drawn at `size` pixels.
    pub fn of(state: &AppState, size: (u32, u32)) -> Self {
        Self {
            scenario: state.current_scenario(),
            frame: state.frame(),
            scored: state.entry().is_some_and(|e| e.scores().is_some()),
            selected: state.selected_track(),
            settings: state.settings().clone(),
            threshold: state.threshold().to_bits(),
            labeling: state.is_labeling(),
            size,
        }
    }
}

/// A drawn view.
pub struct ViewImage {
    /// The pixels.
    pub image: RgbaImage,
    /// Where the camera frame lies in the image: its top-left corner and image pixels per
    /// frame pixel (the frame view only; the other views are not hit-tested).
    frame_place: Option<(f32, f32, f32)>,
    /// The camera frame's size in pixels.
    pub frame_size: (u32, u32),
}

impl ViewImage {
    /// The frame pixel under image pixel (x, y), when it lies on the camera frame.
    pub fn frame_pixel(&self, x: f32, y: f32) -> Option<(f32, f32)> {
        let (x0, y0, scale) = self.frame_place?;
        let (fx, fy) = ((x - x0) / scale, (y - y0) / scale);
        (fx >= 0.0 && fy >= 0.0).then_some((fx, fy))
    }

    /// The image pixel of frame pixel (x, y) (the inverse of [`Self::frame_pixel`]).
    pub fn image_pixel(&self, x: f32, y: f32) -> Option<(f32, f32)> {
        let (x0, y0, scale) = self.frame_place?;
        Some((x0 + x * scale, y0 + y * scale))
    }

    /// Image pixels per frame pixel (the frame view only).
    pub fn scale(&self) -> Option<f32> {
        self.frame_place.map(|(_, _, scale)| scale)
    }
}

/// The largest scale of `frame` whose frame view (caption and colour bar included, as
/// `options` ask) fits `area`, and that view's size: render lays a view of
/// [`natural_size`] out with the frame 1:1 under the caption strip, at the left edge.
fn fit_frame_view(
    frame: (u32, u32),
    options: &FrameViewOptions,
    area: (u32, u32),
) -> (f32, (u32, u32)) {
    let (fw, fh) = (frame.0.max(1) as f32, frame.1.max(1) as f32);
    let mut scale = (area.0 as f32 / fw).min(area.1 as f32 / fh);
    for _ in 0..4 {
        let scaled = ((fw * scale).round() as u32, (fh * scale).round() as u32);
        let natural = natural_size(scaled, options);
        let shrink = (area.0 as f32 / natural.0 as f32).min(area.1 as f32 / natural.1 as f32);
        if shrink >= 1.0 {
            return (scale, natural);
        }
        scale *= shrink;
    }
    let scaled = (
        (fw * scale).round().max(1.0) as u32,
        (fh * scale).round().max(1.0) as u32,
    );
    (scale, natural_size(scaled, options))
}

/// The current frame's scene: from the score cache when scored, else the bare frame with
/// its ground-truth boxes unscored.
fn scene(state: &AppState, with_flow: bool) -> Result<Option<FrameScene>, AppError> {
    let Some(entry) = state.entry() else {
        return Ok(None);
    };
    let Some(scenario) = &entry.scenario else {
        return Ok(None);
    };
    let index = state.frame();
    let mut flows =
        with_flow.then(|| FlowProvider::new(scenario, state.scoring_setup().request.flow));
    if let Some(cache) = entry.scores().and_then(|s| s.cache()) {
        let scene = FrameScene::load(
            scenario,
            cache,
            index,
            &state.settings().weights,
            PixelReferenceMode::Training,
            flows.as_mut(),
        )
        .map_err(|e| AppError::View(e.to_string()))?;
        return Ok(Some(scene));
    }
    let frame = scenario.rgb(index)?;
    let flow = match flows.as_mut() {
        Some(provider) => provider.flow(index).map_err(ScoreError::from)?,
        None => None,
    };
    let objects = scenario
        .boxes(index)?
        .into_iter()
        .map(|b| crate::score::ObjectScore {
            frame: index as u32,
            track_id: b.track_id,
            class: b.class,
            bbox: [b.x1, b.y1, b.x2, b.y2],
            confidence: b.score,
            s_r: f32::NAN,
            s_p: f32::NAN,
        })
        .collect();
    Ok(Some(FrameScene {
        index,
        frame_id: scenario.frame_id(index),
        frame,
        objects,
        scores: Vec::new(),
        maps: Vec::new(),
        heatmap: None,
        mask: scenario.anomaly_mask(index)?,
        flow,
    }))
}

/// The main view of the current frame fitted into `size`, or `None` when no scenario is
/// open.
pub fn main_image(state: &AppState, size: (u32, u32)) -> Result<Option<ViewImage>, AppError> {
    let settings = state.settings();
    let Some(scene) = scene(state, settings.view == ViewMode::Flow)? else {
        return Ok(None);
    };
    let objects = scene.scene_objects();
    let options = state.dashboard_options();
    let info = state.frame_info();
    let caption = Caption {
        scenario: state.entry().map_or_else(String::new, |e| e.name.clone()),
        index: info.index,
        frame_id: info.id.map(|id| id.0),
        frame_score: info.filtered.filter(|v| v.is_finite()).or(info.raw),
        threshold: Some(state.threshold()),
        weights: Some(settings.weights),
        truth: Some(info.anomalous),
    };
    let view = settings.view.frame_view();
    let input = DashboardInput {
        frame: scene.frame_input(&objects, Some(&caption)),
        flow: scene.flow.as_deref(),
        timeline: TimelineInput::default(),
        evaluation: None,
    };
    let (size, frame_place) = if view == FrameView::Frame {
        let frame = scene.frame.dimensions();
        // render leaves the colour bar out when there is no heatmap (unscored).
        let mut fit = options.frame;
        fit.heatmap &= scene.heatmap.is_some();
        let (scale, fitted) = fit_frame_view(frame, &fit, size);
        let scaled_h = (frame.1 as f32 * scale).round();
        let place = (
            0.0,
            fitted.1 as f32 - scaled_h,
            scaled_h / frame.1.max(1) as f32,
        );
        (fitted, Some(place))
    } else {
        (size, None)
    };
    let image = draw_frame_view(view, &input, &options, size);
    Ok(Some(ViewImage {
        image,
        frame_place,
        frame_size: scene.frame.dimensions(),
    }))
}

/// The selected object's actual, predicted and error patches (render's prediction view
/// of that object alone) at `size`.
pub fn object_image(
    state: &AppState,
    track: u64,
    size: (u32, u32),
) -> Result<Option<RgbaImage>, AppError> {
    let Some(scene) = scene(state, false)? else {
        return Ok(None);
    };
    let objects: Vec<SceneObject<'_>> = scene
        .scene_objects()
        .into_iter()
        .filter(|o| o.track_id == track)
        .collect();
    if objects.is_empty() {
        return Ok(None);
    }
    Ok(Some(pred_view(
        &PredViewInput {
            frame: &scene.frame,
            objects: &objects,
        },
        &state.dashboard_options().pred,
        size,
    )))
}

/// The ROC chart of the current scenario's metric frames at `size`.
pub fn roc_image(state: &AppState, size: (u32, u32)) -> Option<RgbaImage> {
    let analysis = state.current_analysis()?;
    let (scores, labels) = metric_frames(&analysis.series, state.reference_labels());
    Some(roc_chart(
        &ScoreLabels {
            scores,
            labels,
            threshold: Some(state.threshold()),
        },
        size,
    ))
}
