//! Traffic: who drives where, and the simulation that moves everybody.
//!
//! Every moving vehicle follows a route (a lane of the main road, a right turn into a cross
//! street, or a lane of a cross street) and controls its speed with the Intelligent Driver
//! Model (Treiber et al., in its IDM+ form): free-road acceleration towards its desired speed, braking for its
//! leader (the nearest vehicle ahead that overlaps it laterally) and for red traffic lights.
//! Normal braking is limited to [`NORMAL_DECEL_LIMIT`]. Scripted events (sudden braking of
//! the lead, a lane change out of or into the ego lane) are triggered inside the simulation
//! when their preconditions hold. The simulation runs at 20 Hz and records every vehicle at
//! the 10 Hz frame times. A long city recording is simulated twice: the first run tells
//! when the ego comes near each intersection, the second adds cross traffic that arrives
//! there at that time ([`cross_stream`]).

use super::SynthError;
use super::rng::Rng;
use super::road::{CROSSWALK, Intersection, LightState, Road};
use super::spec::{ScenarioKind, ScenarioSpec};
use super::vehicle::{BodyType, VehicleModel};
use crate::sequence::Domain;

/// The largest deceleration (m/s²) any vehicle uses in normal driving.
pub const NORMAL_DECEL_LIMIT: f32 = 3.0;
/// Deceleration limit of the ego when it reacts to an emergency ahead (m/s²).
pub const EGO_EMERGENCY_DECEL: f32 = 9.0;
/// Frame interval (s): AnoVox records at 10 Hz.
pub const FRAME_DT: f32 = 0.1;
/// Simulation substeps per frame.
const SUBSTEPS: usize = 2;
/// Frames simulated before recording starts, so that traffic settles.
const WARMUP_FRAMES: i64 = 40;
/// Speed of a turning vehicle inside the turn (m/s).
const TURN_SPEED: f32 = 4.5;
/// Radius of a right turn into a cross street (m).
const TURN_RADIUS: f32 = 6.0;
/// Distance from an intersection's centre line to the stop line (beyond the half width).
const STOP_LINE_EXTRA: f32 = 1.0 + CROSSWALK + 0.6;
/// Distance from the main road's centre line (m) at which a cross street ends for the
/// vehicles on it, turning leads included. Cross streets are straight lines normal to the
/// road, so on a curving road they meet each other and the main road again from the
/// smallest bend radius (350 m) on; vehicles of a long scenario would get there. Within
/// 200 frames no vehicle gets this far.
pub const CROSS_STREET_END: f32 = 300.0;
/// How narrow (as a fraction of its width at the main road) a cross street may get on the
/// inner side of a bend before it ends ([`cross_street_end`]).
const CROSS_STREET_SQUEEZE: f32 = 0.75;
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
/// The latest recorded frame from which a cut-in may start (30 % into a 200-frame
/// scenario, as in shorter ones).
const CUT_IN_LATEST_TRIGGER: i64 = 60;

/// Why a vehicle is in the scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The camera car.
    Ego,
    /// The vehicle directly ahead of the ego at the start (the anomaly actor in braking
    /// scenarios, the turning vehicle in turning scenarios).
    Lead,
    /// The vehicle that cuts in ahead of the ego.
    CutIn,
    /// Other traffic in the ego's direction.
    Traffic,
    /// Traffic in the opposite direction.
    Oncoming,
    /// Traffic on a cross street.
    Cross,
    /// A parked car.
    Parked,
}

/// The path a vehicle follows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Route {
    /// A lane of the main road at offset `d`, forward (+s) or opposite (-s).
    Lane {
        /// Travel direction is +s.
        forward: bool,
        /// Lateral offset of the lane centre.
        d: f32,
    },
    /// Forward along the lane at `d0`, then a right turn of radius `radius` starting at
    /// `s_turn`, then along the cross street towards -d.
    Turn {
        /// Lane offset before the turn.
        d0: f32,
        /// Arc length where the turn starts.
        s_turn: f32,
        /// Turn radius.
        radius: f32,
    },
    /// A cross-street lane at arc length `s_line`, towards +d (`positive`) or -d.
    Cross {
        /// Arc length of the lane centre.
        s_line: f32,
        /// Travel direction is +d.
        positive: bool,
        /// Index of the intersection.
        intersection: usize,
    },
    /// Standing still at (s, d), facing +s (`forward`) or -s.
    Parked {
        /// Arc length.
        s: f32,
        /// Lateral offset.
        d: f32,
        /// Faces +s.
        forward: bool,
    },
}

