//! [`LabelLane`]: the labels as one cell per frame, for the timeline lane and as the
//! reference flags for evaluation. Built in one pass over the labels plus one over the
//! frames (difference arrays), so it can be rebuilt after every edit.

use super::labels::LabelSet;

/// What the labels say about one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LaneCell {
    /// Number of anomaly intervals covering the frame.
    pub intervals: u32,
    /// Number of failure tags covering the frame.
    pub tags: u32,
    /// Number of visible boxes on the frame.
    pub boxes: u32,
    /// Whether the frame has a note.
    pub note: bool,
}

impl LaneCell {
    /// Whether an anomaly interval covers the frame.
    pub fn anomalous(&self) -> bool {
        self.intervals > 0
    }
}

/// One [`LaneCell`] per frame index.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LabelLane {
    /// Cells by frame index.
    pub cells: Vec<LaneCell>,
}

impl LabelLane {
    /// Builds the lane of `labels`.
    pub fn build(labels: &LabelSet) -> Self {
        let frames = labels.frame_count();
        let mut interval_delta = vec![0i64; frames + 1];
        let mut tag_delta = vec![0i64; frames + 1];
        let mut box_delta = vec![0i64; frames + 1];
        let add = |delta: &mut [i64], start: usize, end: usize| {
            if start < frames {
                delta[start] += 1;
                delta[end.min(frames - 1) + 1] -= 1;
            }
        };
        for interval in labels.intervals() {
            add(&mut interval_delta, interval.start, interval.end);
        }
        for tag in labels.tags() {
            add(&mut tag_delta, tag.start, tag.end);
        }
        for track in labels.tracks() {
            let mut visible_from: Option<usize> = None;
            for (&frame, keyframe) in &track.keyframes {
                match (visible_from, keyframe.outside) {
                    (None, false) => visible_from = Some(frame),
                    (Some(start), true) => {
                        add(&mut box_delta, start, frame.saturating_sub(1));
                        visible_from = None;
                    }
                    _ => {}
                }
            }
            if let Some(start) = visible_from {
                add(&mut box_delta, start, frames.saturating_sub(1));
            }
        }
        let mut cells = vec![LaneCell::default(); frames];
        let (mut intervals, mut tags, mut boxes) = (0i64, 0i64, 0i64);
        for (i, cell) in cells.iter_mut().enumerate() {
            intervals += interval_delta[i];
            tags += tag_delta[i];
            boxes += box_delta[i];
            *cell = LaneCell {
                intervals: intervals as u32,
                tags: tags as u32,
                boxes: boxes as u32,
                note: false,
            };
        }
        for (frame, _) in labels.notes() {
            if let Some(cell) = cells.get_mut(frame) {
                cell.note = true;
            }
        }
        Self { cells }
    }

    /// Per-frame anomaly flags (an interval covers the frame): the analyst's reference for
    /// evaluation.
    pub fn anomaly_flags(&self) -> Vec<bool> {
        self.cells.iter().map(LaneCell::anomalous).collect()
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether the lane has no frames.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }
}
