//! Box sources: motion boxes on a synthetic moving square, IoU matching, detection-file
//! readers (good and malformed input) and their assignment to the frames of a scenario.

use std::path::Path;

use vadscope::score::motion::{blur_frame, motion_boxes};
use vadscope::score::{
    BoxMatchStats, BoxProvider, BoxSource, DetectionFile, DetectionFormat, FrameNumbering,
    MotionParams, box_iou, match_boxes, match_scenario,
};
use vadscope::sequence::detections::{FrameRef, parse_coco, parse_mot, parse_yolo};
use vadscope::sequence::{BoxRecord, FrameId, Scenario};

use crate::support::scenario::{SQUARE, square_box, square_frame, square_scenario, square_x};

fn bbox(x1: f32, y1: f32, x2: f32, y2: f32) -> BoxRecord {
    BoxRecord {
        frame: FrameId(0),
        track_id: 0,
        x1,
        y1,
        x2,
        y2,
        class: 0,
        score: 1.0,
        anomalous: false,
    }
}

/// Motion constants for the small test frames (the driving preset's 24×24 minimum suits
/// 768×512).
fn small_params() -> MotionParams {
    MotionParams {
        contour_min_area: 10 * 10,
        ..MotionParams::driving()
    }
}

fn blurred(k: u64, params: &MotionParams) -> image::RgbImage {
    blur_frame(&square_frame(k), params.gauss_kernel)
}

#[test]
fn a_moving_square_gives_one_box_around_its_motion() {
    let p = small_params();
    let boxes = motion_boxes(
        FrameId(3),
        &blurred(2, &p),
        &blurred(3, &p),
        &blurred(4, &p),
        &p,
        &[],
    )
    .expect("boxes");
    assert_eq!(boxes.len(), 1, "{boxes:?}");
    let b = boxes[0];
    // The square covers x 16..32 at frame 2 and 24..40 at frame 4: the changed pixels span
    // them, grown by the blur (up to 2 px where the difference still passes the threshold)
    // and by the box growth (2 px).
    let motion = bbox(
        square_x(2) as f32 - 3.0,
        21.0,
        (square_x(4) + SQUARE) as f32 + 3.0,
        43.0,
    );
    assert!(box_iou(&b, &motion) > 0.9, "{b:?}");
    let truth = square_box(3);
    assert!(b.x1 <= truth.x1 && b.y1 <= truth.y1 && b.x2 >= truth.x2 && b.y2 >= truth.y2);
    assert_eq!((b.frame, b.track_id), (FrameId(3), 0));
}

#[test]
fn still_frames_detector_boxes_and_small_regions_give_no_motion_box() {
    let p = small_params();
    let still = blurred(3, &p);
    assert!(
        motion_boxes(FrameId(3), &still, &still, &still, &p, &[])
            .expect("ok")
            .is_empty()
    );
    let cover = bbox(10.0, 20.0, 50.0, 44.0);
    let boxes = motion_boxes(
        FrameId(3),
        &blurred(2, &p),
        &blurred(3, &p),
        &blurred(4, &p),
        &p,
        &[cover],
    )
    .expect("ok");
    assert!(
        boxes.is_empty(),
        "motion inside the grown detector box is cleared: {boxes:?}"
    );
    let strict = MotionParams {
        contour_min_area: 40 * 40,
        ..p
    };
    assert!(
        motion_boxes(
            FrameId(3),
            &blurred(2, &p),
            &blurred(3, &p),
            &blurred(4, &p),
            &strict,
            &[]
        )
        .expect("ok")
        .is_empty()
    );
    let tiny = MotionParams {
        max_area_fraction: 0.05,
        ..p
    };
    assert!(
        motion_boxes(
            FrameId(3),
            &blurred(2, &p),
            &blurred(3, &p),
            &blurred(4, &p),
            &tiny,
            &[]
        )
        .expect("ok")
        .is_empty(),
        "boxes over 5 % of the image are dropped"
    );
    let odd = image::RgbImage::new(10, 10);
    assert!(
        motion_boxes(FrameId(0), &odd, &still, &still, &p, &[]).is_err(),
        "size mismatch"
    );
}

