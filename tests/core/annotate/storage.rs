//! Crash-safe saving: the journal is replayed on open, a SIGKILL in the middle of a burst
//! of edits loses no acknowledged edit, damaged `labels.json` and journals are reported,
//! copied aside and their readable part kept, the scenario's files are never touched, and a
//! second editor of the same labels is refused while the first holds them.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};

use vadscope::annotate::{
    AnnotateError, Edit, Editor, IntervalId, JOURNAL_FILE, LABELS_FILE, LabelSet, SaveMode,
};
use vadscope::sequence::Scenario;

use crate::support::annotate::{add_interval, write_scenario};

fn labels_dir(root: &Path) -> std::path::PathBuf {
    root.join(".vadscope")
}

fn open(root: &Path) -> Editor {
    Editor::open(&Scenario::open(root).expect("scenario")).expect("labels")
}

fn source_files(root: &Path) -> Vec<Vec<u8>> {
    ["BBOX_2D/boxes.csv", "frame_labels.csv", "scenario.json"]
        .iter()
        .map(|f| std::fs::read(root.join(f)).expect("source file"))
        .collect()
}

#[test]
fn reopening_replays_the_journal_with_its_undo_history() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = write_scenario(dir.path());
    let sources = source_files(&root);
    let mut editor = open(&root);
    assert!(
        editor.load_problems().is_empty(),
        "{:?}",
        editor.load_problems()
    );
    assert!(
        labels_dir(&root).join(LABELS_FILE).is_file(),
        "first open saves the start"
    );
    for k in 0..5 {
        editor
            .apply(add_interval(10 + k, k as usize, k as usize + 1))
            .expect("apply");
    }
    assert!(editor.undo().expect("undo"));
    let after: LabelSet = editor.labels().clone();
    drop(editor);
    let journal = std::fs::read_to_string(labels_dir(&root).join(JOURNAL_FILE)).expect("journal");
    assert_eq!(journal.lines().count(), 6);

    let mut editor = open(&root);
    assert!(
        editor.load_problems().is_empty(),
        "{:?}",
        editor.load_problems()
    );
    assert_eq!(editor.labels(), &after);
    assert!(editor.redo().expect("redo survives a restart"));
    assert!(editor.labels().interval(IntervalId(14)).is_some());
    editor.compact().expect("compact");
    let journal = std::fs::metadata(labels_dir(&root).join(JOURNAL_FILE)).expect("journal");
    assert_eq!(journal.len(), 0, "compaction empties the journal");
    editor
        .apply(add_interval(40, 0, 0))
        .expect("after compaction");
    let expected = editor.labels().clone();
    drop(editor);
    assert_eq!(open(&root).labels(), &expected);
    assert_eq!(
        source_files(&root),
        sources,
        "source files are never rewritten"
    );
}

#[test]
fn background_saving_is_on_disk_after_flush() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = write_scenario(dir.path());
    let mut editor = open(&root);
    editor.set_save_mode(SaveMode::Background);
    for k in 0..200u64 {
        editor
            .apply(Edit::SetNote {
                frame: (k % 8) as usize,
                text: Some(format!("note {k}")),
            })
            .expect("apply");
    }
    editor.flush().expect("flush");
    assert_eq!(editor.saved_seq(), editor.seq());
    let expected = editor.labels().clone();
    // Without the writer's shutdown (as if the process died here), the files on disk hold
    // every edit. The forgotten editor keeps its lock in this process, so the files are
    // read from a copy of the scenario.
    std::mem::forget(editor);
    let copy_dir = tempfile::tempdir().expect("temp dir");
    let copy = write_scenario(copy_dir.path());
    std::fs::create_dir_all(labels_dir(&copy)).expect("labels folder");
    for file in [LABELS_FILE, JOURNAL_FILE] {
        std::fs::copy(labels_dir(&root).join(file), labels_dir(&copy).join(file)).expect("copy");
    }
    assert_eq!(
        open(&copy).labels(),
        &expected,
        "on disk without the writer's shutdown"
    );
}

#[test]
fn a_second_editor_of_the_same_labels_is_refused_until_the_first_closes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = write_scenario(dir.path());
    let mut first = open(&root);
    first.apply(add_interval(900, 1, 3)).expect("apply");
    let Err(err) = Editor::open(&Scenario::open(&root).expect("scenario")) else {
        panic!("a second editor of the same labels was opened");
    };
    assert!(matches!(err, AnnotateError::Busy { .. }), "{err}");
    let message = err.to_string();
    assert!(
        message.contains(JOURNAL_FILE) && message.contains("another vadscope process"),
        "{message}"
    );
    // The refused editor changed nothing: the first one's edit is what reopening finds.
    let expected = first.labels().clone();
    drop(first);
    assert_eq!(open(&root).labels(), &expected);
}

