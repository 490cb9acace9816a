//! The analyst's labels of one scenario ([`LabelSet`]): anomaly intervals, box tracks with
//! keyframes, failure-case tags and free notes, all keyed by frame index, with the
//! scenario's AnoVox frame ids kept beside them for exports; and the per-frame queries the
//! viewer asks while drawing (intervals covering a frame, interpolated boxes of a frame,
//! the nearest interval edge).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::sequence::FrameId;

/// Identifies an anomaly interval.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct IntervalId(pub u64);

/// Identifies a failure-case tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct TagId(pub u64);

/// Identifies a box track (the ground truth's `track_id` for tracks that came from it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct TrackId(pub u64);

/// Where a label came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Origin {
    /// The scenario's ground truth (`frame_labels.csv`, `BBOX_2D/boxes.csv`, ...).
    GroundTruth,
    /// Drawn or typed by the analyst.
    Analyst,
    /// Read from an imported file.
    Imported,
}

/// An anomaly interval: frames `start..=end` (frame indices, inclusive).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Interval {
    /// Its id.
    pub id: IntervalId,
    /// First frame index.
    pub start: usize,
    /// Last frame index (inclusive).
    pub end: usize,
    /// Anomaly class, e.g. `sudden-braking`.
    pub class: String,
    /// Free text.
    pub note: String,
    /// Where it came from.
    pub origin: Origin,
}

impl Interval {
    /// Whether frame `index` lies in the interval.
    pub fn covers(&self, index: usize) -> bool {
        (self.start..=self.end).contains(&index)
    }

    /// The interval with one edge moved to `frame`; the edges swap when they would cross.
    pub fn with_edge(&self, edge: Edge, frame: usize) -> Interval {
        let (start, end) = match edge {
            Edge::Start => (frame, self.end),
            Edge::End => (self.start, frame),
        };
        Interval {
            start: start.min(end),
            end: start.max(end),
            ..self.clone()
        }
    }
}

/// A failure-case tag on frames `start..=end`, e.g. `glare` or `false-alarm-turning`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FailureTag {
    /// Its id.
    pub id: TagId,
    /// First frame index.
    pub start: usize,
    /// Last frame index (inclusive).
    pub end: usize,
    /// The tag.
    pub tag: String,
    /// Free text.
    pub note: String,
}

impl FailureTag {
    /// Whether frame `index` lies in the tagged range.
    pub fn covers(&self, index: usize) -> bool {
        (self.start..=self.end).contains(&index)
    }
}

/// A box in pixels, x2/y2 exclusive (as in `boxes.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rect {
    /// Left edge.
    pub x1: f32,
    /// Top edge.
    pub y1: f32,
    /// Right edge (exclusive).
    pub x2: f32,
    /// Bottom edge (exclusive).
    pub y2: f32,
}

impl Rect {
    /// Linear interpolation: `t` = 0 gives `self`, 1 gives `other`.
    pub fn lerp(&self, other: &Rect, t: f32) -> Rect {
        let mix = |a: f32, b: f32| a + (b - a) * t;
        Rect {
            x1: mix(self.x1, other.x1),
            y1: mix(self.y1, other.y1),
            x2: mix(self.x2, other.x2),
            y2: mix(self.y2, other.y2),
        }
    }

    /// Whether the coordinates are finite and x2 ≥ x1, y2 ≥ y1.
    pub fn is_valid(&self) -> bool {
        [self.x1, self.y1, self.x2, self.y2]
            .iter()
            .all(|c| c.is_finite())
            && self.x2 >= self.x1
            && self.y2 >= self.y1
    }

    /// The same box moved by (dx, dy).
    pub fn translated(&self, dx: f32, dy: f32) -> Rect {
        Rect {
            x1: self.x1 + dx,
            y1: self.y1 + dy,
            x2: self.x2 + dx,
            y2: self.y2 + dy,
        }
    }
}

/// A track's state from one frame on: its box there, or `outside` (not visible) until the
/// next keyframe.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Keyframe {
    /// The box at this frame (kept, but not shown, while `outside`).
    pub rect: Rect,
    /// The object is not visible from this frame until the next keyframe.
    pub outside: bool,
    /// The object is the anomaly from this frame until the next keyframe.
    pub anomalous: bool,
}

