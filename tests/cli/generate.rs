//! The `vadscope` binary end to end: `generate` writes scenarios that `inspect` reads back,
//! and bad paths or arguments fail with a message instead of a panic.

use std::path::Path;

use crate::support::cli::{scenario_folders, text, tiny_generate_args, vadscope};

#[test]
fn generate_then_inspect_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let gen_args = tiny_generate_args(out, "3");
    let generated = vadscope(&gen_args);
    assert!(
        generated.status.success(),
        "generate failed: {}",
        text(&generated.stderr)
    );

    let scenarios = scenario_folders(dir.path());
    assert_eq!(scenarios.len(), 1);
    for folder in [
        "RGB_IMG",
        "SEMANTIC_IMG",
        "INSTANCE_IMG",
        "DEPTH_IMG",
        "OPTICAL_FLOW",
        "ACTION",
    ] {
        let n = std::fs::read_dir(scenarios[0].join(folder))
            .unwrap()
            .count();
        assert_eq!(n, 12, "{folder} should hold one file per frame");
    }

    let again = vadscope(&gen_args);
    assert!(
        !again.status.success(),
        "existing scenarios must not be overwritten silently"
    );
    assert!(text(&again.stderr).contains("already exists"));

    let inspected = vadscope(&["inspect", out, "--json"]);
    assert!(
        inspected.status.success(),
        "inspect failed: {}",
        text(&inspected.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&inspected.stdout).unwrap();
    let summary = &report["scenarios"][0]["summary"];
    assert_eq!(summary["frames"], 12, "{summary}");

    let human = vadscope(&["inspect", scenarios[0].to_str().unwrap()]);
    assert!(human.status.success());
    assert!(
        text(&human.stdout).contains("96"),
        "text report names the size"
    );
}

#[test]
fn inspect_fails_cleanly_without_frames() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("Scenario_empty");
    std::fs::create_dir_all(empty.join("RGB_IMG")).unwrap();
    let out = vadscope(&["inspect", dir.path().to_str().unwrap()]);
    assert!(!out.status.success());
    let all = text(&out.stdout) + &text(&out.stderr);
    assert!(all.contains("Scenario_empty"), "names the folder: {all}");
    assert!(!all.contains("panicked"));

    let missing = vadscope(&[
        "inspect",
        Path::new("/nonexistent/vadscope").to_str().unwrap(),
    ]);
    assert!(!missing.status.success());
    assert!(text(&missing.stderr).contains("/nonexistent/vadscope"));
}

#[test]
fn generate_rejects_bad_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let out = vadscope(&[
        "generate",
        "--out",
        dir.path().to_str().unwrap(),
        "--size",
        "96by64",
    ]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("WIDTHxHEIGHT"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn omitted_modalities_are_not_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = vadscope(&[
        "generate",
        "--out",
        dir.path().to_str().unwrap(),
        "--kind",
        "normal",
        "--frames",
        "3",
        "--size",
        "64x48",
        "--omit",
        "depth,flow",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let scenario = std::fs::read_dir(dir.path())
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    assert!(scenario.join("RGB_IMG").is_dir());
    assert!(scenario.join("SEMANTIC_IMG").is_dir());
    assert!(!scenario.join("DEPTH_IMG").exists());
    assert!(!scenario.join("OPTICAL_FLOW").exists());
}

#[test]
fn resume_keeps_complete_scenarios_and_refuses_different_ones() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let args = |frames: &'static str, extra: &[&'static str]| {
        let mut args = vec![
            "generate", "--out", out, "--count", "3", "--frames", frames, "--size", "96x64",
            "--seed", "5",
        ];
        args.extend_from_slice(extra);
        args
    };
    let first = vadscope(&args("12", &[]));
    assert!(first.status.success(), "{}", text(&first.stderr));
    let scenarios = scenario_folders(dir.path());
    assert_eq!(scenarios.len(), 3);
    let kept_frame = scenarios[0].join("RGB_IMG/RGB_IMG_5.png");
    let kept_at = std::fs::metadata(&kept_frame).unwrap().modified().unwrap();
    let lost = &scenarios[2];
    let lost_frame = std::fs::read(lost.join("RGB_IMG/RGB_IMG_11.png")).unwrap();

    // What a run killed during the third scenario leaves: two scenarios and a hidden stub.
    std::fs::remove_dir_all(lost).unwrap();
    let name = lost.file_name().unwrap().to_str().unwrap();
    let stub = dir.path().join(format!(".{name}.partial/RGB_IMG"));
    std::fs::create_dir_all(&stub).unwrap();
    std::fs::write(stub.join("RGB_IMG_0.png"), b"half").unwrap();

    let resumed = vadscope(&args("12", &["--resume"]));
    let said = text(&resumed.stdout) + &text(&resumed.stderr);
    assert!(resumed.status.success(), "{said}");
    assert_eq!(said.matches("(complete)").count(), 2, "{said}");
    assert_eq!(scenario_folders(dir.path()), scenarios);
    assert!(!stub.parent().unwrap().exists(), "the stub is cleared");
    assert_eq!(
        std::fs::read(lost.join("RGB_IMG/RGB_IMG_11.png")).unwrap(),
        lost_frame,
        "the missing scenario is generated again, byte for byte"
    );
    assert_eq!(
        std::fs::metadata(&kept_frame).unwrap().modified().unwrap(),
        kept_at,
        "complete scenarios are not rendered again"
    );

    // Folders that hold something else stop the run and are left as they are.
    for (frames, extra, problem) in [
        ("10", &["--resume"][..], "12 RGB frames"),
        (
            "12",
            &["--resume", "--omit", "depth"][..],
            "DEPTH_IMG is there but left out of this run",
        ),
    ] {
        let refused = vadscope(&args(frames, extra));
        let message = text(&refused.stderr);
        assert!(!refused.status.success(), "{frames} {extra:?}");
        assert!(
            message.contains(scenarios[0].to_str().unwrap())
                && message.contains("does not hold this scenario")
                && message.contains(problem),
            "{message}"
        );
        assert_eq!(
            std::fs::metadata(&kept_frame).unwrap().modified().unwrap(),
            kept_at
        );
    }
    let both = vadscope(&args("12", &["--resume", "--force"]));
    assert!(!both.status.success());
    assert!(
        text(&both.stderr).contains("cannot be used with"),
        "{}",
        text(&both.stderr)
    );
}
