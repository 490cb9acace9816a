//! Placing the vehicles of a scenario: the ego and its lead, the actors and light timings
//! of the scenario's event, traffic in both directions of the main road and, in the city,
//! parked cars and cross traffic. Every choice comes from the seeded stream in a fixed
//! order, so the same spec places the same vehicles.

use super::cross::add_cross_traffic;
use super::fleet::{Fleet, idm_for, pick_body, pick_car};
use super::follow::MAX_SPEED;
use super::idm::EGO_EMERGENCY_DECEL;
use super::route::{Route, STOP_LINE_EXTRA, TURN_RADIUS};
use super::script::Script;
use super::types::{FRAME_DT, Role, Vehicle, WARMUP_FRAMES};
use crate::sequence::Domain;
use crate::synth::rng::Rng;
use crate::synth::road::Road;
use crate::synth::spec::{ScenarioKind, ScenarioSpec};
use crate::synth::vehicle::{BodyType, VehicleModel};

/// Spacing (m) of the route waypoints AnoVox counts the lead's start distance in (CARLA's
/// route planner samples every 2 m).
const WAYPOINT_SPACING: f32 = 2.0;

/// The latest recorded frame from which a cut-in may start (30 % into a 200-frame
/// scenario, as in shorter ones).
const CUT_IN_LATEST_TRIGGER: i64 = 60;

/// The ego as placed, which the rest of the traffic is placed around.
struct Ego {
    /// Its lane (0 is the innermost).
    lane: u32,
    /// Lateral offset of its lane.
    d: f32,
    /// Desired speed (m/s).
    v0: f32,
    /// Body length (m).
    length: f32,
}

/// The lead as placed.
struct Lead {
    /// Start of the warm-up along its route.
    s: f32,
    /// Desired speed (m/s).
    v0: f32,
}

/// Places every vehicle of the scenario; index 0 is the ego and index 1 the lead.
pub(super) fn populate(
    spec: &ScenarioSpec,
    road: &mut Road,
    rng: &mut Rng,
) -> (Vec<Vehicle>, Script) {
    let highway = matches!(spec.domain, Domain::Highway);
    let frames = spec.frames as i64;
    let duration = (frames + WARMUP_FRAMES) as f32 * FRAME_DT;
    let mut fleet = Fleet {
        vehicles: Vec::new(),
    };
    // AnoVox's ego follows its lead closely; normal driving does so half of the time, so
    // that a model learns close following without the anomaly.
    let ego_follows = match spec.kind {
        ScenarioKind::Braking => true,
        ScenarioKind::Normal => rng.chance(0.5),
        ScenarioKind::Turning | ScenarioKind::CutIn => false,
    };
    let ego = add_ego(&mut fleet, spec, road, rng, ego_follows);
    let lead = add_lead(&mut fleet, spec, road, rng, &ego, ego_follows);
    let mut script = Script {
        kind: spec.kind,
        brake_frame: None,
        brake_decel: rng.range(7.6, 9.0),
        gentle_brake: None,
        ego_follows,
        trigger_from: 0,
        target_d: ego.d,
        cut_in: None,
        triggered: false,
    };
    let keep_clear = stage_event(
        &mut fleet,
        &mut script,
        spec,
        road,
        rng,
        (&ego, &lead),
        duration,
    );
    let ego_travel = ego.v0 * duration;
    add_lane_traffic(
        &mut fleet,
        spec,
        road,
        rng,
        (&ego, &lead),
        &keep_clear,
        ego_travel,
    );
    add_oncoming_traffic(&mut fleet, spec, road, rng, ego.v0, ego_travel);
    if !highway {
        add_parked_cars(&mut fleet, road, rng, ego_travel);
        add_cross_traffic(&mut fleet, road, rng, ego_travel);
    }
    (fleet.vehicles, script)
}

