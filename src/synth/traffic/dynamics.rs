//! The per-vehicle state the simulation steps: progress along the route, speed, the lane
//! change under way, yellow-light decision and emergency phase.

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
    /// Lateral offset at progress `sigma`, and its rate of change per metre of progress.
    pub(super) fn offset(&self, sigma: f32) -> (f32, f32) {
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

/// Scripted braking a vehicle is in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Emergency {
    /// Driving normally.
    None,
    /// Full brake (the sudden braking of the lead): the scripted deceleration, then held
    /// at standstill, until the script releases it.
    Braking,
    /// Gentle braking of normal driving at `decel` m/s², until the script releases it.
    Slowing {
        /// Deceleration (m/s²).
        decel: f32,
    },
}

/// Per-vehicle dynamic state during the simulation.
#[derive(Debug, Clone, Copy)]
pub(super) struct Dyn {
    /// Progress along the route (see [`super::Vehicle::start`]).
    pub(super) sigma: f32,
    /// Speed (m/s).
    pub(super) v: f32,
    /// Acceleration of the current substep (m/s²).
    pub(super) a: f32,
    /// The lane change under way, if any.
    pub(super) lane_change: Option<LaneChange>,
    /// Yellow-light decision: (intersection, stop?).
    pub(super) yellow: Option<(usize, bool)>,
    /// Scripted braking phase.
    pub(super) phase: Emergency,
    /// Whether the brake lights are on (they go off with some hysteresis).
    pub(super) brake_lights: bool,
}
