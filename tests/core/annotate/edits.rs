//! Every edit kind with undo and redo, invalid edits, interpolation and the per-frame
//! queries, on labels started from the test scenario's ground truth.

use vadscope::annotate::{
    Edge, Edit, Editor, FailureTag, IntervalId, Keyframe, LabelLane, LabelSet, Origin, TagId,
    Track, TrackId, ground_truth_labels,
};
use vadscope::sequence::Scenario;

use crate::support::annotate::{add_interval, keyframe, rect, write_scenario};

fn ground_truth() -> LabelSet {
    let dir = tempfile::tempdir().expect("temp dir");
    let scenario = Scenario::open(&write_scenario(dir.path())).expect("open");
    let (labels, problems) = ground_truth_labels(&scenario);
    assert!(problems.is_empty(), "{problems:?}");
    labels
}

#[test]
fn ground_truth_is_the_starting_point() {
    let labels = ground_truth();
    assert_eq!(labels.frame_count(), 8);
    assert_eq!(labels.frame_id(3).map(|f| f.0), Some(106));
    let intervals: Vec<_> = labels.intervals().collect();
    assert_eq!(intervals.len(), 1);
    assert_eq!((intervals[0].start, intervals[0].end), (3, 5));
    assert_eq!(intervals[0].origin, Origin::GroundTruth);
    let boxes = labels.boxes_at(3);
    assert_eq!(
        boxes.iter().map(|b| b.track.0).collect::<Vec<_>>(),
        vec![5, 9]
    );
    assert_eq!(boxes[0].rect, rect(20.0, 24.0, 36.0, 40.0));
    assert_eq!(boxes[1].rect, rect(54.0, 4.0, 70.0, 12.5));
    assert_eq!(boxes[1].class, 15);
    assert!(!boxes[0].anomalous && labels.boxes_at(4)[0].anomalous);
    assert!(
        labels.boxes_at(5).iter().all(|b| b.track.0 == 5),
        "track 9 ends at 4"
    );
}

/// Applies `edit`, checks it changed something, then undo restores the labels exactly and
/// redo brings the edit back.
fn check_undo_redo(editor: &mut Editor, edit: Edit) {
    let before = editor.labels().clone();
    editor
        .apply(edit.clone())
        .unwrap_or_else(|e| panic!("{edit:?}: {e}"));
    let after = editor.labels().clone();
    assert_ne!(before, after, "{edit:?} changed nothing");
    assert!(editor.undo().expect("undo"));
    assert_eq!(editor.labels(), &before, "undo of {edit:?}");
    assert!(editor.redo().expect("redo"));
    assert_eq!(editor.labels(), &after, "redo of {edit:?}");
}