/// A lane change, as a function of the distance travelled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneChange {
    /// Progress (route parameter) where it starts.
    pub start: f32,
    /// Distance over which it happens.
    pub length: f32,
    /// Lateral offset before.
    pub from: f32,
    /// Lateral offset after.
    pub to: f32,
}

impl LaneChange {
    fn offset(&self, sigma: f32) -> (f32, f32) {
        let u = ((sigma - self.start) / self.length).clamp(0.0, 1.0);
        // Quintic smootherstep: zero lateral speed and acceleration at both ends.
        let s = u * u * u * (u * (u * 6.0 - 15.0) + 10.0);
        let ds = 30.0 * u * u * (u - 1.0) * (u - 1.0);
        (
            self.from + (self.to - self.from) * s,
            (self.to - self.from) * ds / self.length,
        )
    }
}

/// Intelligent Driver Model parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Idm {
    /// Desired speed (m/s).
    pub v0: f32,
    /// Time headway (s).
    pub t_headway: f32,
    /// Jam distance (m).
    pub s0: f32,
    /// Maximum acceleration (m/s²).
    pub a_max: f32,
    /// Comfortable deceleration (m/s²).
    pub b: f32,
    /// Hard deceleration limit (m/s²).
    pub b_max: f32,
}

impl Idm {
    /// Acceleration at speed `v` behind an obstacle `gap` metres ahead moving at `v_lead`
    /// (no obstacle: `gap` infinite). This is the IDM+ form (Schakel et al. 2010), the
    /// minimum of the free-road and the interaction terms, so that a follower keeps the
    /// desired gap `s0 + v·T` instead of the inflated IDM equilibrium gap.
    pub fn accel(&self, v: f32, gap: f32, v_lead: f32) -> f32 {
        let free = 1.0 - (v / self.v0.max(0.1)).powi(4);
        if !gap.is_finite() {
            return self.a_max * free;
        }
        let dv = v - v_lead;
        let s_star =
            self.s0 + (v * self.t_headway + v * dv / (2.0 * (self.a_max * self.b).sqrt())).max(0.0);
        let g = gap.max(0.05);
        self.a_max * free.min(1.0 - (s_star / g) * (s_star / g))
    }
}

/// One vehicle of the scenario.
#[derive(Debug, Clone)]
pub struct Vehicle {
    /// Track id: the instance id in INSTANCE_IMG and the box track id; stable.
    pub track_id: u32,
    /// Role in the scenario.
    pub role: Role,
    /// Geometry and paint.
    pub model: VehicleModel,
    /// Route.
    pub route: Route,
    /// Progress along the route at the start of the warm-up (s for forward lanes, -s for
    /// opposite lanes, the signed distance along a cross street).
    pub start: f32,
    /// Car-following parameters.
    pub idm: Idm,
}

/// The recorded state of one vehicle at one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VehicleState {
    /// World x of the footprint centre.
    pub x: f32,
    /// World y.
    pub y: f32,
    /// Heading (radians).
    pub yaw: f32,
    /// Frenet arc length.
    pub s: f32,
    /// Frenet lateral offset.
    pub d: f32,
    /// Speed (m/s).
    pub speed: f32,
    /// Commanded acceleration (m/s²).
    pub accel: f32,
    /// Brake command in [0, 1] (1.0 exactly during emergency braking).
    pub brake: f32,
    /// Throttle command in [0, 1].
    pub throttle: f32,
    /// Steering command in [-1, 1].
    pub steer: f32,
    /// Whether the brake lights are on.
    pub brake_lights: bool,
    /// Whether the vehicle is emergency braking (brake onset to standstill).
    pub emergency: bool,
    /// Whether the vehicle is on a cross street beyond its end ([`CROSS_STREET_END`] from
    /// the main road, less on the inner side of a bend): it has driven off it, or (streamed
    /// cross traffic) has yet to arrive. It is neither drawn nor checked for collisions.
    pub beyond_street_end: bool,
}

