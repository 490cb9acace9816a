//! Per-frame anomaly flags: the explicit `frame_labels.csv` (`frame,anomaly`, 0/1), and
//! their derivation when that file is missing (anovox-format.md B.9 rule 3).

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;

use super::csv_table::CsvTable;
use super::discovery::ScenarioFiles;
use super::images::read_semantic;
use super::index::{FrameIndex, FrameRun};
use super::keyvalue::read_key_values;
use super::layout::FRAME_LABELS_FILE;
use super::problem::FileProblem;
use super::{AnomalyType, FrameId, Modality, ScenarioMeta, SequenceError, palette};

/// The header of `frame_labels.csv`.
pub const FRAME_LABELS_HEADER: &str = "frame,anomaly";

/// Formats `frame_labels.csv` text, sorted by frame id.
pub fn format_frame_labels(labels: &[(FrameId, bool)]) -> String {
    let mut sorted = labels.to_vec();
    sorted.sort_by_key(|(frame, _)| *frame);
    let mut text = String::from(FRAME_LABELS_HEADER);
    text.push('\n');
    for (frame, anomalous) in sorted {
        text.push_str(&format!("{},{}\n", frame.0, u8::from(anomalous)));
    }
    text
}

/// Writes `frame_labels.csv`.
pub fn write_frame_labels(path: &Path, labels: &[(FrameId, bool)]) -> Result<(), SequenceError> {
    std::fs::write(path, format_frame_labels(labels)).map_err(|e| SequenceError::io(path, e))
}

/// Parses `frame_labels.csv` text. Columns are found by name, so the `frame,tick,anomaly`
/// variant is read as well. A frame listed twice is an error.
pub fn parse_frame_labels(path: &Path, text: &str) -> Result<Vec<(FrameId, bool)>, SequenceError> {
    table_to_labels(&CsvTable::parse(path, text, &["frame", "anomaly"])?)
}

/// Reads `frame_labels.csv`.
pub fn read_frame_labels(path: &Path) -> Result<Vec<(FrameId, bool)>, SequenceError> {
    table_to_labels(&CsvTable::read(path, &["frame", "anomaly"])?)
}

fn table_to_labels(table: &CsvTable) -> Result<Vec<(FrameId, bool)>, SequenceError> {
    let frame = table.column("frame").unwrap_or(usize::MAX);
    let anomaly = table.column("anomaly").unwrap_or(usize::MAX);
    let mut labels = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for row in table.rows() {
        let id = FrameId(row.parse(frame, "frame")?);
        if !seen.insert(id) {
            return Err(row.error(format!("frame {id} is listed twice")));
        }
        labels.push((id, row.flag(anomaly, "anomaly")?));
    }
    Ok(labels)
}

/// Where the per-frame anomaly flags of a scenario came from, in order of preference.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum LabelSource {
    /// `frame_labels.csv`.
    FrameLabelsFile,
    /// A semantic image contains an anomaly id (100, 29–34) or colour.
    SemanticImages,
    /// The anomaly window of the scenario metadata (`scenario.json`, or AnoVox's
    /// sudden-braking ticks: sorted indices 124–154 of a 200-frame scenario).
    ScenarioWindow,
    /// The ANOMALY CSV's `brake` ≥ 0.99 (the lead vehicle's emergency brake).
    AnomalyBrake,
    /// No source: every frame counts as normal.
    None,
}

impl std::fmt::Display for LabelSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LabelSource::FrameLabelsFile => "frame_labels.csv",
            LabelSource::SemanticImages => "semantic images (anomaly pixels)",
            LabelSource::ScenarioWindow => "scenario anomaly window",
            LabelSource::AnomalyBrake => "ANOMALY csv brake >= 0.99",
            LabelSource::None => "none (all normal)",
        })
    }
}

/// AnoVox's sudden-braking window in recorded-frame terms: sorted indices 124–154 of a
/// complete 200-frame scenario (ticks 140–170, tick = index + 16).
pub const SUDDEN_BRAKING_INDICES: std::ops::RangeInclusive<usize> = 124..=154;
/// Frames of a complete AnoVox scenario.
pub const ANOVOX_FRAMES: usize = 200;
/// A lead-vehicle brake at or above this counts as the emergency brake.
pub const EMERGENCY_BRAKE: f64 = 0.99;

