//! The scenario browser: every scenario of the open data set with its frame count,
//! conditions, scoring status and AUROC under the current weights; a click opens it.

use crate::app::action::Action;
use crate::app::dataset::ScoreStatus;
use crate::app::state::AppState;

/// Draws the list.
pub fn show(ui: &mut egui::Ui, state: &mut AppState) {
    ui.heading("Scenarios");
    let Some(dataset) = state.dataset() else {
        ui.weak("Open a scenario or data-set folder (File > Open, Ctrl+O, or drop it here).");
        return;
    };
    ui.weak(dataset.root.display().to_string());
    let mut chosen = None;
    for (i, entry) in dataset.scenarios.iter().enumerate() {
        let selected = i == state.current_scenario();
        let response = ui.selectable_label(selected, egui::RichText::new(&entry.name).strong());
        if response.clicked() {
            chosen = Some(i);
        }
        let auroc = state
            .analysis(i)
            .and_then(|a| a.metrics)
            .map_or_else(|| "AUROC –".into(), |m| format!("AUROC {:.3}", m.auroc));
        let conditions = format!("{:?} · {:?}", entry.domain, entry.weather).to_lowercase();
        let events = crate::eval::anomaly_events(&entry.labels).len();
        ui.horizontal_wrapped(|ui| {
            ui.weak(format!(
                "{} frames · {conditions} · {events} events",
                entry.frames
            ));
            match &entry.status {
                ScoreStatus::Failed(why) => {
                    ui.colored_label(egui::Color32::from_rgb(230, 110, 60), "scoring failed")
                        .on_hover_text(why);
                }
                status => {
                    ui.weak(format!("· {} · {auroc}", status.label()));
                }
            }
        });
        if let Some(error) = &entry.error {
            ui.colored_label(egui::Color32::from_rgb(230, 80, 60), error);
        }
        ui.add_space(2.0);
    }
    if let Some(i) = chosen {
        state.apply(Action::SelectScenario(i));
    }
}
