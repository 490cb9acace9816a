//! The viewer's labeling mode driven headlessly with egui_kittest over a small generated
//! data set scored by a tiny model: the labeling keys create and edit an interval (in the
//! editor and on disk), undo and redo, an interval edge dragged on the timeline lands on
//! the frame under the pointer, a box drawn on the frame is added and can be moved and
//! deleted, the reference switch makes the analyst's labels the reference of the metrics,
//! and a damaged label file is reported and set aside.

use egui::{Key, Modifiers};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use vadscope::annotate::{Editor, Interval, LabelSet, Origin, Step, read_journal};
use vadscope::app::{Action, AppState, Dataset, LogLevel, Reference, ViewSettings, ViewerApp};
use vadscope::sequence::Scenario;

use crate::support::app::{drag, generate_dataset, setup, viewer_harness};

/// The harness with the labeling mode on.
fn labeling(dir: &std::path::Path) -> Harness<'static, ViewerApp> {
    let mut h = viewer_harness(dir);
    h.key_press(Key::L);
    h.run();
    assert!(h.state().state().is_labeling());
    assert!(h.state().state().current_labels().is_some(), "labels open");
    h
}

fn labels(h: &Harness<'_, ViewerApp>) -> LabelSet {
    h.state()
        .state()
        .current_labels()
        .expect("labels open")
        .labels()
        .clone()
}

fn analyst_intervals(labels: &LabelSet) -> Vec<(usize, usize)> {
    labels
        .intervals()
        .filter(|i| i.origin == Origin::Analyst)
        .map(|i| (i.start, i.end))
        .collect()
}

fn seek(h: &mut Harness<'_, ViewerApp>, frame: usize) {
    h.state_mut().state_mut().apply(Action::Seek(frame));
    h.run();
}

/// The current scenario, opened afresh from disk.
fn scenario_on_disk(h: &Harness<'_, ViewerApp>) -> Scenario {
    let root = h.state().state().entry().expect("entry").root.clone();
    Scenario::open(&root).expect("scenario")
}

#[test]
fn labeling_keys_create_and_edit_an_interval_with_undo_and_redo_on_disk() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = labeling(dir.path());
    seek(&mut h, 2);
    h.key_press(Key::OpenBracket);
    h.run();
    assert_eq!(h.state().state().labeling().mark, Some(2));
    for _ in 0..3 {
        h.key_press(Key::ArrowRight);
    }
    h.run();
    h.key_press(Key::CloseBracket);
    h.run();
    assert_eq!(analyst_intervals(&labels(&h)), vec![(2, 5)]);

    // E at frame 4: the nearest edge is the new interval's end (5).
    h.key_press(Key::ArrowLeft);
    h.run();
    h.key_press(Key::E);
    h.run();
    assert_eq!(analyst_intervals(&labels(&h)), vec![(2, 4)]);

    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.run();
    assert_eq!(analyst_intervals(&labels(&h)), vec![(2, 5)], "undo");
    h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z);
    h.run();
    assert_eq!(analyst_intervals(&labels(&h)), vec![(2, 4)], "redo");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.run();
    h.key_press_modifiers(Modifiers::COMMAND, Key::Y);
    h.run();
    assert_eq!(
        analyst_intervals(&labels(&h)),
        vec![(2, 4)],
        "Ctrl+Y redoes"
    );

    // T tags the marked range with the text typed in the labeling bar.
    h.key_press(Key::OpenBracket);
    h.run();
    seek(&mut h, 6);
    *h.state_mut().state_mut().tag_text_mut() = "glare".into();
    h.key_press(Key::T);
    h.run();
    let tags: Vec<(usize, usize, String)> = labels(&h)
        .tags()
        .map(|t| (t.start, t.end, t.tag.clone()))
        .collect();
    assert_eq!(tags, vec![(4, 6, "glare".to_string())]);

    // Every edit is in the journal already; a fresh editor opened from disk has them.
    let in_memory = labels(&h);
    let dir_of_labels = h
        .state()
        .state()
        .current_labels()
        .and_then(|l| l.editor().dir().map(std::path::Path::to_path_buf))
        .expect("labels on disk");
    let journal = read_journal(&dir_of_labels.join("labels.journal")).expect("journal");
    let steps: Vec<Step> = journal.records.iter().map(|r| r.step).collect();
    assert!(
        steps.contains(&Step::Undo) && steps.contains(&Step::Redo),
        "{steps:?}"
    );
    let scenario = scenario_on_disk(&h);
    drop(h);
    let reopened = Editor::open(&scenario).expect("reopen");
    assert_eq!(
        *reopened.labels(),
        in_memory,
        "the labels on disk are the shown ones"
    );
}

