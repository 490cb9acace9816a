//! Writer → reader round trips through `Scenario`: every modality, boxes, labels, metadata,
//! key-value CSVs, semantic L and palette encodings, and the bounded frame cache.

use image::{Luma, Rgb, RgbImage};
use vadscope::sequence::images::SemanticEncoding;
use vadscope::sequence::palette::{self, colourise};
use vadscope::sequence::{
    AnomalyType, BoxRecord, BoxSource, Domain, FlowField, FrameId, FrameRecord, FrameWindow,
    KeyValues, LabelSource, Modality, Scenario, ScenarioMeta, ScenarioOptions, Weather,
};

use crate::support::scenario::ScenarioBuilder;
use crate::support::sequence::{H, W, rgb_frame, rgb_only, save_rgb, semantic_with_block};

fn full_frame(id: u64) -> FrameRecord {
    let mut action = KeyValues::default();
    action.push("frame_id", id);
    action.push("speed", 50.0 + id as f64);
    action.push("camera transformation matrix", "[[1.0, 0.0], [0.0, 1.0]]");
    let mut anomaly = KeyValues::default();
    anomaly.push("brake", if id == 2 { 1.0 } else { 0.0 });
    let instance = RgbImage::from_fn(W, H, |x, y| {
        if (4..8).contains(&x) && (3..7).contains(&y) {
            Rgb([14, 7, 1])
        } else {
            Rgb([1, 0, 0])
        }
    });
    // Every field spelled out, so that a new modality does not compile here until the round
    // trip covers it.
    FrameRecord {
        id: FrameId(id),
        rgb: rgb_frame(id),
        semantic: Some(semantic_with_block(if id == 2 { 100 } else { 114 })),
        instance: Some(instance),
        depth_m: Some((0..W * H).map(|i| 1.0 + i as f32 * 0.5).collect()),
        flow: (id > 0).then(|| FlowField {
            width: W,
            height: H,
            uv: (0..2 * W * H)
                .map(|i| (i % 7) as f32 * 0.25 - 0.75)
                .collect(),
            valid: None,
        }),
        action: Some(action),
        anomaly: Some(anomaly),
        boxes: vec![BoxRecord {
            frame: FrameId(id),
            track_id: 7 + 256,
            x1: 4.0,
            y1: 3.0,
            x2: 8.0,
            y2: 7.0,
            class: 14,
            score: 1.0,
            anomalous: id == 2,
        }],
        anomalous: Some(id == 2),
    }
}

fn meta() -> ScenarioMeta {
    ScenarioMeta {
        domain: Domain::City,
        weather: Weather::Rain,
        time_of_day: Some("night".into()),
        anomaly_type: Some(AnomalyType::SuddenBraking),
        anomaly_window: Some(FrameWindow {
            start: FrameId(2),
            end: FrameId(2),
        }),
        town: Some("Synthetic City".into()),
        seed: Some(7),
        generator: Some("test".into()),
        fps: 10.0,
        camera: None,
    }
}