#[test]
fn every_edit_kind_undoes_and_redoes() {
    let mut editor = Editor::in_memory(ground_truth());
    let gt_interval = editor.labels().intervals().next().expect("gt").clone();
    let square = TrackId(5);
    let moved = |k: Keyframe| Keyframe {
        rect: k.rect.translated(3.0, -2.0),
        ..k
    };
    let at2 = editor.labels().track(square).expect("square").keyframes[&2];
    let edits = vec![
        add_interval(10, 1, 2),
        Edit::UpdateInterval(gt_interval.with_edge(Edge::Start, 2)),
        Edit::UpdateInterval(vadscope::annotate::Interval {
            class: "cut-in".into(),
            note: "not braking".into(),
            ..gt_interval.clone()
        }),
        Edit::DeleteInterval(IntervalId(10)),
        Edit::AddTrack(Track {
            id: TrackId(40),
            class: 14,
            keyframes: [(1, keyframe(rect(0.0, 0.0, 5.0, 5.0)))].into(),
            origin: Origin::Analyst,
        }),
        Edit::SetTrackClass {
            track: square,
            class: 16,
        },
        Edit::SetKeyframe {
            track: square,
            frame: 2,
            keyframe: Some(moved(at2)),
        },
        Edit::SetKeyframe {
            track: square,
            frame: 2,
            keyframe: Some(Keyframe {
                rect: rect(
                    at2.rect.x1,
                    at2.rect.y1,
                    at2.rect.x2 + 8.0,
                    at2.rect.y2 + 4.0,
                ),
                ..at2
            }),
        },
        Edit::SetKeyframe {
            track: square,
            frame: 3,
            keyframe: Some(Keyframe {
                outside: true,
                ..at2
            }),
        },
        Edit::SetKeyframe {
            track: square,
            frame: 4,
            keyframe: None,
        },
        Edit::DeleteTrack(TrackId(40)),
        Edit::DeleteTrack(TrackId(9)),
        Edit::AddTag(FailureTag {
            id: TagId(1),
            start: 0,
            end: 6,
            tag: "glare".into(),
            note: String::new(),
        }),
        Edit::UpdateTag(FailureTag {
            id: TagId(1),
            start: 2,
            end: 7,
            tag: "glare".into(),
            note: "low sun".into(),
        }),
        Edit::DeleteTag(TagId(1)),
        Edit::SetNote {
            frame: 4,
            text: Some("brake lights visible".into()),
        },
        Edit::SetNote {
            frame: 4,
            text: None,
        },
        Edit::Batch(vec![add_interval(20, 0, 0), add_interval(21, 7, 7)]),
    ];
    for edit in edits {
        check_undo_redo(&mut editor, edit);
    }
    let mut undone = 0;
    while editor.undo().expect("undo") {
        undone += 1;
    }
    assert_eq!(undone, 18);
    assert_eq!(
        editor.labels(),
        &ground_truth(),
        "undoing everything gives the ground truth"
    );
    assert!(editor.redo().expect("redo"));
    editor.apply(add_interval(30, 0, 1)).expect("apply");
    assert!(!editor.can_redo(), "a new edit clears the redo stack");
}

#[test]
fn invalid_edits_change_nothing() {
    let mut editor = Editor::in_memory(ground_truth());
    let before = editor.labels().clone();
    for (edit, needle) in [
        (add_interval(9, 2, 8), "outside the scenario"),
        (add_interval(9, 5, 4), "ends before it starts"),
        (add_interval(1, 0, 0), "exists already"),
        (Edit::DeleteInterval(IntervalId(77)), "no interval 77"),
        (
            Edit::SetKeyframe {
                track: TrackId(5),
                frame: 1,
                keyframe: Some(keyframe(rect(f32::NAN, 0.0, 1.0, 1.0))),
            },
            "not finite",
        ),
        (
            Edit::SetKeyframe {
                track: TrackId(5),
                frame: 1,
                keyframe: Some(keyframe(rect(4.0, 0.0, 1.0, 1.0))),
            },
            "x2 >= x1",
        ),
        (Edit::DeleteTag(TagId(3)), "no tag 3"),
        (
            Edit::Batch(vec![add_interval(9, 0, 1), add_interval(9, 2, 3)]),
            "edit 1 of a batch of 2",
        ),
    ] {
        let message = editor.apply(edit).expect_err(needle).to_string();
        assert!(message.contains(needle), "{message}");
        assert_eq!(editor.labels(), &before, "{needle}");
    }
    assert!(!editor.can_undo());
}