/// The per-frame anomaly flags of a scenario, by frame index.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrameLabels {
    /// `flags[i]` is true when frame index `i` is anomalous.
    pub flags: Vec<bool>,
    /// Where the flags came from.
    pub source: LabelSource,
    /// Files that could not be used while deriving (not fatal).
    pub problems: Vec<FileProblem>,
}

impl FrameLabels {
    /// Whether frame `index` is anomalous (false outside the scenario).
    pub fn is_anomalous(&self, index: usize) -> bool {
        self.flags.get(index).copied().unwrap_or(false)
    }

    /// Number of anomalous frames.
    pub fn anomalous_count(&self) -> usize {
        self.flags.iter().filter(|&&f| f).count()
    }
}

/// What label derivation reads of an opened scenario: its folder, files, frame index and
/// metadata. A view rather than the scenario itself, so that this file sits below
/// `scenario.rs` (which caches the derived labels) instead of importing it back.
#[derive(Debug, Clone, Copy)]
pub struct LabelInputs<'a> {
    /// The scenario folder.
    pub root: &'a Path,
    /// Every per-frame file, by modality.
    pub files: &'a ScenarioFiles,
    /// The frame index (sorted ids).
    pub index: &'a FrameIndex,
    /// The scenario's metadata.
    pub meta: &'a ScenarioMeta,
}

impl LabelInputs<'_> {
    fn len(&self) -> usize {
        self.index.len()
    }

    fn has(&self, modality: Modality) -> bool {
        self.files.of(modality).is_some_and(|f| !f.is_empty())
    }

    fn file(&self, modality: Modality, index: usize) -> Option<&Path> {
        self.files.file(modality, self.index.frame_id(index)?)
    }
}

/// Derives the flags of `scenario`, in order of preference:
/// 1. `frame_labels.csv` (frames without a row count as normal and are noted);
/// 2. the semantic images: a frame is anomalous when any pixel has an anomaly id (100,
///    29–34) or colour ((245, 0, 0), (245, k, 0));
/// 3. the scenario window: `scenario.json`'s `anomaly_window`, or for AnoVox
///    `SUDDEN_BREAKING_OF_VEHICLE_AHEAD` scenarios of exactly 200 frames the sorted indices
///    124–154;
/// 4. the ANOMALY csv: `brake` ≥ 0.99;
/// 5. otherwise every frame is normal.
///
/// A source that cannot be read at all (e.g. a malformed `frame_labels.csv`) is noted and
/// the next one is tried; single unreadable files count as normal frames and are noted.
pub fn derive_frame_labels(scenario: &LabelInputs<'_>) -> FrameLabels {
    let mut problems = Vec::new();
    let file = scenario.root.join(FRAME_LABELS_FILE);
    if file.is_file() {
        match read_frame_labels(&file) {
            Ok(rows) => return labels_from_rows(scenario, &file, &rows, problems),
            Err(error) => problems.push(FileProblem::from_error(&error)),
        }
    }
    if scenario.has(Modality::Semantic) {
        let (flags, mut unreadable) = flags_from_files(scenario, Modality::Semantic, |path| {
            let semantic = read_semantic(path)?;
            Ok(semantic
                .ids
                .as_raw()
                .iter()
                .any(|&id| palette::is_anomaly_id(id)))
        });
        problems.append(&mut unreadable);
        return FrameLabels {
            flags,
            source: LabelSource::SemanticImages,
            problems,
        };
    }
    if let Some(flags) = flags_from_window(scenario) {
        return FrameLabels {
            flags,
            source: LabelSource::ScenarioWindow,
            problems,
        };
    }
    if scenario.has(Modality::Anomaly) {
        let (flags, mut unreadable) = flags_from_files(scenario, Modality::Anomaly, |path| {
            Ok(read_key_values(path)?
                .brake()
                .is_some_and(|b| b >= EMERGENCY_BRAKE))
        });
        problems.append(&mut unreadable);
        return FrameLabels {
            flags,
            source: LabelSource::AnomalyBrake,
            problems,
        };
    }
    FrameLabels {
        flags: vec![false; scenario.len()],
        source: LabelSource::None,
        problems,
    }
}