#[test]
fn iou_and_greedy_matching() {
    let a = bbox(0.0, 0.0, 10.0, 10.0);
    assert_eq!(box_iou(&a, &a), 1.0);
    assert_eq!(
        box_iou(&a, &bbox(10.0, 0.0, 20.0, 10.0)),
        0.0,
        "touching edges do not overlap"
    );
    assert!((box_iou(&a, &bbox(5.0, 0.0, 15.0, 10.0)) - 1.0 / 3.0).abs() < 1e-6);
    assert_eq!(box_iou(&bbox(3.0, 3.0, 3.0, 9.0), &a), 0.0, "empty box");

    let truth = [bbox(0.0, 0.0, 10.0, 10.0), bbox(8.0, 0.0, 18.0, 10.0)];
    // P0 overlaps both truths; P1 fits T1 well. Greedy: (T1, P1) first, then (T0, P0).
    let predicted = [
        bbox(1.0, 0.0, 11.0, 10.0),
        bbox(8.0, 0.0, 18.0, 10.0),
        bbox(50.0, 50.0, 60.0, 60.0),
    ];
    let m = match_boxes(&truth, &predicted);
    assert_eq!(m.len(), 2);
    assert_eq!((m[0].truth, m[0].predicted, m[0].iou), (1, 1, 1.0));
    assert_eq!((m[1].truth, m[1].predicted), (0, 0));

    let mut stats = BoxMatchStats::new(0.5);
    stats.add_frame(&truth, &predicted);
    stats.add_frame(&[bbox(0.0, 0.0, 4.0, 4.0)], &[]);
    assert_eq!(
        (
            stats.frames,
            stats.truth_boxes,
            stats.predicted_boxes,
            stats.found
        ),
        (2, 3, 3, 2)
    );
    let iou0 = f64::from(box_iou(&truth[0], &predicted[0]));
    assert!((stats.mean_iou().expect("truth") - (1.0 + iou0) / 3.0).abs() < 1e-6);
    assert_eq!(stats.recall(), Some(2.0 / 3.0));
    assert_eq!(stats.precision(), Some(2.0 / 3.0));
    assert_eq!(BoxMatchStats::new(0.5).mean_iou(), None);
}

fn line_error(
    result: Result<impl std::fmt::Debug, vadscope::sequence::SequenceError>,
    needle: &str,
) {
    let message = result.expect_err("malformed input").to_string();
    assert!(message.contains(needle), "expected {needle:?} in {message}");
}

#[test]
fn malformed_detection_rows_name_file_and_line() {
    let p = Path::new("dets/det.txt");
    line_error(
        parse_mot(p, "1,1,0,0,5,5\n2,1,0,0,5\n"),
        "dets/det.txt:2: 5 fields",
    );
    line_error(parse_mot(p, "1,1,0,zero,5,5\n"), "det.txt:1: top \"zero\"");
    line_error(
        parse_mot(p, "\n\n1,1,0,0,-5,5\n"),
        "det.txt:3: box size -5×5 is negative",
    );
    line_error(parse_mot(p, "1.5,1,0,0,5,5\n"), "det.txt:1: frame");
    line_error(parse_mot(p, "1,1,0,0,5,inf\n"), "height");
    line_error(parse_mot(p, "1,1,0,0,5,5,0.5,x\n"), "class");

    let y = Path::new("labels/RGB_IMG_3.txt");
    let frame = FrameRef::Id(FrameId(3));
    line_error(
        parse_yolo(y, "0 0.5 0.5 0.1\n", frame.clone(), 96, 64),
        "RGB_IMG_3.txt:1: 4 fields",
    );
    line_error(
        parse_yolo(
            y,
            "0 0.5 0.5 0.1 0.1\n1 48 32 10 10\n",
            frame.clone(),
            96,
            64,
        ),
        "RGB_IMG_3.txt:2: cx",
    );
    line_error(
        parse_yolo(y, "car 0.5 0.5 0.1 0.1\n", frame.clone(), 96, 64),
        "class",
    );

    let c = Path::new("coco.json");
    line_error(
        parse_coco(c, "[{\"image_id\": 1, \"bbox\": [1, 2, 3]}]"),
        "coco.json:1",
    );
    line_error(
        parse_coco(
            c,
            "{\"annotations\": [\n{\"image_id\": 1,\n\"bbox\": [1, 2, 3, 4],}\n]}",
        ),
        "coco.json:3",
    );
    line_error(
        parse_coco(c, "[{\"image_id\": 4, \"bbox\": [1, 2, -3, 4]}]"),
        "annotation 0 (image_id 4)",
    );
    line_error(
        parse_coco(
            c,
            "{\"images\": [{\"id\": 1, \"file_name\": \"a.png\"}], \"annotations\": [{\"image_id\": 2, \"bbox\": [0, 0, 1, 1]}]}",
        ),
        "not in `images`",
    );
}

