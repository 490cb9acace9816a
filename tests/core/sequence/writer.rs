//! The benchmark-layout writer: every modality written by `ScenarioWriter` reads back
//! through the file readers, frames can be written from several threads, and bad frames
//! are rejected with an error naming the file.

use std::path::Path;

use image::{GrayImage, Luma, Rgb, RgbImage};
use vadscope::sequence::boxes::read_boxes;
use vadscope::sequence::images::{
    SemanticEncoding, read_depth, read_instance, read_rgb, read_semantic,
};
use vadscope::sequence::keyvalue::read_key_values;
use vadscope::sequence::labels::read_frame_labels;
use vadscope::sequence::meta::read_scenario_json;
use vadscope::sequence::{
    AnomalyType, BoxRecord, CameraIntrinsics, Domain, FlowField, FrameId, FrameRecord, FrameWindow,
    KeyValues, ScenarioMeta, ScenarioWriter, Weather,
};

const W: u32 = 24;
const H: u32 = 16;

fn meta() -> ScenarioMeta {
    ScenarioMeta {
        domain: Domain::Highway,
        weather: Weather::Fog,
        time_of_day: Some("dusk".into()),
        anomaly_type: Some(AnomalyType::SuddenBraking),
        anomaly_window: Some(FrameWindow {
            start: FrameId(2),
            end: FrameId(3),
        }),
        town: Some("Synthetic".into()),
        seed: Some(42),
        generator: Some("vadscope-synth 0.1".into()),
        fps: 10.0,
        camera: Some(CameraIntrinsics::anovox(W, H)),
    }
}

fn full_frame(id: u64) -> FrameRecord {
    let k = id as u8;
    let rgb = RgbImage::from_fn(W, H, |x, y| Rgb([x as u8 * 10, y as u8 * 15, k]));
    let semantic = GrayImage::from_fn(W, H, |x, _| Luma([if x < 8 { 14 } else { 1 + k }]));
    let instance = RgbImage::from_fn(W, H, |x, y| Rgb([14, (x + y) as u8, k]));
    let depth_m = (0..W * H).map(|i| 2.0 + i as f32 * 0.25).collect();
    let flow = FlowField {
        width: W,
        height: H,
        uv: (0..2 * W * H)
            .map(|i| (i % 11) as f32 * 0.5 - 2.5)
            .collect(),
        valid: None,
    };
    let mut action = KeyValues::default();
    action.push("frame_id", id);
    action.push("speed", 36.5 + id as f64);
    action.push("center_of_mass", "(0.1, 0.0, -0.3)");
    let mut anomaly = KeyValues::default();
    anomaly.push("brake", if id >= 2 { "1.0" } else { "0.0" });
    let boxes = vec![BoxRecord {
        frame: FrameId(999),
        track_id: 7,
        x1: 1.0,
        y1: 2.0,
        x2: 8.5,
        y2: 9.0,
        class: 14,
        score: 1.0,
        anomalous: id >= 2,
    }];
    // Every field spelled out, so that a new modality does not compile here until the round
    // trip covers it.
    FrameRecord {
        id: FrameId(id),
        rgb,
        semantic: Some(semantic),
        instance: Some(instance),
        depth_m: Some(depth_m),
        flow: Some(flow),
        action: Some(action),
        anomaly: Some(anomaly),
        boxes,
        anomalous: Some(id >= 2),
    }
}

fn file(dir: &Path, folder: &str, id: u64, ext: &str) -> std::path::PathBuf {
    dir.join(folder).join(format!("{folder}_{id}.{ext}"))
}

