//! The per-frame views by name, and the one place that picks the drawing function of a
//! view: `vadscope render`, `vadscope export` and the viewer all draw through
//! [`draw_frame_view`], so a view is the same pixels wherever it is shown.

use image::RgbaImage;

use super::dashboard::{DashboardInput, DashboardOptions, dashboard};
use super::flow_view::{FlowViewInput, flow_view};
use super::frame_view::{frame_view, natural_size};
use super::pred_view::{PredViewInput, pred_view};

/// The views of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameView {
    /// Every view of one frame in one image.
    Dashboard,
    /// The frame with heatmap, boxes, truth contour and caption.
    Frame,
    /// Actual vs predicted frame and patches.
    Pred,
    /// Flow vs reconstruction.
    Flow,
}

impl FrameView {
    /// Every view.
    pub const ALL: [Self; 4] = [Self::Dashboard, Self::Frame, Self::Pred, Self::Flow];

    /// The view's name in file names (`frame_00012.png`, `dashboard.gif`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Dashboard => "dashboard",
            Self::Frame => "frame",
            Self::Pred => "pred",
            Self::Flow => "flow",
        }
    }

    /// Whether drawing the view needs the frame's optical flow.
    pub fn needs_flow(self) -> bool {
        matches!(self, Self::Dashboard | Self::Flow)
    }

    /// The view's size when none is asked for, for a frame of `frame` pixels.
    pub fn default_size(self, frame: (u32, u32), options: &DashboardOptions) -> (u32, u32) {
        match self {
            Self::Dashboard => (1600, 1000),
            Self::Frame => natural_size(frame, &options.frame),
            Self::Pred => (2 * frame.0, 2 * frame.1),
            Self::Flow => (3 * frame.0, 2 * frame.1),
        }
    }
}

/// Draws `view` of the frame `input` describes at `size`. Only the dashboard reads the
/// timeline and the evaluation.
pub fn draw_frame_view(
    view: FrameView,
    input: &DashboardInput<'_>,
    options: &DashboardOptions,
    size: (u32, u32),
) -> RgbaImage {
    let frame = &input.frame;
    match view {
        FrameView::Frame => frame_view(frame, &options.frame, size),
        FrameView::Pred => pred_view(
            &PredViewInput {
                frame: frame.frame,
                objects: frame.objects,
            },
            &options.pred,
            size,
        ),
        FrameView::Flow => flow_view(
            &FlowViewInput {
                frame: frame.frame,
                flow: input.flow,
                objects: frame.objects,
            },
            &options.flow,
            size,
        ),
        FrameView::Dashboard => dashboard(input, options, size),
    }
}
