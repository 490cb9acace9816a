//! The labeling mode on screen: the labeling bar above the frame (the interval mark, the
//! tag text, undo and redo, what is labelled and whether it is saved) and the box editor
//! over the frame view (the analyst's boxes of the frame; drag on empty ground to draw a
//! box, drag a box to move it, drag a corner of the selected box to resize it, click to
//! select). Every change is one [`Action`] sent to the core on release, so one drag is one
//! undoable edit.

use egui::{Color32, CursorIcon, Pos2, Stroke, StrokeKind};

use crate::annotate::{Rect, TrackId};
use crate::app::action::Action;
use crate::app::state::AppState;

use super::views::ViewImage;

/// Colour of the analyst's boxes at a keyframe.
const KEYFRAME_BOX: Color32 = Color32::from_rgb(255, 150, 40);
/// Colour of the analyst's boxes between keyframes (interpolated).
const INTERPOLATED_BOX: Color32 = Color32::from_rgb(200, 130, 60);
/// Colour of the selected box, its handles and the box being drawn.
const SELECTED_BOX: Color32 = Color32::from_rgb(255, 235, 90);
/// Half the side of a corner handle, in points.
const HANDLE: f32 = 4.0;
/// How close (points) the pointer must be to a corner to grab it.
const HANDLE_GRAB: f32 = 7.0;

/// The labeling bar: mode, interval mark, tag text, undo / redo, counts and save state.
pub fn toolbar(ui: &mut egui::Ui, state: &mut AppState) {
    ui.horizontal_wrapped(|ui| {
        ui.colored_label(KEYFRAME_BOX, "LABELING");
        match state.labeling().mark {
            Some(mark) => ui.label(format!(
                "interval from frame {mark}: ] ends it at the cursor"
            )),
            None => ui.weak("[ start · ] end · E move nearest edge · T tag"),
        };
        ui.separator();
        ui.label("tag:");
        ui.add(egui::TextEdit::singleline(state.tag_text_mut()).desired_width(110.0))
            .on_hover_text("the text T gives the range ([ to cursor, or the selected failure run)");
        ui.separator();
        let (can_undo, can_redo) = state.current_labels().map_or((false, false), |l| {
            (l.editor().can_undo(), l.editor().can_redo())
        });
        if ui
            .add_enabled(can_undo, egui::Button::new("Undo"))
            .on_hover_text("Ctrl+Z")
            .clicked()
        {
            state.apply(Action::Undo);
        }
        if ui
            .add_enabled(can_redo, egui::Button::new("Redo"))
            .on_hover_text("Ctrl+Shift+Z or Ctrl+Y")
            .clicked()
        {
            state.apply(Action::Redo);
        }
        if let Some(labels) = state.current_labels() {
            let set = labels.labels();
            ui.weak(format!(
                "{} intervals · {} tracks · {} tags",
                set.intervals().len(),
                set.tracks().len(),
                set.tags().len()
            ));
            let editor = labels.editor();
            let saved = if editor.saved_seq() >= editor.seq() {
                "saved"
            } else {
                "saving…"
            };
            let dir = editor
                .dir()
                .map_or_else(String::new, |d| d.display().to_string());
            ui.weak(saved)
                .on_hover_text(format!("labels.json and labels.journal in {dir}"));
        }
    });
}

/// A box drag in progress (frame pixels).
#[derive(Debug, Clone, Copy, PartialEq)]
enum BoxDrag {
    /// Drawing a new box from `from` to the pointer.
    Draw { from: (f32, f32) },
    /// Moving `track`'s box `rect` by the pointer's travel since `from`.
    Move {
        track: TrackId,
        rect: Rect,
        from: (f32, f32),
    },
    /// Dragging corner `corner` (0 top-left, 1 top-right, 2 bottom-right, 3 bottom-left)
    /// of `track`'s box `rect`.
    Resize {
        track: TrackId,
        rect: Rect,
        corner: usize,
    },
}

/// The box editor's state: the drag in progress and the pointer (frame pixels).
#[derive(Debug, Default)]
pub struct BoxEditor {
    drag: Option<BoxDrag>,
    pointer: Option<(f32, f32)>,
}