#[test]
fn coco_shapes_parse() {
    let c = Path::new("c.json");
    let results = parse_coco(
        c,
        "[{\"image_id\": 3, \"category_id\": 2, \"bbox\": [1, 2, 3, 4], \"score\": 0.5}]",
    )
    .expect("results");
    assert_eq!(results[0].frame, FrameRef::Number(3));
    let b = results[0].bbox;
    assert_eq!(
        (b.x1, b.y1, b.x2, b.y2, b.class, b.score),
        (1.0, 2.0, 4.0, 6.0, 2, 0.5)
    );
    let dataset = parse_coco(
        c,
        "{\"images\": [{\"id\": 9, \"file_name\": \"RGB_IMG/RGB_IMG_2.png\"}], \"annotations\": [{\"image_id\": 9, \"bbox\": [0, 0, 1, 1], \"track_id\": 4}]}",
    )
    .expect("dataset");
    assert_eq!(dataset[0].frame, FrameRef::Stem("RGB_IMG_2".into()));
    assert_eq!(dataset[0].bbox.track_id, 4);
}

#[test]
fn imported_files_are_assigned_to_frames_and_keyed_by_content() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = square_scenario(6).write(&dir.path().join("s"));
    let scenario = Scenario::open(&root).expect("open");

    // MOT numbers frames from 1; frame 9 is not in the scenario.
    let mot = dir.path().join("det.txt");
    std::fs::write(
        &mot,
        "1,7,8,24,16,16,0.9\n3,7,16,24,16,16,0.8\n9,7,0,0,4,4,0.7\n",
    )
    .expect("write");
    let file = DetectionFile::guess(&mot).expect("guess");
    assert_eq!(
        (file.format, file.numbering),
        (DetectionFormat::Mot, FrameNumbering::OneBasedIndex)
    );
    let mut provider =
        BoxProvider::new(&scenario, &BoxSource::Imported(file.clone())).expect("provider");
    assert_eq!(provider.unmatched_detections(), 1);
    let boxes = provider.boxes(2).expect("boxes");
    assert_eq!(boxes.len(), 1);
    assert_eq!(
        (boxes[0].frame, boxes[0].x1, boxes[0].track_id),
        (FrameId(2), 16.0, 7)
    );
    assert!(provider.boxes(1).expect("boxes").is_empty());
    let key = BoxSource::Imported(file.clone()).key().expect("key");
    assert!(key.starts_with("mot-"), "{key}");

    let min_score = DetectionFile {
        min_score: Some(0.85),
        ..file.clone()
    };
    let mut strict =
        BoxProvider::new(&scenario, &BoxSource::Imported(min_score.clone())).expect("provider");
    assert!(strict.boxes(2).expect("boxes").is_empty(), "0.8 < 0.85");
    assert_ne!(BoxSource::Imported(min_score).key().expect("key"), key);
    std::fs::write(&mot, "1,7,8,24,16,16,0.95\n").expect("write");
    assert_ne!(
        BoxSource::Imported(file).key().expect("key"),
        key,
        "new content, new key"
    );

    // YOLO: one file per frame, named like the RGB files.
    let yolo = dir.path().join("labels");
    std::fs::create_dir(&yolo).expect("mkdir");
    std::fs::write(yolo.join("RGB_IMG_4.txt"), "2 0.5 0.5 0.25 0.25 0.6\n").expect("write");
    std::fs::write(yolo.join("RGB_IMG_77.txt"), "2 0.5 0.5 0.25 0.25\n").expect("write");
    let file = DetectionFile::guess(&yolo).expect("guess");
    assert_eq!(file.format, DetectionFormat::Yolo);
    let mut provider = BoxProvider::new(&scenario, &BoxSource::Imported(file)).expect("provider");
    assert_eq!(provider.unmatched_detections(), 1);
    let b = provider.boxes(4).expect("boxes")[0];
    assert_eq!(
        (b.x1, b.y1, b.x2, b.y2, b.class),
        (36.0, 24.0, 60.0, 40.0, 2)
    );

    // A malformed file fails when the provider is built, naming file and line.
    std::fs::write(yolo.join("RGB_IMG_5.txt"), "2 0.5 0.5\n").expect("write");
    let error = BoxProvider::new(
        &scenario,
        &BoxSource::Imported(DetectionFile::guess(&yolo).expect("guess")),
    )
    .err()
    .expect("malformed")
    .to_string();
    assert!(error.contains("RGB_IMG_5.txt:1"), "{error}");

    // COCO results with frame-id numbering.
    let coco = dir.path().join("results.json");
    std::fs::write(&coco, "[{\"image_id\": 5, \"bbox\": [1, 1, 2, 2]}]").expect("write");
    let file = DetectionFile {
        numbering: FrameNumbering::FrameId,
        ..DetectionFile::guess(&coco).expect("guess")
    };
    let mut provider = BoxProvider::new(&scenario, &BoxSource::Imported(file)).expect("provider");
    assert_eq!(provider.boxes(5).expect("boxes").len(), 1);
}