#[test]
fn sigkill_in_a_burst_of_edits_loses_no_acknowledged_edit() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = write_scenario(dir.path());
    let mut child = Command::new(env!("CARGO_BIN_EXE_vadscope"))
        .arg("labels")
        .arg(&root)
        .args(["--stress-edits", "1000000"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn vadscope");
    let mut lines = BufReader::new(child.stdout.take().expect("stdout")).lines();
    let mut acks = Vec::new();
    while acks.len() < 300 {
        let line = lines
            .next()
            .expect("the child stopped early")
            .expect("line");
        acks.push(line);
    }
    child.kill().expect("SIGKILL");
    acks.extend(lines.map_while(Result::ok));
    let status = child.wait().expect("wait");
    assert!(!status.success(), "killed, not finished: {status}");

    let editor = open(&root);
    for problem in editor.load_problems() {
        let message = problem.to_string();
        assert!(
            message.contains(JOURNAL_FILE) && message.contains("cut short"),
            "only an interrupted last write may be damaged: {message}"
        );
    }
    let labels = editor.labels();
    for ack in &acks {
        let fields: Vec<usize> = ack
            .strip_prefix("ack ")
            .expect("ack line")
            .split(' ')
            .map(|f| f.parse().expect("number"))
            .collect();
        let interval = labels
            .interval(IntervalId(fields[0] as u64))
            .unwrap_or_else(|| panic!("acknowledged edit lost: {ack}"));
        assert_eq!(
            (interval.start, interval.end),
            (fields[1], fields[2]),
            "{ack}"
        );
    }
    assert!(
        labels.intervals().len() > acks.len(),
        "ground truth plus the acknowledged"
    );
}

#[test]
fn a_truncated_labels_file_is_reported_set_aside_and_read_up_to_the_cut() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = write_scenario(dir.path());
    let mut editor = open(&root);
    for k in 0..20 {
        editor.apply(add_interval(10 + k, 0, 7)).expect("apply");
    }
    editor.compact().expect("compact");
    let full = editor.labels().clone();
    drop(editor);
    let path = labels_dir(&root).join(LABELS_FILE);
    let text = std::fs::read_to_string(&path).expect("labels.json");
    let cut = &text[..text.len() * 2 / 3];
    std::fs::write(&path, cut).expect("truncate");

    let editor = open(&root);
    let messages: Vec<String> = editor
        .load_problems()
        .iter()
        .map(|p| p.to_string())
        .collect();
    assert!(
        messages
            .iter()
            .any(|m| m.contains("labels.json:") && m.contains("not valid labels JSON")),
        "{messages:?}"
    );
    let copies = editor.set_aside();
    assert_eq!(copies.len(), 1);
    assert_eq!(
        std::fs::read_to_string(&copies[0]).expect("copy"),
        cut,
        "kept as it was"
    );
    let mut kept = 0;
    for interval in full.intervals() {
        let line = format!(
            "{{\"interval\":{}}}",
            serde_json::to_string(interval).expect("json")
        );
        if cut.contains(&format!("{line},\n")) {
            assert_eq!(editor.labels().interval(interval.id), Some(interval));
            kept += 1;
        }
    }
    assert!(kept >= 10, "the intact lines are kept ({kept})");
    drop(editor);
    assert!(
        open(&root).load_problems().is_empty(),
        "the recovered labels were saved"
    );
}

#[test]
fn a_damaged_journal_record_is_reported_and_the_rest_replayed() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = write_scenario(dir.path());
    let mut editor = open(&root);
    for k in 0..6 {
        editor
            .apply(add_interval(10 + k, k as usize, 7))
            .expect("apply");
    }
    drop(editor);
    let path = labels_dir(&root).join(JOURNAL_FILE);
    let text = std::fs::read_to_string(&path).expect("journal");
    let damaged = text.replacen("\"start\":2", "\"start\":3", 1);
    assert_ne!(damaged, text);
    std::fs::write(&path, &damaged).expect("damage");

    let editor = open(&root);
    let messages: Vec<String> = editor
        .load_problems()
        .iter()
        .map(|p| p.to_string())
        .collect();
    assert_eq!(messages.len(), 1, "{messages:?}");
    assert!(
        messages[0].contains("labels.journal:3") && messages[0].contains("checksum"),
        "{messages:?}"
    );
    assert_eq!(editor.set_aside().len(), 1);
    let labels = editor.labels();
    assert!(
        labels.interval(IntervalId(12)).is_none(),
        "the damaged record"
    );
    for id in [10, 11, 13, 14, 15] {
        assert!(labels.interval(IntervalId(id)).is_some(), "interval {id}");
    }
}
