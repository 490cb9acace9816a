//! Frame-level anomaly flags in their order of preference (frame_labels.csv, semantic
//! images, scenario window, ANOMALY brake, none) and boxes derived from instance images.

use image::{GrayImage, Luma, Rgb, RgbImage};
use vadscope::sequence::{
    AnomalyType, BoxSource, FrameId, FrameRecord, FrameWindow, KeyValues, LabelSource, Scenario,
    ScenarioMeta,
};

use crate::support::scenario::ScenarioBuilder;
use crate::support::sequence::{H, W, rgb_only, save_text, semantic_with_block};

fn with_semantic(id: u64, class: u8) -> FrameRecord {
    FrameRecord {
        semantic: Some(semantic_with_block(class)),
        ..rgb_only(id)
    }
}

fn with_brake(id: u64, brake: f64) -> FrameRecord {
    let mut anomaly = KeyValues::default();
    anomaly.push("speed", 20.0);
    anomaly.push("brake", brake);
    FrameRecord {
        anomaly: Some(anomaly),
        ..rgb_only(id)
    }
}

fn sudden_braking() -> ScenarioMeta {
    ScenarioMeta {
        anomaly_type: Some(AnomalyType::SuddenBraking),
        ..ScenarioMeta::default()
    }
}

#[test]
fn frame_labels_file_wins_over_semantic_images() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = (0..4)
        .map(|id| FrameRecord {
            anomalous: Some(id == 0),
            ..with_semantic(id, if id == 3 { 100 } else { 14 })
        })
        .collect();
    let dir = ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_a"));
    let scenario = Scenario::open(&dir).expect("opens");
    let labels = scenario.frame_labels();
    assert_eq!(labels.source, LabelSource::FrameLabelsFile);
    assert_eq!(labels.flags, vec![true, false, false, false]);
}

#[test]
fn malformed_frame_labels_fall_back_to_semantic_images_and_are_noted() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = (0..3)
        .map(|id| with_semantic(id, if id == 1 { 100 } else { 14 }))
        .collect();
    let dir = ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_b"));
    save_text(
        &dir.join("frame_labels.csv"),
        "frame,anomaly\n0,1\n1,maybe\n",
    );
    let scenario = Scenario::open(&dir).expect("opens");
    let labels = scenario.frame_labels();
    assert_eq!(labels.source, LabelSource::SemanticImages);
    assert_eq!(labels.flags, vec![false, true, false]);
    assert_eq!(labels.problems.len(), 1);
    let problem = labels.problems[0].to_string();
    assert!(
        problem.contains("frame_labels.csv") && problem.contains("line 3"),
        "{problem}"
    );
}

#[test]
fn frame_labels_with_missing_and_unknown_rows_are_noted() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = (0..4).map(rgb_only).collect();
    let dir = ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_c"));
    save_text(
        &dir.join("frame_labels.csv"),
        "frame,anomaly\n0,0\n1,1\n9,1\n",
    );
    let scenario = Scenario::open(&dir).expect("opens");
    let labels = scenario.frame_labels();
    assert_eq!(labels.source, LabelSource::FrameLabelsFile);
    assert_eq!(labels.flags, vec![false, true, false, false]);
    let problems: Vec<String> = labels.problems.iter().map(ToString::to_string).collect();
    assert!(
        problems.iter().any(|p| p.contains("do not exist: 9")),
        "{problems:?}"
    );
    assert!(
        problems
            .iter()
            .any(|p| p.contains("no row for frames #2-#3")),
        "{problems:?}"
    );
}

#[test]
fn frames_without_a_semantic_image_are_noted_when_semantic_images_decide() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames = vec![
        with_semantic(0, 100),
        rgb_only(1),
        rgb_only(2),
        with_semantic(3, 14),
    ];
    let dir = ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_partial"));
    let labels = Scenario::open(&dir).expect("opens").frame_labels().clone();
    assert_eq!(labels.source, LabelSource::SemanticImages);
    assert_eq!(labels.flags, vec![true, false, false, false]);
    let problems: Vec<String> = labels.problems.iter().map(ToString::to_string).collect();
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].contains("SEMANTIC_IMG") && problems[0].contains("#1-#2"),
        "{problems:?}"
    );
}

#[test]
fn scenario_window_from_metadata_is_used_without_images() {
    let root = tempfile::tempdir().expect("temp dir");
    let meta = ScenarioMeta {
        anomaly_window: Some(FrameWindow {
            start: FrameId(11),
            end: FrameId(12),
        }),
        ..sudden_braking()
    };
    let frames: Vec<FrameRecord> = (10..15).map(|id| with_brake(id, 1.0)).collect();
    let dir = ScenarioBuilder::new()
        .meta(meta)
        .frames(frames)
        .write(&root.path().join("Scenario_d"));
    let labels = Scenario::open(&dir).expect("opens").frame_labels().clone();
    assert_eq!(labels.source, LabelSource::ScenarioWindow);
    assert_eq!(labels.flags, vec![false, true, true, false, false]);
}

