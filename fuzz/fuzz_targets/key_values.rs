//! ACTION / ANOMALY files: `key ; value` lines with Python literals.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use vadscope::sequence::keyvalue::parse_key_values;
use vadscope::sequence::py_literal::PyValue;
use vadscope_fuzz::text;

fuzz_target!(|bytes: &[u8]| {
    let text = text(bytes);
    if let Ok(values) = parse_key_values(Path::new("ANOMALY_1.txt"), &text) {
        for key in ["anomaly_type", "position", "bbox", "speed"] {
            let _ = values.get_literal(key);
        }
    }
    let _ = PyValue::parse(&text);
});
