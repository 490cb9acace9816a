//! One YOLO label file (`class cx cy w h [conf]` per line, normalised to the image).
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use vadscope::sequence::detections::{FrameRef, parse_yolo};
use vadscope_fuzz::text;

fuzz_target!(|bytes: &[u8]| {
    let _ = parse_yolo(
        Path::new("labels/7.txt"),
        &text(bytes),
        FrameRef::Stem("7".into()),
        384,
        256,
    );
});
