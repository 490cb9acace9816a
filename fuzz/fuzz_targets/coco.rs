//! COCO JSON detection files (result arrays and data set objects).
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use vadscope_fuzz::text;

fuzz_target!(|bytes: &[u8]| {
    let _ = vadscope::sequence::detections::parse_coco(Path::new("det.json"), &text(bytes));
});
