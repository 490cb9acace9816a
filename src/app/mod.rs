//! The desktop viewer: an egui/eframe application over a GUI-free core.
//!
//! The core ([`AppState`]) holds the open data set ([`Dataset`]), the current scenario and
//! frame ([`Playback`]), the analyst's settings ([`ViewSettings`]), fused scores and live
//! metrics ([`ScenarioAnalysis`], [`DatasetMetrics`]), ranked failure cases with tags
//! ([`FailureCase`]), the background scoring job ([`ScoringJob`]), the labeling mode
//! ([`Labeling`]: the analyst's labels of each scenario through `annotate`, optionally the
//! reference of the metrics), the export job ([`ExportJob`]) and the log. It is driven by
//! [`Action`]s and setting changes and is tested without a display.
//!
//! [`ui`] draws panels over it (scenario browser, main view, timeline, weights and
//! metrics, failure cases, object inspector, labeling bar and box editor, export dialog,
//! log, help) and turns keys, clicks and drags into actions; the views themselves are
//! images drawn by `render`. [`Layout`] keeps panel sizes, settings and recent data sets
//! between runs. [`run`] opens the window.

pub mod action;
pub mod analysis;
pub mod background;
pub mod dataset;
pub mod error;
pub mod export_job;
pub mod failures;
pub mod jobs;
pub mod labeling;
pub mod layout;
pub mod playback;
pub mod settings;
pub mod state;
pub mod ui;

use std::path::PathBuf;

pub use action::Action;
pub use analysis::{DatasetMetrics, ScenarioAnalysis};
pub use dataset::{Dataset, ScenarioEntry, ScoreStatus, Scores};
pub use error::AppError;
pub use export_job::{ExportChoice, ExportJob};
pub use failures::{FailureCase, FailureKind, FailureTags, TagKey};
pub use jobs::{JobEvent, ScoringJob, ScoringSetup};
pub use labeling::{Labeling, ScenarioLabels};
pub use layout::Layout;
pub use playback::Playback;
pub use settings::{Overlay, Overlays, Reference, ThresholdMode, ViewMode, ViewSettings};
pub use state::{
    AppState, BACKGROUND_FRAME_CACHE, CURRENT_FRAME_CACHE, FrameInfo, LogEntry, LogLevel,
    ObjectInfo,
};
pub use ui::ViewerApp;

/// What the viewer opens with.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewerOptions {
    /// A scenario or data-set root to open at start.
    pub path: Option<PathBuf>,
    /// Model, boxes and flows to score with.
    pub setup: ScoringSetup,
    /// Where the layout is kept; `None` = not kept.
    pub layout_file: Option<PathBuf>,
}

/// Opens the viewer window and runs it until it is closed.
pub fn run(options: ViewerOptions) -> Result<(), AppError> {
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("vadscope")
            .with_inner_size([1400.0, 900.0])
            .with_drag_and_drop(true),
        ..Default::default()
    };
    eframe::run_native(
        "vadscope",
        native,
        Box::new(move |cc| Ok(Box::new(ViewerApp::new(&cc.egui_ctx, options)))),
    )
    .map_err(|e| AppError::Window(e.to_string()))
}
