//! KITTI 16-bit PNG flow files.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vadscope_fuzz::scratch_file;

fuzz_target!(|bytes: &[u8]| {
    let path = scratch_file("flow.png", bytes);
    let _ = vadscope::sequence::flow_file::read_kitti_png(&path);
});
