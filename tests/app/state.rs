//! The viewer's core without egui: stepping, seeking and playback, event navigation,
//! weights changing the metrics, failure cases and their jumps, tags and CSV, the scoring
//! job on generated scenarios with a tiny model, and malformed data ending up as errors in
//! the state, never as a panic.

use vadscope::app::{
    Action, AppState, BACKGROUND_FRAME_CACHE, CURRENT_FRAME_CACHE, FailureKind, LogLevel, Playback,
    ScoreStatus, ThresholdMode, ViewSettings,
};
use vadscope::score::{FusionWeights, ModelKey, ScoreRequest};
use vadscope::sequence::Scenario;

use crate::support::app::{
    ANOMALY, FRAMES, generate_dataset, scored_state, setup, state_of_tables, table, tiny_checkpoint,
};

/// Labels of `frames` frames, anomalous in `window`.
fn labels(frames: usize, window: std::ops::RangeInclusive<usize>) -> Vec<bool> {
    (0..frames).map(|i| window.contains(&i)).collect()
}

/// Settings that score frames by S_r alone, unfiltered, with a manual threshold.
fn flow_only(threshold: f64) -> ViewSettings {
    ViewSettings {
        weights: FusionWeights {
            w_r: 1.0,
            w_p: 0.0,
            w_r_p: 1.0,
            w_p_p: 0.0,
        },
        median_kernel: 1,
        threshold_mode: ThresholdMode::Manual,
        manual_threshold: threshold,
        ..ViewSettings::default()
    }
}

/// Two in-memory scenarios with known failures under [`flow_only`]`(1.0)` (score = S_r − 2):
/// A has a false alarm at frames 8–10 (peak at 9) and an anomaly 15–25 first reached at
/// 22 (7 frames late); B has a missed anomaly 10–14 and a false alarm at 20–21.
fn failure_state() -> AppState {
    let a = table(
        30,
        |i| match i {
            9 => 6.0,
            8 | 10 => 5.0,
            22..=25 => 5.0,
            _ => 2.0,
        },
        |_| 0.5,
    );
    let b = table(
        30,
        |i| if (20..=21).contains(&i) { 4.0 } else { 2.0 },
        |_| 0.5,
    );
    let mut state = state_of_tables(vec![
        ("A", a, labels(30, 15..=25)),
        ("B", b, labels(30, 10..=14)),
    ]);
    state.set_settings(flow_only(1.0));
    state
}

#[test]
fn stepping_and_seeking_stay_inside_the_scenario() {
    let mut state = state_of_tables(vec![(
        "A",
        table(20, |_| 2.0, |_| 0.5),
        labels(20, 10..=12),
    )]);
    assert_eq!(state.frame(), 0);
    state.apply(Action::Step(1));
    assert_eq!(state.frame(), 1);
    state.apply(Action::Step(-5));
    assert_eq!(state.frame(), 0, "clamped at the first frame");
    state.apply(Action::Step(10));
    assert_eq!(state.frame(), 10);
    state.apply(Action::Step(10));
    assert_eq!(state.frame(), 19, "clamped at the last frame");
    state.apply(Action::First);
    assert_eq!(state.frame(), 0);
    state.apply(Action::Last);
    assert_eq!(state.frame(), 19);
    state.apply(Action::Seek(1000));
    assert_eq!(state.frame(), 19);
    state.apply(Action::Seek(7));
    let info = state.frame_info();
    assert_eq!((info.index, info.anomalous), (7, false));
    assert!(info.filtered.is_some_and(f64::is_finite));
}

#[test]
fn playback_moves_by_whole_frames_and_stops_at_the_end() {
    let mut playback = Playback::new(20, 10.0);
    assert!(!playback.advance(1.0), "paused playback does not move");
    playback.toggle();
    assert!(playback.advance(0.25));
    assert_eq!(playback.frame(), 2, "0.25 s at 10 fps is two frames");
    assert!(!playback.advance(0.04), "less than a frame");
    assert!(playback.advance(0.06));
    assert_eq!(playback.frame(), 3, "the remainder is kept");
    playback.advance(100.0);
    assert_eq!(playback.frame(), 19);
    assert!(!playback.is_playing(), "stops at the last frame");
    playback.toggle();
    assert_eq!(playback.frame(), 0, "playing from the end starts over");
}

#[test]
fn event_keys_jump_to_anomaly_onsets() {
    let mut state = failure_state();
    state.apply(Action::NextEvent);
    assert_eq!(state.frame(), 15);
    state.apply(Action::NextEvent);
    assert_eq!(state.frame(), 15, "no later event");
    state.apply(Action::Seek(20));
    state.apply(Action::PreviousEvent);
    assert_eq!(state.frame(), 15);
    state.apply(Action::StepScenario(1));
    assert_eq!((state.current_scenario(), state.frame()), (1, 0));
    state.apply(Action::NextEvent);
    assert_eq!(state.frame(), 10);
}