#[test]
fn labeling_keys_do_nothing_outside_the_labeling_mode() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = viewer_harness(dir.path());
    h.key_press(Key::OpenBracket);
    h.run();
    assert_eq!(h.state().state().labeling().mark, None);
    assert!(
        h.state()
            .state()
            .log_entries()
            .iter()
            .any(|e| e.level == LogLevel::Warning && e.message.contains("press L"))
    );
}

#[test]
fn dragging_an_interval_edge_on_the_timeline_moves_it_to_the_frame_under_the_pointer() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = labeling(dir.path());
    let truth: Interval = labels(&h)
        .intervals()
        .find(|i| i.origin == Origin::GroundTruth)
        .cloned()
        .expect("the ground truth's interval");
    assert_eq!((truth.start, truth.end), (8, 13));
    let start = h.state().timeline_label_point(8).expect("timeline drawn");
    h.hover_at(start);
    h.run();
    assert_eq!(
        h.output().platform_output.cursor_icon,
        egui::CursorIcon::ResizeHorizontal,
        "the edge shows it can be dragged"
    );
    let frame_before = h.state().state().frame();
    let target = h.state().timeline_label_point(4).expect("timeline drawn");
    drag(&mut h, start, target);
    let moved = labels(&h).interval(truth.id).cloned().expect("interval");
    assert_eq!((moved.start, moved.end), (4, 13));
    assert_eq!(
        h.state().state().frame(),
        frame_before,
        "an edge drag does not seek"
    );
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.run();
    let back = labels(&h).interval(truth.id).cloned().expect("interval");
    assert_eq!(
        (back.start, back.end),
        (8, 13),
        "the drag is one undoable edit"
    );
}

#[test]
fn drawing_a_box_on_the_frame_adds_it_and_it_can_be_moved_and_deleted() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = labeling(dir.path());
    seek(&mut h, 3);
    let tracks_before = labels(&h).tracks().len();
    // A corner of the frame that no ground-truth box covers.
    let empty = |h: &Harness<'_, ViewerApp>, x: f32, y: f32| {
        labels(h)
            .boxes_at(3)
            .iter()
            .all(|b| !(b.rect.x1..=b.rect.x2).contains(&x) || !(b.rect.y1..=b.rect.y2).contains(&y))
    };
    assert!(empty(&h, 4.0, 4.0), "the top-left corner is free");
    let from = h.state().frame_point(4.0, 4.0).expect("frame drawn");
    let to = h.state().frame_point(24.0, 16.0).expect("frame drawn");
    drag(&mut h, from, to);
    let set = labels(&h);
    assert_eq!(set.tracks().len(), tracks_before + 1, "a track was added");
    let new = set
        .tracks()
        .find(|t| t.origin == Origin::Analyst)
        .expect("the drawn track");
    let rect = new.box_at(3).expect("visible at the frame").rect;
    for (got, want) in [
        (rect.x1, 4.0),
        (rect.y1, 4.0),
        (rect.x2, 24.0),
        (rect.y2, 16.0),
    ] {
        assert!((got - want).abs() <= 1.0, "{rect:?}");
    }
    let track = new.id;
    assert_eq!(h.state().state().labeling().selected_box, Some(track));

    // Drag it by (10, 6) frame pixels: a keyframe at this frame.
    let grab = h.state().frame_point(14.0, 10.0).expect("frame drawn");
    let drop = h.state().frame_point(24.0, 16.0).expect("frame drawn");
    drag(&mut h, grab, drop);
    let moved = labels(&h)
        .track(track)
        .and_then(|t| t.box_at(3))
        .expect("box");
    assert!(
        (moved.rect.x1 - 14.0).abs() <= 1.0 && (moved.rect.y1 - 10.0).abs() <= 1.0,
        "{moved:?}"
    );
    assert!(moved.keyframe);

    h.key_press(Key::Delete);
    h.run();
    assert!(
        labels(&h).track(track).and_then(|t| t.box_at(3)).is_none(),
        "deleted"
    );
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.run();
    assert!(
        labels(&h).track(track).and_then(|t| t.box_at(3)).is_some(),
        "undone"
    );
}

