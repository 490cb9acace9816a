//! Export and import round trips for every label format, imports as undoable edits, and
//! clear errors for malformed files.

use std::path::Path;

use vadscope::annotate::{
    Edit, Editor, FailureTag, Interval, IntervalId, Keyframe, LabelFormat, LabelLane, LabelSet,
    Origin, TagId, Track, TrackId, export_labels, ground_truth_labels, import_labels,
};
use vadscope::sequence::Scenario;

use crate::support::annotate::{FRAMES, frame_id, keyframe, rect, write_scenario};

/// Ground truth plus an analyst's interval, tag, note and an interpolated track.
fn edited(scenario: &Scenario) -> Editor {
    let (labels, _) = ground_truth_labels(scenario);
    let mut editor = Editor::in_memory(labels);
    for edit in [
        Edit::AddInterval(Interval {
            id: IntervalId(7),
            start: 0,
            end: 1,
            class: "cut-in".into(),
            note: "left lane, \"late\"\nsecond look".into(),
            origin: Origin::Analyst,
        }),
        Edit::AddTag(FailureTag {
            id: TagId(2),
            start: 5,
            end: 7,
            tag: "glare".into(),
            note: "sun, low".into(),
        }),
        Edit::SetNote {
            frame: 6,
            text: Some("re-check".into()),
        },
        Edit::AddTrack(Track {
            id: TrackId(30),
            class: 16,
            keyframes: [
                (1, keyframe(rect(0.0, 0.0, 10.0, 10.0))),
                (
                    4,
                    Keyframe {
                        anomalous: true,
                        ..keyframe(rect(7.0, 3.0, 20.0, 13.0))
                    },
                ),
                (
                    6,
                    Keyframe {
                        outside: true,
                        ..keyframe(rect(7.0, 3.0, 20.0, 13.0))
                    },
                ),
            ]
            .into(),
            origin: Origin::Analyst,
        }),
    ] {
        editor.apply(edit).expect("edit");
    }
    editor
}

fn assert_same_boxes(a: &LabelSet, b: &LabelSet, with_anomalous: bool, format: LabelFormat) {
    for frame in 0..FRAMES as usize {
        let (left, right) = (a.boxes_at(frame), b.boxes_at(frame));
        assert_eq!(left.len(), right.len(), "{format}: frame {frame}");
        for (x, y) in left.iter().zip(&right) {
            assert_eq!(
                (x.track, x.class),
                (y.track, y.class),
                "{format}: frame {frame}"
            );
            let (p, q) = (x.rect, y.rect);
            for (u, v) in [(p.x1, q.x1), (p.y1, q.y1), (p.x2, q.x2), (p.y2, q.y2)] {
                assert!(
                    (u - v).abs() < 1e-3,
                    "{format}: frame {frame}: {p:?} vs {q:?}"
                );
            }
            if with_anomalous {
                assert_eq!(x.anomalous, y.anomalous, "{format}: frame {frame}");
            }
        }
    }
}

/// Exports `format`, imports it into the plain ground truth, and returns both editors.
fn round_trip(scenario: &Scenario, format: LabelFormat, path: &Path) -> (Editor, Editor) {
    let source = edited(scenario);
    let summary = export_labels(scenario, source.labels(), format, path).expect("export");
    assert!(summary.records > 0, "{format}");
    let (labels, _) = ground_truth_labels(scenario);
    let mut target = Editor::in_memory(labels);
    let before = target.labels().clone();
    let import = import_labels(scenario, target.labels(), format, path).expect("import");
    assert_eq!(import.unmatched, 0, "{format}");
    target.apply(import.edit).expect("apply import");
    assert!(target.undo().expect("undo"), "{format}");
    assert_eq!(target.labels(), &before, "{format}: the import undoes");
    assert!(target.redo().expect("redo"));
    (source, target)
}