/// One object's boxes over time: keyframes by frame index, linearly interpolated between
/// visible keyframes; after the last keyframe the last box is held, so a track that ends
/// has an `outside` keyframe after its last frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Track {
    /// Its id.
    pub id: TrackId,
    /// AnoVox / CARLA class id (14 car, 15 truck, ...).
    pub class: u16,
    /// Keyframes by frame index.
    pub keyframes: BTreeMap<usize, Keyframe>,
    /// Where it came from.
    pub origin: Origin,
}

impl Track {
    /// The track's box at frame `index`: interpolated between the keyframes around it,
    /// `None` before the first keyframe and while outside.
    pub fn box_at(&self, index: usize) -> Option<FrameBox> {
        let (&at, before) = self.keyframes.range(..=index).next_back()?;
        if before.outside {
            return None;
        }
        let rect = match self.keyframes.range(index + 1..).next() {
            Some((&next_at, next)) if !next.outside && at != index => {
                let t = (index - at) as f32 / (next_at - at) as f32;
                before.rect.lerp(&next.rect, t)
            }
            _ => before.rect,
        };
        Some(FrameBox {
            track: self.id,
            class: self.class,
            rect,
            anomalous: before.anomalous,
            keyframe: at == index,
        })
    }

    /// First and last frame with a visible box (`None` when it has none).
    pub fn visible_span(&self) -> Option<(usize, usize)> {
        let first = self.keyframes.iter().find(|(_, k)| !k.outside)?.0;
        let last_visible = self.keyframes.iter().rev().find(|(_, k)| !k.outside)?.0;
        let end = self
            .keyframes
            .range(last_visible + 1..)
            .next()
            .map_or(usize::MAX, |(&f, _)| f - 1);
        Some((*first, end))
    }
}

/// A track's box at one frame, as drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameBox {
    /// The track.
    pub track: TrackId,
    /// The track's class.
    pub class: u16,
    /// The (possibly interpolated) box.
    pub rect: Rect,
    /// Whether the object is the anomaly here.
    pub anomalous: bool,
    /// Whether the frame is one of the track's keyframes (not interpolated).
    pub keyframe: bool,
}

/// Which edge of an interval.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Edge {
    /// The first frame.
    Start,
    /// The last frame.
    End,
}

/// An interval edge near a frame, as found by [`LabelSet::nearest_edge`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EdgeRef {
    /// The interval.
    pub interval: IntervalId,
    /// Which edge.
    pub edge: Edge,
    /// The edge's frame index.
    pub frame: usize,
}

/// Every label of one scenario. Changed only through [`super::Edit`]s, so that each change
/// can be undone and journaled.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LabelSet {
    pub(super) frames: Vec<FrameId>,
    pub(super) intervals: BTreeMap<IntervalId, Interval>,
    pub(super) tracks: BTreeMap<TrackId, Track>,
    pub(super) tags: BTreeMap<TagId, FailureTag>,
    pub(super) notes: BTreeMap<usize, String>,
}

impl LabelSet {
    /// Empty labels for a scenario whose frames have these AnoVox ids (in index order).
    pub fn new(frames: Vec<FrameId>) -> Self {
        Self {
            frames,
            ..Self::default()
        }
    }

    /// Number of frames of the scenario.
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// The AnoVox frame ids by frame index.
    pub fn frame_ids(&self) -> &[FrameId] {
        &self.frames
    }

    /// The AnoVox id of frame `index`.
    pub fn frame_id(&self, index: usize) -> Option<FrameId> {
        self.frames.get(index).copied()
    }

    /// Every interval, by id.
    pub fn intervals(&self) -> impl ExactSizeIterator<Item = &Interval> {
        self.intervals.values()
    }

    /// One interval.
    pub fn interval(&self, id: IntervalId) -> Option<&Interval> {
        self.intervals.get(&id)
    }

    /// Every track, by id.
    pub fn tracks(&self) -> impl ExactSizeIterator<Item = &Track> {
        self.tracks.values()
    }

    /// One track.
    pub fn track(&self, id: TrackId) -> Option<&Track> {
        self.tracks.get(&id)
    }

    /// Every failure tag, by id.
    pub fn tags(&self) -> impl ExactSizeIterator<Item = &FailureTag> {
        self.tags.values()
    }

