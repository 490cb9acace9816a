//! The viewer's egui layer driven headlessly with egui_kittest: a small generated data set
//! scored by a tiny model, frames stepped with keys, a weight slider moved (the metrics text
//! changes), the threshold line dragged on the timeline, a failure case clicked (the
//! timeline jumps there), overlays and views toggled, the help overlay, the export dialog
//! writing PNG, GIF and `scores.csv`, and a malformed scenario shown as an error instead of
//! a crash.

use egui::accesskit::Role;
use egui::{Key, Modifiers};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use vadscope::app::{ThresholdMode, ViewMode, ViewerApp};
use vadscope::render::SCORES_HEADER;

use crate::support::app::{drag, viewer_harness};

fn harness(dir: &std::path::Path) -> Harness<'static, ViewerApp> {
    viewer_harness(dir)
}

#[test]
fn keys_step_frames_and_the_frame_is_always_shown() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(dir.path());
    assert_eq!(h.state().state().frame(), 0);
    h.key_press(Key::ArrowRight);
    h.run();
    assert_eq!(h.state().state().frame(), 1);
    h.key_press_modifiers(Modifiers::SHIFT, Key::ArrowRight);
    h.run();
    assert_eq!(h.state().state().frame(), 11);
    h.key_press(Key::ArrowLeft);
    h.run();
    assert_eq!(h.state().state().frame(), 10);
    let id = h.state().state().frame_info().id.expect("AnoVox id").0;
    h.get_by_label_contains(&format!("frame 10 / 15   AnoVox id {id}"));
    h.key_press(Key::End);
    h.run();
    assert_eq!(h.state().state().frame(), 15);
    h.key_press(Key::Home);
    h.key_press_modifiers(Modifiers::COMMAND, Key::ArrowRight);
    h.run();
    let onset = h
        .state()
        .state()
        .labels()
        .iter()
        .position(|&l| l)
        .expect("an event");
    assert_eq!(
        h.state().state().frame(),
        onset,
        "Ctrl+→ goes to the anomaly onset"
    );
    h.key_press(Key::PageDown);
    h.run();
    assert_eq!(h.state().state().current_scenario(), 1);
}

#[test]
fn moving_a_weight_slider_changes_the_metrics_text() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(dir.path());
    let auroc = |h: &Harness<'_, ViewerApp>| {
        h.state()
            .state()
            .dataset_metrics()
            .micro
            .expect("both classes in the data set")
            .auroc
    };
    let before = auroc(&h);
    assert!(
        h.query_all_by_label(&format!("{before:.3}"))
            .next()
            .is_some()
    );
    h.get_all_by_label("w_r")
        .next()
        .expect("w_r slider")
        .set_value_accesskit(0.0);
    h.run();
    assert_eq!(h.state().state().settings().weights.w_r, 0.0);
    let after = auroc(&h);
    assert_ne!(
        format!("{before:.3}"),
        format!("{after:.3}"),
        "the weight matters"
    );
    assert!(
        h.query_all_by_label(&format!("{after:.3}"))
            .next()
            .is_some(),
        "the new AUROC is shown"
    );
}

#[test]
fn clicking_a_failure_case_jumps_to_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(dir.path());
    let mut settings = h.state().state().settings().clone();
    settings.threshold_mode = ThresholdMode::Manual;
    settings.manual_threshold = -1e12;
    h.state_mut().state_mut().set_settings(settings);
    h.run();
    let case = h
        .state()
        .state()
        .failures()
        .first()
        .cloned()
        .expect("a false alarm");
    let text = format!("frames {}–{}", case.start, case.end);
    h.get_all_by_label_contains(&text)
        .next()
        .expect("listed")
        .click();
    h.run();
    let state = h.state().state();
    assert_eq!(
        (state.current_scenario(), state.frame()),
        (case.scenario, case.focus)
    );
    assert_eq!(state.failure_cursor(), Some(0));
}

