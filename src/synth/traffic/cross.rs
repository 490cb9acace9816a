//! Cross traffic in the city: the vehicles placed on both lanes of every cross street at
//! the start (but the lane the turning lead drives into), and for long recordings a stream
//! of vehicles timed to reach each intersection while the ego is near it.

use super::fleet::{Fleet, idm_for, pick_car};
use super::idm::Idm;
use super::route::Route;
use super::types::{EGO, FRAME_DT, LEAD, Role, Traffic, Vehicle, WARMUP_FRAMES};
use crate::sequence::Domain;
use crate::synth::rng::Rng;
use crate::synth::road::{Intersection, Road};
use crate::synth::spec::ScenarioSpec;
use crate::synth::vehicle::{BodyType, VehicleModel};

/// Recordings longer than this many frames get a stream of cross traffic
/// ([`cross_stream`]); in shorter ones the vehicles placed on the cross streets at the start
/// keep them busy to the end.
const CROSS_STREAM_FROM_FRAMES: u32 = 300;
/// Desired speeds of cross-street traffic (m/s).
const CROSS_V0: (f32, f32) = (8.0, 11.0);
/// The ego watches an intersection's cross traffic from this far before its centre line
/// until this far past it (m).
const CROSS_WATCH: (f32, f32) = (150.0, 20.0);
/// Seconds of streamed cross traffic before and after the ego's watch: the stream's queues
/// at the red light build up before, and the ego may come a little later than without it.
const CROSS_WATCH_PAD_S: f32 = 10.0;
/// Time between two streamed vehicles of one cross-street lane (s): about the 0.1 vehicles
/// a second that a cross green of 5–8 s in a cycle of about 40 s lets through.
const CROSS_HEADWAY_S: (f32, f32) = (6.0, 14.0);
/// Least distance between the starts of two streamed vehicles of one lane (m).
const CROSS_MIN_SPACING: f32 = 12.0;

/// Adds cross traffic on the cross streets of the intersections the ego may reach.
pub(super) fn add_cross_traffic(fleet: &mut Fleet, road: &Road, rng: &mut Rng, ego_travel: f32) {
    let domain = road.domain;
    let turn_lane = turn_lane(&fleet.vehicles);
    for (xi, x) in road.intersections.iter().enumerate() {
        if x.s > ego_travel + 450.0 {
            break;
        }
        for (positive, s_line) in cross_traffic_lanes(x, turn_lane) {
            let mut dist = road.road_half + 12.0 + rng.range(0.0, 20.0);
            while dist < 160.0 {
                let (model, idm) = cross_vehicle(rng, domain, 20_000 + fleet.vehicles.len());
                let route = Route::Cross {
                    s_line,
                    positive,
                    intersection: xi,
                };
                fleet.add(Role::Cross, model, route, -dist, idm);
                dist += rng.range(14.0, 40.0);
            }
        }
    }
}

/// The lane line of the cross street the turning lead drives into (its -d lane), which
/// cross traffic keeps free.
fn turn_lane(vehicles: &[Vehicle]) -> Option<f32> {
    match vehicles.get(LEAD).map(|v| v.route) {
        Some(Route::Turn { s_turn, radius, .. }) => Some(s_turn + radius),
        _ => None,
    }
}

/// The body and driver of a vehicle on a cross street; `label` picks its paint and shape.
fn cross_vehicle(rng: &mut Rng, domain: Domain, label: usize) -> (VehicleModel, Idm) {
    let body = if rng.chance(0.9) {
        pick_car(rng)
    } else {
        BodyType::Van
    };
    let model = VehicleModel::new(body, &mut rng.fork(label as u64));
    let v0 = rng.range(CROSS_V0.0, CROSS_V0.1);
    (model, idm_for(rng, domain, v0, body))
}

