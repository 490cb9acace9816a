//! Middlebury `.flo` flow files.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = vadscope::sequence::flow_file::decode_flo(Path::new("fuzz.flo"), bytes);
});
