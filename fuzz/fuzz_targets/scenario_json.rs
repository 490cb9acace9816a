//! `scenario.json`, a scenario's metadata.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vadscope_fuzz::scratch_file;

fuzz_target!(|bytes: &[u8]| {
    let path = scratch_file("scenario.json", bytes);
    let _ = vadscope::sequence::meta::read_scenario_json(&path);
});