/// The inclusive frame window of the anomaly (brake onset to standstill).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AnomalyWindow {
    /// First frame of the window (brake onset).
    pub start: u32,
    /// Last frame of the window (first frame at standstill).
    pub end: u32,
}

impl AnomalyWindow {
    /// Whether `frame` lies in the window.
    pub fn contains(&self, frame: u32) -> bool {
        frame >= self.start && frame <= self.end
    }
}

/// The whole simulated traffic of a scenario.
#[derive(Debug, Clone)]
pub struct Traffic {
    /// All vehicles; index 0 is the ego, index 1 the lead.
    pub vehicles: Vec<Vehicle>,
    /// `states[frame][vehicle]`.
    pub states: Vec<Vec<VehicleState>>,
    /// Main-road light of each intersection at each frame.
    pub lights: Vec<Vec<LightState>>,
    /// Index of the cut-in vehicle (cut-in scenarios).
    pub cut_in: Option<usize>,
    /// Anomaly window (braking scenarios).
    pub anomaly: Option<AnomalyWindow>,
    /// Lane offset of the ego.
    pub ego_lane_d: f32,
}

/// Index of the ego in [`Traffic::vehicles`].
pub const EGO: usize = 0;
/// Index of the lead vehicle in [`Traffic::vehicles`].
pub const LEAD: usize = 1;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Emergency {
    None,
    Braking,
    Holding { until: f32 },
}

/// Per-vehicle dynamic state during the simulation.
#[derive(Debug, Clone, Copy)]
struct Dyn {
    sigma: f32,
    v: f32,
    a: f32,
    lane_change: Option<LaneChange>,
    /// Yellow-light decision: (intersection, stop?).
    yellow: Option<(usize, bool)>,
    phase: Emergency,
    /// Frame whose snapshot first shows the emergency stop completed.
    stop_frame: Option<i64>,
    brake_lights: bool,
}

/// Frenet pose of a vehicle during the simulation.
#[derive(Debug, Clone, Copy)]
struct Pose {
    s: f32,
    d: f32,
    /// Heading relative to the road tangent.
    rel_heading: f32,
    /// Component of the travel direction along +s.
    dir: f32,
    /// Cross-street lane (s_line, towards +d?) when on a cross street.
    cross_lane: Option<(f32, bool)>,
    /// Inside the arc of a turn.
    turning: bool,
}

fn pose_of(route: &Route, dy: &Dyn) -> Pose {
    use std::f32::consts::{FRAC_PI_2, PI};
    let plain = |s, d, rel, dir| Pose {
        s,
        d,
        rel_heading: rel,
        dir,
        cross_lane: None,
        turning: false,
    };
    match *route {
        Route::Lane { forward, d } => {
            let (d, slope) = match dy.lane_change {
                Some(lc) => lc.offset(dy.sigma),
                None => (d, 0.0),
            };
            if forward {
                plain(dy.sigma, d, slope.atan(), 1.0)
            } else {
                plain(-dy.sigma, d, PI - slope.atan(), -1.0)
            }
        }
        Route::Turn { d0, s_turn, radius } => {
            let quarter = FRAC_PI_2 * radius;
            let p = dy.sigma - s_turn;
            if p <= 0.0 {
                plain(dy.sigma, d0, 0.0, 1.0)
            } else if p < quarter {
                let alpha = p / radius;
                Pose {
                    turning: true,
                    ..plain(
                        s_turn + radius * alpha.sin(),
                        d0 - radius * (1.0 - alpha.cos()),
                        -alpha,
                        alpha.cos(),
                    )
                }
            } else {
                Pose {
                    cross_lane: Some((s_turn + radius, false)),
                    ..plain(
                        s_turn + radius,
                        d0 - radius - (p - quarter),
                        -FRAC_PI_2,
                        0.0,
                    )
                }
            }
        }
        Route::Cross {
            s_line, positive, ..
        } => Pose {
            cross_lane: Some((s_line, positive)),
            ..plain(
                s_line,
                if positive { dy.sigma } else { -dy.sigma },
                if positive { FRAC_PI_2 } else { -FRAC_PI_2 },
                0.0,
            )
        },
        Route::Parked { s, d, forward } => plain(s, d, if forward { 0.0 } else { PI }, 0.0),
    }
}

