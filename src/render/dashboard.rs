//! The dashboard: every view of one frame composed in one image — frame with overlays and
//! predicted vs actual on top, flow vs reconstruction with the ROC chart and the score
//! histogram in the middle, the timeline across the bottom.

use image::RgbaImage;

use super::canvas::{BACKGROUND, Canvas};
use super::charts::{ScoreLabels, draw_histogram, draw_roc};
use super::flow_view::{FlowViewInput, FlowViewOptions, draw_flow_view};
use super::frame_view::{FrameViewInput, FrameViewOptions, draw_frame_view};
use super::pred_view::{PredViewInput, PredViewOptions, draw_pred_view};
use super::timeline::{TimelineInput, TimelineOptions, draw_timeline};
use crate::sequence::FlowField;

/// The data of a dashboard; everything is borrowed.
#[derive(Debug, Clone, Copy)]
pub struct DashboardInput<'a> {
    /// The frame, its objects, heatmap, mask and caption.
    pub frame: FrameViewInput<'a>,
    /// The flow leading into the frame, if any.
    pub flow: Option<&'a FlowField>,
    /// The scenario's score series, with the cursor on this frame.
    pub timeline: TimelineInput<'a>,
    /// Frame scores and ground truth for the ROC chart and histogram (`None` = not drawn).
    pub evaluation: Option<ScoreLabels<'a>>,
}

/// The options of the composed views.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DashboardOptions {
    /// The frame view's overlays.
    pub frame: FrameViewOptions,
    /// The prediction view's ranges.
    pub pred: PredViewOptions,
    /// The flow view's ranges.
    pub flow: FlowViewOptions,
    /// The timeline's series and window.
    pub timeline: TimelineOptions,
}

/// Separator between panels.
const SEPARATOR: [u8; 3] = [55, 58, 64];

/// Renders the dashboard at `size` (width, height).
pub fn dashboard(
    input: &DashboardInput<'_>,
    options: &DashboardOptions,
    size: (u32, u32),
) -> RgbaImage {
    let mut canvas = Canvas::new(size.0, size.1, BACKGROUND);
    let (w, h) = (canvas.width(), canvas.height());
    let top_h = h / 2;
    let mid_h = h * 26 / 100;
    let bottom_h = h - top_h - mid_h;
    let half = w / 2;
    draw_frame_view(
        &mut canvas,
        &input.frame,
        &options.frame,
        (0, 0, half.saturating_sub(2), top_h),
    );
    let pred = PredViewInput {
        frame: input.frame.frame,
        objects: input.frame.objects,
    };
    draw_pred_view(
        &mut canvas,
        &pred,
        &options.pred,
        (half as i32 + 2, 0, (w - half).saturating_sub(2), top_h),
    );
    let flow = FlowViewInput {
        frame: input.frame.frame,
        flow: input.flow,
        objects: input.frame.objects,
    };
    let flow_w = if input.evaluation.is_some() {
        w * 3 / 5
    } else {
        w
    };
    draw_flow_view(
        &mut canvas,
        &flow,
        &options.flow,
        (
            0,
            top_h as i32 + 2,
            flow_w.saturating_sub(2),
            mid_h.saturating_sub(4),
        ),
    );
    if let Some(evaluation) = &input.evaluation {
        let chart_w = (w - flow_w) / 2;
        let mut roc = Canvas::new(
            chart_w.saturating_sub(2),
            mid_h.saturating_sub(4),
            BACKGROUND,
        );
        draw_roc(&mut roc, evaluation);
        canvas.paste(&roc, flow_w as i32 + 2, top_h as i32 + 2);
        let mut hist = Canvas::new(
            (w - flow_w - chart_w).saturating_sub(2),
            mid_h.saturating_sub(4),
            BACKGROUND,
        );
        draw_histogram(&mut hist, evaluation);
        canvas.paste(&hist, (flow_w + chart_w) as i32 + 2, top_h as i32 + 2);
    }
    let mut timeline = Canvas::new(w, bottom_h.saturating_sub(2), BACKGROUND);
    draw_timeline(&mut timeline, &input.timeline, &options.timeline);
    canvas.paste(&timeline, 0, (top_h + mid_h) as i32 + 2);

    let (wi, top, mid) = (w as i32, top_h as i32, (top_h + mid_h) as i32);
    canvas.fill_rect(half as i32 - 1, 0, half as i32 + 1, top, SEPARATOR, 1.0);
    canvas.fill_rect(0, top, wi, top + 2, SEPARATOR, 1.0);
    canvas.fill_rect(0, mid, wi, mid + 2, SEPARATOR, 1.0);
    if input.evaluation.is_some() {
        canvas.fill_rect(
            flow_w as i32 - 1,
            top,
            flow_w as i32 + 1,
            mid,
            SEPARATOR,
            1.0,
        );
    }
    canvas.into_rgba()
}
