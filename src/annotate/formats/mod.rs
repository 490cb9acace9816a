//! Import and export of labels in the formats analysts exchange:
//!
//! | [`LabelFormat`] | file | carries |
//! |---|---|---|
//! | `frame-labels` | `frame_labels.csv` (`frame,anomaly`, AnoVox ids) | per-frame anomaly flags |
//! | `boxes-csv` | `BBOX_2D/boxes.csv` layout | boxes per frame with track, class, anomalous |
//! | `mot` | MOTChallenge `gt.txt` (frame = index + 1) | boxes with track and class |
//! | `coco` | COCO dataset JSON (`images`, `annotations` with `track_id`) | boxes with track and class |
//! | `yolo` | a folder of `<RGB stem>.txt`, `class cx cy w h conf track_id` | boxes with track and class |
//! | `intervals-csv` | `kind,id,start_index,end_index,start_frame,end_frame,label,note,origin` | intervals, tags and notes |
//!
//! Exports write every visible (interpolated) box of every frame, and files atomically.
//! An import is one [`Edit`] (undoable, journaled) that replaces the kinds of label the
//! format carries; the box formats are read with `sequence::detections`' parsers.

mod boxes;
mod tables;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::sequence::Scenario;

use super::AnnotateError;
use super::edit::Edit;
use super::labels::LabelSet;

/// A label file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LabelFormat {
    /// `frame_labels.csv`: per-frame anomaly flags by AnoVox frame id.
    FrameLabels,
    /// `BBOX_2D/boxes.csv`: our box layout.
    BoxesCsv,
    /// MOTChallenge `gt.txt`.
    Mot,
    /// COCO dataset JSON.
    Coco,
    /// YOLO text files with track ids, one per frame, in a folder.
    Yolo,
    /// CSV of intervals, failure tags and notes.
    IntervalsCsv,
}

impl LabelFormat {
    /// Every format.
    pub const ALL: [LabelFormat; 6] = [
        LabelFormat::FrameLabels,
        LabelFormat::BoxesCsv,
        LabelFormat::Mot,
        LabelFormat::Coco,
        LabelFormat::Yolo,
        LabelFormat::IntervalsCsv,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LabelFormat::FrameLabels => "frame-labels",
            LabelFormat::BoxesCsv => "boxes-csv",
            LabelFormat::Mot => "mot",
            LabelFormat::Coco => "coco",
            LabelFormat::Yolo => "yolo",
            LabelFormat::IntervalsCsv => "intervals-csv",
        }
    }

    /// The file (a folder for YOLO) an export of this format is written to when only a
    /// destination folder is given, as `vadscope export --labels` does.
    pub fn default_file_name(self) -> &'static str {
        match self {
            LabelFormat::FrameLabels => "frame_labels.csv",
            LabelFormat::BoxesCsv => "boxes.csv",
            LabelFormat::Mot => "gt.txt",
            LabelFormat::Coco => "coco.json",
            LabelFormat::Yolo => "yolo",
            LabelFormat::IntervalsCsv => "intervals.csv",
        }
    }

    /// The format named `name` (see [`LabelFormat::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }
}

impl std::fmt::Display for LabelFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What an export wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExportSummary {
    /// Files written.
    pub files: usize,
    /// Rows (boxes, frames, intervals, ...) written.
    pub records: usize,
}

/// An import, ready to apply.
#[derive(Debug, Clone, PartialEq)]
pub struct Import {
    /// The edit that replaces the labels the format carries.
    pub edit: Edit,
    /// Rows read.
    pub records: usize,
    /// Rows whose frame is not in the scenario (skipped).
    pub unmatched: usize,
}

/// Writes `labels` of `scenario` to `path` in `format` (a folder for YOLO).
pub fn export_labels(
    scenario: &Scenario,
    labels: &LabelSet,
    format: LabelFormat,
    path: &Path,
) -> Result<ExportSummary, AnnotateError> {
    match format {
        LabelFormat::FrameLabels => tables::export_frame_labels(labels, path),
        LabelFormat::IntervalsCsv => tables::export_intervals(labels, path),
        LabelFormat::BoxesCsv => boxes::export_boxes_csv(labels, path),
        LabelFormat::Mot => boxes::export_mot(labels, path),
        LabelFormat::Coco => boxes::export_coco(scenario, labels, path),
        LabelFormat::Yolo => boxes::export_yolo(scenario, labels, path),
    }
}

/// Reads `path` in `format` for `scenario` and returns the edit that puts its content in
/// place of the current `labels` of the kinds the format carries.
pub fn import_labels(
    scenario: &Scenario,
    labels: &LabelSet,
    format: LabelFormat,
    path: &Path,
) -> Result<Import, AnnotateError> {
    match format {
        LabelFormat::FrameLabels => tables::import_frame_labels(scenario, labels, path),
        LabelFormat::IntervalsCsv => tables::import_intervals(scenario, labels, path),
        LabelFormat::BoxesCsv | LabelFormat::Mot | LabelFormat::Coco | LabelFormat::Yolo => {
            boxes::import_boxes(scenario, labels, format, path)
        }
    }
}
