//! The log panel: what was opened and scored, and every error from bad data, newest last,
//! so that nothing goes wrong silently.

use crate::app::state::{AppState, LogLevel};

/// Draws the log.
pub fn show(ui: &mut egui::Ui, state: &mut AppState) {
    ui.horizontal(|ui| {
        ui.strong("Log");
        let errors = state
            .log_entries()
            .iter()
            .filter(|e| e.level == LogLevel::Error)
            .count();
        if errors > 0 {
            ui.colored_label(error_colour(), format!("{errors} errors"));
        }
    });
    egui::ScrollArea::vertical()
        .id_salt("log scroll")
        .stick_to_bottom(true)
        .auto_shrink([false, false])
        .show(ui, |ui| {
            for entry in state.log_entries() {
                let text = egui::RichText::new(&entry.message).monospace();
                match entry.level {
                    LogLevel::Info => ui.label(text),
                    LogLevel::Warning => {
                        ui.colored_label(egui::Color32::from_rgb(220, 170, 60), text)
                    }
                    LogLevel::Error => ui.colored_label(error_colour(), text),
                };
            }
        });
}

fn error_colour() -> egui::Color32 {
    egui::Color32::from_rgb(235, 90, 70)
}