/// Scripted-event settings of one simulation run.
#[derive(Debug, Clone)]
struct Script {
    kind: ScenarioKind,
    /// Braking: frame of brake onset.
    brake_frame: Option<i64>,
    /// Emergency deceleration of the lead (m/s²).
    brake_decel: f32,
    /// Standstill hold time after emergency braking (s).
    hold_s: f32,
    /// Earliest frame of the lane change (turning on the highway, cut-in).
    trigger_from: i64,
    /// Lane the lead or the cut-in vehicle moves to.
    target_d: f32,
    /// Index of the cut-in vehicle.
    cut_in: Option<usize>,
    triggered: bool,
}

/// Builds the vehicles of a scenario and simulates them. Tries a few seeded variants until
/// the scenario does what its kind says without violating the dynamics bounds; the road's
/// light timings may be adjusted (braking and cut-in keep the main road green around the
/// event), and for a turn in the city its intersections may be moved nearer.
pub fn simulate(spec: &ScenarioSpec, road: &mut Road, rng: &Rng) -> Result<Traffic, SynthError> {
    let mut last_problem = String::new();
    if let Some(traffic) = try_variants(spec, road, rng, &mut last_problem) {
        return Ok(traffic);
    }
    // A short city recording can end before the lead reaches the road's first intersection
    // after the warm-up, whatever the variant. Then the intersections move nearer, so that
    // the lead reaches one early in the recording, and the variants run again. Scenarios
    // that succeed without this keep their road.
    if spec.kind == ScenarioKind::Turning && spec.domain == Domain::City {
        let mut nearer = road.clone();
        if let Some(x) = nearer.intersections.iter().find(|x| x.s > TURN_SEARCH_FROM) {
            nearer.shift_intersections(TURN_AT - x.s);
            if let Some(traffic) = try_variants(spec, &mut nearer, rng, &mut last_problem) {
                *road = nearer;
                return Ok(traffic);
            }
        }
    }
    Err(SynthError::Unsatisfiable {
        scenario: spec.name.clone(),
        problem: last_problem,
    })
}

/// Arc length beyond which the lead's turning intersection is sought when the
/// intersections are moved: past the latest point from which a lead looks for one
/// ([`populate`]: its start plus six seconds, 107 m at most).
const TURN_SEARCH_FROM: f32 = 110.0;

/// Where that intersection is moved to: well within reach of the slowest lead in the twelve
/// seconds of the shortest turning scenario.
const TURN_AT: f32 = 125.0;

/// Runs the seeded variants of `spec` on `road` and returns the first that passes
/// [`check`], keeping the road it ran on; records the last problem otherwise.
fn try_variants(
    spec: &ScenarioSpec,
    road: &mut Road,
    rng: &Rng,
    last_problem: &mut String,
) -> Option<Traffic> {
    for attempt in 0..16u64 {
        let mut attempt_rng = rng.fork(0x7aff_1c00 + attempt);
        let mut attempt_road = road.clone();
        let (vehicles, script) = populate(spec, &mut attempt_road, &mut attempt_rng);
        let first = run(spec, &attempt_road, vehicles.clone(), script.clone());
        let mut stream_rng = attempt_rng.fork(0xc055_57ea);
        let traffic = match cross_stream(spec, &attempt_road, &first, &vehicles, &mut stream_rng) {
            Some(more) => {
                // Long recordings: not both runs' states in memory at once.
                drop(first);
                run(spec, &attempt_road, more, script)
            }
            None => first,
        };
        match check(spec, &attempt_road, &traffic) {
            Ok(()) => {
                *road = attempt_road;
                return Some(traffic);
            }
            Err(problem) => *last_problem = problem,
        }
    }
    None
}

fn pick_body(rng: &mut Rng, domain: Domain) -> BodyType {
    let u = rng.unit();
    let (truck, bus, van) = match domain {
        Domain::Highway => (0.17, 0.04, 0.1),
        _ => (0.05, 0.05, 0.1),
    };
    if u < truck {
        BodyType::Truck
    } else if u < truck + bus {
        BodyType::Bus
    } else if u < truck + bus + van {
        BodyType::Van
    } else {
        pick_car(rng)
    }
}

