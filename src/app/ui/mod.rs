//! The egui layer of the viewer: [`ViewerApp`] lays out the panels over an
//! [`AppState`], feeds it keys, dropped folders and the passing of time, and keeps the
//! [`Layout`] up to date. Each panel is its own module and only reads the state and sends
//! it actions or new settings.

mod browser;
mod export_dialog;
mod failures;
mod help;
pub mod input;
mod inspector;
mod labeling_view;
mod log;
mod main_view;
mod texture;
mod timeline;
mod top_bar;
mod views;
mod weights;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use super::layout::Layout;
use super::state::{AppState, LogLevel};
use super::{ViewerOptions, settings::ViewSettings};

/// The viewer application: the core state plus what only the GUI needs.
pub struct ViewerApp {
    state: AppState,
    layout: Layout,
    layout_file: Option<PathBuf>,
    saved_layout: Layout,
    saved_at: Instant,
    main_view: main_view::MainView,
    timeline: timeline::TimelinePanel,
    weights: weights::WeightsPanel,
    failures: failures::FailurePanel,
    inspector: inspector::InspectorPanel,
    export: export_dialog::ExportDialog,
}

/// How often a changed layout is written at most.
const LAYOUT_SAVE_INTERVAL: Duration = Duration::from_secs(2);

impl ViewerApp {
    /// The viewer of `options`: reads the layout (a bad file is logged and replaced by the
    /// default) and opens the path, if any.
    pub fn new(ctx: &egui::Context, options: ViewerOptions) -> Self {
        let (layout, problem) = match options.layout_file.as_deref().map(Layout::load) {
            Some(Ok(layout)) => (layout, None),
            Some(Err(e)) => (Layout::default(), Some(e.to_string())),
            None => (Layout::default(), None),
        };
        let state = AppState::new(options.setup, layout.settings.clone());
        let mut app = Self::with_state(state, layout);
        app.layout_file = options.layout_file;
        if let Some(problem) = problem {
            app.state
                .log(LogLevel::Warning, format!("layout not read: {problem}"));
        }
        if let Some(path) = options.path {
            app.open(&path);
        }
        ctx.request_repaint();
        app
    }

    /// A viewer over `state` with `layout`, remembering nothing on disk (tests, benches).
    pub fn with_state(state: AppState, layout: Layout) -> Self {
        Self {
            state,
            saved_layout: layout.clone(),
            layout,
            layout_file: None,
            saved_at: Instant::now(),
            main_view: main_view::MainView::default(),
            timeline: timeline::TimelinePanel::default(),
            weights: weights::WeightsPanel::default(),
            failures: failures::FailurePanel::default(),
            inspector: inspector::InspectorPanel::default(),
            export: export_dialog::ExportDialog::default(),
        }
    }

    /// The core state.
    pub fn state(&self) -> &AppState {
        &self.state
    }

    /// The core state, to drive it directly.
    pub fn state_mut(&mut self) -> &mut AppState {
        &mut self.state
    }

    /// Where frame `frame` of the analyst-labels lane was drawn on the timeline (screen
    /// points), for pointer tests and tools driving the window.
    pub fn timeline_label_point(&self, frame: usize) -> Option<egui::Pos2> {
        self.timeline.label_lane_point(frame)
    }

    /// Where score `value` above frame `frame` was drawn on the timeline's score panel.
    pub fn timeline_score_point(&self, frame: usize, value: f64) -> Option<egui::Pos2> {
        self.timeline.score_point(frame, value)
    }

    /// Where frame pixel (x, y) of the frame view was drawn on screen.
    pub fn frame_point(&self, x: f32, y: f32) -> Option<egui::Pos2> {
        self.main_view.screen_point(x, y)
    }

    /// Opens a scenario or data set and remembers it among the recent ones.
    pub fn open(&mut self, path: &std::path::Path) {
        if self.state.open(path) {
            self.layout.remember(path);
        }
    }

