//! Scenario metadata: vadscope's `scenario.json` (read and written), AnoVox's
//! `Scenario_Configuration_Files/scenario_config_map_<Town>.json` (town, weather preset and
//! anomaly type of the entry whose `id` is the scenario's uuid) and `sensor_setup.json`
//! (camera size and field of view).

use std::path::Path;

use serde_json::Value;

use super::layout::{CONFIG_FOLDER, SENSOR_SETUP_FILE};
use super::{AnomalyType, CameraIntrinsics, ScenarioMeta, SequenceError, Weather};

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

/// What AnoVox's scenario configuration says about one scenario.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AnovoxConfigEntry {
    /// `scenario_definition.map`, e.g. `Town10HD`.
    pub town: Option<String>,
    /// `weather_preset`, e.g. `SOFT_RAIN_SUNSET`.
    pub weather_preset: Option<String>,
    /// `anomaly_config.anomalytype`, e.g. `SUDDEN_BREAKING_OF_VEHICLE_AHEAD`.
    pub anomaly_type: Option<String>,
}

/// Looks up `uuid` in every `scenario_config_map_*.json` of `<dataset_root>/Scenario_Configuration_Files/`.
/// `Ok(None)` when the folder or the entry does not exist; an error for unreadable or
/// malformed JSON.
pub fn find_anovox_config(
    dataset_root: &Path,
    uuid: &str,
) -> Result<Option<AnovoxConfigEntry>, SequenceError> {
    let folder = dataset_root.join(CONFIG_FOLDER);
    let Ok(entries) = std::fs::read_dir(&folder) else {
        return Ok(None);
    };
    let mut files: Vec<_> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    for path in files {
        let text = std::fs::read_to_string(&path).map_err(|e| SequenceError::io(&path, e))?;
        let json: Value = serde_json::from_str(&text)
            .map_err(|e| SequenceError::format(&path, format!("invalid JSON: {e}")))?;
        if let Some(entry) = config_entry(&json, uuid) {
            return Ok(Some(entry));
        }
    }
    Ok(None)
}

fn config_entry(json: &Value, uuid: &str) -> Option<AnovoxConfigEntry> {
    let definition = json.get("scenario_definition")?;
    let scenario = definition
        .get("scenarios")?
        .as_array()?
        .iter()
        .find(|s| s.get("id").and_then(Value::as_str) == Some(uuid))?;
    let text = |v: Option<&Value>| v.and_then(Value::as_str).map(str::to_string);
    Some(AnovoxConfigEntry {
        town: text(definition.get("map")),
        weather_preset: text(scenario.get("weather_preset")),
        anomaly_type: text(
            scenario
                .get("anomaly_config")
                .and_then(|a| a.get("anomalytype")),
        ),
    })
}

/// Maps an AnoVox/CARLA weather preset (`CLEAR_NOON`, `HARD_RAIN_SUNSET`, ...) to our
/// weather and time of day. AnoVox's presets have no fog or night.
pub fn weather_from_preset(preset: &str) -> (Weather, Option<String>) {
    let upper = preset.to_ascii_uppercase();
    let weather = if upper.contains("RAIN") {
        Weather::Rain
    } else if upper.contains("FOG") {
        Weather::Fog
    } else if upper.contains("NIGHT") {
        Weather::Night
    } else {
        Weather::Sun
    };
    let time_of_day = ["NOON", "SUNSET", "NIGHT", "MORNING"]
        .into_iter()
        .find(|t| upper.contains(t))
        .map(str::to_ascii_lowercase);
    (weather, time_of_day)
}

/// Maps AnoVox's `anomalytype` names to [`AnomalyType`].
pub fn anomaly_type_from_name(name: &str) -> Option<AnomalyType> {
    match name {
        "NORMALITY" => Some(AnomalyType::Normality),
        "STATIC" => Some(AnomalyType::Static),
        "SUDDEN_BREAKING_OF_VEHICLE_AHEAD" => Some(AnomalyType::SuddenBraking),
        _ => None,
    }
}

