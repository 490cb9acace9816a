//! Malformed input: every problem gives an error (or a validation entry) that names the file
//! and the problem, and nothing panics.

use image::{GrayImage, ImageBuffer, Luma, RgbImage};
use vadscope::sequence::{FlowField, FrameId, FrameRecord, Modality, Scenario, ScenarioMeta};

use crate::support::scenario::ScenarioBuilder;
use crate::support::sequence::{
    H, W, assert_names, rgb_frame, rgb_only, save_gray, save_rgb, save_text,
};

fn scenario_of(frames: usize) -> (tempfile::TempDir, std::path::PathBuf) {
    let root = tempfile::tempdir().expect("temp dir");
    let records: Vec<FrameRecord> = (0..frames as u64).map(rgb_only).collect();
    let dir = ScenarioBuilder::new()
        .frames(records)
        .write(&root.path().join("Scenario_m"));
    (root, dir)
}

#[test]
fn folders_without_rgb_frames_are_not_scenarios() {
    let root = tempfile::tempdir().expect("temp dir");
    let empty = root.path().join("Scenario_empty");
    std::fs::create_dir_all(&empty).expect("mkdir");
    assert_names(
        &Scenario::open(&empty).expect_err("empty").to_string(),
        "Scenario_empty",
        "no RGB frames",
    );

    let empty_rgb = root.path().join("Scenario_empty_rgb");
    std::fs::create_dir_all(empty_rgb.join("RGB_IMG")).expect("mkdir");
    save_text(&empty_rgb.join("RGB_IMG/notes.txt"), "no frames here");
    assert_names(
        &Scenario::open(&empty_rgb)
            .expect_err("no frames")
            .to_string(),
        "Scenario_empty_rgb",
        "no RGB frames",
    );

    let missing = root.path().join("does_not_exist");
    assert_names(
        &Scenario::open(&missing).expect_err("missing").to_string(),
        "does_not_exist",
        "not a folder",
    );

    let broken = root.path().join("Scenario_broken");
    save_text(&broken.join("RGB_IMG/RGB_IMG_0.png"), "not a png");
    save_text(&broken.join("RGB_IMG/RGB_IMG_1.png"), "");
    let message = Scenario::open(&broken).expect_err("unreadable").to_string();
    assert_names(
        &message,
        "Scenario_broken",
        "none of the 2 RGB frames can be read",
    );
    assert!(
        message.contains("RGB_IMG_1.png"),
        "the last error is quoted: {message}"
    );
}

#[test]
fn mismatched_image_sizes_are_errors_and_listed() {
    let (_root, dir) = scenario_of(3);
    save_rgb(&dir.join("RGB_IMG/RGB_IMG_2.png"), &RgbImage::new(W + 1, H));
    save_gray(
        &dir.join("SEMANTIC_IMG/SEMANTIC_IMG_1.png"),
        &GrayImage::new(W, H + 2),
    );
    save_gray(
        &dir.join("SEMANTIC_IMG/SEMANTIC_IMG_0.png"),
        &GrayImage::new(W, H),
    );
    let scenario = Scenario::open(&dir).expect("opens");
    assert_names(
        &scenario.rgb(2).expect_err("size").to_string(),
        "RGB_IMG_2.png",
        "17x12",
    );
    assert_names(
        &scenario.semantic(1).expect_err("size").to_string(),
        "SEMANTIC_IMG_1.png",
        "16x14",
    );
    assert!(scenario.anomaly_mask(1).is_err());
    assert!(scenario.semantic(0).expect("right size").is_some());

    let report = scenario.validate().expect("validates");
    let mismatched: Vec<_> = report
        .size_mismatches
        .iter()
        .map(|m| (m.modality, m.size))
        .collect();
    assert_eq!(
        mismatched,
        vec![
            (Modality::Rgb, (W + 1, H)),
            (Modality::Semantic, (W, H + 2))
        ]
    );
    assert!(!report.is_clean());
    assert!(report.render_text().contains("RGB_IMG_2.png is 17x12"));
}

