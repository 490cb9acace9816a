//! Traffic: who drives where, and the simulation that moves everybody.
//!
//! Every moving vehicle follows a route (a lane of the main road, a right turn into a cross
//! street, or a lane of a cross street) and controls its speed with the Intelligent Driver
//! Model (Treiber et al., in its IDM+ form): free-road acceleration towards its desired speed, braking for its
//! leader (the nearest vehicle ahead that overlaps it laterally) and for red traffic lights.
//! Normal braking is limited to [`NORMAL_DECEL_LIMIT`]. In sudden-braking scenarios, and in
//! half of the normal ones, the ego instead follows its lead with AnoVox's car-following
//! rule (`follow`), close behind it. Scripted events (sudden braking of the lead, its gentle
//! braking in normal driving, a lane change out of or into the ego lane) are triggered
//! inside the simulation when their preconditions hold. The simulation runs at 20 Hz and records every vehicle at
//! the 10 Hz frame times. A long city recording is simulated twice: the first run tells
//! when the ego comes near each intersection, the second adds cross traffic that arrives
//! there at that time ([`cross::cross_stream`]).
//!
//! [`simulate`] tries seeded variants until one passes. The files, each using only those
//! after it in this list: `populate` (the ego, its lead, the event's actors, main-road
//! traffic, parked cars), `cross` (city cross traffic), `fleet` (track ids, bodies,
//! drivers), `check` (collisions, deceleration bounds, the event seen), `sim` (the 20 Hz
//! integration and the recorded states), `snapshot` (poses, leaders, stop lines at one
//! instant), `follow` (AnoVox's car-following rule), `script` (scripted events), `types`
//! (the public data), `route` (routes, poses,
//! turn and cross-street geometry), `dynamics` (the per-vehicle state being stepped), `idm`
//! (the driver model and deceleration limits).

mod check;
mod cross;
mod dynamics;
mod fleet;
mod follow;
mod idm;
mod populate;
mod route;
mod script;
mod sim;
mod snapshot;
mod types;

pub use check::{first_collision, max_decel};
pub use idm::NORMAL_DECEL_LIMIT;
pub use route::{CROSS_STREET_END, Route};
pub use types::{AnomalyWindow, EGO, FRAME_DT, LEAD, Role, Traffic, Vehicle, VehicleState};

use check::check;
use cross::cross_stream;
use populate::populate;
use sim::run;

use super::SynthError;
use super::rng::Rng;
use super::road::Road;
use super::spec::{ScenarioKind, ScenarioSpec};
use crate::sequence::Domain;

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
/// ([`populate()`]: its start plus six seconds, 107 m at most).
const TURN_SEARCH_FROM: f32 = 110.0;

/// Where that intersection is moved to: well within reach of the slowest lead in the twelve
/// seconds of the shortest turning scenario.
const TURN_AT: f32 = 125.0;

/// Runs the seeded variants of `spec` on `road` and returns the first that passes
/// [`check()`], keeping the road it ran on; records the last problem otherwise.
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