fn pick_car(rng: &mut Rng) -> BodyType {
    match rng.below(20) {
        0..=8 => BodyType::Sedan,
        9..=14 => BodyType::Hatchback,
        _ => BodyType::Suv,
    }
}

fn idm_for(rng: &mut Rng, domain: Domain, v0: f32, body: BodyType) -> Idm {
    let heavy = matches!(body, BodyType::Truck | BodyType::Bus);
    let (t, s0, a) = match domain {
        Domain::Highway => (rng.range(1.2, 1.7), 2.5, rng.range(1.0, 1.5)),
        _ => (rng.range(1.1, 1.5), 2.0, rng.range(1.3, 1.9)),
    };
    Idm {
        v0,
        t_headway: t,
        s0,
        a_max: if heavy { a * 0.6 } else { a },
        b: 2.0,
        b_max: NORMAL_DECEL_LIMIT,
    }
}

/// Adds vehicles one by one with increasing track ids.
struct Fleet {
    vehicles: Vec<Vehicle>,
}

impl Fleet {
    fn add(
        &mut self,
        role: Role,
        model: VehicleModel,
        route: Route,
        start: f32,
        idm: Idm,
    ) -> usize {
        let i = self.vehicles.len();
        self.vehicles.push(Vehicle {
            track_id: i as u32 + 1,
            role,
            model,
            route,
            start,
            idm,
        });
        i
    }
}

