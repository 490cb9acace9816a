//! Both AnoVox layouts: discovery of scenarios under a dataset root, the generator layout's
//! sensor folders (names with spaces, commas and parentheses, global CARLA frame ids),
//! AnoVox metadata files, HF²-VAD `.npy` flows next to the images, and `inspect`.

use std::path::{Path, PathBuf};

use image::{Rgb, RgbImage};
use vadscope::sequence::discovery::LayoutKind;
use vadscope::sequence::{
    AnomalyType, FrameId, LabelSource, Modality, Scenario, Weather, discover_scenarios, inspect,
};

use crate::support::scenario::ScenarioBuilder;
use crate::support::sequence::{
    H, W, rgb_frame, rgb_only, save_gray, save_rgb, save_text, semantic_with_block,
};

const UUID: &str = "ef183332-0f4e-4d3c-9d7e-123456789abc";
const CAMERA: &str = "(0, 0, 1.8)(0, 0, 0)_8112341084538454858";
const FIRST_TICK: u64 = 5720;

fn sensor_file(scenario: &Path, sensor: &str, tick: u64, ext: &str) -> PathBuf {
    let folder = format!("{sensor}{CAMERA}");
    scenario
        .join(&folder)
        .join(format!("{folder}_{tick}.{ext}"))
}

/// A generator-layout scenario of 4 frames with global ticks 5720..=5723, plus a dataset
/// root around it (configuration files, a stray file).
fn generator_dataset(root: &Path) -> PathBuf {
    let scenario = root.join(format!("Scenario_{UUID}"));
    for k in 0..4 {
        let tick = FIRST_TICK + k;
        save_rgb(
            &sensor_file(&scenario, "RGB-CAM", tick, "png"),
            &rgb_frame(k),
        );
        let class = if k == 2 { 100 } else { 114 };
        save_gray(
            &sensor_file(&scenario, "SEMANTIC-CAM", tick, "png"),
            &semantic_with_block(class),
        );
        let instance = RgbImage::from_fn(W, H, |x, y| {
            if (4..8).contains(&x) && (3..7).contains(&y) {
                Rgb([14, 0x34, 0x12])
            } else {
                Rgb([1, 0, 0])
            }
        });
        save_rgb(
            &sensor_file(&scenario, "INSTANCE-CAM", tick, "png"),
            &instance,
        );
        save_rgb(
            &sensor_file(&scenario, "DEPTH_CAM", tick, "png"),
            &RgbImage::from_pixel(W, H, Rgb([0, 0, 1])),
        );
        save_text(&sensor_file(&scenario, "LIDAR", tick, "npy"), "not read");
        save_text(
            &sensor_file(&scenario, "SEMANTIC-LIDAR", tick, "npy"),
            "not read",
        );
        save_text(
            &scenario.join(format!("ACTION/ACTION_{tick}.csv")),
            &format!("frame_id ; {tick}\nspeed ; 30.5\nsteer ; -0.0\nreverse ; False\n"),
        );
        save_text(
            &scenario.join(format!("ANOMALY/ANOMALY_{tick}.csv")),
            &format!(
                "frame_id ; {tick}\nbrake ; {}\n",
                if k == 2 { "1.0" } else { "0.0" }
            ),
        );
    }
    let other_camera = "RGB-CAM(-1, 0, 1.8)(0, 0, 90)_5";
    save_rgb(
        &scenario
            .join(other_camera)
            .join(format!("{other_camera}_{FIRST_TICK}.png")),
        &rgb_frame(99),
    );
    let rgb_folder = format!("RGB-CAM{CAMERA}");
    save_text(
        &scenario.join("sensor_setup.json"),
        &format!(
            r#"{{"{rgb_folder}": {{"sensor_type": "RGB-CAM", "file_ending": ".png", "location": [0, 0, 1.8],
                "rotation": [0, 0, 0], "args": {{"image_height": {H}, "image_width": {W}, "camera_fov": 90.0}},
                "save_data": true}}}}"#
        ),
    );
    save_text(
        &root.join("Scenario_Configuration_Files/scenario_config_map_Town07.json"),
        &format!(
            r#"{{"scenario_definition": {{"map": "Town07", "scenarios": [
                {{"id": "other", "weather_preset": "CLEAR_NOON", "anomaly_config": {{"anomalytype": "NORMALITY"}}}},
                {{"id": "{UUID}", "weather_preset": "SOFT_RAIN_SUNSET",
                  "anomaly_config": {{"anomalytype": "SUDDEN_BREAKING_OF_VEHICLE_AHEAD", "anomaly_bp_name": "vehicle.audi.tt"}}}}]}}}}"#
        ),
    );
    save_text(&root.join("color_palette.txt"), "stray file");
    scenario
}

