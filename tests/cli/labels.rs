//! `vadscope labels` end to end: show, export then import, clear errors, and labels another
//! process holds refused.

use std::process::Output;

use vadscope::annotate::Editor;
use vadscope::sequence::Scenario;

use crate::support::annotate::write_scenario;
use crate::support::cli::{text, vadscope};

fn labels(args: &[&str]) -> Output {
    vadscope(&[&["labels"], args].concat())
}

#[test]
fn labels_command_shows_exports_imports_and_reports_errors() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = write_scenario(dir.path());
    let scenario = root.to_str().expect("utf-8 path");
    let shown = labels(&[scenario, "--show"]);
    assert!(shown.status.success(), "{}", text(&shown.stderr));
    let out = text(&shown.stdout);
    assert!(out.contains("8 frames"), "{out}");
    assert!(out.contains("interval 1: #3-#5 (ids 106-110)"), "{out}");

    let csv = dir.path().join("intervals.csv");
    let csv = csv.to_str().expect("utf-8 path");
    let exported = labels(&[scenario, "--export", csv, "--format", "intervals-csv"]);
    assert!(exported.status.success(), "{}", text(&exported.stderr));
    let imported = labels(&[scenario, "--import", csv, "--format", "intervals-csv"]);
    assert!(imported.status.success(), "{}", text(&imported.stderr));
    assert!(
        text(&imported.stdout).contains("imported 1 rows"),
        "{}",
        text(&imported.stdout)
    );

    for (args, needle) in [
        (vec![scenario], "nothing to do"),
        (
            vec![scenario, "--export", csv, "--format", "bogus"],
            "unknown format",
        ),
        (vec![scenario, "--export", csv], "--format"),
        (
            vec![scenario, "--import", "missing-gt.txt", "--format", "mot"],
            "missing-gt.txt",
        ),
    ] {
        let failed = labels(&args);
        assert!(!failed.status.success(), "{args:?}");
        let message = text(&failed.stderr);
        assert!(message.contains(needle), "{args:?}: {message}");
    }
}

#[test]
fn labels_held_by_another_process_are_refused_with_a_message() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = write_scenario(dir.path());
    let scenario = root.to_str().expect("utf-8 path");
    // This test process holds the labels open, as a viewer would.
    let holder = Editor::open(&Scenario::open(&root).expect("scenario")).expect("labels");
    let refused = labels(&[scenario, "--show"]);
    assert!(!refused.status.success());
    let message = text(&refused.stderr);
    assert!(
        message.contains("labels.journal") && message.contains("another vadscope process"),
        "{message}"
    );
    drop(holder);
    let shown = labels(&[scenario, "--show"]);
    assert!(shown.status.success(), "{}", text(&shown.stderr));
}

#[test]
fn export_writes_the_labels_in_every_format_without_scoring() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = write_scenario(dir.path());
    let scenario = root.to_str().expect("utf-8 path");
    let out = dir.path().join("export");
    let out = out.to_str().expect("utf-8 path");
    let exported = vadscope(&[
        "export",
        scenario,
        "--out",
        out,
        "--labels",
        "frame-labels,boxes-csv,mot,coco,yolo,intervals-csv",
        "--labels-only",
    ]);
    assert!(exported.status.success(), "{}", text(&exported.stderr));
    let labels_dir = dir.path().join("export/labels");
    for name in [
        "frame_labels.csv",
        "boxes.csv",
        "gt.txt",
        "coco.json",
        "intervals.csv",
    ] {
        assert!(labels_dir.join(name).is_file(), "{name} missing");
    }
    assert!(labels_dir.join("yolo").is_dir());
    assert!(
        !dir.path().join("export/scores.csv").exists(),
        "--labels-only writes no scores"
    );

    // The same bytes as `vadscope labels --export` writes.
    let mot = dir.path().join("gt.txt");
    let mot = mot.to_str().expect("utf-8 path");
    let single = labels(&[scenario, "--export", mot, "--format", "mot"]);
    assert!(single.status.success(), "{}", text(&single.stderr));
    assert_eq!(
        std::fs::read(mot).expect("mot"),
        std::fs::read(labels_dir.join("gt.txt")).expect("exported mot")
    );

    let bad = vadscope(&[
        "export",
        scenario,
        "--out",
        out,
        "--labels",
        "pdf",
        "--labels-only",
    ]);
    assert!(!bad.status.success());
    assert!(
        text(&bad.stderr).contains("unknown format"),
        "{}",
        text(&bad.stderr)
    );
}
