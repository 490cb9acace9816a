//! Per-frame anomaly flags: the explicit `frame_labels.csv` (`frame,anomaly`, 0/1) and the
//! names of the sources a flag can be derived from when that file is missing.

use std::path::Path;

use serde::Serialize;

use super::csv_table::CsvTable;
use super::{FrameId, SequenceError};

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