/// Adds the ego in its lane at progress 0 (free to reach AnoVox's 70 km/h when it
/// follows its lead by AnoVox's rule).
fn add_ego(
    fleet: &mut Fleet,
    spec: &ScenarioSpec,
    road: &Road,
    rng: &mut Rng,
    follows: bool,
) -> Ego {
    let domain = spec.domain;
    let kind = spec.kind;
    let highway = matches!(domain, Domain::Highway);
    // The ego: lane 0 is the innermost.
    let ego_lane = if highway {
        match kind {
            ScenarioKind::Turning | ScenarioKind::CutIn => 1,
            _ => [0u32, 1, 1, 1, 2][rng.below(5)],
        }
    } else {
        match kind {
            ScenarioKind::Turning => 1,
            _ => rng.below(2) as u32,
        }
    };
    let ego_d = road.lane_center(ego_lane, true);
    let ego_v0 = if highway {
        rng.range(27.0, 31.0) - ego_lane as f32 * 1.5
    } else {
        rng.range(12.5, 14.0)
    };
    let ego_model = VehicleModel::new(BodyType::Sedan, &mut rng.fork(1));
    let ego_len = ego_model.length;
    let mut ego_idm = idm_for(rng, domain, ego_v0, BodyType::Sedan);
    ego_idm.t_headway = if highway { 1.05 } else { 1.0 };
    ego_idm.s0 = if highway { 3.0 } else { 2.5 };
    if kind == ScenarioKind::Braking {
        ego_idm.b_max = EGO_EMERGENCY_DECEL;
    }
    if follows {
        ego_idm.v0 = MAX_SPEED;
    }
    fleet.add(Role::Ego, ego_model, lane(ego_d), 0.0, ego_idm);
    Ego {
        lane: ego_lane,
        d: ego_d,
        v0: ego_v0,
        length: ego_len,
    }
}

/// Adds the lead, directly ahead of the ego in its lane (in a city turning scenario, on a
/// route that turns right at the first intersection it reaches a few seconds into the
/// recording). A lead the ego follows by AnoVox's rule starts 7–12 route waypoints of 2 m
/// ahead, centre to centre, and is no faster than the ego may drive.
fn add_lead(
    fleet: &mut Fleet,
    spec: &ScenarioSpec,
    road: &Road,
    rng: &mut Rng,
    ego: &Ego,
    followed: bool,
) -> Lead {
    let domain = spec.domain;
    let kind = spec.kind;
    let highway = matches!(domain, Domain::Highway);
    let lead_body = match kind {
        ScenarioKind::Normal => pick_body(rng, domain),
        _ => pick_car(rng),
    };
    let lead_model = VehicleModel::new(lead_body, &mut rng.fork(2));
    let lead_v0 = match kind {
        ScenarioKind::CutIn => ego.v0 + rng.range(1.5, 2.5),
        _ => ego.v0 - rng.range(0.5, 2.0),
    };
    let lead_v0 = if followed {
        lead_v0.min(rng.range(MAX_SPEED - 3.0, MAX_SPEED - 1.0))
    } else {
        lead_v0
    };
    let lead_s = if followed {
        WAYPOINT_SPACING * rng.range(7.0, 12.0)
    } else {
        let lead_gap = match kind {
            ScenarioKind::CutIn => rng.range(45.0, 60.0),
            _ => 2.5 + lead_v0 * rng.range(1.1, 1.4),
        };
        0.5 * ego.length + lead_gap + 0.5 * lead_model.length
    };
    let lead_route = if kind == ScenarioKind::Turning && !highway {
        // The first intersection the lead reaches a few seconds into the recording.
        let min_s = lead_s + lead_v0 * (WARMUP_FRAMES as f32 * FRAME_DT + 2.0);
        let x = road.intersections.iter().find(|x| x.s > min_s);
        let (xs, hw) = x.map_or((min_s + 60.0, 3.5), |x| (x.s, x.half_width));
        Route::Turn {
            d0: ego.d,
            s_turn: xs - 0.5 * hw - TURN_RADIUS,
            radius: TURN_RADIUS,
        }
    } else {
        lane(ego.d)
    };
    let lead_idm = idm_for(rng, domain, lead_v0, lead_body);
    fleet.add(Role::Lead, lead_model, lead_route, lead_s, lead_idm);
    Lead {
        s: lead_s,
        v0: lead_v0,
    }
}

