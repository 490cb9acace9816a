//! The top bar: the File and View menus (open, recent data sets, exports, panels, labeling
//! mode, help), where the analyst is (scenario, frame index and AnoVox id, ground truth and
//! labels) and the scoring and export jobs' progress with their cancel buttons.

use std::path::PathBuf;

use crate::app::action::Action;
use crate::app::layout::Layout;
use crate::app::state::AppState;

use super::export_dialog::{self, ExportDialog};
use super::main_view::MainView;

/// Draws the bar; returns a data set to open when the analyst chose one.
pub fn show(
    ui: &mut egui::Ui,
    state: &mut AppState,
    layout: &mut Layout,
    main_view: &mut MainView,
    export: &mut ExportDialog,
) -> Option<PathBuf> {
    let mut open = None;
    if ui
        .ctx()
        .input_mut(|i| i.consume_key(egui::Modifiers::COMMAND, egui::Key::O))
    {
        open = pick_folder();
    }
    if ui
        .ctx()
        .input_mut(|i| i.consume_key(egui::Modifiers::COMMAND, egui::Key::S))
    {
        main_view.export_png(state);
    }
    if ui
        .ctx()
        .input_mut(|i| i.consume_key(egui::Modifiers::COMMAND, egui::Key::E))
    {
        export.open(state);
    }
    egui::Panel::top("top bar").show(ui, |ui| {
        ui.horizontal_wrapped(|ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open scenario or data set…  (Ctrl+O)").clicked() {
                    open = pick_folder();
                    ui.close();
                }
                ui.menu_button("Recent", |ui| {
                    if layout.recent.is_empty() {
                        ui.label("(none yet)");
                    }
                    for path in layout.recent.clone() {
                        if ui.button(path.display().to_string()).clicked() {
                            open = Some(path);
                            ui.close();
                        }
                    }
                });
                ui.separator();
                if ui.button("Export current view as PNG…  (Ctrl+S)").clicked() {
                    main_view.export_png(state);
                    ui.close();
                }
                if ui
                    .button("Export frames, GIF and scores.csv…  (Ctrl+E)")
                    .clicked()
                {
                    export.open(state);
                    ui.close();
                }
                if ui.button("Export failure cases as CSV…").clicked() {
                    super::failures::export(state);
                    ui.close();
                }
            });
            ui.menu_button("View", |ui| {
                ui.checkbox(&mut layout.left_open, "Scenarios and failure cases");
                ui.checkbox(&mut layout.right_open, "Weights, metrics and inspector");
                ui.checkbox(&mut layout.timeline_open, "Timeline");
                ui.checkbox(&mut layout.log_open, "Log");
                ui.separator();
                let mut labeling = state.is_labeling();
                if ui.checkbox(&mut labeling, "Labeling mode (L)").changed() {
                    state.apply(Action::ToggleLabeling);
                }
                if ui.button("Keys (F1)").clicked() {
                    state.apply(Action::ToggleHelp);
                    ui.close();
                }
            });
            ui.separator();
            where_am_i(ui, state);
            scoring_status(ui, state);
            if state.is_exporting() {
                ui.separator();
                export_dialog::progress(ui, state);
            }
        });
    });
    open
}

/// Scenario, frame index of frame count, AnoVox id and ground truth, always visible.
fn where_am_i(ui: &mut egui::Ui, state: &AppState) {
    let Some(entry) = state.entry() else {
        ui.label("No data set open: File > Open, or drop a folder here.");
        return;
    };
    ui.strong(&entry.name);
    let info = state.frame_info();
    let id = info.id.map_or_else(|| "–".into(), |id| id.0.to_string());
    ui.monospace(format!(
        "frame {} / {}   AnoVox id {id}",
        info.index,
        entry.frames.saturating_sub(1)
    ));
    if info.anomalous {
        ui.colored_label(
            egui::Color32::from_rgb(230, 80, 60),
            "ANOMALY (ground truth)",
        );
    } else {
        ui.weak("normal (ground truth)");
    }
    if let Some(labels) = state.current_labels() {
        let cell = labels
            .lane()
            .cells
            .get(info.index)
            .copied()
            .unwrap_or_default();
        if cell.anomalous() {
            ui.colored_label(egui::Color32::from_rgb(255, 150, 40), "anomaly (labels)");
        } else {
            ui.weak("normal (labels)");
        }
    }
    if state.is_labeling() {
        ui.colored_label(egui::Color32::from_rgb(255, 150, 40), "LABELING");
    }
    if state.playback().is_playing() {
        ui.label("playing");
    }
}

/// The job's progress bar and cancel button, while it runs.
fn scoring_status(ui: &mut egui::Ui, state: &mut AppState) {
    if !state.is_scoring() {
        return;
    }
    ui.separator();
    let queue = state.scoring_queue();
    match state.scoring_progress() {
        Some((index, p)) => {
            let name = state
                .dataset()
                .and_then(|d| d.scenarios.get(index))
                .map_or("", |e| e.name.as_str())
                .to_string();
            let fraction = p.frames_done as f32 / p.frames_total.max(1) as f32;
            ui.add(
                egui::ProgressBar::new(fraction)
                    .desired_width(180.0)
                    .text(format!(
                        "scoring {name}: {}/{}",
                        p.frames_done, p.frames_total
                    )),
            );
        }
        None => {
            ui.spinner();
            ui.label("loading model and caches…");
        }
    }
    if queue > 0 {
        ui.weak(format!("{queue} waiting"));
    }
    if ui.button("Cancel scoring").clicked() {
        state.apply(Action::CancelScoring);
    }
}

fn pick_folder() -> Option<PathBuf> {
    rfd::FileDialog::new()
        .set_title("Open a scenario or data-set folder")
        .pick_folder()
}
