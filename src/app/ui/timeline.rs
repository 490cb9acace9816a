//! The timeline panel: render's timeline chart of the current scenario (raw and filtered
//! score, threshold, z-scores, ground-truth and analyst-label lanes, cursor) with
//! interaction on top: click or drag to seek, drag the threshold line to move the
//! threshold, wheel to zoom around the pointer, Shift+wheel or right-drag to pan,
//! double-click to see every frame, hover for the frame's values; in the labeling mode,
//! drag an interval edge in the labels lane to move it (frame-exact, one edit on release).

use std::ops::Range;

use egui::{Color32, CursorIcon, Pos2, Stroke};

use crate::annotate::{Edge, EdgeRef};
use crate::app::action::Action;
use crate::app::settings::{ThresholdMode, ViewSettings};
use crate::app::state::AppState;
use crate::render::{TimelineInput, TimelineLayout, TimelineOptions, timeline};

use super::texture::CachedTexture;

/// Fewest frames a zoomed timeline shows.
const MIN_WINDOW: usize = 8;

/// How close (points) the pointer must be to grab the threshold line or an interval edge.
const GRAB_DISTANCE: f32 = 5.0;

/// Colour of the grab affordances (hovered edge or threshold, dragged edge).
const GRAB_COLOR: Color32 = Color32::from_rgb(255, 230, 80);

/// What a primary drag on the chart does, decided where it starts.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Drag {
    /// Seek to the frame under the pointer.
    Seek,
    /// Move the threshold to the score under the pointer, in the score range the chart
    /// had when the drag started (so the scale holds still under the pointer).
    Threshold((f64, f64)),
    /// Move an interval edge to the frame under the pointer (applied on release).
    Edge(EdgeRef, usize),
}

/// Where the chart was drawn last, for hit-testing and for tests.
#[derive(Debug, Clone)]
struct Placed {
    rect: egui::Rect,
    layout: TimelineLayout,
    score_range: (f64, f64),
    ppp: f32,
}

impl Placed {
    fn frame_at(&self, pos: Pos2) -> Option<usize> {
        self.layout.frame_at((pos.x - self.rect.min.x) * self.ppp)
    }

    fn x_of(&self, frame: usize) -> f32 {
        self.rect.min.x + self.layout.x_of(frame) / self.ppp
    }

    /// Width of one frame's column, in points.
    fn frame_width(&self) -> f32 {
        (self.x_of(1) - self.x_of(0)).abs()
    }

    /// Where an interval edge at `frame` lies: a start edge on the left side of its first
    /// frame's column, an end edge on the right side of its last frame's.
    fn edge_x(&self, edge: Edge, frame: usize) -> f32 {
        let half = self.frame_width() / 2.0;
        match edge {
            Edge::Start => self.x_of(frame) - half,
            Edge::End => self.x_of(frame) + half,
        }
    }

    fn y_of_row(&self, row: f32) -> f32 {
        self.rect.min.y + row / self.ppp
    }

    fn threshold_y(&self, threshold: f64) -> f32 {
        self.y_of_row(self.layout.score_row(threshold, self.score_range) as f32)
    }

    fn rows(&self, rows: &Range<i32>) -> std::ops::RangeInclusive<f32> {
        self.y_of_row(rows.start as f32)..=self.y_of_row(rows.end as f32)
    }

    fn in_rows(&self, rows: &Range<i32>, pos: Pos2) -> bool {
        let r = self.rows(rows);
        pos.y >= r.start() - 1.0 && pos.y <= r.end() + 1.0
    }
}

/// The panel's own state: the texture, the visible frames, the drag in progress and
/// where the chart lies on screen.
pub struct TimelinePanel {
    texture: CachedTexture<TimelineKey>,
    window: Option<Range<usize>>,
    drag: Option<Drag>,
    placed: Option<Placed>,
}

