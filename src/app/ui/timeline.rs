//! The timeline panel: render's timeline chart of the current scenario (raw and filtered
//! score, threshold, z-scores, ground-truth lane, cursor) with interaction on top: click or
//! drag to seek, wheel to zoom around the pointer, Shift+wheel or right-drag to pan,
//! double-click to see every frame, hover for the frame's values.

use std::ops::Range;

use crate::app::settings::ViewSettings;
use crate::app::state::{Action, AppState};
use crate::render::{TimelineInput, TimelineLayout, TimelineOptions, timeline};

use super::texture::CachedTexture;

/// Fewest frames a zoomed timeline shows.
const MIN_WINDOW: usize = 8;

/// The panel's own state: the texture and the visible frames.
pub struct TimelinePanel {
    texture: CachedTexture<TimelineKey>,
    window: Option<Range<usize>>,
}

impl Default for TimelinePanel {
    fn default() -> Self {
        Self {
            texture: CachedTexture::new("timeline"),
            window: None,
        }
    }
}

/// What the chart shows.
#[derive(PartialEq)]
struct TimelineKey {
    scenario: usize,
    frame: usize,
    scored: bool,
    settings: ViewSettings,
    threshold: u64,
    window: Option<Range<usize>>,
    size: (u32, u32),
}

impl TimelinePanel {
    /// Draws the panel.
    pub fn show(&mut self, ui: &mut egui::Ui, state: &mut AppState, settings: &ViewSettings) {
        let Some(entry) = state.entry() else {
            ui.weak("No scenario open.");
            return;
        };
        let frames = entry.frames;
        if self.window.as_ref().is_some_and(|w| w.end > frames) {
            self.window = None;
        }
        ui.horizontal(|ui| {
            ui.strong("Timeline");
            let shown = self.window.clone().unwrap_or(0..frames);
            ui.weak(format!(
                "frames {}–{} of {frames} · wheel: zoom · Shift+wheel / right-drag: pan · double-click: all",
                shown.start,
                shown.end.saturating_sub(1)
            ));
            if state.current_analysis().is_none() {
                ui.weak("· not scored yet: ground truth only");
            }
        });
        let ppp = ui.ctx().pixels_per_point();
        let avail = ui.available_size();
        let size = (
            (avail.x * ppp).clamp(64.0, 4096.0) as u32,
            (avail.y * ppp).clamp(48.0, 2048.0) as u32,
        );
        let options = TimelineOptions {
            window: self.window.clone(),
            ..TimelineOptions::default()
        };
        let key = TimelineKey {
            scenario: state.current_scenario(),
            frame: state.frame(),
            scored: state.current_analysis().is_some(),
            settings: settings.clone(),
            threshold: state.threshold().to_bits(),
            window: self.window.clone(),
            size,
        };
        let texture = self.texture.get(ui.ctx(), key, || {
            Some(timeline(&chart_input(state), &options, size))
        });
        let Some(texture) = texture.cloned() else {
            return;
        };
        let response = ui.add(
            egui::Image::new((texture.id(), egui::vec2(size.0 as f32, size.1 as f32) / ppp))
                .sense(egui::Sense::click_and_drag()),
        );
        let layout = TimelineLayout::new(frames, &options, size);
        self.interact(ui, state, &response, &layout, ppp, frames);
    }

