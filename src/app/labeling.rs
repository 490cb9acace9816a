//! The labeling mode's core, GUI-free: one [`annotate::Editor`](crate::annotate::Editor)
//! per scenario (opened on first use, journaling every edit to the scenario's `.vadscope/`
//! before it returns), the interval mark, the selected box and the tag text; the labeling
//! operations that keys, the timeline and the frame ask for, each one undoable
//! [`Edit`]; and the analyst's per-frame anomaly flags, which can replace the ground truth
//! as the reference of the metrics.

use std::fmt;

use crate::annotate::{
    DEFAULT_CLASS, Edge, Edit, Editor, FailureTag, Interval, IntervalId, Keyframe, LabelLane,
    LabelSet, Origin, Rect, Track, TrackId, scenario_class,
};
use crate::sequence::Scenario;

use super::action::Action;
use super::error::AppError;

/// Class given to a box the analyst draws (CARLA's `car`).
pub const NEW_BOX_CLASS: u16 = 14;

/// Boxes smaller than this (pixels, either side) are not drawn: a click is not a box.
pub const MIN_BOX_SIDE: f32 = 2.0;

/// Tag text used until the analyst types another.
pub const DEFAULT_TAG: &str = "review";

/// One scenario's labels: its editor and what the viewer derives from them after each
/// edit (the per-frame lane and anomaly flags).
pub struct ScenarioLabels {
    editor: Editor,
    class: String,
    lane: LabelLane,
    flags: Vec<bool>,
    timeline: Vec<Option<bool>>,
}

impl fmt::Debug for ScenarioLabels {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ScenarioLabels")
            .field("dir", &self.editor.dir())
            .field("seq", &self.editor.seq())
            .field("labels", &self.editor.labels().label_count())
            .finish()
    }
}

/// What opening a scenario's labels found wrong: each problem names its file, and the
/// damaged files were copied aside (`<file>.corrupt-<time>`) before being replaced.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OpenReport {
    /// The problems, as the log shows them.
    pub problems: Vec<String>,
    /// The copies of damaged files.
    pub set_aside: Vec<std::path::PathBuf>,
}

impl ScenarioLabels {
    /// Opens the labels of `scenario` (see [`Editor::open`]); edits are on disk when they
    /// return ([`crate::annotate::SaveMode::Durable`]).
    pub fn open(scenario: &Scenario) -> Result<(Self, OpenReport), AppError> {
        let editor = Editor::open(scenario)?;
        let report = OpenReport {
            problems: editor
                .load_problems()
                .iter()
                .map(ToString::to_string)
                .collect(),
            set_aside: editor.set_aside().to_vec(),
        };
        Ok((Self::with_editor(editor, scenario_class(scenario)), report))
    }

    /// Labels over an editor built elsewhere (an in-memory one in tests); new intervals
    /// get `class`.
    pub fn with_editor(editor: Editor, class: String) -> Self {
        let mut labels = Self {
            editor,
            class,
            lane: LabelLane::default(),
            flags: Vec::new(),
            timeline: Vec::new(),
        };
        labels.rebuild();
        labels
    }

    fn rebuild(&mut self) {
        self.lane = self.editor.lane();
        self.flags = self.lane.anomaly_flags();
        self.timeline = self.flags.iter().map(|&f| Some(f)).collect();
    }

    /// The editor (labels, undo state, sequence numbers, files).
    pub fn editor(&self) -> &Editor {
        &self.editor
    }

    /// The labels as they are now.
    pub fn labels(&self) -> &LabelSet {
        self.editor.labels()
    }

    /// The per-frame lane of the labels.
    pub fn lane(&self) -> &LabelLane {
        &self.lane
    }

    /// Per frame: whether an analyst interval covers it.
    pub fn flags(&self) -> &[bool] {
        &self.flags
    }

    /// The labels lane as render's timeline takes it (every frame labelled).
    pub fn timeline_lane(&self) -> &[Option<bool>] {
        &self.timeline
    }

    /// Applies one edit (journaled before it returns).
    pub fn apply(&mut self, edit: Edit) -> Result<(), AppError> {
        let result = self.editor.apply(edit);
        self.rebuild();
        Ok(result?)
    }

    /// Undoes the last edit; `false` when there was none.
    pub fn undo(&mut self) -> Result<bool, AppError> {
        let done = self.editor.undo();
        self.rebuild();
        Ok(done?)
    }

