//! AnoVox's car-following rule for the ego (`shared/design/anovox-format.md` §5.2): the
//! ego of a sudden-braking scenario follows its lead as CARLA's `BehaviorAgent`
//! `car_following_manager` does with AnoVox's `DISTANCE_BETWEEN_CARS` of 5 m, which keeps
//! the lead close and large in the image.
//!
//! With `distance` = centre-to-centre distance − 5 m and `ttc` = distance / max(1 m/s,
//! v_ego − v_lead), the target speed is the lead's minus 12 km/h below a ttc of 3 s, the
//! lead's up to 6 s and 70 km/h beyond; following at the lead's speed this settles at 8–11 m
//! centre to centre. CARLA's PID controller saturates within a km/h of error, so the speed is
//! tracked with a stiff gain up to a comfortable deceleration. Where that would not stop the
//! ego behind a braking lead (CARLA's controller brakes at 0.3 and would collide at these
//! gaps) it brakes as hard as needed, up to its emergency limit: the scenario shows a
//! near miss, never a crash.

/// `DISTANCE_BETWEEN_CARS`: subtracted from the centre-to-centre distance (m).
const DISTANCE_BETWEEN_CARS: f32 = 5.0;
/// Below this time to collision the ego drops below the lead's speed (s).
const TTC_SLOWER: f32 = 3.0;
/// Below this time to collision the ego matches the lead's speed (s).
const TTC_MATCH: f32 = 6.0;
/// How far below the lead's speed the ego aims when too close: 12 km/h (m/s).
const SPEED_DECREASE: f32 = 12.0 / 3.6;
/// The "normal" behaviour's top speed: 70 km/h (m/s).
pub const MAX_SPEED: f32 = 70.0 / 3.6;
/// Speed-tracking gain (1/s): 1 m/s of error asks for 2 m/s².
const GAIN: f32 = 2.0;
/// Deceleration (m/s²) the speed controller uses at most; harder braking only to avoid a
/// collision.
const CONTROL_DECEL: f32 = 3.0;
/// Distance (m) the ego keeps from the lead's rear bumper when it must brake hard.
const STANDSTILL_GAP: f32 = 1.5;

/// The target speed (m/s) of the rule for a lead `centre_distance` metres ahead moving at
/// `v_lead`, the ego at `v`.
pub(super) fn target_speed(v: f32, centre_distance: f32, v_lead: f32) -> f32 {
    let distance = centre_distance - DISTANCE_BETWEEN_CARS;
    let ttc = distance / (v - v_lead).max(1.0);
    let target = if ttc < TTC_SLOWER {
        v_lead - SPEED_DECREASE
    } else if ttc < TTC_MATCH {
        v_lead
    } else {
        MAX_SPEED
    };
    target.clamp(0.0, MAX_SPEED)
}

/// The ego's acceleration (m/s²) behind a lead: at speed `v`, the lead `gap` metres ahead
/// bumper to bumper (`centre_distance` centre to centre) at speed `v_lead` and acceleration
/// `a_lead`; at most `a_max`, at least −`b_emergency`.
pub(super) fn follow_accel(
    v: f32,
    gap: f32,
    centre_distance: f32,
    v_lead: f32,
    a_lead: f32,
    a_max: f32,
    b_emergency: f32,
) -> f32 {
    let target = target_speed(v, centre_distance, v_lead);
    let a = (GAIN * (target - v)).clamp(-CONTROL_DECEL, a_max);
    // Where the lead will stop if it keeps braking, and what it takes to stop behind it.
    let lead_stop = if v_lead <= 0.05 {
        0.0
    } else if a_lead < -0.5 {
        v_lead * v_lead / (-2.0 * a_lead)
    } else {
        return a;
    };
    let room = (gap - STANDSTILL_GAP + lead_stop).max(0.05);
    let need = v * v / (2.0 * room);
    if need > CONTROL_DECEL {
        a.min(-need.min(b_emergency))
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rule_settles_between_eight_and_eleven_metres() {
        let v = 12.0;
        // Matching the lead's speed: target = lead speed from 8 m to 11 m centre to centre.
        assert!(target_speed(v, 7.9, v) < v);
        assert_eq!(target_speed(v, 8.0, v), v);
        assert_eq!(target_speed(v, 10.9, v), v);
        assert_eq!(target_speed(v, 11.0, v), MAX_SPEED);
        // Closing at 3 m/s from 20 m: ttc 5 s, match the lead.
        assert_eq!(target_speed(v + 3.0, 20.0, v), v);
        // Closing at 3 m/s from 12 m: ttc 2.3 s, drop 12 km/h below it.
        assert!((target_speed(v + 3.0, 12.0, v) - (v - SPEED_DECREASE)).abs() < 1e-5);
    }

    #[test]
    fn a_braking_lead_close_ahead_makes_the_ego_brake_hard_but_no_harder_than_needed() {
        // Lead 5 m ahead braking at 8 m/s² from 12 m/s: it stops in 9 m.
        let a = follow_accel(12.0, 5.0, 9.6, 12.0, -8.0, 2.0, 9.0);
        let room = 5.0 - STANDSTILL_GAP + 9.0;
        assert!((a + 144.0 / (2.0 * room)).abs() < 1e-4, "{a}");
        // Not braking: only the speed controller, within its limits.
        let a = follow_accel(12.0, 5.0, 9.6, 12.0, 0.0, 2.0, 9.0);
        assert!((-CONTROL_DECEL..=2.0).contains(&a));
        // A stopped lead 2 m ahead of a fast ego: the emergency limit.
        assert_eq!(follow_accel(12.0, 2.0, 6.6, 0.0, 0.0, 2.0, 9.0), -9.0);
    }
}
