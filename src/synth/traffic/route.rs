//! Routes and where a vehicle on one is: the lanes, turns and cross-street lanes vehicles
//! follow, the Frenet pose from a vehicle's progress (with its lane change), and the road
//! geometry traffic keeps to (turn radius, stop lines, where cross streets end).

use super::dynamics::Dyn;
use crate::synth::road::CROSSWALK;

/// Radius of a right turn into a cross street (m).
pub(super) const TURN_RADIUS: f32 = 6.0;
/// Distance from an intersection's centre line to the stop line (beyond the half width).
pub(super) const STOP_LINE_EXTRA: f32 = 1.0 + CROSSWALK + 0.6;
/// Distance from the main road's centre line (m) at which a cross street ends for the
/// vehicles on it, turning leads included. Cross streets are straight lines normal to the
/// road, so on a curving road they meet each other and the main road again from the
/// smallest bend radius (350 m) on; vehicles of a long scenario would get there. Within
/// 200 frames no vehicle gets this far.
pub const CROSS_STREET_END: f32 = 300.0;
/// How narrow (as a fraction of its width at the main road) a cross street may get on the
/// inner side of a bend before it ends ([`cross_street_end`]).
const CROSS_STREET_SQUEEZE: f32 = 0.75;

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

/// Frenet pose of a vehicle during the simulation.
#[derive(Debug, Clone, Copy)]
pub(super) struct Pose {
    /// Arc length.
    pub(super) s: f32,
    /// Lateral offset.
    pub(super) d: f32,
    /// Heading relative to the road tangent.
    pub(super) rel_heading: f32,
    /// Component of the travel direction along +s.
    pub(super) dir: f32,
    /// Cross-street lane (s_line, towards +d?) when on a cross street.
    pub(super) cross_lane: Option<(f32, bool)>,
    /// Inside the arc of a turn.
    pub(super) turning: bool,
}

/// The pose of a vehicle on `route` at the progress and lane change of `dy`.
pub(super) fn pose_of(route: &Route, dy: &Dyn) -> Pose {
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

/// How far from the main road's centre line a cross street where the road's curvature is
/// `kappa` reaches on the side of `d`: [`CROSS_STREET_END`], or less on the inner side of
/// a bend. A cross street is a band of Frenet lines normal to the road, and on the bend's
/// inner side those lines converge towards its centre: the street, and the distance between
/// its two lanes, shrink by the factor `1 - κ·d`. It ends where they have shrunk to
/// [`CROSS_STREET_SQUEEZE`], 87 m out at the sharpest bend, before vehicles in its two
/// lanes could touch.
pub(super) fn cross_street_end(kappa: f32, d: f32) -> f32 {
    if kappa * d > 0.0 {
        CROSS_STREET_END.min((1.0 - CROSS_STREET_SQUEEZE) / kappa.abs())
    } else {
        CROSS_STREET_END
    }
}