#[test]
fn weights_change_the_metrics_of_the_scenario_and_the_data_set() {
    // S_r rises inside the anomaly, S_p falls: the flow weight separates, the frame weight
    // inverts.
    let frames = 60;
    let truth = labels(frames, 30..=45);
    let wobble = |i: usize| ((i * 37) % 11) as f32 * 0.05;
    let t = table(
        frames,
        |i| {
            if truth_at(i) {
                5.0 + wobble(i)
            } else {
                2.0 + wobble(i)
            }
        },
        |i| {
            if truth_at(i) {
                0.2 + wobble(i) * 0.1
            } else {
                0.8 + wobble(i) * 0.1
            }
        },
    );
    fn truth_at(i: usize) -> bool {
        (30..=45).contains(&i)
    }
    let mut state = state_of_tables(vec![("A", t, truth)]);
    state.set_settings(flow_only(1.0));
    let flow = state
        .current_analysis()
        .and_then(|a| a.metrics)
        .expect("metrics");
    let data_flow = state.dataset_metrics().micro.expect("data set metrics");
    assert!(flow.auroc > 0.95, "{flow:?}");
    assert_eq!(
        flow.auroc, data_flow.auroc,
        "one scenario: micro = scenario"
    );
    assert_eq!(state.dataset_metrics().macro_auroc.map(|(_, n)| n), Some(1));

    let mut settings = state.settings().clone();
    settings.weights.w_r = 0.0;
    settings.weights.w_p = 1.0;
    state.set_settings(settings);
    let frame = state
        .current_analysis()
        .and_then(|a| a.metrics)
        .expect("metrics");
    assert!(frame.auroc < 0.05, "{frame:?}");
    assert_ne!(
        state.dataset_metrics().micro.expect("metrics").auroc,
        data_flow.auroc
    );
}

#[test]
fn failure_cases_are_found_ranked_and_jumped_to() {
    let mut state = failure_state();
    let cases: Vec<(FailureKind, usize, usize, usize, usize)> = state
        .failures()
        .iter()
        .map(|c| (c.kind, c.scenario, c.start, c.end, c.focus))
        .collect();
    assert_eq!(
        cases,
        vec![
            (FailureKind::FalseAlarm, 0, 8, 10, 9),
            (FailureKind::FalseAlarm, 1, 20, 21, 20),
            (FailureKind::Missed, 1, 10, 14, 10),
            (FailureKind::Late, 0, 15, 25, 22),
        ]
    );
    assert_eq!(state.failures()[3].latency, Some(7));
    let data = state.dataset_metrics();
    assert_eq!(
        (data.events, data.detected, data.mean_latency),
        (2, 1, Some(7.0))
    );

    state.apply(Action::JumpToFailure(2));
    assert_eq!((state.current_scenario(), state.frame()), (1, 10));
    state.apply(Action::StepFailure(1));
    assert_eq!((state.current_scenario(), state.frame()), (0, 22));
    state.apply(Action::StepFailure(1));
    assert_eq!(
        (state.current_scenario(), state.frame()),
        (0, 9),
        "wraps around"
    );
    state.apply(Action::StepFailure(-1));
    assert_eq!(state.failure_cursor(), Some(3));

    // Allowing 10 frames of latency, the late anomaly counts as found in time.
    let mut settings = state.settings().clone();
    settings.late_after = 10;
    state.set_settings(settings);
    assert!(state.failures().iter().all(|c| c.kind != FailureKind::Late));
    assert_eq!(state.failure_cursor(), None, "the case jumped to is gone");
}

#[test]
fn failure_csv_lists_every_case_with_its_tag() {
    let mut state = failure_state();
    state.set_failure_tag(0, "turning vehicle, left");
    assert_eq!(state.failure_tag(0), Some("turning vehicle, left"));
    let csv = state.failures_csv();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 5, "{csv}");
    assert!(lines[0].starts_with("scenario,kind,start_frame,end_frame,focus_frame"));
    assert_eq!(
        lines[1],
        "A,false alarm,8,10,9,,,,4.000000,,\"turning vehicle, left\""
    );
    assert!(lines[4].starts_with("A,late detection,15,25,22,"), "{csv}");
    state.set_failure_tag(0, "  ");
    assert_eq!(state.failure_tag(0), None, "an empty tag removes it");
}

