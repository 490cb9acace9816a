//! `vadscope inspect`: a [`ScenarioSummary`] (frames, size, modalities, anomaly windows,
//! boxes per frame, conditions, label source) and the [`ValidationReport`] of every
//! scenario under a path, as text or JSON.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;

use super::discovery::{LayoutKind, discover_scenarios};
use super::index::FrameRun;
use super::labels::{LabelSource, join_runs};
use super::problem::FileProblem;
use super::scenario::{BoxSource, Scenario};
use super::validate::ValidationReport;
use super::{AnomalyType, Domain, FrameId, Modality, SequenceError, Weather};

/// Boxes per frame over a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BoxStats {
    /// Fewest boxes in a frame.
    pub min: usize,
    /// Mean boxes per frame.
    pub mean: f64,
    /// Most boxes in a frame.
    pub max: usize,
    /// Total boxes.
    pub total: usize,
}

/// Scenario conditions from the metadata.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Conditions {
    /// City or highway.
    pub domain: Domain,
    /// Weather.
    pub weather: Weather,
    /// Time of day.
    pub time_of_day: Option<String>,
    /// Town / map.
    pub town: Option<String>,
    /// Kind of event.
    pub anomaly_type: Option<AnomalyType>,
    /// Frames per second.
    pub fps: f32,
}

/// What `vadscope inspect` shows about one scenario.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScenarioSummary {
    /// Scenario name.
    pub name: String,
    /// Scenario folder.
    pub path: PathBuf,
    /// Benchmark or generator layout.
    pub layout: LayoutKind,
    /// Number of frames.
    pub frames: usize,
    /// First and last frame id.
    pub frame_ids: (FrameId, FrameId),
    /// Frame size.
    pub resolution: (u32, u32),
    /// Modalities with at least one file, with their file counts.
    pub modalities: Vec<(Modality, usize)>,
    /// Runs of anomalous frames.
    pub anomaly_windows: Vec<FrameRun>,
    /// Number of anomalous frames.
    pub anomalous_frames: usize,
    /// Where the anomaly flags came from.
    pub label_source: LabelSource,
    /// Where the boxes came from.
    pub box_source: BoxSource,
    /// Boxes per frame (`None` without boxes).
    pub boxes_per_frame: Option<BoxStats>,
    /// Conditions from the metadata.
    pub conditions: Conditions,
    /// Files that could not be used for labels or boxes.
    pub problems: Vec<FileProblem>,
}

impl ScenarioSummary {
    /// Summarises an opened scenario. Derives labels and boxes, which decodes semantic or
    /// instance images when no label or box file exists.
    pub fn of(scenario: &Scenario) -> Self {
        let labels = scenario.frame_labels();
        let index = scenario.frame_index();
        let mut problems = labels.problems.clone();
        let box_source = scenario.box_source().clone();
        let boxes_per_frame = if box_source == BoxSource::None {
            None
        } else {
            let counts: Vec<Result<usize, SequenceError>> = (0..scenario.len())
                .into_par_iter()
                .map(|i| scenario.boxes(i).map(|b| b.len()))
                .collect();
            let mut readable = Vec::with_capacity(counts.len());
            for count in counts {
                match count {
                    Ok(n) => readable.push(n),
                    Err(error) => {
                        let problem = FileProblem::from_error(&error);
                        if !problems.contains(&problem) {
                            problems.push(problem);
                        }
                    }
                }
            }
            box_stats(&readable)
        };
        let meta = scenario.meta();
        Self {
            name: scenario.name().to_string(),
            path: scenario.root().to_path_buf(),
            layout: scenario.layout(),
            frames: scenario.len(),
            frame_ids: (
                index.frame_id(0).unwrap_or(FrameId(0)),
                index
                    .frame_id(scenario.len().saturating_sub(1))
                    .unwrap_or(FrameId(0)),
            ),
            resolution: scenario.resolution(),
            modalities: scenario
                .files()
                .frames
                .iter()
                .map(|(m, files)| (*m, files.len()))
                .collect(),
            anomaly_windows: index.runs(|i| labels.is_anomalous(i)),
            anomalous_frames: labels.anomalous_count(),
            label_source: labels.source,
            box_source,
            boxes_per_frame,
            conditions: Conditions {
                domain: meta.domain,
                weather: meta.weather,
                time_of_day: meta.time_of_day.clone(),
                town: meta.town.clone(),
                anomaly_type: meta.anomaly_type,
                fps: meta.fps,
            },
            problems,
        }
    }