    /// Draws one frame of the whole viewer into `ui`.
    pub fn show(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        if self.state.poll_jobs() || self.state.is_scoring() || self.state.is_exporting() {
            ctx.request_repaint_after(Duration::from_millis(100));
        }
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .filter(|p| !p.as_os_str().is_empty())
                .collect()
        });
        if let Some(path) = dropped.first() {
            self.open(path);
        }
        input::apply_keys(&ctx, &mut self.state);
        if self.state.playback().is_playing() {
            let dt = ctx.input(|i| f64::from(i.stable_dt));
            self.state.advance(dt.min(0.25));
            ctx.request_repaint();
        }

        let mut settings: ViewSettings = self.state.settings().clone();
        if let Some(path) = top_bar::show(
            ui,
            &mut self.state,
            &mut self.layout,
            &mut self.main_view,
            &mut self.export,
        ) {
            self.open(&path);
        }
        self.show_side_panels(ui, &mut settings);
        self.show_bottom_panels(ui, &mut settings);
        egui::CentralPanel::default().show(ui, |ui| {
            self.main_view.show(ui, &mut self.state, &mut settings);
        });
        help::show(&ctx, &mut self.state);
        self.export.show(&ctx, &mut self.state);
        if settings != *self.state.settings() {
            self.state.set_settings(settings);
        }
        self.layout.settings = self.state.settings().clone();
        self.save_layout_if_changed(false);
    }

    fn show_side_panels(&mut self, ui: &mut egui::Ui, settings: &mut ViewSettings) {
        let left = egui::Panel::left("scenarios")
            .resizable(true)
            .default_size(self.layout.left_width)
            .size_range(180.0..=600.0)
            .show_collapsible(ui, &mut self.layout.left_open, |ui| {
                egui::ScrollArea::vertical()
                    .id_salt("left scroll")
                    .show(ui, |ui| {
                        browser::show(ui, &mut self.state);
                        ui.separator();
                        self.failures.show(ui, &mut self.state);
                    });
            });
        if let Some(r) = left {
            self.layout.left_width = r.response.rect.width();
        }
        let right = egui::Panel::right("weights")
            .resizable(true)
            .default_size(self.layout.right_width)
            .size_range(240.0..=600.0)
            .show_collapsible(ui, &mut self.layout.right_open, |ui| {
                egui::ScrollArea::vertical()
                    .id_salt("right scroll")
                    .show(ui, |ui| {
                        self.weights.show(ui, &self.state, settings);
                        ui.separator();
                        self.inspector.show(ui, &mut self.state);
                    });
            });
        if let Some(r) = right {
            self.layout.right_width = r.response.rect.width();
        }
    }

    fn show_bottom_panels(&mut self, ui: &mut egui::Ui, settings: &mut ViewSettings) {
        egui::Panel::bottom("log")
            .resizable(true)
            .default_size(90.0)
            .show_collapsible(ui, &mut self.layout.log_open, |ui| {
                log::show(ui, &mut self.state);
            });
        let timeline = egui::Panel::bottom("timeline")
            .resizable(true)
            .default_size(self.layout.timeline_height)
            .size_range(100.0..=500.0)
            .show_collapsible(ui, &mut self.layout.timeline_open, |ui| {
                self.timeline.show(ui, &mut self.state, settings);
            });
        if let Some(r) = timeline {
            self.layout.timeline_height = r.response.rect.height();
        }
    }

    /// Writes the layout when it changed (at most every [`LAYOUT_SAVE_INTERVAL`] unless
    /// `now`); a failure is logged once per change.
    fn save_layout_if_changed(&mut self, now: bool) {
        let Some(path) = &self.layout_file else {
            return;
        };
        if self.layout == self.saved_layout
            || (!now && self.saved_at.elapsed() < LAYOUT_SAVE_INTERVAL)
        {
            return;
        }
        if let Err(e) = self.layout.save(path) {
            self.state
                .log(LogLevel::Warning, format!("layout not saved: {e}"));
        }
        self.saved_layout = self.layout.clone();
        self.saved_at = Instant::now();
    }
}

impl eframe::App for ViewerApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.show(ui);
    }

    fn on_exit(&mut self) {
        self.save_layout_if_changed(true);
    }
}