    /// One failure tag.
    pub fn tag(&self, id: TagId) -> Option<&FailureTag> {
        self.tags.get(&id)
    }

    /// Every note, by frame index.
    pub fn notes(&self) -> impl ExactSizeIterator<Item = (usize, &str)> {
        self.notes.iter().map(|(&f, n)| (f, n.as_str()))
    }

    /// The note on frame `index`.
    pub fn note(&self, index: usize) -> Option<&str> {
        self.notes.get(&index).map(String::as_str)
    }

    /// Total number of labels (intervals, keyframes, tags and notes).
    pub fn label_count(&self) -> usize {
        self.intervals.len()
            + self
                .tracks
                .values()
                .map(|t| t.keyframes.len())
                .sum::<usize>()
            + self.tags.len()
            + self.notes.len()
    }

    /// The intervals covering frame `index`.
    pub fn intervals_at(&self, index: usize) -> Vec<&Interval> {
        self.intervals
            .values()
            .filter(|i| i.covers(index))
            .collect()
    }

    /// The failure tags covering frame `index`.
    pub fn tags_at(&self, index: usize) -> Vec<&FailureTag> {
        self.tags.values().filter(|t| t.covers(index)).collect()
    }

    /// The boxes of frame `index`, interpolated between keyframes, by track id.
    pub fn boxes_at(&self, index: usize) -> Vec<FrameBox> {
        self.tracks
            .values()
            .filter_map(|t| t.box_at(index))
            .collect()
    }

    /// The interval edge closest to frame `index` (ties: the lower interval id, start
    /// before end); `None` without intervals.
    pub fn nearest_edge(&self, index: usize) -> Option<EdgeRef> {
        self.intervals
            .values()
            .flat_map(|i| {
                [(Edge::Start, i.start), (Edge::End, i.end)].map(|(edge, frame)| EdgeRef {
                    interval: i.id,
                    edge,
                    frame,
                })
            })
            .min_by_key(|e| e.frame.abs_diff(index))
    }

    /// An interval id not in use.
    pub fn fresh_interval_id(&self) -> IntervalId {
        IntervalId(self.intervals.keys().next_back().map_or(1, |id| id.0 + 1))
    }

    /// A tag id not in use.
    pub fn fresh_tag_id(&self) -> TagId {
        TagId(self.tags.keys().next_back().map_or(1, |id| id.0 + 1))
    }

    /// A track id not in use.
    pub fn fresh_track_id(&self) -> TrackId {
        TrackId(self.tracks.keys().next_back().map_or(1, |id| id.0 + 1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x: f32) -> Rect {
        Rect {
            x1: x,
            y1: 0.0,
            x2: x + 10.0,
            y2: 10.0,
        }
    }

    fn key(x: f32, outside: bool) -> Keyframe {
        Keyframe {
            rect: rect(x),
            outside,
            anomalous: false,
        }
    }

    #[test]
    fn boxes_interpolate_hold_and_hide() {
        let track = Track {
            id: TrackId(3),
            class: 14,
            keyframes: BTreeMap::from([
                (2, key(0.0, false)),
                (6, key(40.0, false)),
                (8, key(0.0, true)),
                (10, key(5.0, false)),
            ]),
            origin: Origin::Analyst,
        };
        assert_eq!(track.box_at(1), None, "before the first keyframe");
        assert_eq!(track.box_at(3).map(|b| b.rect), Some(rect(10.0)));
        assert!(!track.box_at(3).is_some_and(|b| b.keyframe));
        assert!(track.box_at(6).is_some_and(|b| b.keyframe));
        assert_eq!(track.box_at(7).map(|b| b.rect), Some(rect(40.0)), "held");
        assert_eq!(track.box_at(9), None, "outside");
        assert_eq!(track.box_at(500).map(|b| b.rect), Some(rect(5.0)));
        assert_eq!(track.visible_span(), Some((2, usize::MAX)));
    }

    #[test]
    fn moving_an_edge_past_the_other_swaps_them() {
        let interval = Interval {
            id: IntervalId(1),
            start: 4,
            end: 9,
            class: "a".into(),
            note: String::new(),
            origin: Origin::Analyst,
        };
        let moved = interval.with_edge(Edge::End, 2);
        assert_eq!((moved.start, moved.end), (2, 4));
    }
}
