//! `boxes.csv`, a scenario's ground-truth boxes.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use vadscope_fuzz::text;

fuzz_target!(|bytes: &[u8]| {
    let _ = vadscope::sequence::boxes::parse_boxes(Path::new("boxes.csv"), &text(bytes));
});