#[test]
fn generator_layout_maps_sensor_folders_by_type_prefix() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = generator_dataset(root.path());
    let scenario = Scenario::open(&dir).expect("opens");

    assert_eq!(scenario.layout(), LayoutKind::Generator);
    assert_eq!(scenario.len(), 4);
    assert_eq!(scenario.frame_id(0), Some(FrameId(FIRST_TICK)));
    assert_eq!(scenario.index_of(FrameId(FIRST_TICK + 3)), Some(3));
    assert!(scenario.frame_index().gaps().is_empty());
    for (modality, present) in [
        (Modality::Rgb, true),
        (Modality::Semantic, true),
        (Modality::Instance, true),
        (Modality::Depth, true),
        (Modality::Action, true),
        (Modality::Anomaly, true),
        (Modality::Flow, false),
    ] {
        assert_eq!(scenario.has(modality), present, "{modality:?}");
    }
    assert_eq!(
        scenario.rgb(2).expect("rgb").get_pixel(0, 0).0[2],
        2,
        "the forward camera is read"
    );
    assert!(
        scenario
            .notes()
            .iter()
            .any(|n| n.path.ends_with("RGB-CAM(-1, 0, 1.8)(0, 0, 90)_5")),
        "the second camera is noted: {:?}",
        scenario.notes()
    );
    let instance = scenario.instance(0).expect("instance").expect("present");
    assert_eq!(instance.ids[3 * W as usize + 4], 0x1234);
    let depth = scenario.depth_m(1).expect("depth").expect("present");
    assert!((depth.get_pixel(0, 0).0[0] - 3.906_25).abs() < 1e-3);
    let action = scenario.action(3).expect("action").expect("present");
    assert_eq!(action.get_f64("frame_id"), Some((FIRST_TICK + 3) as f64));
    assert_eq!(action.get_f64("reverse"), Some(0.0));

    let meta = scenario.meta();
    assert_eq!(meta.town.as_deref(), Some("Town07"));
    assert_eq!(meta.weather, Weather::Rain);
    assert_eq!(meta.time_of_day.as_deref(), Some("sunset"));
    assert_eq!(meta.anomaly_type, Some(AnomalyType::SuddenBraking));
    let camera = meta.camera.expect("camera from sensor_setup.json");
    assert_eq!((camera.width, camera.height), (W, H));
    assert!(
        (camera.fx - W as f32 / 2.0).abs() < 1e-3,
        "FOV 90 gives f = W/2"
    );

    let labels = scenario.frame_labels();
    assert_eq!(labels.source, LabelSource::SemanticImages);
    assert_eq!(labels.flags, vec![false, false, true, false]);

    let boxes = scenario.boxes(2).expect("derived boxes");
    assert_eq!(boxes.len(), 1);
    assert_eq!(boxes[0].track_id, 0x1234);
    assert_eq!(boxes[0].frame, FrameId(FIRST_TICK + 2));
    assert!(boxes[0].anomalous);
    assert!(!scenario.boxes(1).expect("derived")[0].anomalous);
}

