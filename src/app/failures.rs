//! Failure cases at the current threshold: false alarms (maximal runs of frames at or above
//! the threshold outside every anomaly), missed anomalies (events no frame of which reaches
//! it) and late detections (events first reached more than a given number of frames after
//! their onset), ranked worst first; the analyst's tags on them and their CSV export.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::eval::runs_above;
use crate::sequence::FrameId;

use super::analysis::ScenarioAnalysis;
use super::error::AppError;

/// The three kinds of failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FailureKind {
    /// Frames above the threshold outside every anomaly.
    FalseAlarm,
    /// An anomaly no frame of which reaches the threshold.
    Missed,
    /// An anomaly reached only late.
    Late,
}

impl FailureKind {
    /// The kinds in the panel's order.
    pub const ALL: [Self; 3] = [Self::FalseAlarm, Self::Missed, Self::Late];

    /// A name for the panel and the CSV.
    pub fn name(self) -> &'static str {
        match self {
            Self::FalseAlarm => "false alarm",
            Self::Missed => "missed anomaly",
            Self::Late => "late detection",
        }
    }
}

/// One failure case in one scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct FailureCase {
    /// Index of the scenario in the data set.
    pub scenario: usize,
    /// What went wrong.
    pub kind: FailureKind,
    /// First frame index of the run or event.
    pub start: usize,
    /// Last frame index (inclusive).
    pub end: usize,
    /// The frame to look at: the (first) peak of a false alarm, the onset of a missed anomaly, the
    /// first detected frame of a late one.
    pub focus: usize,
    /// The filtered score at `focus`.
    pub score: f64,
    /// Frames from the onset to the first detection (late detections).
    pub latency: Option<usize>,
}

impl FailureCase {
    /// How bad the case is (larger = worse) for ranking within its kind: the peak score
    /// of a false alarm, the length of a missed event, the latency of a late one.
    pub fn severity(&self) -> f64 {
        match self.kind {
            FailureKind::FalseAlarm => self.score,
            FailureKind::Missed => (self.end - self.start + 1) as f64,
            FailureKind::Late => self.latency.unwrap_or(0) as f64,
        }
    }

    /// The key its tag is stored under.
    pub fn tag_key(&self) -> TagKey {
        TagKey {
            kind: self.kind,
            start: self.start,
            end: self.end,
        }
    }
}

/// The failure cases of one scenario's analysis at `threshold` (the analysis's outcomes
/// must have been computed at the same threshold); detections more than `late_after`
/// frames after the onset count as late.
pub fn scenario_failures(
    scenario: usize,
    analysis: &ScenarioAnalysis,
    labels: &[bool],
    threshold: f64,
    late_after: usize,
) -> Vec<FailureCase> {
    let n = analysis.series.filtered.len().min(labels.len());
    let scores = &analysis.series.filtered[..n];
    let mut out: Vec<FailureCase> =
        runs_above((0..n).map(|i| scores[i] >= threshold && !labels[i]))
            .into_iter()
            .map(|run| {
                let focus = (run.start..=run.end)
                    .max_by(|&a, &b| scores[a].total_cmp(&scores[b]).then(b.cmp(&a)))
                    .unwrap_or(run.start);
                FailureCase {
                    scenario,
                    kind: FailureKind::FalseAlarm,
                    start: run.start,
                    end: run.end,
                    focus,
                    score: scores[focus],
                    latency: None,
                }
            })
            .collect();
    for outcome in &analysis.outcomes {
        let event = outcome.event;
        let (kind, focus) = match outcome.latency_frames {
            None => (FailureKind::Missed, event.start),
            Some(l) if l > late_after => (FailureKind::Late, event.start + l),
            Some(_) => continue,
        };
        out.push(FailureCase {
            scenario,
            kind,
            start: event.start,
            end: event.end,
            focus,
            score: scores.get(focus).copied().unwrap_or(f64::NAN),
            latency: outcome.latency_frames,
        });
    }
    out
}

/// Sorts cases by kind (panel order), then worst first, then by scenario and frame.
pub fn rank(cases: &mut [FailureCase]) {
    cases.sort_by(|a, b| {
        a.kind
            .cmp(&b.kind)
            .then(b.severity().total_cmp(&a.severity()))
            .then(a.scenario.cmp(&b.scenario))
            .then(a.start.cmp(&b.start))
    });
}