#[test]
fn the_reference_switch_measures_the_metrics_against_the_analyst_labels() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = labeling(dir.path());
    let auroc = |h: &Harness<'_, ViewerApp>| {
        h.state()
            .state()
            .dataset_metrics()
            .micro
            .expect("both classes")
            .auroc
    };
    let truth_auroc = auroc(&h);
    // Label frames 4–7 anomalous too: the analyst's reference differs from the truth.
    seek(&mut h, 4);
    h.key_press(Key::OpenBracket);
    h.run();
    seek(&mut h, 7);
    h.key_press(Key::CloseBracket);
    h.run();
    assert_eq!(
        auroc(&h),
        truth_auroc,
        "ground truth is still the reference"
    );
    h.get_by_label("analyst labels").click();
    h.run();
    assert_eq!(
        h.state().state().settings().reference,
        Reference::AnalystLabels
    );
    let analyst_auroc = auroc(&h);
    assert_ne!(format!("{truth_auroc:.3}"), format!("{analyst_auroc:.3}"));
    h.get_by_label_contains("measured against the analyst's labels");
    assert!(
        h.query_all_by_label(&format!("{analyst_auroc:.3}"))
            .next()
            .is_some(),
        "the new AUROC is shown"
    );
    assert!(
        h.state().state().reference_labels()[5],
        "frame 5 is labelled"
    );
    h.get_by_label("ground truth").click();
    h.run();
    assert_eq!(auroc(&h), truth_auroc);
}

#[test]
fn a_damaged_label_file_is_reported_and_set_aside() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = generate_dataset(dir.path());
    let model = crate::support::app::tiny_checkpoint(dir.path());
    let mut state = AppState::new(setup(&model), ViewSettings::default());
    state.set_dataset(Dataset::open(&root).expect("data set"));
    let scenario = state
        .entry()
        .and_then(|e| e.scenario.as_ref())
        .expect("scenario");
    let folder = scenario.cache_dir().expect("cache dir");
    std::fs::create_dir_all(&folder).expect("mkdir");
    let damaged = folder.join("labels.json");
    std::fs::write(&damaged, b"{ this is not json\n").expect("write");
    state.apply(Action::ToggleLabeling);
    assert!(state.current_labels().is_some(), "labels open anyway");
    let log = state.log_entries();
    assert!(
        log.iter()
            .any(|e| e.level == LogLevel::Error && e.message.contains("labels.json")),
        "{log:?}"
    );
    let copies: Vec<_> = std::fs::read_dir(&folder)
        .expect("read dir")
        .filter_map(Result::ok)
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .starts_with("labels.json.corrupt-")
        })
        .collect();
    assert_eq!(copies.len(), 1, "the damaged file is kept aside");
    assert_eq!(
        std::fs::read(copies[0].path()).expect("copy"),
        b"{ this is not json\n"
    );
    assert!(
        log.iter().any(|e| e.message.contains("corrupt-")),
        "the copy is named in the log"
    );
}
