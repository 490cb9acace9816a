//! The Intelligent Driver Model every moving vehicle controls its speed with, and the
//! deceleration limits of normal driving and of the ego's emergency reaction.

/// The largest deceleration (m/s²) any vehicle uses in normal driving.
pub const NORMAL_DECEL_LIMIT: f32 = 3.0;
/// Deceleration limit of the ego when it reacts to an emergency ahead (m/s²).
pub const EGO_EMERGENCY_DECEL: f32 = 9.0;

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
