//! AnoVox's configuration files: a data set's `Scenario_Configuration_Files/*.json` (looked
//! up by scenario uuid) and a scenario's `sensor_setup.json` (the camera). The input is the
//! first file, a NUL byte, then the second.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vadscope::sequence::meta::{find_anovox_config, read_sensor_setup_camera};
use vadscope_fuzz::{scratch_dir, scratch_file, split_at_separator};

fuzz_target!(|bytes: &[u8]| {
    let (config, sensors) = split_at_separator(bytes, b"\0");
    scratch_file(
        "Scenario_Configuration_Files/scenario_config_map_0.json",
        config,
    );
    let _ = find_anovox_config(scratch_dir(), "2b6a3f0e-5d8c-4f6e-9a51-0c3d2e1f4b7a");
    scratch_file("scenario/sensor_setup.json", sensors);
    let scenario = scratch_dir().join("scenario");
    let _ = read_sensor_setup_camera(&scenario, None);
    let _ = read_sensor_setup_camera(&scenario, Some("RGB_IMG"));
});