#[test]
fn the_scoring_job_scores_generated_scenarios_and_reuses_their_caches() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = generate_dataset(dir.path());
    let model = tiny_checkpoint(dir.path());
    let mut state = scored_state(&root, &model);
    let dataset = state.dataset().expect("open");
    assert_eq!(dataset.len(), 2);
    for entry in &dataset.scenarios {
        assert!(
            matches!(entry.status, ScoreStatus::Ready(_)),
            "{}: {:?}",
            entry.name,
            entry.status.label()
        );
        assert_eq!(entry.frames, FRAMES as usize);
    }
    let onset = state.labels().iter().position(|&l| l);
    assert_eq!(
        onset,
        Some(*ANOMALY.start() as usize),
        "the city scenario's labels are read"
    );
    let analysis = state.current_analysis().expect("fused");
    assert_eq!(analysis.series.fused.len(), FRAMES as usize);
    assert!(analysis.series.fused.iter().all(|s| s.is_finite()));
    assert_eq!(state.dataset_metrics().scenarios, 2);
    let frame = (0..FRAMES as usize)
        .find(|&i| {
            state.apply(Action::Seek(i));
            !state.frame_objects().is_empty()
        })
        .expect("a frame with objects");
    let objects = state.frame_objects();
    let maps = state.frame_maps().expect("cache").expect("maps");
    assert_eq!(maps.len(), objects.len(), "frame {frame}");
    let o = objects[0];
    assert!(
        (o.score - (10.0 * o.z_r + 0.1 * o.z_p)).abs() < 1e-9,
        "paper-text weights"
    );
    let [x1, y1, x2, y2] = o.bbox;
    let hit = state
        .object_at((x1 + x2) / 2.0, (y1 + y2) / 2.0)
        .expect("box under its centre");
    assert!(hit.bbox[2] - hit.bbox[0] <= x2 - x1);

    let again = scored_state(&root, &model);
    assert!(
        again
            .log_entries()
            .iter()
            .filter(|e| e.message.contains("scores read from cache"))
            .count()
            == 2,
        "{:?}",
        again.log_entries()
    );
}

#[test]
fn tags_survive_reopening_and_the_csv_is_written() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = generate_dataset(dir.path());
    let model = tiny_checkpoint(dir.path());
    let mut state = scored_state(&root, &model);
    // A threshold below every score: every normal frame is a false alarm.
    let mut settings = state.settings().clone();
    settings.threshold_mode = ThresholdMode::Manual;
    settings.manual_threshold = -1e12;
    state.set_settings(settings.clone());
    assert!(!state.failures().is_empty());
    state.set_failure_tag(0, "missed box");
    let csv_path = dir.path().join("out").join("cases.csv");
    state.export_failures(&csv_path).expect("export");
    let csv = std::fs::read_to_string(&csv_path).expect("read csv");
    assert!(csv.contains("missed box"), "{csv}");

    let mut again = AppState::new(setup(&model), settings);
    assert!(again.open(&root));
    again.wait_for_scoring();
    assert_eq!(again.failure_tag(0), Some("missed box"));
}