#[test]
fn overlays_and_views_toggle_and_change_the_picture() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(dir.path());
    h.key_press(Key::ArrowRight);
    h.run();
    let with_boxes = h.render().expect("render");
    h.key_press(Key::B);
    h.run();
    assert!(!h.state().state().settings().overlays.boxes);
    let without_boxes = h.render().expect("render");
    assert_ne!(
        with_boxes.as_raw(),
        without_boxes.as_raw(),
        "the boxes are drawn"
    );
    h.get_by_label("heatmap").click();
    h.run();
    assert!(!h.state().state().settings().overlays.heatmap);
    h.key_press(Key::Num2);
    h.run();
    assert_eq!(h.state().state().settings().view, ViewMode::Prediction);
    h.key_press(Key::Num3);
    h.run();
    assert_eq!(h.state().state().settings().view, ViewMode::Flow);
    let flow = h.render().expect("render");
    assert_ne!(flow.as_raw(), without_boxes.as_raw());
}

#[test]
fn the_help_overlay_lists_the_keys() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(dir.path());
    assert!(h.query_by_label("previous anomaly event").is_none());
    h.key_press(Key::F1);
    h.run();
    h.get_by_label("previous anomaly event");
    h.get_by_label("Shift+Right");
    h.key_press(Key::F1);
    h.run();
    assert!(h.query_by_label("previous anomaly event").is_none());
}

#[test]
fn a_malformed_scenario_is_an_error_in_the_log_not_a_crash() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(dir.path());
    let broken = dir.path().join("broken").join("Scenario_0_bad");
    std::fs::create_dir_all(broken.join("RGB_IMG")).expect("mkdir");
    std::fs::write(broken.join("RGB_IMG").join("RGB_IMG_0.png"), b"not a png").expect("write");
    h.state_mut().open(&dir.path().join("broken"));
    h.state_mut().state_mut().wait_for_scoring();
    for _ in 0..3 {
        h.key_press(Key::ArrowRight);
        h.run();
    }
    let errors = h.query_all_by_label_contains("RGB_IMG_0.png").count();
    assert!(errors > 0, "the bad file is named in the log");
}

#[test]
fn dragging_the_threshold_line_moves_the_threshold() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(dir.path());
    let before = h.state().state().threshold();
    let on_line = h
        .state()
        .timeline_score_point(6, before)
        .expect("timeline drawn");
    h.hover_at(on_line);
    h.run();
    assert_eq!(
        h.output().platform_output.cursor_icon,
        egui::CursorIcon::ResizeVertical,
        "the threshold line shows it can be dragged"
    );
    let frame_before = h.state().state().frame();
    drag(&mut h, on_line, on_line + egui::vec2(0.0, -25.0));
    let state = h.state().state();
    assert_eq!(state.settings().threshold_mode, ThresholdMode::Manual);
    let after = state.threshold();
    assert!(after > before, "dragged up: {before} -> {after}");
    assert_eq!(
        state.frame(),
        frame_before,
        "a threshold drag does not seek"
    );
    h.get_by_label(&format!("threshold {after:.3}"));
}

#[test]
fn the_export_dialog_writes_png_gif_and_scores_csv() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(dir.path());
    h.key_press_modifiers(Modifiers::COMMAND, Key::E);
    h.run();
    h.get_by_label("all frames").click();
    h.run();
    h.get_by_label("animated GIF").click();
    h.run();
    let out = dir.path().join("exported");
    let field = h.get_by_role_and_label(Role::TextInput, "export folder");
    field.focus();
    h.run();
    h.get_by_role_and_label(Role::TextInput, "export folder")
        .type_text(&out.display().to_string());
    h.run();
    h.get_by_label("Export").click();
    h.run_steps(2);
    h.state_mut().state_mut().wait_for_export();
    h.run();
    let frames = h.state().state().entry().expect("entry").frames;
    for index in 0..frames {
        assert!(
            out.join(format!("frame_{index:05}.png")).is_file(),
            "frame {index} written"
        );
    }
    let gif = std::fs::read(out.join("frame.gif")).expect("the GIF");
    assert!(gif.starts_with(b"GIF89a"));
    let csv = std::fs::read_to_string(out.join("scores.csv")).expect("scores.csv");
    assert!(csv.contains(SCORES_HEADER));
    assert_eq!(
        csv.lines().filter(|l| !l.starts_with('#')).count(),
        frames + 1,
        "a header and one row per frame"
    );
    assert!(
        h.state()
            .state()
            .log_entries()
            .iter()
            .any(|e| e.message.contains(&format!("{} files written", frames + 2)))
    );
}
