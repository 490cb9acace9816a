//! The main view: the image `render` draws for the current frame and view (frame with
//! overlays, predicted vs actual, flow vs reconstruction), scaled to fit, with the view and
//! overlay switches above it; hovering a box shows its scores, clicking selects it for the
//! inspector; the shown image exports as PNG. In the labeling mode, the labeling bar and
//! the analyst's boxes (see [`super::labeling_view`]) take over the frame.

use image::RgbaImage;

use crate::app::action::Action;
use crate::app::settings::{Overlay, ViewMode, ViewSettings};
use crate::app::state::{AppState, LogLevel};

use super::labeling_view::{self, BoxEditor};
use super::texture::CachedTexture;
use super::views::{self, FrameKey, ViewImage};

/// The main view's own state: the texture, the image it holds (for export), where it was
/// drawn on screen and the box editing of the labeling mode.
pub struct MainView {
    texture: CachedTexture<FrameKey>,
    shown: Option<ViewImage>,
    placed: Option<(egui::Rect, f32)>,
    boxes: BoxEditor,
}

impl Default for MainView {
    fn default() -> Self {
        Self {
            texture: CachedTexture::new("main view"),
            shown: None,
            placed: None,
            boxes: BoxEditor::default(),
        }
    }
}

impl MainView {
    /// Draws the view, editing `settings` (view mode and overlays).
    pub fn show(&mut self, ui: &mut egui::Ui, state: &mut AppState, settings: &mut ViewSettings) {
        ui.horizontal_wrapped(|ui| {
            for (i, mode) in ViewMode::ALL.into_iter().enumerate() {
                ui.selectable_value(
                    &mut settings.view,
                    mode,
                    format!("{} {}", i + 1, mode.name()),
                );
            }
            ui.separator();
            for overlay in Overlay::ALL {
                let mut on = settings.overlays.is_on(overlay);
                if ui.checkbox(&mut on, overlay.name()).changed() {
                    settings.overlays.toggle(overlay);
                }
            }
        });
        if state.is_labeling() {
            labeling_view::toolbar(ui, state);
        }
        if state.entry().is_none() {
            ui.centered_and_justified(|ui| {
                ui.label(
                    "Open a scenario or data set: File > Open (Ctrl+O), or drop a folder here.",
                );
            });
            return;
        }
        let ppp = ui.ctx().pixels_per_point();
        let avail = ui.available_size();
        let size = (
            (avail.x * ppp).clamp(64.0, 4096.0) as u32,
            (avail.y * ppp).clamp(48.0, 4096.0) as u32,
        );
        let key = FrameKey::of(state, size);
        let mut problem = None;
        let texture = self
            .texture
            .get(ui.ctx(), key, || match views::main_image(state, size) {
                Ok(view) => {
                    let image = view.as_ref().map(|v| v.image.clone());
                    self.shown = view;
                    image
                }
                Err(e) => {
                    problem = Some(e.to_string());
                    self.shown = None;
                    None
                }
            });
        let Some(texture) = texture.cloned() else {
            if let Some(problem) = problem {
                state.log(LogLevel::Error, problem);
            }
            ui.centered_and_justified(|ui| {
                ui.label("This frame could not be drawn (see the log).")
            });
            return;
        };
        let labeling = state.is_labeling() && settings.view == ViewMode::Frame;
        let sense = if labeling {
            egui::Sense::click_and_drag()
        } else {
            egui::Sense::click()
        };
        let response = ui.add(
            egui::Image::new((texture.id(), egui::vec2(size.0 as f32, size.1 as f32) / ppp))
                .sense(sense),
        );
        self.placed = Some((response.rect, ppp));
        match (&self.shown, labeling) {
            (Some(view), true) => self.boxes.show(ui, state, &response, view, ppp),
            _ => self.pointer(state, &response, ppp),
        }
    }

    /// The point on screen of frame pixel (x, y), as last drawn (frame view only).
    pub fn screen_point(&self, x: f32, y: f32) -> Option<egui::Pos2> {
        let (rect, ppp) = self.placed?;
        let (ix, iy) = self.shown.as_ref()?.image_pixel(x, y)?;
        Some(rect.min + egui::vec2(ix, iy) / ppp)
    }

    /// Hover tooltip and click selection of the box under the pointer.
    fn pointer(&self, state: &mut AppState, response: &egui::Response, ppp: f32) {
        let Some(view) = &self.shown else {
            return;
        };
        let Some(pos) = response.hover_pos() else {
            return;
        };
        let local = (pos - response.rect.min) * ppp;
        let Some((x, y)) = view.frame_pixel(local.x, local.y) else {
            return;
        };
        let object = state.object_at(x, y);
        if response.clicked() {
            state.apply(Action::SelectObject(object.map(|o| o.track_id)));
        }
        if let Some(o) = object {
            let symbol = state.component_symbol();
            response.clone().on_hover_ui_at_pointer(|ui| {
                ui.monospace(format!(
                    "track {}  score {:.2}\nS_r {:.3} ({symbol} {:.2})  S_p {:.4} ({symbol} {:.2})",
                    o.track_id, o.score, o.s_r, o.z_r, o.s_p, o.z_p
                ));
            });
        }
    }

    /// Asks where to write the shown image and writes it as PNG.
    pub fn export_png(&self, state: &mut AppState) {
        let Some(view) = &self.shown else {
            state.log(LogLevel::Warning, "nothing to export: no view is shown");
            return;
        };
        let name = format!("frame_{:05}.png", state.frame());
        let Some(path) = rfd::FileDialog::new().set_file_name(name).save_file() else {
            return;
        };
        save_png(state, &view.image, &path);
    }
}

fn save_png(state: &mut AppState, image: &RgbaImage, path: &std::path::Path) {
    match image.save(path) {
        Ok(()) => state.log(
            LogLevel::Info,
            format!("view written to {}", path.display()),
        ),
        Err(e) => state.log(LogLevel::Error, format!("{}: {e}", path.display())),
    }
}
