//! The simulation: every vehicle's acceleration from the Intelligent Driver Model, red
//! lights and scripted events, integrated at 20 Hz over the warm-up and the recording, and
//! the recorded state of every vehicle at the 10 Hz frame times.

use super::dynamics::{Dyn, Emergency};
use super::follow::follow_accel;
use super::route::{Pose, Route, TURN_RADIUS, cross_street_end, pose_of};
use super::script::{BRAKE_FRAMES, Script, apply_script};
use super::snapshot::{Snapshot, box_occupancy, next_stop_line};
use super::types::{AnomalyWindow, EGO, FRAME_DT, Traffic, Vehicle, VehicleState, WARMUP_FRAMES};
use crate::synth::road::{LightState, Road};
use crate::synth::spec::ScenarioSpec;

/// Simulation substeps per frame.
const SUBSTEPS: usize = 2;
/// Speed of a turning vehicle inside the turn (m/s).
const TURN_SPEED: f32 = 4.5;

/// Acceleration of every vehicle at time `t`; may update yellow-light decisions.
fn accelerations(
    snap: &Snapshot,
    dyns: &mut [Dyn],
    road: &Road,
    script: &Script,
    t: f32,
    warmup: bool,
) -> Vec<f32> {
    let n = snap.vehicles.len();
    let mut out = vec![0.0; n];
    let (main_in_box, cross_in_box) = box_occupancy(snap, road);
    for i in 0..n {
        let v = &snap.vehicles[i];
        let p = snap.poses[i];
        if matches!(v.route, Route::Parked { .. }) {
            continue;
        }
        let scripted_decel = match dyns[i].phase {
            Emergency::Braking => Some(script.brake_decel),
            Emergency::Slowing { decel } => Some(decel),
            Emergency::None => None,
        };
        if let Some(decel) = scripted_decel {
            out[i] = if dyns[i].v > 0.0 { -decel } else { 0.0 };
            continue;
        }
        let speed = dyns[i].v;
        let mut idm = v.idm;
        if p.turning {
            idm.v0 = TURN_SPEED;
        } else if p.cross_lane.is_some() && matches!(v.route, Route::Turn { .. }) {
            idm.v0 = 9.0;
        }
        let mut a = idm.accel(speed, f32::INFINITY, 0.0);
        if let Some((gap, j)) = snap.leader_index(i) {
            let (v_lead, a_lead) = (dyns[j].v, dyns[j].a);
            a = if i == EGO && script.ego_follows {
                let centre = gap + 0.5 * (v.model.length + snap.vehicles[j].model.length);
                follow_accel(speed, gap, centre, v_lead, a_lead, idm.a_max, idm.b_max)
            } else {
                a.min(idm.accel(speed, gap, v_lead))
            };
        }
        if let Some((xi, dist, cross)) = next_stop_line(road, v, &p)
            && dist < 120.0
        {
            {
                let x = &road.intersections[xi];
                let light = if cross {
                    x.cross_light(t)
                } else {
                    x.main_light(t)
                };
                let stop = match light {
                    LightState::Green => {
                        dyns[i].yellow = None;
                        false
                    }
                    LightState::Yellow => match dyns[i].yellow {
                        Some((k, decision)) if k == xi => decision,
                        _ => {
                            let need = speed * speed / (2.0 * dist.max(0.1));
                            let decision = dist > 0.5 && need <= 2.5;
                            dyns[i].yellow = Some((xi, decision));
                            decision
                        }
                    },
                    LightState::Red => !matches!(dyns[i].yellow, Some((k, false)) if k == xi),
                };
                // Do not enter while traffic of the other direction is still inside the
                // intersection.
                let other_inside = if cross {
                    main_in_box[xi]
                } else {
                    cross_in_box[xi]
                };
                let stop = stop || (other_inside && dist > 0.5 && dist < 25.0);
                if stop {
                    // Stop about a metre before the line.
                    a = a.min(idm.accel(speed, dist + idm.s0 - 1.0, 0.0));
                }
            }
        }
        if let Route::Turn { s_turn, .. } = v.route
            && !p.turning
            && p.cross_lane.is_none()
        {
            let dist = s_turn - p.s;
            if speed > TURN_SPEED {
                let need = (speed * speed - TURN_SPEED * TURN_SPEED) / (2.0 * dist.max(0.5));
                if need > 1.0 {
                    a = a.min(-need);
                }
            }
        }
        let limit = if warmup {
            idm.b_max.max(6.0)
        } else {
            idm.b_max
        };
        out[i] = a.clamp(-limit, idm.a_max);
    }
    out
}