#[test]
fn discovery_skips_configuration_folder_and_stray_files() {
    let root = tempfile::tempdir().expect("temp dir");
    let generator = generator_dataset(root.path());
    let benchmark = ScenarioBuilder::new()
        .frames([rgb_only(0)])
        .write(&root.path().join("Scenario_0bench"));
    std::fs::create_dir_all(root.path().join("not_a_scenario")).expect("mkdir");

    let found = discover_scenarios(root.path()).expect("discovers");
    assert_eq!(found, vec![benchmark.clone(), generator.clone()]);
    assert_eq!(
        discover_scenarios(&generator).expect("itself"),
        vec![generator]
    );
    assert_eq!(
        discover_scenarios(&benchmark).expect("itself"),
        vec![benchmark]
    );

    let empty = tempfile::tempdir().expect("temp dir");
    let message = discover_scenarios(empty.path())
        .expect_err("nothing there")
        .to_string();
    assert!(message.contains("no Scenario_* folders"), "{message}");
}

#[test]
fn npy_flows_next_to_the_images_are_found() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = generator_dataset(root.path());
    let image = sensor_file(&dir, "RGB-CAM", FIRST_TICK + 1, "png");
    let npy = PathBuf::from(format!("{}.npy", image.display()));
    let values: Vec<f32> = (0..2 * W * H).map(|i| i as f32 * 0.125).collect();
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    let mut header =
        format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({H}, {W}, 2), }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    bytes.extend((header.len() as u16).to_le_bytes());
    bytes.extend(header.as_bytes());
    bytes.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(&npy, bytes).expect("write npy");

    let scenario = Scenario::open(&dir).expect("opens");
    assert!(scenario.flow(0).expect("none").is_none());
    let flow = scenario.flow(1).expect("reads").expect("present");
    assert_eq!(flow.uv, values);
    assert_eq!(scenario.len(), 4, "the .npy file is not an RGB frame");
}

#[test]
fn inspect_reports_every_scenario_and_the_ones_that_fail() {
    let root = tempfile::tempdir().expect("temp dir");
    generator_dataset(root.path());
    let frames: Vec<_> = (0..3).map(rgb_only).collect();
    ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_bench"));
    std::fs::create_dir_all(root.path().join("Scenario_empty")).expect("mkdir");

    let report = inspect(root.path()).expect("inspects");
    assert_eq!(report.scenarios.len(), 2);
    assert_eq!(report.failed.len(), 1);
    assert!(report.failed[0].path.ends_with("Scenario_empty"));
    assert!(report.failed[0].problem.contains("no RGB frames"));

    let generator = report
        .scenarios
        .iter()
        .find(|s| s.summary.layout == LayoutKind::Generator)
        .expect("generator scenario");
    let summary = &generator.summary;
    assert_eq!(summary.frames, 4);
    assert_eq!(summary.anomalous_frames, 1);
    assert_eq!(summary.anomaly_windows.len(), 1);
    assert_eq!(summary.anomaly_windows[0].start_id, FrameId(FIRST_TICK + 2));
    let stats = summary.boxes_per_frame.expect("boxes");
    assert_eq!((stats.min, stats.max, stats.total), (1, 1, 4));
    assert_eq!(summary.conditions.town.as_deref(), Some("Town07"));

    let text = report.render_text();
    assert!(text.contains(&format!("Scenario_{UUID}")), "{text}");
    assert!(
        text.contains("Town07") && text.contains("Scenario_empty"),
        "{text}"
    );
    let json: serde_json::Value = serde_json::from_str(&report.to_json()).expect("valid JSON");
    assert_eq!(json["scenarios"].as_array().map(Vec::len), Some(2));

    let single = inspect(&root.path().join("Scenario_bench")).expect("single scenario");
    assert_eq!(single.scenarios.len(), 1);
    assert_eq!(single.scenarios[0].summary.frames, 3);
    assert!(single.scenarios[0].validation.is_clean());
}