/// Places every vehicle of the scenario; index 0 is the ego and index 1 the lead.
fn populate(spec: &ScenarioSpec, road: &mut Road, rng: &mut Rng) -> (Vec<Vehicle>, Script) {
    let domain = spec.domain;
    let kind = spec.kind;
    let highway = matches!(domain, Domain::Highway);
    let frames = spec.frames as i64;
    let duration = (frames + WARMUP_FRAMES) as f32 * FRAME_DT;
    let mut fleet = Fleet {
        vehicles: Vec::new(),
    };

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
    let lane = |d| Route::Lane { forward: true, d };
    fleet.add(Role::Ego, ego_model, lane(ego_d), 0.0, ego_idm);

    // The lead, directly ahead in the ego lane.
    let lead_body = match kind {
        ScenarioKind::Normal => pick_body(rng, domain),
        _ => pick_car(rng),
    };
    let lead_model = VehicleModel::new(lead_body, &mut rng.fork(2));
    let lead_v0 = match kind {
        ScenarioKind::CutIn => ego_v0 + rng.range(1.5, 2.5),
        _ => ego_v0 - rng.range(0.5, 2.0),
    };
    let lead_gap = match kind {
        ScenarioKind::CutIn => rng.range(45.0, 60.0),
        _ => 2.5 + lead_v0 * rng.range(1.1, 1.4),
    };
    let lead_s = 0.5 * ego_len + lead_gap + 0.5 * lead_model.length;
    let lead_route = if kind == ScenarioKind::Turning && !highway {
        // The first intersection the lead reaches a few seconds into the recording.
        let min_s = lead_s + lead_v0 * (WARMUP_FRAMES as f32 * FRAME_DT + 2.0);
        let x = road.intersections.iter().find(|x| x.s > min_s);
        let (xs, hw) = x.map_or((min_s + 60.0, 3.5), |x| (x.s, x.half_width));
        Route::Turn {
            d0: ego_d,
            s_turn: xs - 0.5 * hw - TURN_RADIUS,
            radius: TURN_RADIUS,
        }
    } else {
        lane(ego_d)
    };
    let lead_idm = idm_for(rng, domain, lead_v0, lead_body);
    fleet.add(Role::Lead, lead_model, lead_route, lead_s, lead_idm);

    let mut script = Script {
        kind,
        brake_frame: None,
        brake_decel: rng.range(7.6, 9.0),
        hold_s: rng.range(2.0, 3.5),
        trigger_from: 0,
        target_d: ego_d,
        cut_in: None,
        triggered: false,
    };

    // Scenario-specific actors and timing; `keep_clear` lists (d, s0, s1) spans of lanes
    // where no other traffic is placed.
    let mut keep_clear: Vec<(f32, f32, f32)> = Vec::new();
    match kind {
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
        ScenarioKind::Turning if !highway => {
            // Keep the lead moving towards its turn.
            for x in &mut road.intersections {
                x.force_main_green(-(WARMUP_FRAMES as f32) * FRAME_DT, frames as f32 * FRAME_DT);
            }
        }
        ScenarioKind::Turning => {
            script.trigger_from = (frames as f32 * 0.35) as i64;
            script.target_d = road.lane_center(ego_lane + 1, true);
            keep_clear.push((
                script.target_d,
                lead_s - 80.0,
                lead_s + 120.0 + duration * lead_v0,
            ));
        }
        ScenarioKind::CutIn => {
            let from_lane = if highway {
                if rng.chance(0.5) { 0 } else { 2 }
            } else {
                1 - ego_lane
            };
            let from_d = road.lane_center(from_lane, true);
            let body = pick_car(rng);
            let model = VehicleModel::new(body, &mut rng.fork(3));
            let v0 = ego_v0
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

    // Other traffic in the ego direction (none behind the ego in its own lane).
    let ego_travel = ego_v0 * duration;
    for lane_i in 0..road.lanes {
        let d = road.lane_center(lane_i, true);
        let lane_v0 = if highway {
            ego_v0 + (1.0 - lane_i as f32) * 1.5 + 1.5
        } else {
            ego_v0
        };
        let (s_from, s_to) = if lane_i == ego_lane {
            (lead_s + 25.0, lead_s + ego_travel + 250.0)
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
            let beside_ego = lane_i != ego_lane && s > -15.0 && s < 15.0;
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
    // Oncoming traffic, far enough ahead to keep coming for the whole scenario.
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
    if !highway {
        populate_city_extras(&mut fleet, road, rng, ego_travel);
    }
    (fleet.vehicles, script)
}

/// Whether arc length `s` lies in an intersection or its crosswalks (no spawning there).
fn in_intersection(road: &Road, s: f32) -> bool {
    road.nearest_intersection(s)
        .is_some_and(|x| (s - x.s).abs() < x.half_width + STOP_LINE_EXTRA + 4.0)
}

/// Parked cars along both kerbs and cross traffic at the intersections.
fn populate_city_extras(fleet: &mut Fleet, road: &Road, rng: &mut Rng, ego_travel: f32) {
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
fn cross_stream(
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

/// Everything the acceleration of one vehicle depends on, for one instant.
struct Snapshot<'a> {
    vehicles: &'a [Vehicle],
    poses: Vec<Pose>,
    /// Indices of main-road vehicles (not on a cross street) sorted by s.
    by_s: Vec<usize>,
    /// The vehicles on each cross-street lane, each lane's in ascending index order: a
    /// crossing vehicle's leader is one of its lane's, and long city scenarios have hundreds
    /// of crossing vehicles on dozens of lanes.
    cross_lanes: Vec<Vec<usize>>,
    /// Each vehicle's lane in `cross_lanes` (meaningless for vehicles not on a cross street).
    lane_of: Vec<usize>,
}

impl<'a> Snapshot<'a> {
    fn new(vehicles: &'a [Vehicle], dyns: &[Dyn]) -> Self {
        let poses: Vec<Pose> = vehicles
            .iter()
            .zip(dyns)
            .map(|(v, d)| pose_of(&v.route, d))
            .collect();
        let mut crossing: Vec<(bool, f32, usize)> = Vec::new();
        let mut by_s: Vec<usize> = Vec::new();
        for (i, p) in poses.iter().enumerate() {
            match p.cross_lane {
                Some((line, positive)) => crossing.push((positive, line, i)),
                None => by_s.push(i),
            }
        }
        by_s.sort_by(|&a, &b| poses[a].s.total_cmp(&poses[b].s).then(a.cmp(&b)));
        // A lane is a run of equal direction and lines within half a metre of its first: the
        // two lanes of a street lie half its width apart, and streets tens of metres.
        crossing.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut cross_lanes: Vec<Vec<usize>> = Vec::new();
        let mut lane_of = vec![usize::MAX; vehicles.len()];
        let mut lane_start = (f32::NAN, false);
        for (positive, line, i) in crossing {
            if lane_start.1 == positive && (line - lane_start.0).abs() < 0.5 {
                if let Some(lane) = cross_lanes.last_mut() {
                    lane.push(i);
                }
            } else {
                lane_start = (line, positive);
                cross_lanes.push(vec![i]);
            }
            lane_of[i] = cross_lanes.len() - 1;
        }
        for lane in &mut cross_lanes {
            lane.sort_unstable();
        }
        Self {
            vehicles,
            poses,
            by_s,
            cross_lanes,
            lane_of,
        }
    }

    /// Gap to and speed of the leader of vehicle `i`.
    fn leader(&self, i: usize, dyns: &[Dyn]) -> Option<(f32, f32)> {
        let p = self.poses[i];
        let me = &self.vehicles[i];
        let mut best: Option<(f32, f32)> = None;
        let mut consider = |j: usize, along: f32| {
            let other = &self.vehicles[j];
            let gap = along - 0.5 * (me.model.length + other.model.length);
            if best.is_none_or(|(g, _)| gap < g) {
                best = Some((gap, dyns[j].v));
            }
        };
        if let Some((_, positive)) = p.cross_lane {
            let sign = if positive { 1.0 } else { -1.0 };
            for &j in &self.cross_lanes[self.lane_of[i]] {
                let along = (self.poses[j].d - p.d) * sign;
                if j != i && along > 0.0 {
                    consider(j, along);
                }
            }
            return best;
        }
        if p.turning || p.dir == 0.0 {
            // Inside a turn the cross street ahead is kept clear; parked cars never move.
            return None;
        }
        let k = self.by_s.partition_point(|&j| self.poses[j].s < p.s);
        let lateral_ok = |j: usize| {
            let q = &self.poses[j];
            let w = 0.5 * (me.model.width + self.vehicles[j].model.width) + 0.25;
            (q.d - p.d).abs() < w
                && (q.dir * p.dir > 0.0 || matches!(self.vehicles[j].route, Route::Parked { .. }))
        };
        if p.dir > 0.0 {
            for &j in &self.by_s[k..] {
                let along = self.poses[j].s - p.s;
                if along > 150.0 {
                    break;
                }
                if j != i && along > 0.0 && lateral_ok(j) {
                    consider(j, along);
                }
            }
        } else {
            for &j in self.by_s[..k].iter().rev() {
                let along = p.s - self.poses[j].s;
                if along > 150.0 {
                    break;
                }
                if j != i && along > 0.0 && lateral_ok(j) {
                    consider(j, along);
                }
            }
        }
        best
    }
}

/// The stop line a vehicle approaches next: (intersection, distance from its front bumper,
/// whether the approach is on the cross street).
fn next_stop_line(road: &Road, v: &Vehicle, p: &Pose) -> Option<(usize, f32, bool)> {
    let half_len = 0.5 * v.model.length;
    if let Route::Cross {
        positive,
        intersection,
        ..
    } = v.route
    {
        let line = road.road_half + 0.8 + CROSSWALK + 0.6;
        let dist = if positive {
            -line - (p.d + half_len)
        } else {
            (p.d - half_len) - line
        };
        return (dist > -0.5).then_some((intersection, dist, true));
    }
    if p.cross_lane.is_some() || p.turning || p.dir == 0.0 {
        return None;
    }
    let xs = &road.intersections;
    if p.dir > 0.0 {
        let front = p.s + half_len;
        let k = xs.partition_point(|x| x.s - x.half_width - STOP_LINE_EXTRA < front - 0.5);
        let x = xs.get(k)?;
        Some((k, x.s - x.half_width - STOP_LINE_EXTRA - front, false))
    } else {
        let front = p.s - half_len;
        let k = xs.partition_point(|x| x.s + x.half_width + STOP_LINE_EXTRA <= front + 0.5);
        let x = xs.get(k.checked_sub(1)?)?;
        Some((k - 1, front - (x.s + x.half_width + STOP_LINE_EXTRA), false))
    }
}

/// Which intersections have a main-road vehicle, and which a cross-street vehicle, inside
/// their conflict area.
fn box_occupancy(snap: &Snapshot, road: &Road) -> (Vec<bool>, Vec<bool>) {
    let n = road.intersections.len();
    let mut main = vec![false; n];
    let mut cross = vec![false; n];
    for (v, p) in snap.vehicles.iter().zip(&snap.poses) {
        let half = 0.5 * v.model.length + 0.5;
        match v.route {
            Route::Parked { .. } => {}
            Route::Cross { intersection, .. } => {
                if p.d.abs() < road.road_half + half
                    && let Some(c) = cross.get_mut(intersection)
                {
                    *c = true;
                }
            }
            _ => {
                if p.cross_lane.is_some() {
                    continue;
                }
                let k = road.intersections.partition_point(|x| x.s < p.s);
                for j in [k.wrapping_sub(1), k] {
                    if let Some(x) = road.intersections.get(j)
                        && (p.s - x.s).abs() < x.half_width + half
                    {
                        main[j] = true;
                    }
                }
            }
        }
    }
    (main, cross)
}

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
        match dyns[i].phase {
            Emergency::Braking => {
                out[i] = if dyns[i].v > 0.0 {
                    -script.brake_decel
                } else {
                    0.0
                };
                continue;
            }
            Emergency::Holding { until } if t < until => {
                out[i] = 0.0;
                continue;
            }
            _ => {}
        }
        let speed = dyns[i].v;
        let mut idm = v.idm;
        if p.turning {
            idm.v0 = TURN_SPEED;
        } else if p.cross_lane.is_some() && matches!(v.route, Route::Turn { .. }) {
            idm.v0 = 9.0;
        }
        let mut a = idm.accel(speed, f32::INFINITY, 0.0);
        if let Some((gap, v_lead)) = snap.leader(i, dyns) {
            a = a.min(idm.accel(speed, gap, v_lead));
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

/// Applies scripted events that start at `frame`.
fn apply_script(
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

/// Runs the simulation and records the frames.
fn run(
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
            stop_frame: None,
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
                states.push(record(road, &vehicles, &dyns, &snap, frame));
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
                    if dy.phase == Emergency::Braking {
                        dy.phase = Emergency::Holding {
                            until: t + dt + script.hold_s,
                        };
                        dy.stop_frame = Some(frame + 1);
                    }
                } else {
                    dy.sigma += 0.5 * (dy.v + v_new) * dt;
                    dy.v = v_new;
                }
            }
        }
    }
    let anomaly = match (script.brake_frame, dyns[LEAD].stop_frame) {
        (Some(a), Some(b)) if a >= 0 && b < frames => Some(AnomalyWindow {
            start: a as u32,
            end: b as u32,
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

/// The recorded states of all vehicles at `frame`.
fn record(
    road: &Road,
    vehicles: &[Vehicle],
    dyns: &[Dyn],
    snap: &Snapshot,
    frame: i64,
) -> Vec<VehicleState> {
    vehicles
        .iter()
        .zip(dyns)
        .zip(&snap.poses)
        .map(|((v, dy), p)| {
            let (x, y) = road.centerline.to_world(p.s, p.d);
            let heading = road.centerline.heading(p.s);
            let emergency = dy.phase == Emergency::Braking || dy.stop_frame == Some(frame);
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

/// How far from the main road's centre line a cross street where the road's curvature is
/// `kappa` reaches on the side of `d`: [`CROSS_STREET_END`], or less on the inner side of
/// a bend. A cross street is a band of Frenet lines normal to the road, and on the bend's
/// inner side those lines converge towards its centre: the street, and the distance between
/// its two lanes, shrink by the factor `1 - κ·d`. It ends where they have shrunk to
/// [`CROSS_STREET_SQUEEZE`], 87 m out at the sharpest bend, before vehicles in its two
/// lanes could touch.
fn cross_street_end(kappa: f32, d: f32) -> f32 {
    if kappa * d > 0.0 {
        CROSS_STREET_END.min((1.0 - CROSS_STREET_SQUEEZE) / kappa.abs())
    } else {
        CROSS_STREET_END
    }
}

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
fn check(spec: &ScenarioSpec, road: &Road, traffic: &Traffic) -> Result<(), String> {
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
                .ok_or("the lead does not come to a standstill in time")?;
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
            // The ego follows the lead closely when it brakes.
            let st = &traffic.states[w.start as usize];
            let lengths =
                0.5 * (traffic.vehicles[LEAD].model.length + traffic.vehicles[EGO].model.length);
            let gap = st[LEAD].s - st[EGO].s - lengths;
            let max_gap = (1.8 * st[EGO].speed).max(12.0);
            if gap > max_gap {
                return Err(format!(
                    "the ego is {gap:.0} m behind the lead at brake onset"
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
