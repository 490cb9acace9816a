//! The simulated traffic as data: the vehicles with their roles, routes and drivers, every
//! vehicle's recorded state at every frame, the anomaly window, and the frame timing.

use super::idm::Idm;
use super::route::Route;
use crate::synth::road::LightState;
use crate::synth::vehicle::VehicleModel;

/// Frame interval (s): AnoVox records at 10 Hz.
pub const FRAME_DT: f32 = 0.1;
/// Frames simulated before recording starts, so that traffic settles.
pub(super) const WARMUP_FRAMES: i64 = 40;

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
    /// Whether the vehicle is in the scripted full brake (the lead's 30 frames, standstill
    /// included).
    pub emergency: bool,
    /// Whether the vehicle is on a cross street beyond its end ([`CROSS_STREET_END`] from
    /// the main road, less on the inner side of a bend): it has driven off it, or (streamed
    /// cross traffic) has yet to arrive. It is neither drawn nor checked for collisions.
    ///
    /// [`CROSS_STREET_END`]: super::CROSS_STREET_END
    pub beyond_street_end: bool,
}

/// The inclusive frame window of the anomaly: brake onset to the frame the brake is
/// released, 31 frames as AnoVox labels them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AnomalyWindow {
    /// First frame of the window (brake onset).
    pub start: u32,
    /// Last frame of the window (brake onset + 30).
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
