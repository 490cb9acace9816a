//! The weights panel: sliders and numeric fields for the four fusion weights, the median
//! filter, the threshold (reference, F1-max or manual), colormap and heatmap opacity; the
//! presets; the switch of what the metrics are measured against (ground truth or the
//! analyst's labels); and the live metrics of the scenario and the whole data set with a
//! small ROC chart. Every change goes back as new settings and is re-fused before the next
//! frame is drawn.

use crate::app::settings::{Reference, ThresholdMode, ViewSettings};
use crate::app::state::AppState;
use crate::eval::ScoreMetrics;
use crate::render::Colormap;
use crate::score::FusionWeights;

use super::texture::CachedTexture;
use super::views;

/// The panel's own state: the ROC chart texture.
pub struct WeightsPanel {
    roc: CachedTexture<RocKey>,
}

impl Default for WeightsPanel {
    fn default() -> Self {
        Self {
            roc: CachedTexture::new("roc chart"),
        }
    }
}

/// What the ROC chart shows.
#[derive(PartialEq)]
struct RocKey {
    scenario: usize,
    labels: Option<u64>,
    settings: ViewSettings,
    threshold: u64,
    scored: usize,
}

impl WeightsPanel {
    /// Draws the panel, editing `settings`.
    pub fn show(&mut self, ui: &mut egui::Ui, state: &AppState, settings: &mut ViewSettings) {
        ui.heading("Weights");
        ui.horizontal_wrapped(|ui| {
            for (name, preset) in FusionWeights::PRESETS {
                if ui
                    .selectable_label(settings.weights == preset, short_name(name))
                    .on_hover_text(name)
                    .clicked()
                {
                    settings.weights = preset;
                }
            }
        });
        let w = &mut settings.weights;
        weight(
            ui,
            &mut w.w_r,
            "w_r",
            "frame: weight of the flow-reconstruction z-score",
        );
        weight(
            ui,
            &mut w.w_p,
            "w_p",
            "frame: weight of the frame-prediction z-score",
        );
        weight(
            ui,
            &mut w.w_r_p,
            "w_r_p",
            "pixel: weight of the flow error map",
        );
        weight(
            ui,
            &mut w.w_p_p,
            "w_p_p",
            "pixel: weight of the frame error map",
        );
        let mut kernel = settings.median_kernel as u32;
        ui.add(
            egui::Slider::new(&mut kernel, 1..=51)
                .step_by(2.0)
                .text("median filter"),
        )
        .on_hover_text("kernel of the median filter over frame scores (1 = none; reference 17)");
        settings.median_kernel = (kernel | 1) as usize;
        threshold(ui, state, settings);
        ui.add(egui::Slider::new(&mut settings.opacity, 0.0..=1.0).text("heatmap opacity"));
        egui::ComboBox::from_label("colormap")
            .selected_text(settings.colormap.name())
            .show_ui(ui, |ui| {
                for colormap in Colormap::ALL {
                    ui.selectable_value(&mut settings.colormap, colormap, colormap.name());
                }
            });

        ui.separator();
        ui.heading("Metrics");
        ui.horizontal_wrapped(|ui| {
            ui.label("reference:");
            for (k, reference) in Reference::ALL.into_iter().enumerate() {
                if k > 0 {
                    ui.label("|");
                }
                ui.selectable_value(&mut settings.reference, reference, reference.name())
                    .on_hover_text(
                        "what AUROC, FPR95, failure cases and detection latency are measured against",
                    );
            }
        });
        if state.settings().reference == Reference::AnalystLabels {
            ui.colored_label(
                egui::Color32::from_rgb(255, 150, 40),
                "measured against the analyst's labels (not the ground truth)",
            );
        }
        metrics_grid(ui, state);
        let size = (ui.available_width().clamp(120.0, 320.0) as u32, 180);
        let key = RocKey {
            scenario: state.current_scenario(),
            labels: state.current_labels().map(|l| l.editor().seq()),
            settings: state.settings().clone(),
            threshold: state.threshold().to_bits(),
            scored: state.dataset_metrics().scenarios,
        };
        if let Some(texture) = self
            .roc
            .get(ui.ctx(), key, || views::roc_image(state, size))
        {
            ui.image((texture.id(), egui::vec2(size.0 as f32, size.1 as f32)));
        }
    }
}

