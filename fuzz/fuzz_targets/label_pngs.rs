//! The label images of a scenario: semantic, instance and CARLA-encoded depth PNGs, and
//! an image file's header.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vadscope::sequence::images::{read_depth, read_header, read_instance, read_semantic};
use vadscope_fuzz::scratch_file;

fuzz_target!(|bytes: &[u8]| {
    let path = scratch_file("label.png", bytes);
    let _ = read_header(&path);
    let _ = read_semantic(&path);
    let _ = read_instance(&path);
    let _ = read_depth(&path);
});
