//! `frame_labels.csv`, the per-frame anomaly flags.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use vadscope_fuzz::text;

fuzz_target!(|bytes: &[u8]| {
    let _ =
        vadscope::sequence::labels::parse_frame_labels(Path::new("frame_labels.csv"), &text(bytes));
});