    fn interact(
        &mut self,
        ui: &egui::Ui,
        state: &mut AppState,
        response: &egui::Response,
        layout: &TimelineLayout,
        ppp: f32,
        frames: usize,
    ) {
        let to_x = |pos: egui::Pos2| (pos.x - response.rect.min.x) * ppp;
        if response.double_clicked() {
            self.window = None;
            return;
        }
        if let Some(pos) = response.interact_pointer_pos()
            && (response.clicked() || response.dragged_by(egui::PointerButton::Primary))
            && let Some(frame) = layout.frame_at(to_x(pos))
        {
            state.apply(Action::Seek(frame));
        }
        let visible = self.window.clone().unwrap_or(0..frames);
        let span = visible.len().max(1) as f64;
        let plot_width =
            f64::from((layout.plot_x.end - layout.plot_x.start).max(1)) / f64::from(ppp);
        if response.dragged_by(egui::PointerButton::Secondary) {
            let frames_per_point = span / plot_width;
            let shift = -(f64::from(response.drag_delta().x) * frames_per_point).round() as i64;
            self.pan(shift, frames);
        }
        let Some(pos) = response.hover_pos() else {
            return;
        };
        let (scroll, shift) = ui.input(|i| (i.smooth_scroll_delta, i.modifiers.shift));
        let wheel = if scroll.y != 0.0 { scroll.y } else { scroll.x };
        if wheel != 0.0 {
            if shift || (scroll.x != 0.0 && scroll.y == 0.0) {
                let shift = -(f64::from(wheel) * span / plot_width).round() as i64;
                self.pan(shift, frames);
            } else if let Some(anchor) = layout.frame_at(to_x(pos)) {
                self.zoom(anchor, (-f64::from(wheel) / 200.0).exp(), frames);
            }
        }
        if let Some(frame) = layout.frame_at(to_x(pos)) {
            response.clone().on_hover_ui_at_pointer(|ui| {
                ui.monospace(hover_text(state, frame));
            });
        }
    }

    /// Scales the visible span by `factor` keeping `anchor` under the pointer.
    fn zoom(&mut self, anchor: usize, factor: f64, frames: usize) {
        let visible = self.window.clone().unwrap_or(0..frames);
        let span = visible.len() as f64;
        let new_span = (span * factor).clamp(MIN_WINDOW.min(frames) as f64, frames as f64);
        let t = (anchor - visible.start) as f64 / span.max(1.0);
        let start = (anchor as f64 - t * new_span).round().max(0.0) as usize;
        let end = (start + new_span.round() as usize).min(frames);
        let start = end.saturating_sub(new_span.round() as usize);
        self.window = (end - start < frames).then_some(start..end);
    }

    /// Moves the visible frames by `shift`.
    fn pan(&mut self, shift: i64, frames: usize) {
        let Some(window) = self.window.clone() else {
            return;
        };
        let len = window.len() as i64;
        let start = (window.start as i64 + shift).clamp(0, frames as i64 - len);
        self.window = Some(start as usize..(start + len) as usize);
    }
}

/// The chart's series: the analysis of the current scenario, or its ground truth alone.
fn chart_input(state: &AppState) -> TimelineInput<'_> {
    let cursor = Some(state.frame());
    match state.current_analysis() {
        Some(analysis) => analysis
            .series
            .timeline(&[], Some(state.threshold()), cursor),
        None => TimelineInput {
            truth: state.labels(),
            cursor,
            ..TimelineInput::default()
        },
    }
}

/// The values of `frame` for the hover tooltip.
fn hover_text(state: &AppState, frame: usize) -> String {
    let id = state
        .entry()
        .and_then(|e| e.scenario.as_ref())
        .and_then(|s| s.frame_id(frame))
        .map_or_else(|| "–".into(), |id| id.0.to_string());
    let truth = if state.labels().get(frame).copied().unwrap_or(false) {
        "ANOMALY"
    } else {
        "normal"
    };
    let mut text = format!("frame {frame} · AnoVox id {id} · ground truth {truth}");
    if let Some(a) = state.current_analysis() {
        let s = &a.series;
        let value = |v: &[f64]| {
            v.get(frame)
                .filter(|v| v.is_finite())
                .map_or_else(|| "–".into(), |v| format!("{v:.3}"))
        };
        text.push_str(&format!(
            "\nscore {} · filtered {} · threshold {:.3}\nz(S_r) {} · z(S_p) {}",
            value(&s.fused),
            value(&s.filtered),
            state.threshold(),
            value(&s.z_r),
            value(&s.z_p)
        ));
    }
    text
}