#[test]
fn malformed_data_ends_up_as_errors_in_the_state() {
    let dir = tempfile::tempdir().expect("tempdir");
    let model = tiny_checkpoint(dir.path());
    let mut state = AppState::new(setup(&model), ViewSettings::default());

    assert!(!state.open(&dir.path().join("does-not-exist")));
    let last = state.log_entries().last().expect("logged");
    assert_eq!(last.level, LogLevel::Error);
    assert!(last.message.contains("does-not-exist"), "{}", last.message);
    assert!(state.dataset().is_none());
    state.apply(Action::Step(1));
    state.apply(Action::NextEvent);
    state.apply(Action::StepFailure(1));

    // A data set with a good scenario, one with an undecodable frame, one with no frames
    // and one whose score cache is garbage.
    let root = generate_dataset(dir.path());
    let broken = root.join("Scenario_9998_broken");
    std::fs::create_dir_all(broken.join("RGB_IMG")).expect("mkdir");
    std::fs::write(broken.join("RGB_IMG").join("RGB_IMG_0.png"), b"not a png").expect("write");
    std::fs::write(broken.join("RGB_IMG").join("RGB_IMG_1.png"), b"").expect("write");
    std::fs::create_dir_all(root.join("Scenario_9999_empty").join("RGB_IMG")).expect("mkdir");
    let normal = std::fs::read_dir(&root)
        .expect("list")
        .flatten()
        .map(|e| e.path())
        .find(|p| p.to_string_lossy().contains("highway"))
        .expect("highway scenario");
    let scenario = Scenario::open(&normal).expect("open");
    let request: ScoreRequest = setup(&model).request;
    let key = request
        .key(&scenario, ModelKey::of_checkpoint(&model).expect("hash"))
        .expect("key");
    let cache = key.path_in(&scenario.cache_dir().expect("cache dir"));
    std::fs::create_dir_all(cache.parent().expect("parent")).expect("mkdir");
    std::fs::write(&cache, b"garbage").expect("write");

    assert!(state.open(&root), "{:?}", state.log_entries());
    state.wait_for_scoring();
    let dataset = state.dataset().expect("open");
    assert_eq!(dataset.len(), 4);
    for (i, entry) in dataset.scenarios.iter().enumerate() {
        let ok = matches!(entry.status, ScoreStatus::Ready(_));
        let failed = matches!(entry.status, ScoreStatus::Failed(_)) || entry.error.is_some();
        assert!(ok || failed, "{i} {}: {}", entry.name, entry.status.label());
        if entry.name.contains("city") {
            assert!(ok, "the good scenario is scored");
        } else {
            assert!(failed, "{} is reported", entry.name);
        }
    }
    let errors: Vec<&str> = state
        .log_entries()
        .iter()
        .filter(|e| e.level == LogLevel::Error)
        .map(|e| e.message.as_str())
        .collect();
    assert!(
        errors.iter().any(|m| m.contains("score cache")),
        "{errors:?}"
    );
    assert!(errors.iter().any(|m| m.contains("broken")), "{errors:?}");
    assert!(errors.iter().any(|m| m.contains("empty")), "{errors:?}");
    for i in 0..dataset.len() {
        state.apply(Action::SelectScenario(i));
        state.apply(Action::Step(3));
        state.apply(Action::Last);
        let _ = state.frame_info();
        let _ = state.frame_objects();
        let _ = state.frame_maps();
    }
}

#[test]
fn cancelling_leaves_no_scenario_half_scored() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = generate_dataset(dir.path());
    let model = tiny_checkpoint(dir.path());
    let mut state = AppState::new(setup(&model), ViewSettings::default());
    assert!(state.open(&root));
    state.apply(Action::CancelScoring);
    state.wait_for_scoring();
    assert!(!state.is_scoring());
    let dataset = state.dataset().expect("open");
    let cancelled = dataset
        .scenarios
        .iter()
        .filter(|e| matches!(&e.status, ScoreStatus::Failed(why) if why.contains("cancelled")))
        .count();
    let ready = dataset
        .scenarios
        .iter()
        .filter(|e| matches!(e.status, ScoreStatus::Ready(_)))
        .count();
    assert_eq!(
        cancelled + ready,
        2,
        "every scenario is scored or marked cancelled"
    );
    assert!(cancelled > 0, "the job stopped before the end");
    // Scoring again picks up what was cancelled.
    state.start_scoring();
    state.wait_for_scoring();
    let dataset = state.dataset().expect("open");
    assert!(
        dataset
            .scenarios
            .iter()
            .all(|e| matches!(e.status, ScoreStatus::Ready(_)))
    );
}

#[test]
fn only_the_scenario_on_screen_keeps_a_large_frame_cache() {
    let dir = tempfile::tempdir().expect("tempdir");
    let model = tiny_checkpoint(dir.path());
    let mut state = AppState::new(setup(&model), ViewSettings::default());
    assert!(state.open(&generate_dataset(dir.path())));
    state.wait_for_scoring();
    let budgets = |state: &AppState| -> Vec<usize> {
        let dataset = state.dataset().expect("dataset");
        dataset
            .scenarios
            .iter()
            .map(|e| e.scenario.as_ref().expect("opened").cache_budget())
            .collect()
    };
    assert_eq!(
        budgets(&state),
        [CURRENT_FRAME_CACHE, BACKGROUND_FRAME_CACHE]
    );
    // Scrubbing the first scenario fills its cache; switching shrinks it at once.
    for _ in 0..8 {
        state.apply(Action::Step(1));
        let scenario = state.dataset().expect("dataset").scenarios[0]
            .scenario
            .as_ref()
            .expect("opened");
        scenario.rgb(state.frame()).expect("frame");
    }
    let first = |state: &AppState| -> usize {
        state.dataset().expect("dataset").scenarios[0]
            .scenario
            .as_ref()
            .expect("opened")
            .cache_bytes()
    };
    assert!(first(&state) > 0, "the frames on screen are cached");
    state.apply(Action::SelectScenario(1));
    assert_eq!(
        budgets(&state),
        [BACKGROUND_FRAME_CACHE, CURRENT_FRAME_CACHE]
    );
    assert!(first(&state) <= BACKGROUND_FRAME_CACHE);
}