/// Runs the simulation and records the frames.
pub(super) fn run(
    spec: &ScenarioSpec,
    road: &Road,
    mut vehicles: Vec<Vehicle>,
    mut script: Script,
) -> Traffic {
    let frames = spec.frames as i64;
    let mut dyns: Vec<Dyn> = vehicles
        .iter()
        .map(|v| Dyn {
            sigma: v.start,
            v: if matches!(v.route, Route::Parked { .. }) {
                0.0
            } else {
                0.9 * v.idm.v0
            },
            a: 0.0,
            lane_change: None,
            yellow: None,
            phase: Emergency::None,
            brake_lights: false,
        })
        .collect();
    // Vehicles that start in front of a light that is not green start slowly enough to stop.
    let t_start = -WARMUP_FRAMES as f32 * FRAME_DT;
    for (v, dy) in vehicles.iter().zip(dyns.iter_mut()) {
        let p = pose_of(&v.route, dy);
        if let Some((xi, dist, cross)) = next_stop_line(road, v, &p) {
            let x = &road.intersections[xi];
            let light = if cross {
                x.cross_light(t_start)
            } else {
                x.main_light(t_start)
            };
            if light != LightState::Green {
                dy.v = dy.v.min((2.0 * 2.0 * (dist - 1.0).max(0.0)).sqrt());
            }
        }
    }
    let dt = FRAME_DT / SUBSTEPS as f32;
    let mut states = Vec::with_capacity(frames as usize);
    let mut lights = Vec::with_capacity(frames as usize);
    for frame in -WARMUP_FRAMES..frames {
        let t0 = frame as f32 * FRAME_DT;
        for sub in 0..SUBSTEPS {
            let t = t0 + sub as f32 * dt;
            if sub == 0 {
                let poses: Vec<Pose> = vehicles
                    .iter()
                    .zip(&dyns)
                    .map(|(v, d)| pose_of(&v.route, d))
                    .collect();
                apply_script(&mut script, frame, &mut vehicles, &mut dyns, &poses);
            }
            let snap = Snapshot::new(&vehicles, &dyns);
            let acc = accelerations(&snap, &mut dyns, road, &script, t, frame < 0);
            for (dy, &a) in dyns.iter_mut().zip(&acc) {
                dy.a = a;
                dy.brake_lights = if dy.phase == Emergency::Braking || a < -0.6 {
                    true
                } else {
                    a < -0.25 && dy.brake_lights
                };
            }
            if sub == 0 && frame >= 0 {
                states.push(record(road, &vehicles, &dyns, &snap));
                lights.push(road.intersections.iter().map(|x| x.main_light(t)).collect());
            }
            for (i, dy) in dyns.iter_mut().enumerate() {
                if matches!(vehicles[i].route, Route::Parked { .. }) {
                    continue;
                }
                let v_new = dy.v + dy.a * dt;
                if v_new <= 0.0 {
                    if dy.a < 0.0 && dy.v > 0.0 {
                        dy.sigma += dy.v * dy.v / (-2.0 * dy.a);
                    }
                    dy.v = 0.0;
                } else {
                    dy.sigma += 0.5 * (dy.v + v_new) * dt;
                    dy.v = v_new;
                }
            }
        }
    }
    let anomaly = match script.brake_frame {
        Some(a) if a >= 0 && a + BRAKE_FRAMES < frames => Some(AnomalyWindow {
            start: a as u32,
            end: (a + BRAKE_FRAMES) as u32,
        }),
        _ => None,
    };
    let ego_lane_d = match vehicles[EGO].route {
        Route::Lane { d, .. } => d,
        _ => 0.0,
    };
    Traffic {
        vehicles,
        states,
        lights,
        cut_in: script.cut_in,
        anomaly,
        ego_lane_d,
    }
}

/// The recorded states of all vehicles at the current frame.
fn record(road: &Road, vehicles: &[Vehicle], dyns: &[Dyn], snap: &Snapshot) -> Vec<VehicleState> {
    vehicles
        .iter()
        .zip(dyns)
        .zip(&snap.poses)
        .map(|((v, dy), p)| {
            let (x, y) = road.centerline.to_world(p.s, p.d);
            let heading = road.centerline.heading(p.s);
            let emergency = dy.phase == Emergency::Braking;
            let parked = matches!(v.route, Route::Parked { .. });
            let brake = if emergency {
                1.0
            } else if dy.a < -0.25 {
                (-dy.a / 10.0).min(0.9)
            } else if !parked && dy.v < 0.05 {
                0.3
            } else {
                0.0
            };
            let throttle = if emergency || dy.a < -0.25 || parked {
                0.0
            } else {
                (0.2 + 0.5 * dy.a.max(0.0) / v.idm.a_max + 0.3 * dy.v / v.idm.v0.max(1.0)).min(1.0)
            };
            let road_kappa = road.centerline.sample(p.s).kappa;
            let kappa = if p.turning {
                -1.0 / TURN_RADIUS
            } else {
                road_kappa * p.dir
            };
            VehicleState {
                x,
                y,
                yaw: heading + p.rel_heading,
                s: p.s,
                d: p.d,
                speed: dy.v,
                accel: dy.a,
                brake,
                throttle,
                steer: ((2.8 * kappa).atan() / 1.22).clamp(-1.0, 1.0),
                brake_lights: !parked && (dy.brake_lights || emergency || dy.v < 0.05),
                emergency,
                beyond_street_end: p.cross_lane.is_some()
                    && p.d.abs() > cross_street_end(road_kappa, p.d),
            }
        })
        .collect()
}