/// The lanes of the cross street of `x` that cross traffic drives in, as (towards +d, lane
/// line): both, but the -d lane that the turning lead drives into (`turn_lane`).
fn cross_traffic_lanes(
    x: &Intersection,
    turn_lane: Option<f32>,
) -> impl Iterator<Item = (bool, f32)> + '_ {
    [true, false]
        .into_iter()
        .map(|positive| {
            let line = if positive {
                x.s + 0.5 * x.half_width
            } else {
                x.s - 0.5 * x.half_width
            };
            (positive, line)
        })
        .filter(move |&(positive, line)| {
            positive || !turn_lane.is_some_and(|t| (t - line).abs() < 0.5)
        })
}

/// Cross traffic for the rest of a long city recording, or `None` where the vehicles placed
/// on the cross streets at the start last the whole recording.
///
/// Those vehicles have crossed after the first minute or so. For every intersection the ego
/// comes near in `first` (the simulation without the stream), this adds vehicles far down
/// both of its cross streets, each placed from its own desired speed so that it reaches the
/// intersection while the ego is near (one every [`CROSS_HEADWAY_S`] seconds, what the
/// cross street's short green lets through). Beyond [`CROSS_STREET_END`] they are neither
/// drawn nor checked for collisions, so they appear down the street as they approach.
///
/// [`CROSS_STREET_END`]: super::CROSS_STREET_END
pub(super) fn cross_stream(
    spec: &ScenarioSpec,
    road: &Road,
    first: &Traffic,
    vehicles: &[Vehicle],
    rng: &mut Rng,
) -> Option<Vec<Vehicle>> {
    if spec.domain != Domain::City || spec.frames <= CROSS_STREAM_FROM_FRAMES {
        return None;
    }
    let t_start = -(WARMUP_FRAMES as f32) * FRAME_DT;
    let turn_lane = turn_lane(vehicles);
    let ego_s: Vec<f32> = first.states.iter().map(|st| st[EGO].s).collect();
    let mut fleet = Fleet {
        vehicles: vehicles.to_vec(),
    };
    for (xi, x) in road.intersections.iter().enumerate() {
        let Some(fa) = ego_s.iter().position(|&s| s >= x.s - CROSS_WATCH.0) else {
            break;
        };
        let fb = ego_s
            .iter()
            .rposition(|&s| s <= x.s + CROSS_WATCH.1)
            .unwrap_or(fa);
        let ta = fa as f32 * FRAME_DT - CROSS_WATCH_PAD_S;
        let tb = fb as f32 * FRAME_DT + CROSS_WATCH_PAD_S;
        for (positive, s_line) in cross_traffic_lanes(x, turn_lane) {
            let route = Route::Cross {
                s_line,
                positive,
                intersection: xi,
            };
            // The start of the street's last vehicle placed so far.
            let last = fleet
                .vehicles
                .iter()
                .filter(|v| v.route == route)
                .map(|v| -v.start)
                .fold(road.road_half, f32::max);
            let mut placed: Vec<(f32, VehicleModel, Idm)> = Vec::new();
            let mut t = ta + rng.range(0.0, CROSS_HEADWAY_S.1);
            while t < tb {
                let label = 40_000 + fleet.vehicles.len() + placed.len();
                let (model, idm) = cross_vehicle(rng, spec.domain, label);
                placed.push((idm.v0 * (t - t_start), model, idm));
                t += rng.range(CROSS_HEADWAY_S.0, CROSS_HEADWAY_S.1);
            }
            // A faster vehicle placed for a later arrival can start ahead of a slower one:
            // they go down the street in order of their start, at least
            // `CROSS_MIN_SPACING` apart, and the faster one follows. Arrivals that would
            // start among the vehicles placed at the start are theirs already.
            placed.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut dist = last;
            for (want, model, idm) in placed {
                if want < last + CROSS_MIN_SPACING {
                    continue;
                }
                dist = want.max(dist + CROSS_MIN_SPACING);
                fleet.add(Role::Cross, model, route, -dist, idm);
            }
        }
    }
    (fleet.vehicles.len() > vehicles.len()).then_some(fleet.vehicles)
}
