//! File and folder names of the benchmark layout (the one vadscope writes), and the
//! locations of vadscope's per-scenario extension files.

use std::path::{Path, PathBuf};

use super::{FrameId, Modality};

/// Ground-truth boxes, relative to the scenario folder.
pub const BOXES_FILE: &str = "BBOX_2D/boxes.csv";
/// Detector boxes, relative to the scenario folder.
pub const DETECTIONS_FILE: &str = "BBOX_2D_DET/boxes.csv";
/// Explicit per-frame anomaly flags.
pub const FRAME_LABELS_FILE: &str = "frame_labels.csv";
/// vadscope's scenario metadata.
pub const SCENARIO_JSON_FILE: &str = "scenario.json";
/// AnoVox's per-town scenario configurations, in the dataset root.
pub const CONFIG_FOLDER: &str = "Scenario_Configuration_Files";
/// AnoVox's sensor description, in the scenario folder.
pub const SENSOR_SETUP_FILE: &str = "sensor_setup.json";
/// vadscope's own files inside a scenario.
pub const VADSCOPE_FOLDER: &str = ".vadscope";

/// The extension of a modality's files in the benchmark layout.
pub fn benchmark_extension(modality: Modality) -> &'static str {
    match modality {
        Modality::Action | Modality::Anomaly => "csv",
        _ => "png",
    }
}

/// `<FOLDER>_<frame>.<ext>`: the benchmark file name of a modality's frame.
pub fn benchmark_file_name(modality: Modality, frame: FrameId) -> String {
    format!(
        "{}_{}.{}",
        modality.folder(),
        frame.0,
        benchmark_extension(modality)
    )
}

/// `<scenario>/<FOLDER>/<FOLDER>_<frame>.<ext>`.
pub fn benchmark_file(scenario: &Path, modality: Modality, frame: FrameId) -> PathBuf {
    scenario
        .join(modality.folder())
        .join(benchmark_file_name(modality, frame))
}
