//! Scripted events: the sudden braking of the lead, its lane change out of the ego lane
//! (turning on the highway) and the cut-in, each triggered inside the simulation when its
//! preconditions hold.

use super::dynamics::{Dyn, Emergency, LaneChange};
use super::route::{Pose, Route};
use super::types::{EGO, LEAD, Vehicle};
use crate::synth::spec::ScenarioKind;

/// Scripted-event settings of one simulation run.
#[derive(Debug, Clone)]
pub(super) struct Script {
    pub(super) kind: ScenarioKind,
    /// Braking: frame of brake onset.
    pub(super) brake_frame: Option<i64>,
    /// Emergency deceleration of the lead (m/s²).
    pub(super) brake_decel: f32,
    /// Standstill hold time after emergency braking (s).
    pub(super) hold_s: f32,
    /// Earliest frame of the lane change (turning on the highway, cut-in).
    pub(super) trigger_from: i64,
    /// Lane the lead or the cut-in vehicle moves to.
    pub(super) target_d: f32,
    /// Index of the cut-in vehicle.
    pub(super) cut_in: Option<usize>,
    pub(super) triggered: bool,
}

/// Applies scripted events that start at `frame`.
pub(super) fn apply_script(
    script: &mut Script,
    frame: i64,
    vehicles: &mut [Vehicle],
    dyns: &mut [Dyn],
    poses: &[Pose],
) {
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