/// Sets up the event of the scenario's kind: its timing in `script`, the cut-in vehicle,
/// and main-road lights kept green where a red light would get in the way. Returns the
/// (d, s0, s1) spans of lanes where no other traffic is placed.
fn stage_event(
    fleet: &mut Fleet,
    script: &mut Script,
    spec: &ScenarioSpec,
    road: &mut Road,
    rng: &mut Rng,
    (ego, lead): (&Ego, &Lead),
    duration: f32,
) -> Vec<(f32, f32, f32)> {
    let domain = spec.domain;
    let highway = matches!(domain, Domain::Highway);
    let frames = spec.frames as i64;
    let mut keep_clear: Vec<(f32, f32, f32)> = Vec::new();
    match spec.kind {
        ScenarioKind::Braking => {
            let lo = (frames as f32 * 0.5) as i64;
            let hi = ((frames as f32 * 0.65) as i64).min(frames - 45).max(lo);
            let f = lo + rng.below((hi - lo + 1) as usize) as i64;
            script.brake_frame = Some(f);
            // No red light separates the ego from its lead before the event.
            let t_on = f as f32 * FRAME_DT;
            for x in &mut road.intersections {
                x.force_main_green(-(WARMUP_FRAMES as f32) * FRAME_DT, t_on + 14.0);
            }
        }
        ScenarioKind::Normal if frames >= 40 && rng.chance(0.5) => {
            // The lead slows down for a moment, within normal braking.
            let from = rng.range(0.15, 0.75) * frames as f32;
            script.gentle_brake =
                Some((from as i64, 10 + rng.below(21) as i64, rng.range(1.5, 2.8)));
        }
        ScenarioKind::Turning if !highway => {
            // Keep the lead moving towards its turn.
            for x in &mut road.intersections {
                x.force_main_green(-(WARMUP_FRAMES as f32) * FRAME_DT, frames as f32 * FRAME_DT);
            }
        }
        ScenarioKind::Turning => {
            script.trigger_from = (frames as f32 * 0.35) as i64;
            script.target_d = road.lane_center(ego.lane + 1, true);
            keep_clear.push((
                script.target_d,
                lead.s - 80.0,
                lead.s + 120.0 + duration * lead.v0,
            ));
        }
        ScenarioKind::CutIn => {
            let from_lane = if highway {
                if rng.chance(0.5) { 0 } else { 2 }
            } else {
                1 - ego.lane
            };
            let from_d = road.lane_center(from_lane, true);
            let body = pick_car(rng);
            let model = VehicleModel::new(body, &mut rng.fork(3));
            let v0 = ego.v0
                + if highway {
                    rng.range(3.0, 4.5)
                } else {
                    rng.range(2.5, 3.5)
                };
            let s = -rng.range(8.0, 20.0);
            let idm = idm_for(rng, domain, v0, body);
            script.cut_in = Some(fleet.add(Role::CutIn, model, lane(from_d), s, idm));
            // Not later than 6 s in: the cut-in vehicle is faster than the lead as well, and
            // in a long scenario it would have passed the lead before a later trigger.
            script.trigger_from = ((frames as f32 * 0.3) as i64).min(CUT_IN_LATEST_TRIGGER);
            keep_clear.push((from_d, s - 40.0, s + 160.0));
            if !highway {
                for x in &mut road.intersections {
                    x.force_main_green(
                        -(WARMUP_FRAMES as f32) * FRAME_DT,
                        frames as f32 * FRAME_DT,
                    );
                }
            }
        }
        _ => {}
    }
    keep_clear
}