#[test]
fn sudden_braking_of_a_complete_scenario_uses_indices_124_to_154() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = (16..216).map(|id| with_brake(id, 0.0)).collect();
    let dir = ScenarioBuilder::new()
        .meta(sudden_braking())
        .frames(frames)
        .write(&root.path().join("Scenario_e"));
    let scenario = Scenario::open(&dir).expect("opens");
    let labels = scenario.frame_labels();
    assert_eq!(labels.source, LabelSource::ScenarioWindow);
    let anomalous: Vec<usize> = (0..200).filter(|&i| labels.is_anomalous(i)).collect();
    assert_eq!(anomalous, (124..=154).collect::<Vec<_>>());
    assert_eq!(
        scenario.frame_id(124),
        Some(FrameId(140)),
        "tick = index + 16"
    );
}

#[test]
fn incomplete_sudden_braking_falls_back_to_the_brake_column() {
    let root = tempfile::tempdir().expect("temp dir");
    let brakes = [0.0, 0.5, 0.99, 1.0, 0.98];
    let frames: Vec<FrameRecord> = brakes
        .iter()
        .enumerate()
        .map(|(i, &b)| with_brake(i as u64, b))
        .collect();
    let dir = ScenarioBuilder::new()
        .meta(sudden_braking())
        .frames(frames)
        .write(&root.path().join("Scenario_f"));
    let labels = Scenario::open(&dir).expect("opens").frame_labels().clone();
    assert_eq!(labels.source, LabelSource::AnomalyBrake);
    assert_eq!(labels.flags, vec![false, false, true, true, false]);
}

#[test]
fn unreadable_anomaly_files_are_noted_and_count_as_normal() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = (0..3).map(|id| with_brake(id, 1.0)).collect();
    let dir = ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_g"));
    save_text(&dir.join("ANOMALY/ANOMALY_1.csv"), "brake 1.0\n");
    let labels = Scenario::open(&dir).expect("opens").frame_labels().clone();
    assert_eq!(labels.source, LabelSource::AnomalyBrake);
    assert_eq!(labels.flags, vec![true, false, true]);
    assert_eq!(labels.problems.len(), 1);
    let problem = labels.problems[0].to_string();
    assert!(
        problem.contains("ANOMALY_1.csv") && problem.contains("line 1"),
        "{problem}"
    );
}

#[test]
fn no_source_means_all_frames_normal() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = (0..3).map(rgb_only).collect();
    let dir = ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_h"));
    let labels = Scenario::open(&dir).expect("opens").frame_labels().clone();
    assert_eq!(labels.source, LabelSource::None);
    assert_eq!(labels.flags, vec![false; 3]);
}

#[test]
fn boxes_are_derived_per_instance_id_for_vehicles_only() {
    let root = tempfile::tempdir().expect("temp dir");
    let paint = |image: &mut RgbImage,
                 xs: std::ops::Range<u32>,
                 ys: std::ops::Range<u32>,
                 pixel: [u8; 3]| {
        for y in ys {
            for x in xs.clone() {
                image.put_pixel(x, y, Rgb(pixel));
            }
        }
    };
    let mut instance = RgbImage::from_pixel(W, H, Rgb([1, 0, 0]));
    paint(&mut instance, 0..3, 0..2, [14, 1, 0]);
    paint(&mut instance, 0..2, 5..6, [14, 1, 0]);
    paint(&mut instance, 5..9, 2..5, [15, 2, 0]);
    paint(&mut instance, 10..12, 0..4, [12, 3, 0]);
    paint(&mut instance, 0..W, 10..H, [14, 4, 0]);
    let mut semantic = GrayImage::from_pixel(W, H, Luma([1]));
    for x in 0..W {
        for y in 10..H {
            semantic.put_pixel(x, y, Luma([214]));
        }
    }
    let frame = FrameRecord {
        instance: Some(instance),
        semantic: Some(semantic),
        ..rgb_only(0)
    };
    let dir = ScenarioBuilder::new()
        .frames([frame])
        .write(&root.path().join("Scenario_i"));
    let scenario = Scenario::open(&dir).expect("opens");
    assert_eq!(scenario.box_source(), &BoxSource::InstanceImages);
    let boxes = scenario.boxes(0).expect("derived");
    let summary: Vec<(u64, u16, [f32; 4])> = boxes
        .iter()
        .map(|b| (b.track_id, b.class, [b.x1, b.y1, b.x2, b.y2]))
        .collect();
    assert_eq!(
        summary,
        vec![(1, 14, [0.0, 0.0, 3.0, 6.0]), (2, 15, [5.0, 2.0, 9.0, 5.0])],
        "pedestrian (12) and ego vehicle (semantic 214) are not boxed; one id spans its parts"
    );
    assert!(
        boxes
            .iter()
            .all(|b| b.score == 1.0 && !b.anomalous && b.frame == FrameId(0))
    );
}