fn short_name(preset: &str) -> &str {
    match preset.find('(') {
        Some(i) => preset[..i].trim(),
        None => preset,
    }
}

fn weight(ui: &mut egui::Ui, value: &mut f64, name: &str, help: &str) {
    ui.add(
        egui::Slider::new(value, 0.0..=100.0)
            .logarithmic(true)
            .smallest_positive(0.01)
            .max_decimals(3)
            .text(name),
    )
    .on_hover_text(help);
}

fn threshold(ui: &mut egui::Ui, state: &AppState, settings: &mut ViewSettings) {
    ui.horizontal_wrapped(|ui| {
        ui.label("threshold:");
        for mode in ThresholdMode::ALL {
            if ui
                .selectable_label(settings.threshold_mode == mode, mode.name())
                .clicked()
                && settings.threshold_mode != mode
            {
                if mode == ThresholdMode::Manual {
                    settings.manual_threshold = state.threshold();
                }
                settings.threshold_mode = mode;
            }
        }
    });
    let (lo, hi) = score_range(state);
    let manual = settings.threshold_mode == ThresholdMode::Manual;
    let mut value = if manual {
        settings.manual_threshold
    } else {
        state.threshold()
    };
    let range = lo.min(value)..=hi.max(value).max(lo + 1e-6);
    let response = ui.add(
        egui::Slider::new(&mut value, range)
            .clamping(egui::SliderClamping::Never)
            .max_decimals(3)
            .text("threshold"),
    );
    if response.changed() {
        settings.threshold_mode = ThresholdMode::Manual;
        settings.manual_threshold = value;
    }
}

/// The finite range of the filtered scores over the data set.
fn score_range(state: &AppState) -> (f64, f64) {
    let Some(dataset) = state.dataset() else {
        return (0.0, 1.0);
    };
    let (lo, hi) = (0..dataset.len())
        .filter_map(|i| state.analysis(i))
        .flat_map(|a| a.series.filtered.iter().copied())
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo.is_finite() { (lo, hi) } else { (0.0, 1.0) }
}

fn metrics_grid(ui: &mut egui::Ui, state: &AppState) {
    let scenario = state.current_analysis();
    let dataset = state.dataset_metrics();
    let s = scenario.and_then(|a| a.metrics);
    let d = dataset.micro;
    let fmt = |v: Option<f64>| v.map_or_else(|| "–".to_string(), |v| format!("{v:.3}"));
    let of = |m: Option<ScoreMetrics>, f: fn(&ScoreMetrics) -> f64| fmt(m.as_ref().map(f));
    egui::Grid::new("metrics")
        .num_columns(3)
        .striped(true)
        .show(ui, |ui| {
            ui.strong("");
            ui.strong("scenario");
            ui.strong(format!("data set ({})", dataset.scenarios));
            ui.end_row();
            let mut row = |name: &str, a: String, b: String| {
                ui.label(name);
                ui.monospace(a);
                ui.monospace(b);
                ui.end_row();
            };
            row("AUROC", of(s, |m| m.auroc), of(d, |m| m.auroc));
            row(
                "AUROC macro",
                String::new(),
                fmt(dataset.macro_auroc.map(|(v, _)| v)),
            );
            row(
                "AUPR",
                of(s, |m| m.average_precision),
                of(d, |m| m.average_precision),
            );
            row("FPR95", of(s, |m| m.fpr95), of(d, |m| m.fpr95));
            row("F1-max", of(s, |m| m.f1_max), of(d, |m| m.f1_max));
            let latency = |v: Option<f64>, detected: usize, events: usize| {
                format!(
                    "{} ({detected}/{events})",
                    v.map_or_else(|| "–".into(), |v| format!("{v:.1} fr"))
                )
            };
            row(
                "latency (found)",
                scenario.map_or_else(
                    || "–".into(),
                    |a| latency(a.mean_latency(), a.detected(), a.outcomes.len()),
                ),
                latency(dataset.mean_latency, dataset.detected, dataset.events),
            );
        });
    if scenario.is_some_and(|a| a.metrics.is_none()) {
        ui.weak("This scenario has a single class of frames: no ROC metrics of its own.");
    }
    ui.monospace(format!("threshold {:.3}", state.threshold()));
}
