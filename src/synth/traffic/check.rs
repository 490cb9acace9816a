//! Whether a simulated scenario is acceptable: no collisions, no vehicle braking harder
//! than normal driving allows (but the braking lead and the ego reacting to it), and the
//! event of its kind seen in the recording.

use super::idm::NORMAL_DECEL_LIMIT;
use super::types::{EGO, FRAME_DT, LEAD, Role, Traffic, VehicleState};
use crate::sequence::Domain;
use crate::synth::road::Road;
use crate::synth::spec::{ScenarioKind, ScenarioSpec};
use crate::synth::vehicle::VehicleModel;

/// Centre-to-centre distance (m) a braking scenario's ego must follow its lead at when the
/// lead brakes: AnoVox's rule settles at 8–11 m, give or take the controller's overshoot.
const FOLLOWING_CENTRE_DISTANCE: (f32, f32) = (7.0, 12.0);

/// Largest per-frame deceleration of vehicle `i` over the recorded frames (m/s²).
pub fn max_decel(traffic: &Traffic, i: usize) -> f32 {
    traffic
        .states
        .windows(2)
        .map(|w| (w[0][i].speed - w[1][i].speed) / FRAME_DT)
        .fold(0.0, f32::max)
}

/// Whether the footprints of two vehicles overlap (separating-axis test on oriented
/// rectangles, shrunk by `margin` metres on each side).
pub fn footprints_overlap(
    a: &VehicleState,
    am: &VehicleModel,
    b: &VehicleState,
    bm: &VehicleModel,
    margin: f32,
) -> bool {
    let dx = b.x - a.x;
    let dy = b.y - a.y;
    let reach = 0.5 * (am.length + bm.length);
    if dx.abs() > reach || dy.abs() > reach {
        return false;
    }
    let axes = [
        a.yaw,
        a.yaw + std::f32::consts::FRAC_PI_2,
        b.yaw,
        b.yaw + std::f32::consts::FRAC_PI_2,
    ];
    let half = |m: &VehicleModel| (0.5 * m.length - margin, 0.5 * m.width - margin);
    let (al, aw) = half(am);
    let (bl, bw) = half(bm);
    for ang in axes {
        let (ux, uy) = (ang.cos(), ang.sin());
        let proj = |yaw: f32, l: f32, w: f32| {
            let c = (yaw - ang).cos().abs();
            let s = (yaw - ang).sin().abs();
            l * c + w * s
        };
        let ra = proj(a.yaw, al, aw);
        let rb = proj(b.yaw, bl, bw);
        if (dx * ux + dy * uy).abs() > ra + rb {
            return false;
        }
    }
    true
}

/// The first pair of vehicles that collide in the recorded frames, if any.
pub fn first_collision(traffic: &Traffic) -> Option<(u32, usize, usize)> {
    let n = traffic.vehicles.len();
    for (k, st) in traffic.states.iter().enumerate() {
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| st[a].x.total_cmp(&st[b].x));
        for (ai, &a) in order.iter().enumerate() {
            for &b in &order[ai + 1..] {
                if st[b].x - st[a].x > 14.0 {
                    break;
                }
                let (va, vb) = (&traffic.vehicles[a], &traffic.vehicles[b]);
                if va.role == Role::Parked && vb.role == Role::Parked {
                    continue;
                }
                if st[a].beyond_street_end || st[b].beyond_street_end {
                    continue;
                }
                if footprints_overlap(&st[a], &va.model, &st[b], &vb.model, 0.05) {
                    return Some((k as u32, a, b));
                }
            }
        }
    }
    None
}

/// Checks that a simulated scenario does what its kind says; returns the problem otherwise.
pub(super) fn check(spec: &ScenarioSpec, road: &Road, traffic: &Traffic) -> Result<(), String> {
    if let Some((k, a, b)) = first_collision(traffic) {
        let (va, vb) = (&traffic.vehicles[a], &traffic.vehicles[b]);
        let (sa, sb) = (
            &traffic.states[k as usize][a],
            &traffic.states[k as usize][b],
        );
        return Err(format!(
            "vehicles {} ({:?} at s {:.1} d {:.1}, {:.1} m/s) and {} ({:?} at s {:.1} d {:.1}, {:.1} m/s) collide at frame {k}",
            va.track_id, va.role, sa.s, sa.d, sa.speed, vb.track_id, vb.role, sb.s, sb.d, sb.speed
        ));
    }
    let tol = 1e-3;
    for i in 0..traffic.vehicles.len() {
        let exempt = spec.kind == ScenarioKind::Braking && (i == LEAD || i == EGO);
        if !exempt && max_decel(traffic, i) > NORMAL_DECEL_LIMIT + tol {
            return Err(format!(
                "vehicle {} decelerates at {:.2} m/s²",
                traffic.vehicles[i].track_id,
                max_decel(traffic, i)
            ));
        }
    }
    let lane_w = road.lane_width;
    let ego_d = traffic.ego_lane_d;
    match spec.kind {
        ScenarioKind::Normal => Ok(()),
        ScenarioKind::Braking => {
            let w = traffic
                .anomaly
                .ok_or("the brake window does not end inside the recording")?;
            let v_on = traffic.states[w.start as usize][LEAD].speed;
            let min_v = if matches!(spec.domain, Domain::Highway) {
                15.0
            } else {
                6.0
            };
            if v_on < min_v {
                return Err(format!(
                    "the lead is too slow at brake onset ({v_on:.1} m/s)"
                ));
            }
            if max_decel(traffic, LEAD) < 7.0 {
                return Err("the lead brakes too gently".into());
            }
            // The ego follows the lead as AnoVox's does when it brakes: 8–11 m centre to
            // centre, with a little room for the speed controller's overshoot.
            let st = &traffic.states[w.start as usize];
            let centre = st[LEAD].s - st[EGO].s;
            if !(FOLLOWING_CENTRE_DISTANCE.0..=FOLLOWING_CENTRE_DISTANCE.1).contains(&centre) {
                return Err(format!(
                    "the ego is {centre:.1} m behind the lead (centre to centre) at brake onset"
                ));
            }
            Ok(())
        }
        ScenarioKind::Turning => {
            // Off the lane before the recording's last tenth, so that the turn is seen.
            let seen = traffic.states.len() * 9 / 10;
            let left = traffic
                .states
                .iter()
                .take(seen)
                .skip(10)
                .any(|st| (st[LEAD].d - ego_d).abs() > 0.75 * lane_w);
            let in_lane_first = traffic
                .states
                .iter()
                .take(10)
                .all(|st| (st[LEAD].d - ego_d).abs() < 0.2);
            if left && in_lane_first {
                Ok(())
            } else {
                Err("the lead does not leave the ego lane".into())
            }
        }
        ScenarioKind::CutIn => {
            let c = traffic.cut_in.ok_or("no cut-in vehicle")?;
            let outside = traffic
                .states
                .iter()
                .position(|st| (st[c].d - ego_d).abs() > 0.8 * lane_w);
            let inside = traffic
                .states
                .iter()
                .rposition(|st| (st[c].d - ego_d).abs() < 0.3 && st[c].s > st[EGO].s);
            match (outside, inside) {
                (Some(a), Some(b)) if a < b => Ok(()),
                _ => Err("no vehicle cuts into the ego lane".into()),
            }
        }
    }
}
