//! The failure-case panel: at the current threshold, the ranked false alarms, missed
//! anomalies and late detections of every scored scenario, each with a thumbnail of the
//! frame to look at; a click jumps there, a text field tags the case, and the list exports
//! as CSV.

use std::collections::HashMap;
use std::collections::hash_map::Entry;

use crate::app::action::Action;
use crate::app::failures::FailureKind;
use crate::app::state::{AppState, LogLevel};

/// Cases listed per kind until "show all" is ticked.
const SHOWN_PER_KIND: usize = 8;
/// Thumbnail width in pixels.
const THUMB_WIDTH: u32 = 72;
/// Thumbnails kept before the oldest are dropped.
const THUMBS_KEPT: usize = 64;
/// Tags offered with one click.
const SUGGESTED_TAGS: [&str; 5] = [
    "turning vehicle",
    "cut-in",
    "missed box",
    "rain",
    "label error",
];

/// The panel's own state: thumbnails and whether every case is listed.
#[derive(Default)]
pub struct FailurePanel {
    thumbnails: HashMap<(usize, usize), egui::TextureHandle>,
    show_all: bool,
}

impl FailurePanel {
    /// Draws the panel.
    pub fn show(&mut self, ui: &mut egui::Ui, state: &mut AppState) {
        ui.horizontal(|ui| {
            ui.heading("Failure cases");
            if ui
                .button("Export CSV…")
                .on_hover_text("every case with its frames, AnoVox ids, score and tag")
                .clicked()
            {
                export(state);
            }
        });
        ui.weak(format!(
            "at threshold {:.3}; F / Shift+F steps through them",
            state.threshold()
        ));
        ui.checkbox(&mut self.show_all, "show all");
        if self.thumbnails.len() > THUMBS_KEPT {
            self.thumbnails.clear();
        }
        let mut jump = None;
        let mut retag: Option<(usize, String)> = None;
        for kind in FailureKind::ALL {
            let cases: Vec<usize> = (0..state.failures().len())
                .filter(|&i| state.failures()[i].kind == kind)
                .collect();
            let title = format!("{} ({})", plural(kind), cases.len());
            egui::CollapsingHeader::new(title)
                .id_salt(kind.name())
                .default_open(true)
                .show(ui, |ui| {
                    let shown = if self.show_all {
                        cases.len()
                    } else {
                        SHOWN_PER_KIND
                    };
                    for &i in cases.iter().take(shown) {
                        if let Some(action) = self.case_row(ui, state, i, &mut retag) {
                            jump = Some(action);
                        }
                    }
                    if cases.len() > shown {
                        ui.weak(format!("… {} more", cases.len() - shown));
                    }
                });
        }
        if let Some((i, tag)) = retag {
            state.set_failure_tag(i, &tag);
        }
        if let Some(i) = jump {
            state.apply(Action::JumpToFailure(i));
        }
    }

    fn case_row(
        &mut self,
        ui: &mut egui::Ui,
        state: &AppState,
        index: usize,
        retag: &mut Option<(usize, String)>,
    ) -> Option<usize> {
        let case = state.failures()[index].clone();
        let name = state
            .dataset()
            .and_then(|d| d.scenarios.get(case.scenario))
            .map_or_else(String::new, |e| e.name.clone());
        let selected = state.failure_cursor() == Some(index);
        let mut clicked = false;
        ui.horizontal(|ui| {
            if let Some(texture) = self.thumbnail(ui.ctx(), state, case.scenario, case.focus) {
                let size = texture.size_vec2() * (THUMB_WIDTH as f32 / texture.size_vec2().x);
                let image = egui::Image::new((texture.id(), size)).sense(egui::Sense::click());
                clicked |= ui.add(image).clicked();
            }
            ui.vertical(|ui| {
                let detail = match case.kind {
                    FailureKind::FalseAlarm => format!("peak {:.2}", case.score),
                    FailureKind::Missed => format!("{} frames", case.end - case.start + 1),
                    FailureKind::Late => format!("{} frames late", case.latency.unwrap_or(0)),
                };
                let text = format!("frames {}–{} · {detail}", case.start, case.end);
                clicked |= ui
                    .selectable_label(selected, text)
                    .on_hover_text(format!("{name}: go to frame {}", case.focus))
                    .clicked();
                ui.weak(&name);
                let mut tag = state.failure_tag(index).unwrap_or("").to_string();
                ui.horizontal(|ui| {
                    let edit = egui::TextEdit::singleline(&mut tag)
                        .hint_text("tag")
                        .desired_width(110.0);
                    if ui.add(edit).changed() {
                        *retag = Some((index, tag.clone()));
                    }
                    ui.menu_button("+", |ui| {
                        for suggestion in SUGGESTED_TAGS {
                            if ui.button(suggestion).clicked() {
                                *retag = Some((index, suggestion.to_string()));
                                ui.close();
                            }
                        }
                    });
                });
            });
        });
        clicked.then_some(index)
    }

    fn thumbnail(
        &mut self,
        ctx: &egui::Context,
        state: &AppState,
        scenario: usize,
        frame: usize,
    ) -> Option<&egui::TextureHandle> {
        if let Entry::Vacant(slot) = self.thumbnails.entry((scenario, frame)) {
            let rgb = state
                .dataset()?
                .scenarios
                .get(scenario)?
                .scenario
                .as_ref()?
                .rgb(frame)
                .ok()?;
            let height = (rgb.height() * THUMB_WIDTH / rgb.width().max(1)).max(1);
            let small = image::imageops::thumbnail(rgb.as_ref(), THUMB_WIDTH, height);
            let rgba = image::DynamicImage::ImageRgb8(small).to_rgba8();
            let texture = ctx.load_texture(
                format!("thumbnail {scenario} {frame}"),
                super::texture::to_color_image(&rgba),
                egui::TextureOptions::LINEAR,
            );
            slot.insert(texture);
        }
        self.thumbnails.get(&(scenario, frame))
    }
}

fn plural(kind: FailureKind) -> &'static str {
    match kind {
        FailureKind::FalseAlarm => "False alarms",
        FailureKind::Missed => "Missed anomalies",
        FailureKind::Late => "Late detections",
    }
}

/// Asks where to write the failure-case CSV and writes it.
pub fn export(state: &mut AppState) {
    let Some(path) = rfd::FileDialog::new()
        .set_file_name("failure_cases.csv")
        .save_file()
    else {
        return;
    };
    match state.export_failures(&path) {
        Ok(()) => state.log(
            LogLevel::Info,
            format!("failure cases written to {}", path.display()),
        ),
        Err(e) => state.log(LogLevel::Error, format!("failure cases not written: {e}")),
    }
}
