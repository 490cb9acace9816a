//! `vadscope flow` end to end: it fills the `.vadscope/` flow cache without touching the
//! scenario's own files, resumes instead of recomputing, evaluates against the stored flow,
//! and fails with a message on bad input.

use std::path::{Path, PathBuf};

use crate::support::cli::{scenario_folders, text, vadscope};

/// Generates one small scenario (with stored ground-truth flow) and returns its folder.
fn generate(out: &Path, frames: u32, domain: &str, size: &str) -> PathBuf {
    let generated = vadscope(&[
        "generate",
        "--out",
        out.to_str().unwrap(),
        "--kind",
        "normal",
        "--domain",
        domain,
        "--weather",
        "sun",
        "--frames",
        &frames.to_string(),
        "--size",
        size,
        "--seed",
        "12",
    ]);
    assert!(generated.status.success(), "{}", text(&generated.stderr));
    scenario_folders(out).remove(0)
}

fn cached_flows(scenario: &Path, preset: &str) -> Vec<PathBuf> {
    let folder = scenario.join(".vadscope/flow").join(preset);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&folder)
        .map(|d| d.map(|e| e.unwrap().path()).collect())
        .unwrap_or_default();
    files.retain(|p| p.extension().is_some_and(|e| e == "png"));
    files.sort();
    files
}

#[test]
fn missing_flow_is_computed_into_the_cache_and_resumed() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = generate(dir.path(), 6, "highway", "96x64");
    // Real AnoVox data has no flow: take the generator's away so the cache has work to do.
    std::fs::remove_dir_all(scenario.join("OPTICAL_FLOW")).unwrap();
    let rgb_before: Vec<_> = std::fs::read_dir(scenario.join("RGB_IMG"))
        .unwrap()
        .map(|e| std::fs::read(e.unwrap().path()).unwrap())
        .collect();

    let first = vadscope(&["flow", scenario.to_str().unwrap(), "--preset", "ultrafast"]);
    assert!(first.status.success(), "{}", text(&first.stderr));
    assert!(
        text(&first.stderr).contains("5 computed"),
        "{}",
        text(&first.stderr)
    );
    let files = cached_flows(&scenario, "ultrafast");
    assert_eq!(
        files.len(),
        5,
        "one flow per frame after the first: {files:?}"
    );
    let flow = vadscope::sequence::flow_file::read_kitti_png(&files[0]).unwrap();
    assert_eq!((flow.width, flow.height), (96, 64));
    assert!(
        !scenario.join("OPTICAL_FLOW").exists(),
        "source data must not be written"
    );
    let rgb_after: Vec<_> = std::fs::read_dir(scenario.join("RGB_IMG"))
        .unwrap()
        .map(|e| std::fs::read(e.unwrap().path()).unwrap())
        .collect();
    assert_eq!(rgb_before, rgb_after);

    // An interrupted run leaves some files; the next run computes only the rest.
    std::fs::remove_file(&files[2]).unwrap();
    let second = vadscope(&[
        "flow",
        scenario.to_str().unwrap(),
        "--preset",
        "ultrafast",
        "--threads",
        "1",
    ]);
    assert!(second.status.success(), "{}", text(&second.stderr));
    let log = text(&second.stderr);
    assert!(
        log.contains("1 computed") && log.contains("4 already cached"),
        "{log}"
    );
}

#[test]
fn evaluate_reports_endpoint_error_against_stored_flow() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = generate(dir.path(), 5, "city", "128x96");
    let out = vadscope(&[
        "flow",
        scenario.to_str().unwrap(),
        "--preset",
        "medium",
        "--evaluate",
        "--json",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let parsed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let evaluation = &parsed[0];
    assert_eq!(evaluation["frames"].as_array().unwrap().len(), 4);
    let epe_valid = evaluation["mean_epe_valid"].as_f64().unwrap();
    let epe_boxes = evaluation["mean_vehicle_box_epe"].as_f64().unwrap();
    // The yardstick is "no motion": the mean ground-truth displacement on valid pixels.
    let opened = vadscope::sequence::Scenario::open(&scenario).unwrap();
    let (mut sum, mut n) = (0.0f64, 0usize);
    for index in 1..opened.len() {
        let truth = opened.flow(index).unwrap().expect("stored flow");
        for y in 0..truth.height {
            for x in 0..truth.width {
                if truth.is_valid(x, y) {
                    let [u, v] = truth.at(x, y);
                    sum += f64::from(u.hypot(v));
                    n += 1;
                }
            }
        }
    }
    let zero_motion_epe = sum / n as f64;
    assert!(
        epe_valid.is_finite() && epe_valid < 0.6 * zero_motion_epe,
        "DIS EPE {epe_valid} px against {zero_motion_epe} px for zero flow"
    );
    assert!(
        epe_boxes.is_finite() && epe_boxes < 1.0,
        "vehicle 32×32 EPE {epe_boxes} px"
    );
}

#[test]
fn bad_input_fails_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nowhere");
    let out = vadscope(&["flow", missing.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("nowhere"),
        "{}",
        text(&out.stderr)
    );

    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let out = vadscope(&["flow", empty.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("empty"), "{}", text(&out.stderr));

    let scenario = generate(&dir.path().join("data"), 3, "highway", "96x64");
    let out = vadscope(&["flow", scenario.to_str().unwrap(), "--preset", "slowest"]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("slowest"),
        "{}",
        text(&out.stderr)
    );
}
