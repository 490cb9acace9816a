//! Keeping what is derived from the settings current: the settings `render` draws with,
//! the scenario on screen (with its large frame cache), and re-fusing every scored
//! scenario after a change of weights, filter, threshold or reference.

use crate::render::{DashboardOptions, DrawSettings};
use crate::score::{FusionParams, reference_threshold};

use crate::app::analysis::{DatasetMetrics, ScenarioAnalysis};
use crate::app::failures::{rank, scenario_failures};
use crate::app::playback::Playback;
use crate::app::settings::{Reference, ThresholdMode, ViewSettings};

use super::AppState;

/// Decoded-frame cache of the scenario on screen: about 200 frames of 768×512, so scrubbing
/// back and forth near the cursor decodes nothing twice.
pub const CURRENT_FRAME_CACHE: usize = 256 << 20;

/// Decoded-frame cache of every other scenario of the data set: enough for the failure
/// panel's thumbnails to be drawn without decoding on every repaint, small enough that a
/// data set of hundreds of scenarios stays within a few GiB at worst.
pub const BACKGROUND_FRAME_CACHE: usize = 8 << 20;

impl AppState {
    /// The settings `render` draws with: the analyst's weights, filter and colormap and the
    /// threshold in effect.
    pub fn render_settings(&self) -> DrawSettings {
        let settings = &self.settings;
        DrawSettings {
            fusion: FusionParams {
                weights: settings.weights,
                median_kernel: settings.median_kernel,
            },
            threshold: self.threshold,
            colormap: settings.colormap,
            auto_range: false,
        }
    }

    /// The view options `vadscope render` would use for these settings (ranges from the
    /// model's training statistics when scored), with the analyst's overlays and opacity;
    /// while labeling, the analyst's boxes replace the scored ones (drawn by the UI).
    pub fn dashboard_options(&self) -> DashboardOptions {
        let settings = &self.settings;
        let mut options = match self.entry().and_then(|e| e.scores()) {
            Some(scores) => self.render_settings().options(scores.table()),
            None => DashboardOptions::default(),
        };
        let o = &settings.overlays;
        options.frame.heatmap = o.heatmap;
        options.frame.boxes = o.boxes && !self.labeling.active;
        options.frame.mask = o.mask;
        options.frame.caption = o.caption;
        options.frame.opacity = settings.opacity;
        options
    }

    pub(super) fn select_scenario(&mut self, index: usize) {
        let Some(dataset) = &self.dataset else {
            return;
        };
        let index = index.min(dataset.len().saturating_sub(1));
        let entry = dataset.scenarios.get(index);
        let frames = entry.map_or(0, |e| e.frames);
        let fps = entry
            .and_then(|e| e.scenario.as_ref())
            .map_or(10.0, |s| f64::from(s.meta().fps));
        let keep_frame = index == self.current && self.playback.len() == frames;
        // One budget for the scenario on screen, a small one for the rest: memory stays
        // bounded by the data set's size, not by how many scenarios were visited.
        for (i, entry) in dataset.scenarios.iter().enumerate() {
            if let Some(scenario) = &entry.scenario {
                scenario.set_cache_budget(if i == index {
                    CURRENT_FRAME_CACHE
                } else {
                    BACKGROUND_FRAME_CACHE
                });
            }
        }
        self.current = index;
        if !keep_frame {
            self.playback = Playback::new(frames, fps);
            self.selected_track = None;
            self.labeling.mark = None;
            self.labeling.selected_box = None;
        }
        if self.labeling.active {
            self.open_labels(index);
        }
    }

    /// Replaces the settings, re-fusing when weights, filter or threshold changed.
    pub fn set_settings(&mut self, settings: ViewSettings) {
        let refuse = settings.weights != self.settings.weights
            || settings.median_kernel != self.settings.median_kernel
            || settings.threshold_mode != self.settings.threshold_mode
            || settings.manual_threshold != self.settings.manual_threshold
            || settings.late_after != self.settings.late_after
            || settings.reference != self.settings.reference;
        let analyst = settings.reference == Reference::AnalystLabels
            && self.settings.reference != Reference::AnalystLabels;
        self.settings = settings;
        if analyst {
            self.open_all_labels();
        }
        if refuse {
            self.refuse();
        }
    }

    /// Re-fuses every scored scenario and recomputes metrics, threshold and failure cases.
    pub fn refuse(&mut self) {
        let Some(dataset) = &self.dataset else {
            self.analyses.clear();
            self.metrics = DatasetMetrics::default();
            self.failures.clear();
            return;
        };
        let params = FusionParams {
            weights: self.settings.weights,
            median_kernel: self.settings.median_kernel,
        };
        let analyst = self.settings.reference == Reference::AnalystLabels;
        let labeling = &self.labeling;
        let reference = |i: usize, e: &crate::app::dataset::ScenarioEntry| -> Vec<bool> {
            labeling
                .flags(i, e.labels.len())
                .filter(|_| analyst)
                .unwrap_or(&e.labels)
                .to_vec()
        };
        let references: Vec<Vec<bool>> = dataset
            .scenarios
            .iter()
            .enumerate()
            .map(|(i, e)| reference(i, e))
            .collect();
        self.analyses = dataset
            .scenarios
            .iter()
            .zip(&references)
            .map(|(e, labels)| {
                e.scores()
                    .map(|s| ScenarioAnalysis::fuse(s.table(), labels, &params))
            })
            .collect();
        let scored = || {
            self.analyses
                .iter()
                .zip(&references)
                .filter_map(|(a, l)| a.as_ref().map(|a| (a, l.as_slice())))
        };
        self.metrics = DatasetMetrics::compute(scored());
        let reference = reference_threshold(&self.settings.weights);
        self.threshold = match self.settings.threshold_mode {
            ThresholdMode::Reference => reference,
            ThresholdMode::F1Max => self
                .metrics
                .micro
                .map(|m| m.f1_threshold)
                .filter(|t| t.is_finite())
                .unwrap_or(reference),
            ThresholdMode::Manual => self.settings.manual_threshold,
        };
        let mut failures = Vec::new();
        for (i, (analysis, labels)) in self.analyses.iter_mut().zip(&references).enumerate() {
            if let Some(analysis) = analysis {
                analysis.detect(labels, self.threshold);
                failures.extend(scenario_failures(
                    i,
                    analysis,
                    labels,
                    self.threshold,
                    self.settings.late_after,
                ));
            }
        }
        self.metrics.detect(self.analyses.iter().flatten());
        rank(&mut failures);
        let previous = self
            .failure_cursor
            .and_then(|c| self.failures.get(c))
            .map(|c| (c.scenario, c.tag_key()));
        self.failure_cursor = previous.and_then(|(s, key)| {
            failures
                .iter()
                .position(|c| c.scenario == s && c.tag_key() == key)
        });
        self.failures = failures;
    }
}
