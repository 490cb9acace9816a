//! The analyst's labels: `labels.json` and `labels.journal` opened together, as the editor
//! does (the journal replayed onto the document, damaged parts set aside). The input is
//! `labels.json`, a NUL byte, then the journal.
//!
//! Each journal line carries an FNV checksum of its sequence number and JSON, which random
//! mutations almost never match: odd-numbered lines get theirs set right before the journal
//! is written, so the fuzzer reaches the replay of records behind the check, and even ones
//! keep the input's, so damaged lines stay covered too.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vadscope::annotate::{Editor, LabelSet};
use vadscope::fnv::fnv1a32;
use vadscope::sequence::FrameId;
use vadscope_fuzz::{scratch_dir, scratch_file, split_at_separator};

/// `line` (`<seq> <checksum> <json>`) with its checksum set, when it has the three fields.
fn with_checksum(line: &str) -> String {
    let mut fields = line.splitn(3, ' ');
    match (fields.next(), fields.next(), fields.next()) {
        (Some(seq), Some(_), Some(json)) => {
            format!(
                "{seq} {:08x} {json}",
                fnv1a32(format!("{seq} {json}").as_bytes())
            )
        }
        _ => line.to_string(),
    }
}

fuzz_target!(|bytes: &[u8]| {
    let (document, journal) = split_at_separator(bytes, b"\0");
    let journal = String::from_utf8_lossy(journal);
    let journal: Vec<String> = journal
        .split('\n')
        .enumerate()
        .map(|(k, line)| {
            if k % 2 == 1 {
                line.to_string()
            } else {
                with_checksum(line)
            }
        })
        .collect();
    let dir = scratch_dir().join("labels");
    let _ = std::fs::remove_dir_all(&dir);
    scratch_file("labels/labels.json", document);
    scratch_file("labels/labels.journal", journal.join("\n").as_bytes());
    let frames: Vec<FrameId> = (100..108).map(FrameId).collect();
    let base = frames.clone();
    if let Ok(editor) = Editor::open_in(&dir, frames, || (LabelSet::new(base), Vec::new())) {
        let _ = editor.labels().intervals().len();
    }
});
