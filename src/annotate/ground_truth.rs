//! The starting point of a scenario's labels: its ground truth (per-frame anomaly flags as
//! intervals, ground-truth boxes as keyframed tracks), read through `sequence` and never
//! written back.

use crate::sequence::{BoxRecord, Scenario};

use super::AnnotateError;
use super::labels::{Interval, IntervalId, LabelSet, Origin};
use super::tracks::tracks_from_boxes;

/// The class given to intervals when the scenario names no anomaly type.
pub const DEFAULT_CLASS: &str = "anomaly";

/// The anomaly class of a scenario: its AnoVox anomaly type (e.g.
/// `SUDDEN_BREAKING_OF_VEHICLE_AHEAD`), else [`DEFAULT_CLASS`].
pub fn scenario_class(scenario: &Scenario) -> String {
    scenario
        .meta()
        .anomaly_type
        .and_then(|t| serde_json::to_value(t).ok())
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| DEFAULT_CLASS.to_string())
}

/// Intervals of consecutive anomalous frames (ids 1, 2, ... in frame order).
pub fn intervals_from_flags(flags: &[bool], class: &str, origin: Origin) -> Vec<Interval> {
    let mut intervals = Vec::new();
    let mut start = None;
    for (i, &flag) in flags.iter().chain(std::iter::once(&false)).enumerate() {
        match (start, flag) {
            (None, true) => start = Some(i),
            (Some(s), false) => {
                intervals.push(Interval {
                    id: IntervalId(intervals.len() as u64 + 1),
                    start: s,
                    end: i - 1,
                    class: class.to_string(),
                    note: String::new(),
                    origin,
                });
                start = None;
            }
            _ => {}
        }
    }
    intervals
}

/// The ground truth of `scenario` as labels, with the problems met while reading it (a
/// ground-truth file that cannot be read leaves that part empty; the scenario's own
/// label notes are listed too).
pub fn ground_truth_labels(scenario: &Scenario) -> (LabelSet, Vec<AnnotateError>) {
    let mut labels = LabelSet::new(scenario.frame_index().ids().to_vec());
    let mut problems = Vec::new();
    let frame_labels = scenario.frame_labels();
    for problem in &frame_labels.problems {
        problems.push(AnnotateError::file(&problem.path, problem.problem.clone()));
    }
    let class = scenario_class(scenario);
    for interval in intervals_from_flags(&frame_labels.flags, &class, Origin::GroundTruth) {
        labels.intervals.insert(interval.id, interval);
    }
    let mut boxes: Vec<(usize, BoxRecord)> = Vec::new();
    for index in 0..scenario.len() {
        match scenario.boxes(index) {
            Ok(frame_boxes) => boxes.extend(frame_boxes.into_iter().map(|b| (index, b))),
            Err(error) => {
                problems.push(error.into());
                break;
            }
        }
    }
    for track in tracks_from_boxes(boxes, scenario.len(), Origin::GroundTruth) {
        labels.tracks.insert(track.id, track);
    }
    (labels, problems)
}