#[test]
fn motion_and_ground_truth_sources_against_the_ground_truth() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = square_scenario(6).write(&dir.path().join("s"));
    let scenario = Scenario::open(&root).expect("open");

    let gt = match_scenario(&scenario, &BoxSource::GroundTruth, 0.5).expect("gt");
    assert_eq!((gt.truth_boxes, gt.found), (6, 6));
    assert_eq!(gt.mean_iou(), Some(1.0));

    let motion = BoxSource::Motion(small_params());
    let mut provider = BoxProvider::new(&scenario, &motion).expect("provider");
    for i in 0..6u64 {
        let boxes = provider.boxes(i as usize).expect("boxes");
        // Inside the scenario two differences add up to one region; the first and last
        // frames see one difference (reflected), where stripes that coincide in both
        // frames leave a gap that splits the region in two.
        let t = square_box(i);
        let covered = |x: u32| {
            let x = x as f32 + 0.5;
            boxes
                .iter()
                .any(|b| b.x1 <= x && x < b.x2 && b.y1 <= t.y1 && b.y2 >= t.y2)
        };
        let columns = (t.x1 as u32..t.x2 as u32).filter(|&x| covered(x)).count();
        if (1..5).contains(&i) {
            assert_eq!(boxes.len(), 1, "frame {i}: {boxes:?}");
            assert_eq!(columns, SQUARE as usize, "frame {i}: {boxes:?}");
        } else {
            assert!(
                columns >= 13,
                "frame {i}: {columns} of 16 columns: {boxes:?}"
            );
        }
    }
    let stats = match_scenario(&scenario, &motion, 0.3).expect("motion");
    assert_eq!(stats.frames, 6);
    assert_eq!(stats.found, 6, "every square is matched with IoU ≥ 0.3");
    let mean = stats.mean_iou().expect("truth");
    assert!(
        mean > 0.35 && mean < 0.9,
        "motion boxes are larger than the square: {mean}"
    );

    let hybrid = BoxSource::WithMotion {
        base: Box::new(BoxSource::GroundTruth),
        motion: small_params(),
    };
    let mut provider = BoxProvider::new(&scenario, &hybrid).expect("provider");
    for i in 0..6 {
        assert_eq!(
            provider.boxes(i).expect("boxes"),
            vec![square_box(i as u64)],
            "frame {i}"
        );
    }
    assert_eq!(
        hybrid.key().expect("key"),
        format!("gt+{}", small_params().key())
    );
    assert!(
        BoxProvider::new(
            &scenario,
            &BoxSource::Motion(MotionParams {
                gauss_kernel: 2,
                ..small_params()
            })
        )
        .is_err()
    );
    assert!(
        BoxProvider::new(&scenario, &BoxSource::Detections)
            .expect("no file")
            .boxes(0)
            .expect("boxes")
            .is_empty()
    );
}

#[test]
fn a_coco_file_name_names_a_frame_and_is_never_a_path_to_open() {
    let text = r#"{"images": [{"id": 1, "file_name": "../../../../etc/RGB_IMG_7.png"}],
        "annotations": [{"image_id": 1, "bbox": [0, 0, 4, 4]}]}"#;
    let parsed = parse_coco(Path::new("det.json"), text).expect("parses");
    assert_eq!(parsed.len(), 1);
    assert_eq!(parsed[0].frame, FrameRef::Stem("RGB_IMG_7".into()));
}
