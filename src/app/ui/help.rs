//! The help overlay: every key binding (from the one table in `input`) and the mouse
//! gestures, in a window that F1 or ? toggles.

use crate::app::action::Action;
use crate::app::state::AppState;

use super::input::{BINDINGS, OTHER_KEYS};

/// Draws the overlay when it is on.
pub fn show(ctx: &egui::Context, state: &mut AppState) {
    if !state.show_help() {
        return;
    }
    let mut open = true;
    egui::Window::new("Keys")
        .open(&mut open)
        .collapsible(false)
        .resizable(false)
        .anchor(egui::Align2::CENTER_CENTER, egui::Vec2::ZERO)
        .show(ctx, |ui| {
            egui::Grid::new("help keys")
                .num_columns(2)
                .striped(true)
                .show(ui, |ui| {
                    let mut listed: Vec<Action> = Vec::new();
                    for b in BINDINGS {
                        if listed.contains(&b.action) {
                            continue;
                        }
                        listed.push(b.action);
                        ui.monospace(b.keys);
                        ui.label(b.help);
                        ui.end_row();
                    }
                    for (keys, help) in OTHER_KEYS {
                        ui.monospace(*keys);
                        ui.label(*help);
                        ui.end_row();
                    }
                });
        });
    if !open {
        state.apply(Action::ToggleHelp);
    }
}