#[test]
fn boxes_interpolate_between_keyframes_and_follow_edits() {
    let mut editor = Editor::in_memory(ground_truth());
    let track = TrackId(40);
    editor
        .apply(Edit::AddTrack(Track {
            id: track,
            class: 14,
            keyframes: [
                (1, keyframe(rect(0.0, 0.0, 10.0, 10.0))),
                (5, keyframe(rect(40.0, 20.0, 60.0, 30.0))),
            ]
            .into(),
            origin: Origin::Analyst,
        }))
        .expect("add");
    let box_at = |editor: &Editor, frame: usize| {
        editor
            .labels()
            .boxes_at(frame)
            .into_iter()
            .find(|b| b.track == track)
    };
    assert!(box_at(&editor, 0).is_none());
    let mid = box_at(&editor, 3).expect("interpolated");
    assert_eq!(mid.rect, rect(20.0, 10.0, 35.0, 20.0));
    assert!(!mid.keyframe);
    assert_eq!(
        box_at(&editor, 7).expect("held").rect,
        rect(40.0, 20.0, 60.0, 30.0)
    );
    editor
        .apply(Edit::SetKeyframe {
            track,
            frame: 2,
            keyframe: Some(keyframe(rect(4.0, 4.0, 14.0, 14.0))),
        })
        .expect("move at 2");
    let third = box_at(&editor, 3).expect("after the move").rect;
    let expected = [16.0, 4.0 + 16.0 / 3.0, 14.0 + 46.0 / 3.0, 14.0 + 16.0 / 3.0];
    for (got, want) in [third.x1, third.y1, third.x2, third.y2]
        .iter()
        .zip(expected)
    {
        assert!((got - want).abs() < 1e-4, "{third:?}");
    }
    editor
        .apply(Edit::SetKeyframe {
            track,
            frame: 4,
            keyframe: Some(Keyframe {
                outside: true,
                ..keyframe(rect(0.0, 0.0, 1.0, 1.0))
            }),
        })
        .expect("outside from 4");
    assert!(box_at(&editor, 4).is_none());
    assert_eq!(
        box_at(&editor, 3).expect("held before outside").rect,
        rect(4.0, 4.0, 14.0, 14.0),
        "no interpolation into an outside keyframe"
    );
    assert!(box_at(&editor, 5).is_some_and(|b| b.keyframe));
    assert!(editor.undo().expect("undo"));
    assert_eq!(box_at(&editor, 3).expect("again").rect, third);
}

#[test]
fn frame_queries_and_lane() {
    let mut editor = Editor::in_memory(ground_truth());
    editor.apply(add_interval(10, 0, 1)).expect("add");
    editor
        .apply(Edit::AddTag(FailureTag {
            id: TagId(1),
            start: 1,
            end: 3,
            tag: "glare".into(),
            note: String::new(),
        }))
        .expect("tag");
    editor
        .apply(Edit::SetNote {
            frame: 6,
            text: Some("check".into()),
        })
        .expect("note");
    let labels = editor.labels();
    assert_eq!(labels.intervals_at(1).len(), 1);
    assert_eq!(labels.intervals_at(2).len(), 0);
    assert_eq!(labels.intervals_at(4)[0].start, 3);
    assert_eq!(labels.tags_at(3).len(), 1);
    let edge = labels.nearest_edge(2).expect("edge");
    assert_eq!(
        (edge.interval, edge.edge, edge.frame),
        (IntervalId(1), Edge::Start, 3),
        "a tie goes to the lower interval id"
    );
    let edge = labels.nearest_edge(0).expect("edge");
    assert_eq!(
        (edge.interval, edge.edge, edge.frame),
        (IntervalId(10), Edge::Start, 0)
    );
    let edge = labels.nearest_edge(7).expect("edge");
    assert_eq!((edge.edge, edge.frame), (Edge::End, 5));
    let moved = labels
        .interval(edge.interval)
        .expect("interval")
        .with_edge(edge.edge, 7);
    assert_eq!((moved.start, moved.end), (3, 7));

    let lane = editor.lane();
    assert_eq!(lane, LabelLane::build(editor.labels()));
    assert_eq!(
        lane.anomaly_flags(),
        vec![true, true, false, true, true, true, false, false]
    );
    assert_eq!(
        lane.cells.iter().map(|c| c.boxes).collect::<Vec<_>>(),
        vec![1, 1, 2, 2, 2, 1, 1, 1]
    );
    assert_eq!(
        lane.cells.iter().map(|c| c.tags).collect::<Vec<_>>(),
        vec![0, 1, 1, 1, 0, 0, 0, 0]
    );
    assert!(lane.cells[6].note && !lane.cells[5].note);
}
