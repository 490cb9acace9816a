//! Scripted events: the sudden braking of the lead (full brake for 30 frames, then it
//! drives on, as AnoVox's `BREAKING_START`/`BREAKING_STOP`), the gentle braking of a lead
//! in normal driving, its lane change out of the ego lane (turning on the highway) and the
//! cut-in, each triggered inside the simulation when its preconditions hold.

use super::dynamics::{Dyn, Emergency, LaneChange};
use super::route::{Pose, Route};
use super::types::{EGO, LEAD, Vehicle};
use crate::synth::spec::ScenarioKind;

/// Scripted-event settings of one simulation run.
#[derive(Debug, Clone)]
pub(super) struct Script {
    pub(super) kind: ScenarioKind,
    /// Braking: frame of brake onset; the lead brakes fully for [`BRAKE_FRAMES`] frames.
    pub(super) brake_frame: Option<i64>,
    /// Emergency deceleration of the lead (m/s²).
    pub(super) brake_decel: f32,
    /// Normal driving: the lead slows down gently from frame `.0` for `.1` frames at
    /// `.2` m/s².
    pub(super) gentle_brake: Option<(i64, i64, f32)>,
    /// The ego follows its lead with AnoVox's car-following rule ([`super::follow`])
    /// instead of the Intelligent Driver Model.
    pub(super) ego_follows: bool,
    /// Earliest frame of the lane change (turning on the highway, cut-in).
    pub(super) trigger_from: i64,
    /// Lane the lead or the cut-in vehicle moves to.
    pub(super) target_d: f32,
    /// Index of the cut-in vehicle.
    pub(super) cut_in: Option<usize>,
    pub(super) triggered: bool,
}

/// Frames of full braking: AnoVox brakes for ticks 140 ≤ t < 170 and labels the lead
/// anomalous for 140 ≤ t ≤ 170, 31 frames.
pub const BRAKE_FRAMES: i64 = 30;

/// Applies scripted events that start or end at `frame`.
pub(super) fn apply_script(
    script: &mut Script,
    frame: i64,
    vehicles: &mut [Vehicle],
    dyns: &mut [Dyn],
    poses: &[Pose],
) {
    // Braking phases end by the script, whatever else happens.
    let release = match (script.brake_frame, script.gentle_brake) {
        (Some(f), _) => Some(f + BRAKE_FRAMES),
        (None, Some((f, n, _))) => Some(f + n),
        _ => None,
    };
    if release == Some(frame) {
        dyns[LEAD].phase = Emergency::None;
    }
    if let Some((f, _, decel)) = script.gentle_brake
        && f == frame
    {
        dyns[LEAD].phase = Emergency::Slowing { decel };
    }
    if script.triggered {
        return;
    }
    match script.kind {
        ScenarioKind::Braking => {
            if script.brake_frame == Some(frame) {
                dyns[LEAD].phase = Emergency::Braking;
                script.triggered = true;
            }
        }
        ScenarioKind::Turning => {
            if !matches!(vehicles[LEAD].route, Route::Lane { .. }) || frame < script.trigger_from {
                return;
            }
            let p = poses[LEAD];
            let free = poses.iter().enumerate().all(|(j, q)| {
                j == LEAD
                    || q.dir <= 0.0
                    || (q.d - script.target_d).abs() > 1.0
                    || q.s < p.s - 30.0
                    || q.s > p.s + 35.0
            });
            if free && dyns[LEAD].v > 5.0 {
                dyns[LEAD].lane_change = Some(LaneChange {
                    start: dyns[LEAD].sigma,
                    length: (dyns[LEAD].v * 4.0).max(50.0),
                    from: p.d,
                    to: script.target_d,
                });
                // Slowing a little, as for an exit.
                vehicles[LEAD].idm.v0 *= 0.88;
                script.triggered = true;
            }
        }
        ScenarioKind::CutIn => {
            let Some(c) = script.cut_in else { return };
            if frame < script.trigger_from {
                return;
            }
            let pc = poses[c];
            let pe = poses[EGO];
            let pl = poses[LEAD];
            let len_c = vehicles[c].model.length;
            let gap_to_ego = (pc.s - 0.5 * len_c) - (pe.s + 0.5 * vehicles[EGO].model.length);
            let gap_to_lead = (pl.s - 0.5 * vehicles[LEAD].model.length) - (pc.s + 0.5 * len_c);
            let v_ego = dyns[EGO].v;
            if gap_to_ego >= (0.8 * v_ego).max(8.0) && gap_to_lead >= 10.0 + 0.5 * dyns[c].v {
                dyns[c].lane_change = Some(LaneChange {
                    start: dyns[c].sigma,
                    length: (dyns[c].v * 3.0).max(25.0),
                    from: pc.d,
                    to: script.target_d,
                });
                script.triggered = true;
            }
        }
        ScenarioKind::Normal => {}
    }
}
