//! NumPy `.npy` flow files.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = vadscope::sequence::flow_file::decode_npy(Path::new("fuzz.npy"), bytes);
});
