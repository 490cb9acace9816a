//! The viewer's egui layer driven headlessly with egui_kittest: a small generated data set
//! scored by a tiny model, frames stepped with keys, a weight slider moved (the metrics text
//! changes), a failure case clicked (the timeline jumps there), overlays and views toggled,
//! the help overlay, and a malformed scenario shown as an error instead of a crash.

mod app_common;

use app_common::{generate_dataset, scored_state};
use egui::{Key, Modifiers};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use vadscope::app::{Layout, ThresholdMode, ViewMode, ViewerApp};

/// The viewer over a scored generated data set, drawn at 1400×900.
fn harness(dir: &std::path::Path) -> Harness<'static, ViewerApp> {
    let root = generate_dataset(dir);
    let model = app_common::tiny_checkpoint(dir);
    let state = scored_state(&root, &model);
    let app = ViewerApp::with_state(state, Layout::default());
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .wgpu()
        .build_ui_state(|ui, app: &mut ViewerApp| app.show(ui), app);
    harness.run();
    harness
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