impl BoxEditor {
    /// Draws the analyst's boxes of the current frame over `response` (the frame view
    /// `view`) and handles the pointer.
    pub fn show(
        &mut self,
        ui: &egui::Ui,
        state: &mut AppState,
        response: &egui::Response,
        view: &ViewImage,
        ppp: f32,
    ) {
        let Some(scale) = view.scale() else {
            return;
        };
        let origin = response.rect.min;
        let to_screen = |x: f32, y: f32| -> Pos2 {
            let (ix, iy) = view.image_pixel(x, y).unwrap_or((0.0, 0.0));
            origin + egui::vec2(ix, iy) / ppp
        };
        let (fw, fh) = (view.frame_size.0 as f32, view.frame_size.1 as f32);
        let to_frame = |pos: Pos2| -> (f32, f32) {
            let local = (pos - origin) * ppp;
            let (x0, y0) = view.image_pixel(0.0, 0.0).unwrap_or((0.0, 0.0));
            (
                ((local.x - x0) / scale).clamp(0.0, fw),
                ((local.y - y0) / scale).clamp(0.0, fh),
            )
        };
        let frame = state.frame();
        let selected = state.labeling().selected_box;
        let boxes = state
            .current_labels()
            .map(|l| l.labels().boxes_at(frame))
            .unwrap_or_default();
        let painter = ui.painter_at(response.rect);
        let screen_rect =
            |r: &Rect| egui::Rect::from_two_pos(to_screen(r.x1, r.y1), to_screen(r.x2, r.y2));

        // Where a grab would land, for the pointer's affordance and the drag's start.
        let grab = |state: &AppState, pos: Pos2| -> Option<BoxDrag> {
            let point = to_frame(pos);
            if let Some(b) = boxes.iter().find(|b| Some(b.track) == selected) {
                let corners = corners(&b.rect);
                if let Some(corner) = corners
                    .iter()
                    .position(|&(x, y)| to_screen(x, y).distance(pos) <= HANDLE_GRAB)
                {
                    return Some(BoxDrag::Resize {
                        track: b.track,
                        rect: b.rect,
                        corner,
                    });
                }
            }
            let under = state
                .current_labels()
                .and_then(|l| l.box_at(frame, point.0, point.1));
            Some(match under {
                Some(b) => BoxDrag::Move {
                    track: b.track,
                    rect: b.rect,
                    from: point,
                },
                None => BoxDrag::Draw { from: point },
            })
        };

        if response.drag_started_by(egui::PointerButton::Primary) {
            let start = ui
                .input(|i| i.pointer.press_origin())
                .or(response.interact_pointer_pos());
            self.drag = start.and_then(|pos| grab(state, pos));
            if let Some(BoxDrag::Move { track, .. } | BoxDrag::Resize { track, .. }) = self.drag
                && selected != Some(track)
            {
                state.apply(Action::SelectBox(Some(track)));
            }
        }
        if response.dragged()
            && let Some(pos) = response.interact_pointer_pos()
        {
            self.pointer = Some(to_frame(pos));
        }
        let preview = self
            .drag
            .zip(self.pointer)
            .map(|(drag, to)| dragged(drag, to));

        for b in &boxes {
            let moving = matches!(
                self.drag,
                Some(BoxDrag::Move { track, .. } | BoxDrag::Resize { track, .. }) if track == b.track
            );
            if moving {
                continue;
            }
            let color = if Some(b.track) == selected {
                SELECTED_BOX
            } else if b.keyframe {
                KEYFRAME_BOX
            } else {
                INTERPOLATED_BOX
            };
            let width = if b.keyframe { 2.0 } else { 1.0 };
            let rect = screen_rect(&b.rect);
            painter.rect_stroke(rect, 0.0, Stroke::new(width, color), StrokeKind::Middle);
            if Some(b.track) == selected {
                for (x, y) in corners(&b.rect) {
                    painter.rect_filled(
                        egui::Rect::from_center_size(
                            to_screen(x, y),
                            egui::Vec2::splat(2.0 * HANDLE),
                        ),
                        0.0,
                        SELECTED_BOX,
                    );
                }
            }
        }
        if let Some((_, rect)) = preview {
            painter.rect_stroke(
                screen_rect(&rect),
                0.0,
                Stroke::new(2.0, SELECTED_BOX),
                StrokeKind::Middle,
            );
        }

        if response.drag_stopped() {
            if let Some((action, _)) = self.drag.zip(self.pointer).map(|(d, to)| dragged(d, to)) {
                state.apply(action);
            }
            self.drag = None;
            self.pointer = None;
        } else if response.clicked()
            && let Some(pos) = response.interact_pointer_pos()
        {
            let (x, y) = to_frame(pos);
            let under = state
                .current_labels()
                .and_then(|l| l.box_at(frame, x, y))
                .map(|b| b.track);
            state.apply(Action::SelectBox(under));
        }

        if let Some(pos) = response.hover_pos() {
            let icon = match self.drag.or_else(|| grab(state, pos)) {
                Some(BoxDrag::Resize { corner, .. }) if corner % 2 == 0 => CursorIcon::ResizeNwSe,
                Some(BoxDrag::Resize { .. }) => CursorIcon::ResizeNeSw,
                Some(BoxDrag::Move { .. }) => CursorIcon::Grab,
                _ => CursorIcon::Crosshair,
            };
            ui.ctx().set_cursor_icon(icon);
        }
    }
}

/// The corners of `r`: top-left, top-right, bottom-right, bottom-left.
fn corners(r: &Rect) -> [(f32, f32); 4] {
    [(r.x1, r.y1), (r.x2, r.y1), (r.x2, r.y2), (r.x1, r.y2)]
}

/// What `drag` with the pointer at `to` would do, and the box it shows.
fn dragged(drag: BoxDrag, to: (f32, f32)) -> (Action, Rect) {
    match drag {
        BoxDrag::Draw { from } => {
            let rect = Rect {
                x1: from.0.min(to.0),
                y1: from.1.min(to.1),
                x2: from.0.max(to.0),
                y2: from.1.max(to.1),
            };
            (Action::AddBox(rect), rect)
        }
        BoxDrag::Move { track, rect, from } => {
            let moved = rect.translated(to.0 - from.0, to.1 - from.1);
            (Action::SetBox { track, rect: moved }, moved)
        }
        BoxDrag::Resize {
            track,
            rect,
            corner,
        } => {
            let mut r = rect;
            match corner {
                0 => (r.x1, r.y1) = to,
                1 => (r.x2, r.y1) = to,
                2 => (r.x2, r.y2) = to,
                _ => (r.x1, r.y2) = to,
            }
            let r = crate::app::labeling::normalised(r);
            (Action::SetBox { track, rect: r }, r)
        }
    }
}