fn labels_from_rows(
    scenario: &LabelInputs<'_>,
    file: &Path,
    rows: &[(FrameId, bool)],
    mut problems: Vec<FileProblem>,
) -> FrameLabels {
    let mut flags = vec![false; scenario.len()];
    let mut covered = vec![false; scenario.len()];
    let mut unknown = Vec::new();
    for &(id, anomalous) in rows {
        match scenario.index.index_of(id) {
            Some(index) => {
                flags[index] = anomalous;
                covered[index] = true;
            }
            None => unknown.push(id.to_string()),
        }
    }
    if !unknown.is_empty() {
        problems.push(FileProblem::new(
            file,
            format!("rows for frames that do not exist: {}", unknown.join(", ")),
        ));
    }
    let uncovered = scenario.index.runs(|i| !covered[i]);
    if !uncovered.is_empty() {
        problems.push(FileProblem::new(
            file,
            format!(
                "no row for frames {} (taken as normal)",
                join_runs(&uncovered)
            ),
        ));
    }
    FrameLabels {
        flags,
        source: LabelSource::FrameLabelsFile,
        problems,
    }
}

/// Decides each frame that has a `modality` file, in parallel; unreadable files are noted.
fn flags_from_files(
    scenario: &LabelInputs<'_>,
    modality: Modality,
    decide: impl Fn(&Path) -> Result<bool, SequenceError> + Sync,
) -> (Vec<bool>, Vec<FileProblem>) {
    let results: Vec<Result<bool, SequenceError>> = (0..scenario.len())
        .into_par_iter()
        .map(|index| scenario.file(modality, index).map_or(Ok(false), &decide))
        .collect();
    let mut problems = Vec::new();
    let flags = results
        .into_iter()
        .map(|result| {
            result.unwrap_or_else(|error| {
                problems.push(FileProblem::from_error(&error));
                false
            })
        })
        .collect();
    let without_file = scenario
        .index
        .runs(|i| scenario.file(modality, i).is_none());
    if !without_file.is_empty() {
        let folder = scenario.files.folders.get(&modality);
        problems.push(FileProblem::new(
            folder.map_or(scenario.root, PathBuf::as_path),
            format!(
                "no {} file for frames {} (taken as normal)",
                modality.folder(),
                join_runs(&without_file)
            ),
        ));
    }
    (flags, problems)
}

fn flags_from_window(scenario: &LabelInputs<'_>) -> Option<Vec<bool>> {
    let meta = scenario.meta;
    if let Some(window) = meta.anomaly_window {
        let ids = scenario.index.ids();
        return Some(
            ids.iter()
                .map(|id| (window.start..=window.end).contains(id))
                .collect(),
        );
    }
    if meta.anomaly_type == Some(AnomalyType::SuddenBraking) && scenario.len() == ANOVOX_FRAMES {
        return Some(
            (0..scenario.len())
                .map(|i| SUDDEN_BRAKING_INDICES.contains(&i))
                .collect(),
        );
    }
    None
}

/// Runs as text, e.g. `#0-#3 (ids 16-19, 4 frames), #9 (id 25)`.
pub fn join_runs(runs: &[FrameRun]) -> String {
    runs.iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_sorted_and_tick_variant_read() {
        let labels = vec![(FrameId(5), true), (FrameId(2), false)];
        let text = format_frame_labels(&labels);
        assert_eq!(text, "frame,anomaly\n2,0\n5,1\n");
        let back = parse_frame_labels(Path::new("l.csv"), &text).expect("valid");
        assert_eq!(back, vec![(FrameId(2), false), (FrameId(5), true)]);
        let variant = "frame,tick,anomaly\n7,23,1\n";
        let back = parse_frame_labels(Path::new("l.csv"), variant).expect("valid");
        assert_eq!(back, vec![(FrameId(7), true)]);
    }

    #[test]
    fn bad_rows_are_errors_with_file_and_line() {
        for (bad, needle) in [
            ("frame,anomaly\n1,2\n", "l.csv:2"),
            ("frame,anomaly\n1,1\n1,0\n", "listed twice"),
            ("frame,anomaly\n-1,1\n", "column 'frame'"),
            ("frame\n1\n", "anomaly"),
        ] {
            let message = parse_frame_labels(Path::new("l.csv"), bad)
                .expect_err(bad)
                .to_string();
            assert!(
                message.contains("l.csv") && message.contains(needle),
                "{message}"
            );
        }
    }
}
