//! `vadscope labels` end to end: show, export then import, and clear errors.

use std::process::Output;

use super::cli_common::{text, vadscope};
use super::common::write_scenario;

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