    /// Redoes the last undone edit; `false` when there was none.
    pub fn redo(&mut self) -> Result<bool, AppError> {
        let done = self.editor.redo();
        self.rebuild();
        Ok(done?)
    }

    /// Adds the anomaly interval `a..=b` (in either order); returns its id.
    pub fn add_interval(&mut self, a: usize, b: usize) -> Result<IntervalId, AppError> {
        let id = self.labels().fresh_interval_id();
        let class = if self.class.is_empty() {
            DEFAULT_CLASS.to_string()
        } else {
            self.class.clone()
        };
        self.apply(Edit::AddInterval(Interval {
            id,
            start: a.min(b),
            end: a.max(b),
            class,
            note: String::new(),
            origin: Origin::Analyst,
        }))?;
        Ok(id)
    }

    /// Moves one edge of an interval to `frame` (the edges swap when they would cross).
    pub fn move_edge(
        &mut self,
        interval: IntervalId,
        edge: Edge,
        frame: usize,
    ) -> Result<(), AppError> {
        let Some(current) = self.labels().interval(interval) else {
            return Err(AppError::Labeling(format!(
                "there is no interval {}",
                interval.0
            )));
        };
        let moved = current.with_edge(edge, frame);
        if moved == *current {
            return Ok(());
        }
        self.apply(Edit::UpdateInterval(moved))
    }

    /// Moves the interval edge nearest to `frame` there; `false` without intervals.
    pub fn move_nearest_edge(&mut self, frame: usize) -> Result<bool, AppError> {
        let Some(edge) = self.labels().nearest_edge(frame) else {
            return Ok(false);
        };
        self.move_edge(edge.interval, edge.edge, frame)?;
        Ok(true)
    }

    /// Tags frames `start..=end` with `tag`.
    pub fn tag(&mut self, start: usize, end: usize, tag: &str) -> Result<(), AppError> {
        let id = self.labels().fresh_tag_id();
        self.apply(Edit::AddTag(FailureTag {
            id,
            start: start.min(end),
            end: start.max(end),
            tag: tag.to_string(),
            note: String::new(),
        }))
    }

    /// Adds a new track whose box appears at `frame` (held from there on, as annotate's
    /// tracks are); returns its id, or `None` for a box too small to be one.
    pub fn add_box(&mut self, frame: usize, rect: Rect) -> Result<Option<TrackId>, AppError> {
        let rect = normalised(rect);
        if rect.x2 - rect.x1 < MIN_BOX_SIDE || rect.y2 - rect.y1 < MIN_BOX_SIDE {
            return Ok(None);
        }
        let id = self.labels().fresh_track_id();
        let keyframe = Keyframe {
            rect,
            outside: false,
            anomalous: false,
        };
        self.apply(Edit::AddTrack(Track {
            id,
            class: NEW_BOX_CLASS,
            keyframes: [(frame, keyframe)].into_iter().collect(),
            origin: Origin::Analyst,
        }))?;
        Ok(Some(id))
    }

    /// Moves or resizes the box of `track` at `frame`: a keyframe there (interpolation
    /// around it follows).
    pub fn set_box(&mut self, track: TrackId, frame: usize, rect: Rect) -> Result<(), AppError> {
        let anomalous = self.box_of(track, frame)?.anomalous;
        self.apply(Edit::SetKeyframe {
            track,
            frame,
            keyframe: Some(Keyframe {
                rect: normalised(rect),
                outside: false,
                anomalous,
            }),
        })
    }

    /// Deletes the box of `track` from `frame` on (an `outside` keyframe there).
    pub fn delete_box(&mut self, track: TrackId, frame: usize) -> Result<(), AppError> {
        let shown = self.box_of(track, frame)?;
        self.apply(Edit::SetKeyframe {
            track,
            frame,
            keyframe: Some(Keyframe {
                rect: shown.rect,
                outside: true,
                anomalous: shown.anomalous,
            }),
        })
    }

    fn box_of(&self, track: TrackId, frame: usize) -> Result<crate::annotate::FrameBox, AppError> {
        self.labels()
            .track(track)
            .and_then(|t| t.box_at(frame))
            .ok_or_else(|| {
                AppError::Labeling(format!("track {} has no box at frame {frame}", track.0))
            })
    }

    /// The smallest box of `frame` holding pixel (x, y).
    pub fn box_at(&self, frame: usize, x: f32, y: f32) -> Option<crate::annotate::FrameBox> {
        self.labels()
            .boxes_at(frame)
            .into_iter()
            .filter(|b| {
                (b.rect.x1..=b.rect.x2).contains(&x) && (b.rect.y1..=b.rect.y2).contains(&y)
            })
            .min_by(|a, b| area(&a.rect).total_cmp(&area(&b.rect)))
    }
}