#[test]
fn every_modality_round_trips_through_scenario() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = (0..4).map(full_frame).collect();
    let dir = ScenarioBuilder::new()
        .meta(meta())
        .frames(frames.clone())
        .write(&root.path().join("Scenario_rt"));
    let scenario = Scenario::open(&dir).expect("opens");

    assert_eq!(scenario.len(), 4);
    assert_eq!(scenario.name(), "Scenario_rt");
    assert_eq!(scenario.meta(), &meta());
    assert_eq!(scenario.resolution(), (W, H));
    assert_eq!(scenario.frame_id(3), Some(FrameId(3)));
    assert_eq!(scenario.index_of(FrameId(2)), Some(2));
    for modality in Modality::ALL {
        assert!(scenario.has(modality), "{modality:?}");
    }

    for (index, frame) in frames.iter().enumerate() {
        assert_eq!(*scenario.rgb(index).expect("rgb"), frame.rgb);
        let semantic = scenario
            .semantic(index)
            .expect("semantic")
            .expect("present");
        assert_eq!(semantic.encoding, SemanticEncoding::ClassIds);
        assert_eq!(Some(&semantic.ids), frame.semantic.as_ref());
        let instance = scenario
            .instance(index)
            .expect("instance")
            .expect("present");
        assert_eq!(Some(instance.to_rgb()), frame.instance);
        let depth = scenario.depth_m(index).expect("depth").expect("present");
        let want = frame.depth_m.as_ref().expect("depth given");
        assert!(
            depth
                .as_raw()
                .iter()
                .zip(want)
                .all(|(a, b)| (a - b).abs() < 1e-3)
        );
        let flow = scenario.flow(index).expect("flow");
        assert_eq!(flow.as_deref(), frame.flow.as_ref());
        assert_eq!(
            scenario.action(index).expect("action").as_ref(),
            frame.action.as_ref()
        );
        let brake = scenario
            .anomaly_state(index)
            .expect("anomaly")
            .and_then(|kv| kv.brake());
        assert_eq!(brake, Some(if index == 2 { 1.0 } else { 0.0 }));
        assert_eq!(scenario.boxes(index).expect("boxes"), frame.boxes);
        let mask = scenario
            .anomaly_mask(index)
            .expect("mask")
            .expect("present");
        assert_eq!(mask.get_pixel(5, 4).0[0], if index == 2 { 255 } else { 0 });
        assert_eq!(mask.get_pixel(0, 0).0[0], 0);
    }
    assert!(matches!(scenario.box_source(), BoxSource::File(_)));
    assert!(
        scenario
            .detections(0)
            .expect("no detections file")
            .is_empty()
    );

    let labels = scenario.frame_labels();
    assert_eq!(labels.source, LabelSource::FrameLabelsFile);
    assert_eq!(labels.flags, vec![false, false, true, false]);
    assert!(labels.problems.is_empty());

    let report = scenario.validate().expect("validates");
    assert!(report.is_clean(), "{}", report.render_text());
}

#[test]
fn detections_are_read_from_their_own_folder() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = ScenarioBuilder::new()
        .frames([rgb_only(0)])
        .write(&root.path().join("Scenario_det"));
    crate::support::sequence::save_text(
        &dir.join("BBOX_2D_DET/boxes.csv"),
        "frame,track_id,x1,y1,x2,y2,class,score,anomalous\n0,3,1,1,4,4,14,0.5,1\n",
    );
    let scenario = Scenario::open(&dir).expect("opens");
    let detections = scenario.detections(0).expect("detections");
    assert_eq!(detections.len(), 1);
    assert_eq!(detections[0].score, 0.5);
    assert!(detections[0].anomalous);
    assert_eq!(scenario.box_source(), &BoxSource::None);
    assert!(scenario.boxes(0).expect("none").is_empty());
}

#[test]
fn palette_semantic_images_map_back_to_ids_and_anomaly_colours() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = ScenarioBuilder::new()
        .frames([rgb_only(0), rgb_only(1), rgb_only(2)])
        .write(&root.path().join("Scenario_pal"));
    let mut ids = semantic_with_block(14);
    ids.put_pixel(0, 0, Luma([11]));
    save_rgb(
        &dir.join("SEMANTIC_IMG/SEMANTIC_IMG_0.png"),
        &colourise(&ids),
    );
    save_rgb(
        &dir.join("SEMANTIC_IMG/SEMANTIC_IMG_1.png"),
        &colourise(&semantic_with_block(100)),
    );
    let mut static_anomaly = colourise(&semantic_with_block(1));
    static_anomaly.put_pixel(2, 2, Rgb([245, 31, 0]));
    static_anomaly.put_pixel(3, 2, Rgb([9, 9, 9]));
    save_rgb(
        &dir.join("SEMANTIC_IMG/SEMANTIC_IMG_2.png"),
        &static_anomaly,
    );

    let scenario = Scenario::open(&dir).expect("opens");
    let semantic = scenario.semantic(0).expect("decodes").expect("present");
    assert_eq!(semantic.encoding, SemanticEncoding::Palette);
    assert_eq!(semantic.ids, ids);

    let mask = scenario.anomaly_mask(1).expect("mask").expect("present");
    let anomalous = mask.pixels().filter(|p| p.0[0] == 255).count();
    assert_eq!(anomalous, 16, "the (245,0,0) block");
    let mask = scenario.anomaly_mask(2).expect("mask").expect("present");
    assert_eq!(
        mask.get_pixel(2, 2).0[0],
        255,
        "(245,31,0) is a static anomaly"
    );
    assert_eq!(mask.pixels().filter(|p| p.0[0] == 255).count(), 1);
    let unknown = scenario.semantic(2).expect("decodes").expect("present");
    assert_eq!(
        unknown.ids.get_pixel(3, 2).0[0],
        0,
        "colours outside the palette read as unlabeled"
    );

    let labels = scenario.frame_labels();
    assert_eq!(labels.source, LabelSource::SemanticImages);
    assert_eq!(labels.flags, vec![false, true, true]);
    assert_eq!(palette::id_of_colour([245, 0, 0]), Some(100));
}

