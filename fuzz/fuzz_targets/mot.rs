//! MOTChallenge detection files.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use vadscope_fuzz::text;

fuzz_target!(|bytes: &[u8]| {
    let _ = vadscope::sequence::detections::parse_mot(Path::new("det.txt"), &text(bytes));
});
