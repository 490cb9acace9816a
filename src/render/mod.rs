//! Every view as an RGBA image: the GUI shows these as textures and `vadscope render` /
//! `vadscope export` write them to files, so both show the same pixels. Inputs are plain
//! borrowed data plus an options struct with `Default`; drawing never fails and the same
//! inputs give the same bytes (the font is shipped, nothing depends on time or threads).
//!
//! Views:
//! - [`frame_view`]: the frame with heatmap ([`HeatRange`], [`Colormap`]), score-coloured
//!   boxes ([`SceneObject`], [`ScoreScale`]), ground-truth contour and [`Caption`] strip.
//! - [`pred_view`]: actual vs predicted frame and the per-object patch gallery.
//! - [`flow_view`]: flow, its reconstruction and the error, full frame and per object.
//! - [`timeline`]: the score series over frames with lanes and cursor; [`TimelineLayout`]
//!   maps pixels to frames for hit-testing.
//! - [`roc_chart`], [`histogram`]: evaluation charts of [`ScoreLabels`].
//! - [`dashboard`]: all of them for one frame.
//! - [`draw_frame_view`]: any per-frame [`FrameView`] by name (render, export, viewer).
//!
//! Data: [`FrameScene`] gathers the inputs of one frame from a scenario and its score
//! cache (the numbers, `score::ScoreSeries`, are `score`'s); [`scores_csv`] writes an export's score table with its [`Provenance`].

mod canvas;
mod chart_backend;
pub mod charts;
pub mod colormap;
mod comparison;
pub mod dashboard;
mod error;
pub mod export;
pub mod flow_view;
pub mod frame_view;
pub mod frame_views;
mod gallery;
mod legend;
pub mod overlay;
mod patches;
pub mod pred_view;
pub mod scene;
mod text;
pub mod timeline;

pub use charts::{ScoreLabels, histogram, roc_chart};
pub use colormap::{Colormap, UnknownColormap};
pub use dashboard::{DashboardInput, DashboardOptions, dashboard};
pub use error::RenderError;
pub use export::{Provenance, SCORES_HEADER, scores_csv};
pub use flow_view::{FlowViewInput, FlowViewOptions, flow_view};
pub use frame_view::{
    Caption, FrameViewInput, FrameViewOptions, HeatRange, MASK_COLOR, REFERENCE_RANGE_IQR,
    frame_view, natural_size,
};
pub use frame_views::{FrameView, draw_frame_view};
pub use overlay::{LABELLED_BOXES, SceneObject, ScoreScale};
pub use pred_view::{PredViewInput, PredViewOptions, pred_view};
pub use scene::{DrawSettings, FrameScene, reference_error_range};
pub use timeline::{TimelineInput, TimelineLayout, TimelineOptions, timeline};