#[test]
fn frame_cache_stays_within_its_byte_budget() {
    let root = tempfile::tempdir().expect("temp dir");
    let frames: Vec<FrameRecord> = (0..20).map(rgb_only).collect();
    let dir = ScenarioBuilder::new()
        .frames(frames)
        .write(&root.path().join("Scenario_cache"));
    let frame_bytes = (3 * W * H) as usize;
    let options = ScenarioOptions {
        cache_budget_bytes: 3 * frame_bytes,
        ..ScenarioOptions::default()
    };
    let scenario = Scenario::open_with(&dir, options).expect("opens");
    for pass in 0..2 {
        for index in 0..scenario.len() {
            let image = scenario.rgb(index).expect("rgb");
            assert_eq!(image.get_pixel(0, 0).0[2], index as u8, "pass {pass}");
            assert!(scenario.cache_bytes() <= scenario.cache_budget());
        }
    }
    assert_eq!(scenario.cache_entries(), 3);
    let again = scenario.rgb(19).expect("cached");
    let same = scenario.rgb(19).expect("cached");
    assert!(
        std::sync::Arc::ptr_eq(&again, &same),
        "a recent frame comes from the cache"
    );
    scenario.set_cache_budget(frame_bytes);
    assert!(scenario.cache_bytes() <= frame_bytes);
    assert_eq!(scenario.cache_entries(), 1);
    // A batch command done with the scenario lets its frames go; reading again decodes.
    scenario.release_decoded();
    assert_eq!((scenario.cache_entries(), scenario.cache_bytes()), (0, 0));
    let decoded = scenario.rgb(19).expect("decodes again");
    assert_eq!(decoded.get_pixel(0, 0).0[2], 19);
    assert!(!std::sync::Arc::ptr_eq(&decoded, &same));
}

#[test]
fn cache_dir_is_inside_the_scenario_or_falls_back_per_user() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = ScenarioBuilder::new()
        .frames([rgb_only(0)])
        .write(&root.path().join("Scenario_cd"));
    let scenario = Scenario::open(&dir).expect("opens");
    let cache = scenario.cache_dir().expect("cache dir");
    assert_eq!(cache, dir.join(".vadscope"));
    assert!(cache.is_dir());

    let blocked = ScenarioBuilder::new()
        .frames([rgb_only(0)])
        .write(&root.path().join("Scenario_ro"));
    // A file where the folder should be makes `.vadscope/` impossible to create, as a
    // read-only scenario would (tests may run as root, which ignores permissions).
    std::fs::write(blocked.join(".vadscope"), b"").expect("write blocker");
    let user_base = root.path().join("user-cache");
    let options = ScenarioOptions {
        user_cache_base: user_base.clone(),
        ..ScenarioOptions::default()
    };
    let scenario = Scenario::open_with(&blocked, options).expect("opens");
    let fallback = scenario.cache_dir().expect("fallback");
    assert!(fallback.starts_with(&user_base), "{}", fallback.display());
    assert!(fallback.is_dir());
    let name = fallback.file_name().and_then(|n| n.to_str()).expect("name");
    assert!(name.starts_with("Scenario_ro-"), "{name}");
    assert_eq!(scenario.cache_dir().expect("stable"), fallback);
}

#[test]
fn index_out_of_range_is_an_error_not_a_panic() {
    let root = tempfile::tempdir().expect("temp dir");
    let dir = ScenarioBuilder::new()
        .frames([rgb_only(0)])
        .write(&root.path().join("Scenario_oob"));
    let scenario = Scenario::open(&dir).expect("opens");
    let message = scenario.rgb(5).expect_err("out of range").to_string();
    assert!(
        message.contains("out of range") && message.contains("Scenario_oob"),
        "{message}"
    );
    assert!(scenario.semantic(5).is_err());
    assert!(scenario.boxes(5).is_err());
    assert!(scenario.semantic(0).expect("absent is fine").is_none());
    assert!(scenario.flow(0).expect("absent").is_none());
}

#[test]
fn scenario_and_writer_can_be_shared_between_threads() {
    fn shareable<T: Send + Sync>() {}
    shareable::<Scenario>();
    shareable::<vadscope::sequence::ScenarioWriter>();
}