#[test]
fn csv_files_with_bad_rows_name_file_and_line() {
    let (_root, dir) = scenario_of(2);
    save_text(
        &dir.join("BBOX_2D/boxes.csv"),
        "frame,track_id,x1,y1,x2,y2,class,score,anomalous\n0,1,0,0,4,4,14,1,0\n1,2,0,zero,4,4,14,1,0\n",
    );
    save_text(
        &dir.join("ACTION/ACTION_1.csv"),
        "speed ; 3.0\nthrottle 0.5\n",
    );
    save_text(&dir.join("ACTION/ACTION_0.csv"), "speed ; 3.0\n");
    let scenario = Scenario::open(&dir).expect("opens");
    assert_names(
        &scenario.boxes(0).expect_err("bad table").to_string(),
        "boxes.csv:3",
        "column 'y1'",
    );
    assert_names(
        &scenario.action(1).expect_err("bad line").to_string(),
        "ACTION_1.csv:2",
        "no ';'",
    );
    assert_eq!(
        scenario
            .action(0)
            .expect("fine")
            .and_then(|a| a.speed_kmh()),
        Some(3.0)
    );

    let report = scenario.validate().expect("validates");
    let unreadable: Vec<String> = report.unreadable.iter().map(ToString::to_string).collect();
    assert!(
        unreadable
            .iter()
            .any(|u| u.contains("ACTION_1.csv") && u.contains("line 2")),
        "{unreadable:?}"
    );
    assert!(
        unreadable
            .iter()
            .any(|u| u.contains("boxes.csv") && u.contains("line 3")),
        "{unreadable:?}"
    );
}

#[test]
fn missing_frames_gaps_and_orphans_are_reported() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = [0u64, 1, 2, 5, 6]
        .into_iter()
        .map(|id| FrameRecord {
            semantic: (id < 2).then(|| GrayImage::new(W, H)),
            ..rgb_only(id)
        })
        .collect();
    let dir = ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_gaps"));
    save_gray(
        &dir.join("SEMANTIC_IMG/SEMANTIC_IMG_3.png"),
        &GrayImage::new(W, H),
    );
    let scenario = Scenario::open(&dir).expect("opens");
    assert_eq!(scenario.len(), 5);
    assert_eq!(scenario.frame_id(3), Some(FrameId(5)));

    let report = scenario.validate().expect("validates");
    assert_eq!(report.id_gaps.len(), 1);
    assert_eq!(
        (
            report.id_gaps[0].after,
            report.id_gaps[0].before,
            report.id_gaps[0].missing
        ),
        (FrameId(2), FrameId(5), 2)
    );
    let semantic = report
        .modalities
        .iter()
        .find(|m| m.modality == Modality::Semantic)
        .expect("semantic");
    assert_eq!(semantic.frames_with_file, 2);
    assert_eq!(semantic.missing.len(), 1);
    assert_eq!(
        (
            semantic.missing[0].start_index,
            semantic.missing[0].end_index
        ),
        (2, 4)
    );
    assert_eq!(semantic.without_rgb, vec![FrameId(3)]);
    let text = report.render_text();
    assert!(
        text.contains("missing #2-#4") && text.contains("gap after #2"),
        "{text}"
    );
    let json = serde_json::to_value(&report).expect("serialises");
    assert_eq!(json["id_gaps"][0]["missing"], 2);
}

