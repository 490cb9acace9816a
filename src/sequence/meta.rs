//! Scenario metadata: vadscope's `scenario.json` (read and written).

use std::path::Path;

use super::{ScenarioMeta, SequenceError};

/// Reads `scenario.json`; missing fields take their defaults.
pub fn read_scenario_json(path: &Path) -> Result<ScenarioMeta, SequenceError> {
    let text = std::fs::read_to_string(path).map_err(|e| SequenceError::io(path, e))?;
    serde_json::from_str(&text)
        .map_err(|e| SequenceError::format(path, format!("invalid scenario.json: {e}")))
}

/// Writes `scenario.json` (pretty-printed).
pub fn write_scenario_json(path: &Path, meta: &ScenarioMeta) -> Result<(), SequenceError> {
    let text = serde_json::to_string_pretty(meta)
        .map_err(|e| SequenceError::format(path, format!("cannot serialise metadata: {e}")))?;
    std::fs::write(path, text + "\n").map_err(|e| SequenceError::io(path, e))
}