#[test]
fn every_modality_round_trips_through_the_file_readers() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = root.path().join("Scenario_test");
    let writer = ScenarioWriter::create(&dir, &meta()).expect("creates");
    let frames: Vec<FrameRecord> = (0..4).map(full_frame).collect();
    std::thread::scope(|scope| {
        for frame in &frames {
            let writer = &writer;
            scope.spawn(move || writer.write_frame(frame).expect("writes"));
        }
    });
    assert_eq!(writer.finish().expect("finishes"), dir);

    for frame in &frames {
        let id = frame.id.0;
        assert_eq!(
            read_rgb(&file(&dir, "RGB_IMG", id, "png")).expect("rgb"),
            frame.rgb
        );
        let semantic = read_semantic(&file(&dir, "SEMANTIC_IMG", id, "png")).expect("semantic");
        assert_eq!(semantic.encoding, SemanticEncoding::ClassIds);
        assert_eq!(Some(&semantic.ids), frame.semantic.as_ref());
        let instance = read_instance(&file(&dir, "INSTANCE_IMG", id, "png")).expect("instance");
        assert_eq!(Some(instance.to_rgb()), frame.instance);
        assert_eq!(instance.ids[1], 1 + 256 * id as u16);
        let depth = read_depth(&file(&dir, "DEPTH_IMG", id, "png")).expect("depth");
        let expected = frame.depth_m.as_ref().expect("depth given");
        for (got, want) in depth.as_raw().iter().zip(expected) {
            assert!((got - want).abs() < 1e-3, "{got} vs {want}");
        }
        let flow =
            vadscope::sequence::flow_file::read_kitti_png(&file(&dir, "OPTICAL_FLOW", id, "png"))
                .expect("flow");
        assert_eq!(Some(&flow), frame.flow.as_ref());
        let action = read_key_values(&file(&dir, "ACTION", id, "csv")).expect("action");
        assert_eq!(Some(&action), frame.action.as_ref());
        let anomaly = read_key_values(&file(&dir, "ANOMALY", id, "csv")).expect("anomaly");
        assert_eq!(anomaly.brake(), Some(if id >= 2 { 1.0 } else { 0.0 }));
    }

    let boxes = read_boxes(&dir.join("BBOX_2D/boxes.csv")).expect("boxes");
    let frames_of_boxes: Vec<u64> = boxes.iter().map(|b| b.frame.0).collect();
    assert_eq!(
        frames_of_boxes,
        vec![0, 1, 2, 3],
        "sorted, frame taken from the record"
    );
    assert!(boxes[3].anomalous && !boxes[0].anomalous);
    let labels = read_frame_labels(&dir.join("frame_labels.csv")).expect("labels");
    let flags: Vec<bool> = labels.iter().map(|(_, a)| *a).collect();
    assert_eq!(flags, vec![false, false, true, true]);
    assert_eq!(
        read_scenario_json(&dir.join("scenario.json")).expect("json"),
        meta()
    );
}

#[test]
fn rgb_only_frames_write_no_optional_files() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = root.path().join("Scenario_min");
    let writer = ScenarioWriter::create(&dir, &ScenarioMeta::default()).expect("creates");
    let frame = FrameRecord::new(FrameId(0), full_frame(0).rgb);
    writer.write_frame(&frame).expect("writes");
    writer.finish().expect("finishes");
    assert_eq!(names_in(&dir), vec!["RGB_IMG", "scenario.json"]);
}

#[test]
fn mismatched_sizes_and_duplicate_frames_are_rejected() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = root.path().join("Scenario_bad");
    let writer = ScenarioWriter::create(&dir, &ScenarioMeta::default()).expect("creates");

    let mut frame = full_frame(1);
    frame.semantic = Some(GrayImage::new(W + 1, H));
    let message = writer.write_frame(&frame).expect_err("size").to_string();
    assert!(
        message.contains("SEMANTIC_IMG_1.png") && message.contains("25x16"),
        "{message}"
    );

    let mut frame = full_frame(2);
    frame.depth_m = Some(vec![1.0; 5]);
    let message = writer.write_frame(&frame).expect_err("depth").to_string();
    assert!(
        message.contains("DEPTH_IMG_2.png") && message.contains("5 values"),
        "{message}"
    );

    writer.write_frame(&full_frame(3)).expect("first write");
    let message = writer
        .write_frame(&full_frame(3))
        .expect_err("twice")
        .to_string();
    assert!(
        message.contains("RGB_IMG_3.png") && message.contains("twice"),
        "{message}"
    );
}

