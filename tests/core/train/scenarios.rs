//! Cubes gathered from scenarios on disk for training: one cube per normal box and frame
//! from frame `clip_hist` on, frames and flows cropped with the box of the target frame,
//! anomalous frames and boxes and the boxes the model's filter drops left out, one split
//! group per scenario.

use std::path::{Path, PathBuf};

use image::RgbImage;

use vadscope::model::{BoxFilter, ModelConfig};
use vadscope::sequence::{BoxRecord, FlowField, FrameId, FrameRecord};
use vadscope::train::scenarios::{CubeExtraction, cubes_from_scenarios, scenario_folders};

use crate::support::scenario::ScenarioBuilder;

/// An 8-frame scenario: frame k is a gradient whose blue channel is 30·k; the flow stored at
/// frame k ≥ 1 is (k, 0.5); one normal box per frame, plus an anomalous one in frame 5, and
/// frame 4 labelled anomalous.
fn write_scenario(dir: &Path) -> PathBuf {
    let frame = |k: u64| {
        let rgb = RgbImage::from_fn(48, 40, |x, y| {
            image::Rgb([x as u8 * 4, y as u8 * 5, 30 * k as u8])
        });
        let flow = (k > 0).then(|| {
            let mut f = FlowField::zeros(48, 40);
            for px in f.uv.chunks_mut(2) {
                px[0] = k as f32;
                px[1] = 0.5;
            }
            f
        });
        let bbox = |track, anomalous| BoxRecord {
            frame: FrameId(k),
            track_id: track,
            x1: 8.0,
            y1: 4.0,
            x2: 40.0,
            y2: 36.0,
            class: 14,
            score: 1.0,
            anomalous,
        };
        let mut boxes = vec![bbox(1, false)];
        if k == 5 {
            boxes.push(bbox(2, true));
        }
        FrameRecord {
            flow,
            boxes,
            anomalous: Some(k == 4),
            ..FrameRecord::new(FrameId(k), rgb)
        }
    };
    ScenarioBuilder::new().frames((0..8).map(frame)).write(dir)
}

#[test]
fn cubes_come_from_normal_frames_and_boxes_of_each_scenario() {
    let root = tempfile::tempdir().expect("temp dir");
    write_scenario(&root.path().join("Scenario_a"));
    write_scenario(&root.path().join("Scenario_b"));
    let folders = scenario_folders(&[root.path().to_path_buf()]).expect("discover");
    assert_eq!(folders.len(), 2);

    let mut config = ModelConfig::parity();
    config.patch_size = 16;
    let mut calls = Vec::new();
    let set = cubes_from_scenarios(
        &folders,
        &CubeExtraction::for_model(&config),
        &mut |d, t| calls.push((d, t)),
    )
    .expect("cubes");
    assert_eq!(calls, vec![(1, 2), (2, 2)]);
    // Frames 5, 6, 7: none before clip_hist (4), and frame 4 is anomalous; one normal box
    // each, two scenarios.
    assert_eq!(set.len(), 6);
    assert_eq!((set.group_of(0), set.group_of(5)), (0, 1));
    let area = 16 * 16;
    let blue = |cube: usize, t: usize| set.frames_of(cube)[(3 * t + 2) * area];
    for cube in 0..set.len() {
        assert!(
            blue(cube, 0) >= 30,
            "cube {cube} repeats frame 0: no cube may come from a frame before clip_hist"
        );
        assert!(
            set.flows_of(cube).iter().all(|&v| v != 0.0),
            "cube {cube} holds the zero flow stored at frame 0"
        );
    }

    // Cube of frame 5 (the first of scenario a): frames 1..5, flows stored at 2..5.
    let cube = 0;
    assert_eq!((blue(cube, 0), blue(cube, 4)), (30, 150));
    let flows = set.flows_of(cube);
    assert!((flows[0] - 2.0).abs() < 0.01, "KITTI PNG flow quantisation");
    assert!((flows[area] - 0.5).abs() < 0.01);
    assert!((flows[6 * area] - 5.0).abs() < 0.01);
}

#[test]
fn the_models_box_filter_decides_which_boxes_give_cubes() {
    let root = tempfile::tempdir().expect("temp dir");
    write_scenario(&root.path().join("Scenario_a"));
    let folders = scenario_folders(&[root.path().to_path_buf()]).expect("discover");
    let mut config = ModelConfig::parity();
    config.patch_size = 16;
    let count = |config: &ModelConfig| {
        cubes_from_scenarios(&folders, &CubeExtraction::for_model(config), &mut |_, _| {})
            .expect("cubes")
            .len()
    };
    assert_eq!(count(&config), 3);
    // The 32×32 box covers 0.53 of the 48×40 frame.
    config.box_filter = BoxFilter {
        min_area_fraction: 0.5,
        drop_truncated: false,
    };
    assert_eq!(count(&config), 3);
    config.box_filter.min_area_fraction = 0.6;
    assert_eq!(count(&config), 0);
    // Its edges stay 8 px inside the image: not truncated.
    config.box_filter = BoxFilter {
        min_area_fraction: 0.0,
        drop_truncated: true,
    };
    assert_eq!(count(&config), 3);
}