/// The same box with x1 ≤ x2 and y1 ≤ y2.
pub fn normalised(r: Rect) -> Rect {
    Rect {
        x1: r.x1.min(r.x2),
        y1: r.y1.min(r.y2),
        x2: r.x1.max(r.x2),
        y2: r.y1.max(r.y2),
    }
}

fn area(r: &Rect) -> f32 {
    (r.x2 - r.x1).max(0.0) * (r.y2 - r.y1).max(0.0)
}

/// The labeling mode: whether it is on, each scenario's labels once opened, and the
/// analyst's transient choices (the interval mark, the selected box, the tag text).
#[derive(Debug)]
pub struct Labeling {
    /// Whether the labeling mode is on.
    pub active: bool,
    scenarios: Vec<Option<ScenarioLabels>>,
    /// The frame where "start interval" was pressed, waiting for "end interval".
    pub mark: Option<usize>,
    /// The box selected on the frame.
    pub selected_box: Option<TrackId>,
    /// The text "tag range" gives the range.
    pub tag_text: String,
}

impl Labeling {
    /// Labeling for a data set of `scenarios` scenarios, none opened yet.
    pub fn new(scenarios: usize) -> Self {
        Self {
            active: false,
            scenarios: (0..scenarios).map(|_| None).collect(),
            mark: None,
            selected_box: None,
            tag_text: DEFAULT_TAG.to_string(),
        }
    }

    /// The labels of scenario `index`, when opened.
    pub fn get(&self, index: usize) -> Option<&ScenarioLabels> {
        self.scenarios.get(index)?.as_ref()
    }

    /// The labels of scenario `index`, when opened, to edit.
    pub fn get_mut(&mut self, index: usize) -> Option<&mut ScenarioLabels> {
        self.scenarios.get_mut(index)?.as_mut()
    }

    /// Whether scenario `index`'s labels are open.
    pub fn is_open(&self, index: usize) -> bool {
        self.get(index).is_some()
    }

    /// Keeps `labels` as scenario `index`'s.
    pub fn insert(&mut self, index: usize, labels: ScenarioLabels) {
        if index >= self.scenarios.len() {
            self.scenarios.resize_with(index + 1, || None);
        }
        self.scenarios[index] = Some(labels);
    }

    /// The analyst's anomaly flags of scenario `index`, when its labels are open and
    /// cover `frames` frames.
    pub fn flags(&self, index: usize, frames: usize) -> Option<&[bool]> {
        self.get(index)
            .map(ScenarioLabels::flags)
            .filter(|f| f.len() == frames)
    }