/// The names in `dir`, sorted (hidden ones included).
fn names_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_scenario_appears_only_when_it_is_finished() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = root.path().join("Scenario_atomic");
    let writer = ScenarioWriter::create(&dir, &meta()).expect("creates");
    writer.write_frame(&full_frame(0)).expect("writes");
    // While frames are written, readers of the data set see no scenario at all.
    assert!(!dir.exists());
    assert_eq!(names_in(root.path()), vec![".Scenario_atomic.partial"]);
    assert!(vadscope::sequence::discover_scenarios(root.path()).is_err());
    writer.write_frame(&full_frame(1)).expect("writes");
    assert_eq!(writer.finish().expect("finishes"), dir);
    assert_eq!(names_in(root.path()), vec!["Scenario_atomic"]);
    assert!(file(&dir, "RGB_IMG", 1, "png").is_file());
    assert!(dir.join("scenario.json").is_file());
}

#[test]
fn an_unfinished_scenario_leaves_nothing_behind() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = root.path().join("Scenario_dropped");
    {
        let writer = ScenarioWriter::create(&dir, &meta()).expect("creates");
        writer.write_frame(&full_frame(0)).expect("writes");
        let mut bad = full_frame(1);
        bad.depth_m = Some(vec![1.0; 3]);
        writer
            .write_frame(&bad)
            .expect_err("the depth buffer is short");
        // The caller gives up on the scenario here.
    }
    assert!(names_in(root.path()).is_empty());

    // A staging folder left by a killed process is replaced, not mixed in.
    let stale = root.path().join(".Scenario_dropped.partial/RGB_IMG");
    std::fs::create_dir_all(&stale).expect("mkdir");
    std::fs::write(stale.join("RGB_IMG_77.png"), b"half a frame").expect("write");
    let writer = ScenarioWriter::create(&dir, &meta()).expect("creates over the stale folder");
    writer.write_frame(&full_frame(0)).expect("writes");
    writer.finish().expect("finishes");
    assert_eq!(names_in(&dir.join("RGB_IMG")), vec!["RGB_IMG_0.png"]);
    assert_eq!(names_in(root.path()), vec!["Scenario_dropped"]);
}

#[test]
fn a_writer_never_writes_into_an_existing_scenario() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = root.path().join("Scenario_taken");
    std::fs::create_dir_all(dir.join("RGB_IMG")).expect("mkdir");
    std::fs::write(dir.join("RGB_IMG/RGB_IMG_0.png"), b"the user's frame").expect("write");
    let message = ScenarioWriter::create(&dir, &meta())
        .expect_err("not empty")
        .to_string();
    assert!(
        message.contains("Scenario_taken") && message.contains("not empty"),
        "{message}"
    );
    assert_eq!(
        std::fs::read(dir.join("RGB_IMG/RGB_IMG_0.png")).expect("kept"),
        b"the user's frame"
    );

    let file_in_the_way = root.path().join("Scenario_file");
    std::fs::write(&file_in_the_way, b"notes").expect("write");
    let message = ScenarioWriter::create(&file_in_the_way, &meta())
        .expect_err("a file")
        .to_string();
    assert!(
        message.contains("Scenario_file") && message.contains("file"),
        "{message}"
    );

    // An empty folder, as `tempdir` makes, is a fine destination.
    let empty = root.path().join("Scenario_empty");
    std::fs::create_dir(&empty).expect("mkdir");
    let writer = ScenarioWriter::create(&empty, &meta()).expect("creates");
    writer.write_frame(&full_frame(0)).expect("writes");
    assert_eq!(writer.finish().expect("finishes"), empty);
    assert!(file(&empty, "RGB_IMG", 0, "png").is_file());
}
