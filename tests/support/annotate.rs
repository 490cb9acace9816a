//! A small scenario for the annotate tests: the moving square of [`super::scenario`] over 8
//! frames with AnoVox ids 100, 102, ... (so that ids and indices differ), a second track
//! on frames 2–4 and anomalous frames 3–5.

use std::path::{Path, PathBuf};

use vadscope::annotate::{Edit, Interval, IntervalId, Keyframe, Origin, Rect};
use vadscope::sequence::{BoxRecord, FrameId, FrameRecord};

use super::scenario::{ScenarioBuilder, square_box, square_frame};

/// Frames of the test scenario.
pub const FRAMES: u64 = 8;

/// The AnoVox id of frame index `k`.
pub fn frame_id(k: u64) -> FrameId {
    FrameId(100 + 2 * k)
}

/// The second object's box on frame `k` (2 ≤ k ≤ 4).
pub fn second_box(k: u64) -> BoxRecord {
    BoxRecord {
        frame: frame_id(k),
        track_id: 9,
        x1: 60.0 - 2.0 * k as f32,
        y1: 4.0,
        x2: 70.0,
        y2: 12.5,
        class: 15,
        score: 1.0,
        anomalous: false,
    }
}

/// Writes the test scenario into `dir/s` and returns its folder.
pub fn write_scenario(dir: &Path) -> PathBuf {
    let frame = |k: u64| {
        let mut boxes = vec![BoxRecord {
            frame: frame_id(k),
            ..square_box(k)
        }];
        if (2..=4).contains(&k) {
            boxes.push(second_box(k));
        }
        FrameRecord {
            boxes,
            anomalous: Some((3..=5).contains(&k)),
            ..FrameRecord::new(frame_id(k), square_frame(k))
        }
    };
    ScenarioBuilder::new()
        .frames((0..FRAMES).map(frame))
        .write(&dir.join("s"))
}

/// A box.
pub fn rect(x1: f32, y1: f32, x2: f32, y2: f32) -> Rect {
    Rect { x1, y1, x2, y2 }
}

/// A visible keyframe.
pub fn keyframe(r: Rect) -> Keyframe {
    Keyframe {
        rect: r,
        outside: false,
        anomalous: false,
    }
}

/// An analyst's interval.
pub fn interval(id: u64, start: usize, end: usize, class: &str) -> Interval {
    Interval {
        id: IntervalId(id),
        start,
        end,
        class: class.into(),
        note: String::new(),
        origin: Origin::Analyst,
    }
}

/// Adds an interval.
pub fn add_interval(id: u64, start: usize, end: usize) -> Edit {
    Edit::AddInterval(interval(id, start, end, "analyst"))
}