#[test]
fn broken_flow_files_name_file_and_problem() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = (0..5)
        .map(|id| FrameRecord {
            flow: (id > 0).then(|| FlowField::zeros(W, H)),
            ..rgb_only(id)
        })
        .collect();
    let dir = ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_flow"));
    let flow_dir = dir.join("OPTICAL_FLOW");
    std::fs::remove_file(flow_dir.join("OPTICAL_FLOW_1.png")).expect("rm");
    std::fs::write(
        flow_dir.join("OPTICAL_FLOW_1.flo"),
        b"PIEH\x10\0\0\0\x0c\0\0\0\0\0",
    )
    .expect("truncated flo");
    std::fs::remove_file(flow_dir.join("OPTICAL_FLOW_2.png")).expect("rm");
    std::fs::write(
        flow_dir.join("OPTICAL_FLOW_2.flo"),
        [0u8; 12 + 8 * (W * H) as usize],
    )
    .expect("wrong magic");
    RgbImage::new(W, H)
        .save(flow_dir.join("OPTICAL_FLOW_3.png"))
        .expect("8-bit flow png");
    let garbage_npy = dir.join("RGB_IMG/RGB_IMG_4.png.npy");
    std::fs::write(&garbage_npy, b"\x93NUMPY\x01\0\x08\0{'descr'").expect("garbage npy");
    std::fs::remove_file(flow_dir.join("OPTICAL_FLOW_4.png")).expect("rm");

    let scenario = Scenario::open(&dir).expect("opens");
    assert_names(
        &scenario.flow(1).expect_err("truncated").to_string(),
        "OPTICAL_FLOW_1.flo",
        "truncated",
    );
    assert_names(
        &scenario.flow(2).expect_err("magic").to_string(),
        "OPTICAL_FLOW_2.flo",
        "PIEH",
    );
    assert_names(
        &scenario.flow(3).expect_err("depth").to_string(),
        "OPTICAL_FLOW_3.png",
        "16-bit RGB",
    );
    assert_names(
        &scenario.flow(4).expect_err("npy").to_string(),
        "RGB_IMG_4.png.npy",
        "npy header",
    );

    let report = scenario.validate().expect("validates");
    let unreadable: Vec<String> = report.unreadable.iter().map(ToString::to_string).collect();
    for (file, needle) in [
        ("OPTICAL_FLOW_1.flo", "truncated"),
        ("OPTICAL_FLOW_2.flo", "PIEH"),
        ("OPTICAL_FLOW_3.png", "16-bit RGB"),
        ("RGB_IMG_4.png.npy", "npy header"),
    ] {
        assert!(
            unreadable
                .iter()
                .any(|u| u.contains(file) && u.contains(needle)),
            "{file}: {unreadable:?}"
        );
    }
}

#[test]
fn wrong_pixel_layouts_are_rejected_by_reader_and_validation() {
    let (_root, dir) = scenario_of(2);
    std::fs::create_dir_all(dir.join("SEMANTIC_IMG")).expect("mkdir");
    ImageBuffer::<Luma<u16>, Vec<u16>>::new(W, H)
        .save(dir.join("SEMANTIC_IMG/SEMANTIC_IMG_0.png"))
        .expect("16-bit grey");
    save_gray(
        &dir.join("INSTANCE_IMG/INSTANCE_IMG_1.png"),
        &GrayImage::new(W, H),
    );
    let scenario = Scenario::open(&dir).expect("opens");
    assert_names(
        &scenario.semantic(0).expect_err("16-bit").to_string(),
        "SEMANTIC_IMG_0.png",
        "8-bit grey",
    );
    assert_names(
        &scenario.instance(1).expect_err("grey").to_string(),
        "INSTANCE_IMG_1.png",
        "8-bit RGB",
    );
    let report = scenario.validate().expect("validates");
    assert_eq!(report.unreadable.len(), 2, "{}", report.render_text());
}

#[test]
fn broken_metadata_and_stray_files_are_notes_not_failures() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = ScenarioBuilder::new()
        .frames([rgb_only(0), rgb_only(5)])
        .write(&root.path().join("Scenario_1234"));
    save_text(&dir.join("scenario.json"), "{\"domain\": \"moon\"");
    save_text(
        &root
            .path()
            .join("Scenario_Configuration_Files/scenario_config_map_Town01.json"),
        "[not json",
    );
    save_text(&dir.join("RGB_IMG/readme.txt"), "stray");
    save_rgb(&dir.join("RGB_IMG/RGB_IMG_final.png"), &rgb_frame(1));
    save_rgb(&dir.join("RGB_IMG/RGB_IMG_005.png"), &rgb_frame(2));

    let scenario = Scenario::open(&dir).expect("opens despite broken metadata");
    assert_eq!(scenario.len(), 2);
    assert_eq!(scenario.meta(), &ScenarioMeta::default());
    let notes: Vec<String> = scenario.notes().iter().map(ToString::to_string).collect();
    for (file, needle) in [
        ("scenario.json", "invalid scenario.json"),
        ("scenario_config_map_Town01.json", "invalid JSON"),
        ("readme.txt", "not a RGB_IMG file"),
        ("RGB_IMG_final.png", "no frame number"),
        ("RGB_IMG_5.png", "frame 5"),
    ] {
        assert!(
            notes.iter().any(|n| n.contains(file) && n.contains(needle)),
            "{file}: {notes:?}"
        );
    }
    let report = scenario.validate().expect("validates");
    assert_eq!(report.notes.len(), notes.len());
    assert!(report.render_text().contains("note: "));
}