    /// Carries out a labeling `action` on scenario `index` (whose labels are open) at
    /// cursor `frame`; `range` is what "tag range" tags. Returns a message for the log (or
    /// the error) and whether the labels changed.
    pub fn perform(
        &mut self,
        index: usize,
        action: Action,
        frame: usize,
        range: (usize, usize),
    ) -> (Result<Option<String>, AppError>, bool) {
        let Some(Some(labels)) = self.scenarios.get_mut(index) else {
            return (
                Err(AppError::Labeling(
                    "this scenario's labels are not open".into(),
                )),
                false,
            );
        };
        let before = labels.editor().seq();
        let result = match action {
            Action::StartInterval => {
                self.mark = Some(frame);
                Ok(Some(format!(
                    "interval starts at frame {frame}: press ] at its last frame"
                )))
            }
            Action::EndInterval => match self.mark.take() {
                Some(start) => labels.add_interval(start, frame).map(|id| {
                    Some(format!(
                        "interval {} added: frames {}–{}",
                        id.0,
                        start.min(frame),
                        start.max(frame)
                    ))
                }),
                None => Err(AppError::Labeling(
                    "no interval started: press [ at its first frame".into(),
                )),
            },
            Action::MoveNearestEdge => labels.move_nearest_edge(frame).and_then(|moved| {
                if moved {
                    Ok(None)
                } else {
                    Err(AppError::Labeling("there is no interval to move".into()))
                }
            }),
            Action::TagRange => {
                let tag = self.tag_text.trim().to_string();
                if tag.is_empty() {
                    Err(AppError::Labeling("the tag text is empty".into()))
                } else {
                    self.mark = None;
                    labels
                        .tag(range.0, range.1, &tag)
                        .map(|()| Some(format!("frames {}–{} tagged {tag:?}", range.0, range.1)))
                }
            }
            Action::Undo => labels
                .undo()
                .map(|done| (!done).then(|| "nothing to undo".to_string())),
            Action::Redo => labels
                .redo()
                .map(|done| (!done).then(|| "nothing to redo".to_string())),
            Action::SetIntervalEdge {
                interval,
                edge,
                frame,
            } => labels.move_edge(interval, edge, frame).map(|()| None),
            Action::AddBox(rect) => labels.add_box(frame, rect).map(|track| {
                if track.is_some() {
                    self.selected_box = track;
                }
                None
            }),
            Action::SetBox { track, rect } => labels.set_box(track, frame, rect).map(|()| None),
            Action::SelectBox(track) => {
                self.selected_box = track;
                Ok(None)
            }
            Action::DeleteSelectedBox => match self.selected_box.take() {
                Some(track) => labels.delete_box(track, frame).map(|()| None),
                None => Err(AppError::Labeling("no box selected".into())),
            },
            _ => Ok(None),
        };
        let changed = labels.editor().seq() != before;
        (result, changed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::FrameId;

    fn labeling(frames: u64) -> Labeling {
        let set = LabelSet::new((0..frames).map(FrameId).collect());
        let mut labeling = Labeling::new(1);
        labeling.insert(
            0,
            ScenarioLabels::with_editor(Editor::in_memory(set), "braking".into()),
        );
        labeling
    }

    /// Performs `action` at `frame`, asserting it succeeds; returns whether it changed the
    /// labels.
    fn ok(l: &mut Labeling, action: Action, frame: usize) -> bool {
        let (result, changed) = l.perform(0, action, frame, (frame, frame));
        result.expect("the action succeeds");
        changed
    }

    fn intervals(labeling: &Labeling) -> Vec<(usize, usize, String)> {
        labeling
            .get(0)
            .expect("open")
            .labels()
            .intervals()
            .map(|i| (i.start, i.end, i.class.clone()))
            .collect()
    }

    #[test]
    fn mark_end_and_nearest_edge_make_one_edit_each() {
        let mut l = labeling(20);
        assert!(!ok(&mut l, Action::StartInterval, 9), "a mark is no edit");
        assert!(ok(&mut l, Action::EndInterval, 4));
        assert_eq!(intervals(&l), vec![(4, 9, "braking".to_string())]);
        assert_eq!(l.mark, None);
        assert_eq!(l.get(0).expect("open").flags()[4..10], [true; 6]);
        assert!(ok(&mut l, Action::MoveNearestEdge, 11));
        assert_eq!(intervals(&l)[0].1, 11);
        let (result, changed) = l.perform(0, Action::EndInterval, 3, (3, 3));
        assert!(result.is_err() && !changed, "no mark: nothing happens");
        assert!(ok(&mut l, Action::Undo, 0));
        assert_eq!(intervals(&l)[0].1, 9);
    }

    #[test]
    fn boxes_are_drawn_moved_and_deleted_from_a_frame_on() {
        let mut l = labeling(10);
        let rect = |x: f32| Rect {
            x1: x + 20.0,
            y1: 20.0,
            x2: x,
            y2: 5.0,
        };
        assert!(ok(&mut l, Action::AddBox(rect(1.0)), 2));
        let track = l.selected_box.expect("the new box is selected");
        let shown = l.get(0).expect("open").labels().boxes_at(5);
        assert_eq!(shown.len(), 1, "held after its keyframe");
        assert_eq!(shown[0].rect, normalised(rect(1.0)));
        assert!(ok(
            &mut l,
            Action::SetBox {
                track,
                rect: rect(30.0)
            },
            6
        ));
        let at_4 = l.get(0).expect("open").labels().boxes_at(4)[0].rect;
        assert!((at_4.x1 - 15.5).abs() < 1e-4, "interpolated: {at_4:?}");
        assert!(ok(&mut l, Action::DeleteSelectedBox, 8));
        let labels = l.get(0).expect("open").labels();
        assert_eq!(labels.boxes_at(7).len(), 1);
        assert!(labels.boxes_at(8).is_empty() && labels.boxes_at(9).is_empty());
        let tiny = Rect {
            x1: 1.0,
            y1: 1.0,
            x2: 2.0,
            y2: 2.0,
        };
        assert!(!ok(&mut l, Action::AddBox(tiny), 1), "a click is not a box");
    }
}