/// Fills fields of `meta` that are still unknown from an AnoVox configuration entry.
pub fn merge_anovox_config(meta: &mut ScenarioMeta, entry: &AnovoxConfigEntry) {
    if meta.town.is_none() {
        meta.town.clone_from(&entry.town);
    }
    if let Some(preset) = &entry.weather_preset {
        let (weather, time_of_day) = weather_from_preset(preset);
        if meta.weather == Weather::Unknown {
            meta.weather = weather;
        }
        if meta.time_of_day.is_none() {
            meta.time_of_day = time_of_day;
        }
    }
    if meta.anomaly_type.is_none() {
        meta.anomaly_type = entry
            .anomaly_type
            .as_deref()
            .and_then(anomaly_type_from_name);
    }
}

/// Reads the camera of `<scenario>/sensor_setup.json`: the entry of `rgb_folder` when
/// given, else the first entry with image arguments. `Ok(None)` without the file.
pub fn read_sensor_setup_camera(
    scenario: &Path,
    rgb_folder: Option<&str>,
) -> Result<Option<CameraIntrinsics>, SequenceError> {
    let path = scenario.join(SENSOR_SETUP_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(|e| SequenceError::io(&path, e))?;
    let json: Value = serde_json::from_str(&text)
        .map_err(|e| SequenceError::format(&path, format!("invalid JSON: {e}")))?;
    let Some(sensors) = json.as_object() else {
        return Err(SequenceError::format(
            &path,
            "expected an object of sensors",
        ));
    };
    let preferred = rgb_folder.and_then(|name| sensors.get(name));
    Ok(preferred
        .into_iter()
        .chain(sensors.values())
        .find_map(camera_of_sensor))
}

fn camera_of_sensor(sensor: &Value) -> Option<CameraIntrinsics> {
    let args = sensor.get("args")?;
    let width = u32::try_from(args.get("image_width")?.as_u64()?).ok()?;
    let height = u32::try_from(args.get("image_height")?.as_u64()?).ok()?;
    let fov_deg = args
        .get("camera_fov")
        .and_then(Value::as_f64)
        .unwrap_or(90.0) as f32;
    let mount_height_m = sensor
        .get("location")
        .and_then(Value::as_array)
        .and_then(|l| l.get(2))
        .and_then(Value::as_f64)
        .unwrap_or(1.8) as f32;
    Some(CameraIntrinsics::from_fov(
        width,
        height,
        fov_deg,
        mount_height_m,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weather_presets_map_to_weather_and_time() {
        assert_eq!(
            weather_from_preset("SOFT_RAIN_SUNSET"),
            (Weather::Rain, Some("sunset".into()))
        );
        assert_eq!(
            weather_from_preset("CLEAR_NOON"),
            (Weather::Sun, Some("noon".into()))
        );
        assert_eq!(weather_from_preset("WET_CLOUDYSUNSET").0, Weather::Sun);
        assert_eq!(weather_from_preset("MID_RAINY_NOON").0, Weather::Rain);
    }

    #[test]
    fn config_entry_is_found_by_id() {
        let json: Value = serde_json::from_str(
            r#"{"scenario_definition": {"map": "Town07", "scenarios": [
                {"id": "a", "weather_preset": "CLEAR_NOON", "anomaly_config": {"anomalytype": "NORMALITY"}},
                {"id": "b", "weather_preset": "HARD_RAIN_NOON",
                 "anomaly_config": {"anomalytype": "SUDDEN_BREAKING_OF_VEHICLE_AHEAD"}}]}}"#,
        )
        .expect("valid json");
        let entry = config_entry(&json, "b").expect("found");
        assert_eq!(entry.town.as_deref(), Some("Town07"));
        assert_eq!(entry.weather_preset.as_deref(), Some("HARD_RAIN_NOON"));
        let mut meta = ScenarioMeta::default();
        merge_anovox_config(&mut meta, &entry);
        assert_eq!(meta.anomaly_type, Some(AnomalyType::SuddenBraking));
        assert_eq!(meta.weather, Weather::Rain);
        assert!(config_entry(&json, "c").is_none());
    }
}
