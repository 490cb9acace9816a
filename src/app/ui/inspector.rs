//! The object inspector: the current frame's scored objects (click one here or its box in
//! the main view), and for the selected one S_r, S_p, their z-scores, the object score and
//! its actual, predicted and error patches as render draws them.

use crate::app::action::Action;
use crate::app::settings::ViewSettings;
use crate::app::state::{AppState, LogLevel};

use super::texture::CachedTexture;
use super::views;

/// Size of the patch image (pixels).
const PATCH_VIEW: (u32, u32) = (300, 260);

/// The panel's own state: the patch texture.
pub struct InspectorPanel {
    patches: CachedTexture<(usize, usize, u64, ViewSettings)>,
}

impl Default for InspectorPanel {
    fn default() -> Self {
        Self {
            patches: CachedTexture::new("object patches"),
        }
    }
}

impl InspectorPanel {
    /// Draws the panel.
    pub fn show(&mut self, ui: &mut egui::Ui, state: &mut AppState) {
        ui.heading("Object inspector");
        let objects = state.frame_objects();
        if objects.is_empty() {
            ui.weak(if state.current_analysis().is_some() {
                "No scored object in this frame."
            } else {
                "Objects appear here once the scenario is scored."
            });
            return;
        }
        let selected = state.selected_track();
        let mut choose = None;
        let symbol = state.component_symbol();
        egui::Grid::new("objects")
            .num_columns(4)
            .striped(true)
            .show(ui, |ui| {
                ui.strong("track");
                ui.strong("score");
                ui.strong(format!("{symbol}(S_r)"));
                ui.strong(format!("{symbol}(S_p)"));
                ui.end_row();
                for o in &objects {
                    if ui
                        .selectable_label(selected == Some(o.track_id), format!("#{}", o.track_id))
                        .clicked()
                    {
                        choose = Some(o.track_id);
                    }
                    ui.monospace(format!("{:.2}", o.score));
                    ui.monospace(format!("{:.2}", o.z_r));
                    ui.monospace(format!("{:.2}", o.z_p));
                    ui.end_row();
                }
            });
        if let Some(track) = choose {
            state.apply(Action::SelectObject(Some(track)));
        }
        let Some(object) = objects
            .iter()
            .find(|o| Some(o.track_id) == state.selected_track())
        else {
            ui.weak("Click a track (or its box) to see its patches.");
            return;
        };
        ui.monospace(format!(
            "track #{}  class {}\nS_r {:.4}  {symbol} {:.2}\nS_p {:.5}  {symbol} {:.2}\nobject score {:.3}  (threshold {:.3})",
            object.track_id,
            object.class,
            object.s_r,
            object.z_r,
            object.s_p,
            object.z_p,
            object.score,
            state.threshold()
        ));
        let key = (
            state.current_scenario(),
            state.frame(),
            object.track_id,
            state.settings().clone(),
        );
        let mut problem = None;
        let texture = self.patches.get(ui.ctx(), key, || {
            match views::object_image(state, object.track_id, PATCH_VIEW) {
                Ok(image) => image,
                Err(e) => {
                    problem = Some(e.to_string());
                    None
                }
            }
        });
        if let Some(texture) = texture {
            let width = ui.available_width().min(PATCH_VIEW.0 as f32);
            let scale = width / PATCH_VIEW.0 as f32;
            ui.image((
                texture.id(),
                egui::vec2(PATCH_VIEW.0 as f32, PATCH_VIEW.1 as f32) * scale,
            ));
        }
        if let Some(problem) = problem {
            state.log(LogLevel::Error, problem);
        }
    }
}