/// Adds other traffic in the ego direction (none behind the ego in its own lane, none in
/// the `keep_clear` spans).
fn add_lane_traffic(
    fleet: &mut Fleet,
    spec: &ScenarioSpec,
    road: &Road,
    rng: &mut Rng,
    (ego, lead): (&Ego, &Lead),
    keep_clear: &[(f32, f32, f32)],
    ego_travel: f32,
) {
    let domain = spec.domain;
    let highway = matches!(domain, Domain::Highway);
    for lane_i in 0..road.lanes {
        let d = road.lane_center(lane_i, true);
        let lane_v0 = if highway {
            ego.v0 + (1.0 - lane_i as f32) * 1.5 + 1.5
        } else {
            ego.v0
        };
        let (s_from, s_to) = if lane_i == ego.lane {
            (lead.s + 25.0, lead.s + ego_travel + 250.0)
        } else {
            (-150.0, ego_travel + 400.0)
        };
        let (gap_lo, gap_hi) = if highway { (25.0, 85.0) } else { (15.0, 60.0) };
        let mut s = s_from + rng.range(0.0, gap_hi);
        while s < s_to {
            let body = pick_body(rng, domain);
            let kept_clear = keep_clear
                .iter()
                .any(|&(kd, a, b)| (kd - d).abs() < 0.1 && s > a && s < b);
            let beside_ego = lane_i != ego.lane && s > -15.0 && s < 15.0;
            if !kept_clear && !beside_ego && !in_intersection(road, s) {
                let model =
                    VehicleModel::new(body, &mut rng.fork(1000 + fleet.vehicles.len() as u64));
                let heavy = matches!(body, BodyType::Truck | BodyType::Bus);
                let v0 = if heavy {
                    lane_v0.min(if highway { 25.0 } else { 12.0 }) * rng.range(0.95, 1.0)
                } else {
                    lane_v0 * rng.range(0.93, 1.07)
                };
                let idm = idm_for(rng, domain, v0, body);
                fleet.add(Role::Traffic, model, lane(d), s, idm);
            }
            s += rng.range(gap_lo, gap_hi);
        }
    }
}

/// Adds oncoming traffic, far enough ahead to keep coming for the whole scenario.
fn add_oncoming_traffic(
    fleet: &mut Fleet,
    spec: &ScenarioSpec,
    road: &Road,
    rng: &mut Rng,
    ego_v0: f32,
    ego_travel: f32,
) {
    let domain = spec.domain;
    let highway = matches!(domain, Domain::Highway);
    for lane_i in 0..road.lanes {
        let d = road.lane_center(lane_i, false);
        let (gap_lo, gap_hi) = if highway { (35.0, 130.0) } else { (18.0, 70.0) };
        let reach = 2.1 * ego_travel + 400.0;
        let mut s = -60.0 + rng.range(0.0, gap_hi);
        while s < reach {
            let body = pick_body(rng, domain);
            let model = VehicleModel::new(body, &mut rng.fork(5000 + fleet.vehicles.len() as u64));
            let v0 = ego_v0 * rng.range(0.9, 1.08);
            let idm = idm_for(rng, domain, v0, body);
            if !in_intersection(road, s) {
                fleet.add(
                    Role::Oncoming,
                    model,
                    Route::Lane { forward: false, d },
                    -s,
                    idm,
                );
            }
            s += rng.range(gap_lo, gap_hi);
        }
    }
}

/// The forward lane at lateral offset `d`.
fn lane(d: f32) -> Route {
    Route::Lane { forward: true, d }
}

/// Whether arc length `s` lies in an intersection or its crosswalks (no spawning there).
fn in_intersection(road: &Road, s: f32) -> bool {
    road.nearest_intersection(s)
        .is_some_and(|x| (s - x.s).abs() < x.half_width + STOP_LINE_EXTRA + 4.0)
}

/// Adds parked cars along both kerbs (city).
fn add_parked_cars(fleet: &mut Fleet, road: &Road, rng: &mut Rng, ego_travel: f32) {
    let domain = road.domain;
    for forward in [true, false] {
        let d = road.parking_center(forward);
        let mut s = -80.0 + rng.range(0.0, 10.0);
        while s < ego_travel + 400.0 {
            let body = if rng.chance(0.85) {
                pick_car(rng)
            } else {
                BodyType::Van
            };
            let model = VehicleModel::new(body, &mut rng.fork(9000 + fleet.vehicles.len() as u64));
            let len = model.length;
            let near_x = road
                .nearest_intersection(s)
                .is_some_and(|x| (s - x.s).abs() < x.half_width + 14.0);
            if !near_x && rng.chance(0.6) {
                let jitter = rng.range(-0.15, 0.15);
                let idm = idm_for(rng, domain, 1.0, body);
                // Cars park in the direction of their side's traffic.
                let route = Route::Parked {
                    s,
                    d: d + jitter,
                    forward,
                };
                fleet.add(Role::Parked, model, route, 0.0, idm);
            }
            s += len + rng.range(0.8, 6.0);
        }
    }
}