impl Default for TimelinePanel {
    fn default() -> Self {
        Self {
            texture: CachedTexture::new("timeline"),
            window: None,
            drag: None,
            placed: None,
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
    labels: Option<u64>,
    window: Option<Range<usize>>,
    size: (u32, u32),
}

impl TimelinePanel {
    /// Draws the panel.
    pub fn show(&mut self, ui: &mut egui::Ui, state: &mut AppState, settings: &mut ViewSettings) {
        let Some(entry) = state.entry() else {
            ui.weak("No scenario open.");
            return;
        };
        let frames = entry.frames;
        if self.window.as_ref().is_some_and(|w| w.end > frames) {
            self.window = None;
        }
        ui.horizontal_wrapped(|ui| {
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
            if state.is_labeling() {
                ui.weak("· labeling: drag an interval edge in the labels lane");
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
            labels: state.current_labels().map(|l| l.editor().seq()),
            window: self.window.clone(),
            size,
        };
        let input = chart_input(state);
        let layout = TimelineLayout::new(input.frames(), &options, size);
        let score_range = layout.score_range(&input, &options);
        let texture = self
            .texture
            .get(ui.ctx(), key, || Some(timeline(&input, &options, size)));
        let Some(texture) = texture.cloned() else {
            return;
        };
        let response = ui.add(
            egui::Image::new((texture.id(), egui::vec2(size.0 as f32, size.1 as f32) / ppp))
                .sense(egui::Sense::click_and_drag()),
        );
        let placed = Placed {
            rect: response.rect,
            layout,
            score_range,
            ppp,
        };
        self.placed = Some(placed.clone());
        self.interact(ui, state, settings, &response, &placed, frames);
    }

    /// The point on screen of `frame` in the analyst-labels lane, as last drawn.
    pub fn label_lane_point(&self, frame: usize) -> Option<Pos2> {
        let p = self.placed.as_ref()?;
        let rows = p.rows(&p.layout.labels_y);
        Some(Pos2::new(p.x_of(frame), (rows.start() + rows.end()) / 2.0))
    }

    /// The point on screen of score `value` above `frame` in the score panel.
    pub fn score_point(&self, frame: usize, value: f64) -> Option<Pos2> {
        let p = self.placed.as_ref()?;
        Some(Pos2::new(p.x_of(frame), p.threshold_y(value)))
    }

    /// The interval edge within grab distance of `pos` in the labels lane.
    fn edge_under(state: &AppState, placed: &Placed, pos: Pos2) -> Option<EdgeRef> {
        if !state.is_labeling() || !placed.in_rows(&placed.layout.labels_y, pos) {
            return None;
        }
        let labels = state.current_labels()?.labels();
        let frame = placed.frame_at(pos)?;
        let edge = labels.nearest_edge(frame)?;
        let half = placed.frame_width() / 2.0;
        ((pos.x - placed.edge_x(edge.edge, edge.frame)).abs() <= GRAB_DISTANCE.max(half))
            .then_some(edge)
    }

    fn near_threshold(state: &AppState, placed: &Placed, pos: Pos2) -> bool {
        state.current_analysis().is_some()
            && placed.in_rows(&placed.layout.score_y, pos)
            && (pos.y - placed.threshold_y(state.threshold())).abs() <= GRAB_DISTANCE
    }

    fn interact(
        &mut self,
        ui: &egui::Ui,
        state: &mut AppState,
        settings: &mut ViewSettings,
        response: &egui::Response,
        placed: &Placed,
        frames: usize,
    ) {
        let layout = &placed.layout;
        let ppp = placed.ppp;
        let to_x = |pos: egui::Pos2| (pos.x - response.rect.min.x) * ppp;
        if response.double_clicked() {
            self.window = None;
            return;
        }
        if response.drag_started_by(egui::PointerButton::Primary) {
            let origin = ui
                .input(|i| i.pointer.press_origin())
                .or(response.interact_pointer_pos());
            self.drag = Some(match origin {
                Some(pos) => match Self::edge_under(state, placed, pos) {
                    Some(edge) => Drag::Edge(edge, edge.frame),
                    None if Self::near_threshold(state, placed, pos) => {
                        Drag::Threshold(placed.score_range)
                    }
                    None => Drag::Seek,
                },
                None => Drag::Seek,
            });
        }
        let pointer = response.interact_pointer_pos();
        match (self.drag, pointer) {
            (Some(Drag::Threshold(range)), Some(pos)) if response.dragged() => {
                let y = (pos.y - placed.rect.min.y) * placed.ppp;
                let value = placed.layout.score_at(y, range);
                if value.is_finite() {
                    settings.threshold_mode = ThresholdMode::Manual;
                    settings.manual_threshold = value;
                }
                ui.ctx().set_cursor_icon(CursorIcon::ResizeVertical);
            }
            (Some(Drag::Edge(edge, _)), Some(pos)) if response.dragged() => {
                let frame = placed.frame_at(pos).unwrap_or(edge.frame);
                self.drag = Some(Drag::Edge(edge, frame));
                ui.ctx().set_cursor_icon(CursorIcon::ResizeHorizontal);
            }
            _ => {}
        }
        if let Some(Drag::Edge(edge, frame)) = self.drag {
            let x = placed.edge_x(edge.edge, frame);
            let rows = placed.rows(&(layout.score_y.start..layout.labels_y.end));
            ui.painter().vline(x, rows, Stroke::new(2.0, GRAB_COLOR));
            response.clone().on_hover_ui_at_pointer(|ui| {
                let which = match edge.edge {
                    Edge::Start => "start",
                    Edge::End => "end",
                };
                ui.monospace(format!(
                    "interval {} {which}: frame {frame}",
                    edge.interval.0
                ));
            });
        }
        if response.drag_stopped() {
            if let Some(Drag::Edge(edge, frame)) = self.drag.take() {
                state.apply(Action::SetIntervalEdge {
                    interval: edge.interval,
                    edge: edge.edge,
                    frame,
                });
            }
            self.drag = None;
        }
        let seeking = matches!(self.drag, None | Some(Drag::Seek));
        if let Some(pos) = pointer
            && seeking
            && (response.clicked() || response.dragged_by(egui::PointerButton::Primary))
            && let Some(frame) = layout.frame_at(to_x(pos))
        {
            state.apply(Action::Seek(frame));
        }
        if let Some(mark) = state.labeling().mark.filter(|_| state.is_labeling()) {
            let rows = placed.rows(&layout.labels_y);
            ui.painter()
                .vline(placed.x_of(mark), rows, Stroke::new(2.0, Color32::WHITE));
        }
        if self.drag.is_none()
            && let Some(pos) = response.hover_pos()
        {
            if let Some(edge) = Self::edge_under(state, placed, pos) {
                ui.ctx().set_cursor_icon(CursorIcon::ResizeHorizontal);
                let rows = placed.rows(&layout.labels_y);
                let x = placed.edge_x(edge.edge, edge.frame);
                ui.painter().vline(x, rows, Stroke::new(3.0, GRAB_COLOR));
            } else if Self::near_threshold(state, placed, pos) {
                ui.ctx().set_cursor_icon(CursorIcon::ResizeVertical);
                let y = placed.threshold_y(state.threshold());
                ui.painter().hline(
                    placed.x_of(layout.frames.start)
                        ..=placed.x_of(layout.frames.end.saturating_sub(1)),
                    y,
                    Stroke::new(1.5, GRAB_COLOR),
                );
            }
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

/// The chart's series: the analysis of the current scenario, or its ground truth alone,
/// with the analyst's labels lane when they are open.
fn chart_input(state: &AppState) -> TimelineInput<'_> {
    let cursor = Some(state.frame());
    let labels = state
        .current_labels()
        .map_or(&[][..], |l| l.timeline_lane());
    match state.current_analysis() {
        Some(analysis) => {
            let mut input =
                TimelineInput::of_series(&analysis.series, labels, Some(state.threshold()), cursor);
            input.truth = state.labels();
            input
        }
        None => TimelineInput {
            truth: state.labels(),
            labels,
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
    if let Some(labels) = state.current_labels() {
        let cell = labels.lane().cells.get(frame).copied().unwrap_or_default();
        let label = if cell.anomalous() {
            "ANOMALY"
        } else {
            "normal"
        };
        text.push_str(&format!(" · labels {label}"));
        if cell.tags > 0 {
            let tags: Vec<&str> = labels
                .labels()
                .tags_at(frame)
                .into_iter()
                .map(|t| t.tag.as_str())
                .collect();
            text.push_str(&format!(" · tags {}", tags.join(", ")));
        }
    }
    if let Some(a) = state.current_analysis() {
        let s = &a.series;
        let symbol = state.component_symbol();
        let value = |v: &[f64]| {
            v.get(frame)
                .filter(|v| v.is_finite())
                .map_or_else(|| "–".into(), |v| format!("{v:.3}"))
        };
        text.push_str(&format!(
            "\nscore {} · filtered {} · threshold {:.3}\n{symbol}(S_r) {} · {symbol}(S_p) {}",
            value(&s.fused),
            value(&s.filtered),
            state.threshold(),
            value(&s.z_r),
            value(&s.z_p)
        ));
    }
    text
}
