//! What every vehicle's acceleration depends on at one instant: the poses of all vehicles,
//! each one's leader, the next stop line it approaches and which intersections are occupied.

use super::dynamics::Dyn;
use super::route::{Pose, Route, STOP_LINE_EXTRA, pose_of};
use super::types::Vehicle;
use crate::synth::road::{CROSSWALK, Road};

/// Everything the acceleration of one vehicle depends on, for one instant.
pub(super) struct Snapshot<'a> {
    /// All vehicles.
    pub(super) vehicles: &'a [Vehicle],
    /// Their poses.
    pub(super) poses: Vec<Pose>,
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
    /// The poses of `vehicles` in their states `dyns`, sorted for leader searches.
    pub(super) fn new(vehicles: &'a [Vehicle], dyns: &[Dyn]) -> Self {
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

    /// Gap (bumper to bumper) to and index of the leader of vehicle `i`.
    pub(super) fn leader_index(&self, i: usize) -> Option<(f32, usize)> {
        let p = self.poses[i];
        let me = &self.vehicles[i];
        let mut best: Option<(f32, usize)> = None;
        let mut consider = |j: usize, along: f32| {
            let other = &self.vehicles[j];
            let gap = along - 0.5 * (me.model.length + other.model.length);
            if best.is_none_or(|(g, _)| gap < g) {
                best = Some((gap, j));
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
pub(super) fn next_stop_line(road: &Road, v: &Vehicle, p: &Pose) -> Option<(usize, f32, bool)> {
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
pub(super) fn box_occupancy(snap: &Snapshot, road: &Road) -> (Vec<bool>, Vec<bool>) {
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