    /// A human-readable summary.
    pub fn render_text(&self) -> String {
        let mut text = String::new();
        let (first, last) = self.frame_ids;
        let _ = writeln!(text, "{}  ({})", self.name, self.path.display());
        let _ = writeln!(
            text,
            "  frames      {} (ids {first}-{last}), {}x{}, {:?} layout",
            self.frames, self.resolution.0, self.resolution.1, self.layout
        );
        let modalities: Vec<String> = self
            .modalities
            .iter()
            .map(|(m, n)| format!("{} {n}", m.folder()))
            .collect();
        let _ = writeln!(text, "  modalities  {}", modalities.join(", "));
        let c = &self.conditions;
        let _ = writeln!(
            text,
            "  conditions  domain {:?}, weather {:?}, time {}, town {}, event {}, {} fps",
            c.domain,
            c.weather,
            c.time_of_day.as_deref().unwrap_or("unknown"),
            c.town.as_deref().unwrap_or("unknown"),
            c.anomaly_type
                .map_or_else(|| "unknown".to_string(), |t| format!("{t:?}")),
            c.fps
        );
        let windows = if self.anomaly_windows.is_empty() {
            "none".to_string()
        } else {
            join_runs(&self.anomaly_windows)
        };
        let _ = writeln!(
            text,
            "  anomaly     {} frames: {windows}  [labels from {}]",
            self.anomalous_frames, self.label_source
        );
        match &self.boxes_per_frame {
            Some(stats) => {
                let _ = writeln!(
                    text,
                    "  boxes       {} total, per frame min {} / mean {:.2} / max {}  [{}]",
                    stats.total, stats.min, stats.mean, stats.max, self.box_source
                );
            }
            None => {
                let _ = writeln!(text, "  boxes       none");
            }
        }
        for problem in &self.problems {
            let _ = writeln!(text, "  problem: {problem}");
        }
        text
    }
}

impl std::fmt::Display for ScenarioSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render_text())
    }
}

fn box_stats(counts: &[usize]) -> Option<BoxStats> {
    let min = *counts.iter().min()?;
    let max = *counts.iter().max()?;
    let total: usize = counts.iter().sum();
    Some(BoxStats {
        min,
        mean: total as f64 / counts.len() as f64,
        max,
        total,
    })
}

/// One scenario in an [`InspectReport`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScenarioInspection {
    /// Summary.
    pub summary: ScenarioSummary,
    /// Validation.
    pub validation: ValidationReport,
}

/// What `vadscope inspect PATH` reports: every scenario under `PATH` (or `PATH` itself).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InspectReport {
    /// The inspected path.
    pub path: PathBuf,
    /// Scenarios that opened.
    pub scenarios: Vec<ScenarioInspection>,
    /// Scenario folders that could not be opened, with the reason.
    pub failed: Vec<FileProblem>,
}

impl InspectReport {
    /// A human-readable report of every scenario.
    pub fn render_text(&self) -> String {
        let mut text = String::new();
        let _ = writeln!(
            text,
            "{}: {} scenario(s){}",
            self.path.display(),
            self.scenarios.len(),
            if self.failed.is_empty() {
                String::new()
            } else {
                format!(", {} could not be opened", self.failed.len())
            }
        );
        for inspection in &self.scenarios {
            text.push('\n');
            text.push_str(&inspection.summary.render_text());
            text.push_str(&inspection.validation.render_text());
        }
        for failure in &self.failed {
            let _ = writeln!(text, "\ncannot open {failure}");
        }
        text
    }

    /// The report as pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }
}

impl std::fmt::Display for InspectReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render_text())
    }
}

/// Inspects a dataset root (every `Scenario_*` folder) or a single scenario folder.
/// Scenarios that cannot be opened are listed in `failed`; an error only when `path` holds
/// no scenario at all.
pub fn inspect(path: &Path) -> Result<InspectReport, SequenceError> {
    let mut report = InspectReport {
        path: path.to_path_buf(),
        scenarios: Vec::new(),
        failed: Vec::new(),
    };
    for folder in discover_scenarios(path)? {
        let opened = Scenario::open(&folder).and_then(|scenario| {
            let validation = scenario.validate()?;
            Ok(ScenarioInspection {
                summary: ScenarioSummary::of(&scenario),
                validation,
            })
        });
        match opened {
            Ok(inspection) => report.scenarios.push(inspection),
            Err(error) => report.failed.push(FileProblem::from_error(&error)),
        }
    }
    Ok(report)
}
