//! Frame runs: anomaly events in the ground truth, runs of frames above a threshold, and
//! whether (and how late) each event was detected.

use serde::Serialize;

/// A contiguous run of anomalous frames, as frame indices `start..=end`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct AnomalyEvent {
    /// First frame index of the run.
    pub start: usize,
    /// Last frame index of the run (inclusive).
    pub end: usize,
}

/// How one anomaly event fared at a threshold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct DetectionOutcome {
    /// The event.
    pub event: AnomalyEvent,
    /// Frames from the event's onset to the first frame inside it scored at or above the
    /// threshold; `None` when no frame of the event reaches it (a missed anomaly).
    pub latency_frames: Option<usize>,
}

/// The maximal runs of consecutive `true` values, as inclusive index ranges.
pub fn runs_above(flags: impl IntoIterator<Item = bool>) -> Vec<AnomalyEvent> {
    let mut runs = Vec::new();
    let mut open: Option<usize> = None;
    let mut len = 0;
    for (i, flag) in flags.into_iter().enumerate() {
        match (flag, open) {
            (true, None) => open = Some(i),
            (false, Some(start)) => {
                runs.push(AnomalyEvent { start, end: i - 1 });
                open = None;
            }
            _ => {}
        }
        len = i + 1;
    }
    if let Some(start) = open {
        runs.push(AnomalyEvent {
            start,
            end: len - 1,
        });
    }
    runs
}

/// The anomaly events of a label sequence.
pub fn anomaly_events(labels: &[bool]) -> Vec<AnomalyEvent> {
    runs_above(labels.iter().copied())
}

/// For every anomaly event in `labels`, the detection latency of `scores` at `threshold`.
/// `scores` and `labels` are indexed by frame; a shorter `scores` counts missing frames as
/// undetected.
pub fn detection_outcomes(
    scores: &[f64],
    labels: &[bool],
    threshold: f64,
) -> Vec<DetectionOutcome> {
    anomaly_events(labels)
        .into_iter()
        .map(|event| DetectionOutcome {
            event,
            latency_frames: (event.start..=event.end)
                .find(|&i| scores.get(i).is_some_and(|&s| s >= threshold))
                .map(|i| i - event.start),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_cover_both_ends() {
        let r = runs_above([true, true, false, true, false, false, true]);
        assert_eq!(
            r,
            vec![
                AnomalyEvent { start: 0, end: 1 },
                AnomalyEvent { start: 3, end: 3 },
                AnomalyEvent { start: 6, end: 6 }
            ]
        );
        assert!(runs_above([false, false]).is_empty());
    }

    #[test]
    fn latency_counts_from_onset_and_misses_are_none() {
        let labels = [false, true, true, true, false, true, true];
        let scores = [0.9, 0.1, 0.2, 0.8, 0.9, 0.1, 0.3];
        let out = detection_outcomes(&scores, &labels, 0.5);
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].latency_frames, Some(2));
        assert_eq!(out[1].latency_frames, None);
    }
}
