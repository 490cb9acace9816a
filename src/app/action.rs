//! What the analyst asks the viewer for, as data: every key, click and button becomes one
//! [`Action`] that the state applies (labeling actions become one undoable edit each).

use crate::annotate::{Edge, IntervalId, Rect, TrackId};

use super::settings::{Overlay, ViewMode};

/// Something the analyst asks for (by key, click or button).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// Start or stop playback.
    TogglePlay,
    /// Move by this many frames.
    Step(i64),
    /// Go to the first frame.
    First,
    /// Go to the last frame.
    Last,
    /// Go to the onset of the previous anomaly event.
    PreviousEvent,
    /// Go to the onset of the next anomaly event.
    NextEvent,
    /// Go to this frame.
    Seek(usize),
    /// Open this scenario of the data set.
    SelectScenario(usize),
    /// Move this many scenarios up or down the list.
    StepScenario(i64),
    /// Switch the main view.
    SetView(ViewMode),
    /// Turn an overlay on or off.
    ToggleOverlay(Overlay),
    /// Jump to this failure case (index into [`AppState::failures`]).
    JumpToFailure(usize),
    /// Jump to the next (+1) or previous (−1) failure case.
    StepFailure(i64),
    /// Select the object with this track id (or none).
    SelectObject(Option<u64>),
    /// Stop the scoring job.
    CancelScoring,
    /// Stop the export job.
    CancelExport,
    /// Show or hide the help overlay.
    ToggleHelp,
    /// Turn the labeling mode on or off (opens the current scenario's labels).
    ToggleLabeling,
    /// Labeling: mark the cursor as the start of a new interval.
    StartInterval,
    /// Labeling: end the marked interval at the cursor (adds it).
    EndInterval,
    /// Labeling: move the interval edge nearest to the cursor to the cursor.
    MoveNearestEdge,
    /// Labeling: tag the current range (mark to cursor, else the selected failure run in
    /// this scenario, else the cursor's frame) with the tag text.
    TagRange,
    /// Labeling: undo the last edit.
    Undo,
    /// Labeling: redo the last undone edit.
    Redo,
    /// Labeling: move an interval's edge to a frame (timeline drag).
    SetIntervalEdge {
        /// The interval.
        interval: IntervalId,
        /// Which edge.
        edge: Edge,
        /// Where to.
        frame: usize,
    },
    /// Labeling: add a box at the cursor's frame (drawn on the frame, frame pixels).
    AddBox(Rect),
    /// Labeling: move or resize a box at the cursor's frame (a keyframe there).
    SetBox {
        /// The box's track.
        track: TrackId,
        /// Its new rectangle.
        rect: Rect,
    },
    /// Labeling: select a box (or none).
    SelectBox(Option<TrackId>),
    /// Labeling: delete the selected box from the cursor's frame on.
    DeleteSelectedBox,
}
