//! The analyst's labels: `labels.json` and `labels.journal` opened together, as the editor
//! does (the journal replayed onto the document, damaged parts set aside). The input is
//! `labels.json`, a NUL byte, then the journal.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vadscope::annotate::{Editor, LabelSet};
use vadscope::sequence::FrameId;
use vadscope_fuzz::{scratch_dir, scratch_file, split_at_separator};

fuzz_target!(|bytes: &[u8]| {
    let (document, journal) = split_at_separator(bytes, b"\0");
    let dir = scratch_dir().join("labels");
    let _ = std::fs::remove_dir_all(&dir);
    scratch_file("labels/labels.json", document);
    scratch_file("labels/labels.journal", journal);
    let frames: Vec<FrameId> = (100..108).map(FrameId).collect();
    let base = frames.clone();
    if let Ok(editor) = Editor::open_in(&dir, frames, || (LabelSet::new(base), Vec::new())) {
        let _ = editor.labels().intervals().len();
    }
});
