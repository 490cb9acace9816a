//! Accuracy of cached DIS flow against a scenario's stored (ground-truth) flow: EPE over
//! all pixels, over valid pixels, and inside vehicle boxes after HF²-VAD's 32×32
//! crop-and-resize.
//!
//! The box of frame *i* crops the flow stored at frame *i* (the motion from *i−1* to *i*),
//! as HF²-VAD builds its cubes. Cached flows are KITTI PNG, quantised to 1/64 px, which is
//! what the model reads too.

use serde::{Deserialize, Serialize};

use super::cache::read_cached_flow;
use super::cache::{CacheProgress, CacheReport, CacheScope, FlowCacheOptions, fill_flow_cache};
use super::error::FlowError;
use super::metrics::{PixelBox, box_endpoint_error, endpoint_error};
use super::params::DisPreset;
use crate::sequence::palette::is_vehicle_id;
use crate::sequence::{FrameId, Scenario};

/// Side of the square HF²-VAD resizes object crops to.
pub const PATCH_SIZE: u32 = 32;

/// Scores of one frame's flow.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameFlowScore {
    /// Frame index (the flow leads into this frame).
    pub index: usize,
    /// AnoVox frame id.
    pub frame: FrameId,
    /// Mean EPE over every pixel, in pixels.
    pub epe_all: f64,
    /// Mean EPE over pixels the ground truth marks valid.
    pub epe_valid: Option<f64>,
    /// Mean EPE of each vehicle box of the frame (32×32 crops; boxes without valid ground
    /// truth are left out).
    pub vehicle_boxes: Vec<f64>,
}

/// Scores of a scenario's cached flow.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FlowEvaluation {
    /// Scenario name.
    pub scenario: String,
    /// Preset whose cache was scored.
    pub preset: DisPreset,
    /// One entry per frame with both a stored and a cached flow.
    pub frames: Vec<FrameFlowScore>,
    /// Mean over frames of the all-pixel EPE.
    pub mean_epe_all: Option<f64>,
    /// Mean over frames of the valid-pixel EPE.
    pub mean_epe_valid: Option<f64>,
    /// Mean over all vehicle boxes of the 32×32 patch EPE.
    pub mean_vehicle_box_epe: Option<f64>,
    /// Number of vehicle boxes scored.
    pub vehicle_boxes: usize,
}

impl FlowEvaluation {
    /// A one-line summary, e.g. for the command line.
    pub fn summary(&self) -> String {
        let show = |v: Option<f64>| v.map_or_else(|| "–".to_string(), |v| format!("{v:.3}"));
        format!(
            "{} [{}]: {} frames, EPE all {} px, valid {} px, vehicle 32×32 {} px ({} boxes)",
            self.scenario,
            self.preset,
            self.frames.len(),
            show(self.mean_epe_all),
            show(self.mean_epe_valid),
            show(self.mean_vehicle_box_epe),
            self.vehicle_boxes
        )
    }
}

fn mean(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values
        .into_iter()
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// Scores the flows cached for `preset` against the flows stored in the scenario, on every
/// frame that has both. Nothing is computed.
pub fn evaluate_cached_flow(
    scenario: &Scenario,
    preset: DisPreset,
) -> Result<FlowEvaluation, FlowError> {
    let mut frames = Vec::new();
    for index in 1..scenario.len() {
        let Some(truth) = scenario.flow(index)? else {
            continue;
        };
        let Some(estimate) = read_cached_flow(scenario, preset, index)? else {
            continue;
        };
        let epe = endpoint_error(&estimate, &truth)?;
        let mut vehicle_boxes = Vec::new();
        for record in scenario.boxes(index)? {
            let vehicle = u8::try_from(record.class).is_ok_and(is_vehicle_id);
            if !vehicle {
                continue;
            }
            let scored = box_endpoint_error(&estimate, &truth, PixelBox::from(&record), PATCH_SIZE);
            match scored {
                Ok(Some(e)) => vehicle_boxes.push(e),
                // Boxes outside the frame or without valid ground truth are not scored.
                Ok(None) | Err(FlowError::EmptyBox { .. }) => {}
                Err(e) => return Err(e),
            }
        }
        frames.push(FrameFlowScore {
            index,
            frame: scenario.frame_id(index).unwrap_or(FrameId(index as u64)),
            epe_all: epe.mean_all,
            epe_valid: epe.mean_valid,
            vehicle_boxes,
        });
    }
    let boxes: Vec<f64> = frames
        .iter()
        .flat_map(|f| f.vehicle_boxes.iter().copied())
        .collect();
    Ok(FlowEvaluation {
        scenario: scenario.name().to_string(),
        preset,
        mean_epe_all: mean(frames.iter().map(|f| f.epe_all)),
        mean_epe_valid: mean(frames.iter().filter_map(|f| f.epe_valid)),
        mean_vehicle_box_epe: mean(boxes.iter().copied()),
        vehicle_boxes: boxes.len(),
        frames,
    })
}

/// Fills the cache of `options.preset` for every frame (whatever `options.scope` says) and
/// scores it against the scenario's stored flow. Returns the cache run's report and the
/// scores.
pub fn evaluate_flow(
    scenario: &Scenario,
    options: &FlowCacheOptions,
    progress: impl Fn(CacheProgress) + Sync,
) -> Result<(CacheReport, FlowEvaluation), FlowError> {
    let every = FlowCacheOptions {
        scope: CacheScope::EveryFrame,
        ..*options
    };
    let report = fill_flow_cache(scenario, &every, progress)?;
    let evaluation = evaluate_cached_flow(scenario, options.preset)?;
    Ok((report, evaluation))
}
