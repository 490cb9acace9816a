//! The export dialog (File > Export frames…, Ctrl+E): which view, which frames, PNG
//! files and/or an animated GIF, `scores.csv`, and the folder (typed, or chosen with the
//! system dialog); the export itself runs as the core's background job, whose progress and
//! cancel button are shown here and in the top bar.

use std::path::PathBuf;

use crate::app::action::Action;
use crate::app::export_job::ExportChoice;
use crate::app::state::AppState;
use crate::export::FrameView;

/// The dialog's choices, kept between openings.
pub struct ExportDialog {
    open: bool,
    view: FrameView,
    first: usize,
    last: usize,
    png: bool,
    gif: bool,
    scores_csv: bool,
    folder: String,
}

impl Default for ExportDialog {
    fn default() -> Self {
        Self {
            open: false,
            view: FrameView::Frame,
            first: 0,
            last: 0,
            png: true,
            gif: false,
            scores_csv: true,
            folder: String::new(),
        }
    }
}

impl ExportDialog {
    /// Opens the dialog on the current frame and view.
    pub fn open(&mut self, state: &AppState) {
        self.open = true;
        self.first = state.frame();
        self.last = state.frame();
        self.view = state.settings().view.frame_view();
    }

    /// Draws the dialog when it is open.
    pub fn show(&mut self, ctx: &egui::Context, state: &mut AppState) {
        if !self.open {
            return;
        }
        let frames = state.entry().map_or(0, |e| e.frames);
        let last_frame = frames.saturating_sub(1);
        let mut open = true;
        egui::Window::new("Export frames")
            .open(&mut open)
            .collapsible(false)
            .resizable(false)
            .show(ctx, |ui| {
                egui::Grid::new("export grid")
                    .num_columns(2)
                    .show(ui, |ui| {
                        let label = ui.label("view");
                        egui::ComboBox::from_id_salt("export view")
                            .selected_text(self.view.name())
                            .show_ui(ui, |ui| {
                                for view in FrameView::ALL {
                                    ui.selectable_value(&mut self.view, view, view.name());
                                }
                            })
                            .response
                            .labelled_by(label.id);
                        ui.end_row();
                        ui.label("frames");
                        ui.horizontal(|ui| {
                            let first = ui.label("first");
                            ui.add(egui::DragValue::new(&mut self.first).range(0..=last_frame))
                                .labelled_by(first.id);
                            let last = ui.label("last");
                            ui.add(egui::DragValue::new(&mut self.last).range(0..=last_frame))
                                .labelled_by(last.id);
                            if ui.button("this frame").clicked() {
                                (self.first, self.last) = (state.frame(), state.frame());
                            }
                            if ui.button("all frames").clicked() {
                                (self.first, self.last) = (0, last_frame);
                            }
                        });
                        ui.end_row();
                        ui.label("files");
                        ui.horizontal(|ui| {
                            ui.checkbox(&mut self.png, "PNG per frame");
                            ui.checkbox(&mut self.gif, "animated GIF");
                            ui.checkbox(&mut self.scores_csv, "scores.csv");
                        });
                        ui.end_row();
                        let label = ui.label("export folder");
                        ui.horizontal(|ui| {
                            ui.add(
                                egui::TextEdit::singleline(&mut self.folder)
                                    .hint_text("folder to write into")
                                    .desired_width(260.0),
                            )
                            .labelled_by(label.id);
                            if ui.button("Choose…").clicked()
                                && let Some(path) = rfd::FileDialog::new()
                                    .set_title("Export into folder")
                                    .pick_folder()
                            {
                                self.folder = path.display().to_string();
                            }
                        });
                        ui.end_row();
                    });
                ui.separator();
                if state.is_exporting() {
                    progress(ui, state);
                } else {
                    let ready = !self.folder.trim().is_empty()
                        && (self.png || self.gif || self.scores_csv)
                        && frames > 0;
                    if ui.add_enabled(ready, egui::Button::new("Export")).clicked() {
                        let (a, b) = (self.first.min(self.last), self.first.max(self.last));
                        state.start_export(ExportChoice {
                            frames: a..b + 1,
                            view: self.view,
                            png: self.png,
                            gif: self.gif,
                            scores_csv: self.scores_csv,
                            out: PathBuf::from(self.folder.trim()),
                        });
                    }
                }
            });
        if !open {
            self.open = false;
        }
    }
}

/// The export's progress bar and cancel button.
pub fn progress(ui: &mut egui::Ui, state: &mut AppState) {
    match state.export_progress() {
        Some(p) => {
            let fraction = p.frames_done as f32 / p.frames_total.max(1) as f32;
            ui.add(
                egui::ProgressBar::new(fraction)
                    .desired_width(180.0)
                    .text(format!("exporting {}/{}", p.frames_done, p.frames_total)),
            );
        }
        None => {
            ui.spinner();
            ui.label("exporting…");
        }
    }
    if ui.button("Cancel export").clicked() {
        state.apply(Action::CancelExport);
    }
}