/// Identifies a failure case within its scenario for tagging.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct TagKey {
    /// What went wrong.
    pub kind: FailureKind,
    /// First frame index.
    pub start: usize,
    /// Last frame index (inclusive).
    pub end: usize,
}

/// The analyst's tags of one scenario's failure cases, saved as JSON in the scenario's
/// `.vadscope/` folder after every change (written to a temporary file, then renamed).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FailureTags {
    tags: BTreeMap<TagKey, String>,
}

#[derive(Serialize, Deserialize)]
struct TagRecord {
    #[serde(flatten)]
    key: TagKey,
    tag: String,
}

/// File name of the tags inside a scenario's `.vadscope/` folder.
pub const TAGS_FILE: &str = "failure_tags.json";

impl FailureTags {
    /// The tag of `key`.
    pub fn get(&self, key: &TagKey) -> Option<&str> {
        self.tags.get(key).map(String::as_str)
    }

    /// Sets (or, with an empty text, removes) the tag of `key`.
    pub fn set(&mut self, key: TagKey, tag: &str) {
        let tag = tag.trim();
        if tag.is_empty() {
            self.tags.remove(&key);
        } else {
            self.tags.insert(key, tag.to_string());
        }
    }

    /// Reads the tags at `path`; no file means no tags.
    pub fn load(path: &Path) -> Result<Self, AppError> {
        let text = match std::fs::read_to_string(path) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Self::default()),
            Err(e) => return Err(AppError::io(path, e)),
        };
        let records: Vec<TagRecord> = serde_json::from_str(&text).map_err(|e| AppError::File {
            path: path.to_path_buf(),
            problem: format!("not a failure-tag list: {e}"),
        })?;
        Ok(Self {
            tags: records.into_iter().map(|r| (r.key, r.tag)).collect(),
        })
    }

    /// Writes the tags to `path` atomically.
    pub fn save(&self, path: &Path) -> Result<(), AppError> {
        let records: Vec<TagRecord> = self
            .tags
            .iter()
            .map(|(key, tag)| TagRecord {
                key: *key,
                tag: tag.clone(),
            })
            .collect();
        let text = serde_json::to_string_pretty(&records).map_err(|e| AppError::File {
            path: path.to_path_buf(),
            problem: e.to_string(),
        })?;
        write_atomically(path, text.as_bytes())
    }
}

/// Writes `bytes` to `path` atomically ([`crate::atomic_file`]), creating its folder
/// first: the viewer's files live in folders that may not exist yet.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), AppError> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| AppError::io(dir, e))?;
    }
    Ok(crate::atomic_file::write_atomically(path, bytes)?)
}

/// One row of the failure-case CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct FailureRow<'a> {
    /// The case.
    pub case: &'a FailureCase,
    /// Its scenario's name.
    pub scenario: &'a str,
    /// AnoVox ids of its first, focus and last frames.
    pub ids: [Option<FrameId>; 3],
    /// Its tag.
    pub tag: Option<&'a str>,
}

/// Header of the failure-case CSV.
pub const FAILURE_CSV_HEADER: &str = "scenario,kind,start_frame,end_frame,focus_frame,start_id,focus_id,end_id,score,latency_frames,tag";

/// The failure-case CSV: a header and one row per case, in the given order.
pub fn failures_csv<'a>(rows: impl IntoIterator<Item = FailureRow<'a>>) -> String {
    let mut out = String::from(FAILURE_CSV_HEADER);
    out.push('\n');
    let id = |id: Option<FrameId>| id.map_or_else(String::new, |i| i.0.to_string());
    for row in rows {
        let c = row.case;
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{:.6},{},{}",
            csv_field(row.scenario),
            c.kind.name(),
            c.start,
            c.end,
            c.focus,
            id(row.ids[0]),
            id(row.ids[1]),
            id(row.ids[2]),
            c.score,
            c.latency.map_or_else(String::new, |l| l.to_string()),
            csv_field(row.tag.unwrap_or("")),
        );
    }
    out
}

/// A CSV field, quoted when it holds a comma, quote or line break.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}