#[test]
fn box_formats_round_trip() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scenario = Scenario::open(&write_scenario(dir.path())).expect("open");
    for (format, name) in [
        (LabelFormat::BoxesCsv, "boxes.csv"),
        (LabelFormat::Mot, "gt.txt"),
        (LabelFormat::Coco, "labels.json"),
        (LabelFormat::Yolo, "yolo"),
    ] {
        let path = dir.path().join(name);
        let (source, target) = round_trip(&scenario, format, &path);
        assert_same_boxes(
            source.labels(),
            target.labels(),
            format == LabelFormat::BoxesCsv,
            format,
        );
        assert!(
            target
                .labels()
                .tracks()
                .all(|t| t.origin == Origin::Imported),
            "{format}"
        );
        assert_eq!(
            source.labels().intervals().len(),
            target.labels().intervals().len() + 1,
            "{format}: box formats leave intervals alone"
        );
    }
    let boxes = std::fs::read_to_string(dir.path().join("boxes.csv")).expect("boxes.csv");
    assert!(
        boxes
            .lines()
            .nth(1)
            .is_some_and(|l| l.starts_with("100,5,")),
        "AnoVox ids: {boxes}"
    );
    let mot = std::fs::read_to_string(dir.path().join("gt.txt")).expect("gt.txt");
    assert!(
        mot.starts_with("1,5,8,24,16,16,1,14,1\n"),
        "MOT frames count from 1: {mot}"
    );
    let yolo = std::fs::read_to_string(dir.path().join("yolo/RGB_IMG_104.txt")).expect("yolo");
    assert_eq!(
        yolo.lines().count(),
        3,
        "frame 2: square, second box, track 30"
    );
    assert!(yolo.lines().all(|l| l.split(' ').count() == 7), "{yolo}");
}

#[test]
fn table_formats_round_trip() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scenario = Scenario::open(&write_scenario(dir.path())).expect("open");

    let path = dir.path().join("intervals.csv");
    let (source, target) = round_trip(&scenario, LabelFormat::IntervalsCsv, &path);
    let (a, b) = (source.labels(), target.labels());
    assert_eq!(
        a.intervals().collect::<Vec<_>>(),
        b.intervals().collect::<Vec<_>>()
    );
    assert_eq!(a.tags().collect::<Vec<_>>(), b.tags().collect::<Vec<_>>());
    assert_eq!(a.notes().collect::<Vec<_>>(), b.notes().collect::<Vec<_>>());
    let text = std::fs::read_to_string(&path).expect("csv");
    assert!(
        text.contains(",100,102,cut-in,"),
        "AnoVox ids beside indices: {text}"
    );

    let path = dir.path().join("frame_labels.csv");
    let (source, target) = round_trip(&scenario, LabelFormat::FrameLabels, &path);
    let flags = LabelLane::build(source.labels()).anomaly_flags();
    assert_eq!(flags, LabelLane::build(target.labels()).anomaly_flags());
    assert_eq!(
        flags,
        vec![true, true, false, true, true, true, false, false]
    );
    let rows = vadscope::sequence::labels::read_frame_labels(&path).expect("frame labels");
    assert_eq!(rows[3], (frame_id(3), true));
}

#[test]
fn malformed_imports_name_the_file_and_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scenario = Scenario::open(&write_scenario(dir.path())).expect("open");
    let (labels, _) = ground_truth_labels(&scenario);
    for (format, name, text, needle) in [
        (
            LabelFormat::Mot,
            "gt.txt",
            "1,5,8,24,16,16\n2,5,8,x,16,16\n",
            "gt.txt:2",
        ),
        (
            LabelFormat::IntervalsCsv,
            "i.csv",
            "kind,id,start_index,end_index,start_frame,end_frame,label,note\nwindow,1,0,1,,,a,\n",
            "i.csv:2",
        ),
        (
            LabelFormat::IntervalsCsv,
            "j.csv",
            "kind,id\n",
            "lacks column",
        ),
        (
            LabelFormat::FrameLabels,
            "f.csv",
            "frame,anomaly\n100,7\n",
            "f.csv:2",
        ),
        (LabelFormat::Coco, "c.json", "{\"annotations\": [", "c.json"),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).expect("write");
        let message = import_labels(&scenario, &labels, format, &path)
            .expect_err(name)
            .to_string();
        assert!(message.contains(needle), "{message}");
    }
}
