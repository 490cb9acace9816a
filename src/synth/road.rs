//! The road: a gently curving centreline with Frenet coordinates (s along, d to the left),
//! the cross-section of a city street or a highway, intersections with their traffic-light
//! cycles, the ground regions (road, kerb, sidewalk, terrain) and the lane markings.
//!
//! All geometry of the world is defined in Frenet coordinates and mapped to world x/y
//! through [`Centerline::to_world`]; the ground shader maps back with
//! [`Centerline::to_frenet`]. The two are exact inverses of each other (up to rounding), so
//! markings and textures defined in (s, d) stay attached to the same world points.

use super::math::V3;
use super::rng::Rng;
use super::texture::{filtered_band, filtered_pulse};
use crate::sequence::Domain;

/// Spacing of the tabulated centreline samples (metres).
const STEP: f32 = 1.0;

/// The road centreline: positions, unit tangents and curvature tabulated every metre and
/// interpolated linearly.
#[derive(Debug, Clone)]
pub struct Centerline {
    s_start: f32,
    /// One sample per metre, position, tangent and curvature side by side, so that an
    /// interpolation reads its two neighbours from one place (the ground of every pixel is
    /// sampled several times).
    knots: Vec<Knot>,
}

/// A tabulated sample of the centreline: position, unit tangent and curvature.
#[derive(Debug, Clone, Copy)]
struct Knot {
    x: f32,
    y: f32,
    tx: f32,
    ty: f32,
    kappa: f32,
}

/// A point of the centreline with its unit tangent and curvature.
#[derive(Debug, Clone, Copy)]
pub struct CenterSample {
    /// Position x.
    pub x: f32,
    /// Position y.
    pub y: f32,
    /// Tangent x (unit length up to interpolation error).
    pub tx: f32,
    /// Tangent y.
    pub ty: f32,
    /// Signed curvature (1/m, positive turns left).
    pub kappa: f32,
}

impl Centerline {
    /// A centreline from `s_start` to `s_end` whose curvature alternates between straight
    /// stretches and gentle bends of radius at least `1 / max_curvature`.
    pub fn generate(rng: &mut Rng, s_start: f32, s_end: f32, max_curvature: f32) -> Self {
        // Piecewise-constant target curvature, eased over 60 m so that curvature is smooth.
        let mut knots: Vec<(f32, f32)> = vec![(s_start, 0.0)];
        let mut s = s_start + rng.range(80.0, 200.0);
        while s < s_end {
            let k = if rng.chance(0.35) {
                0.0
            } else {
                let mag = rng.range(0.3, 1.0) * max_curvature;
                if rng.chance(0.5) { mag } else { -mag }
            };
            knots.push((s, k));
            s += rng.range(120.0, 320.0);
        }
        let target = |s: f32| -> f32 {
            let mut k = 0.0;
            let mut prev = 0.0;
            for &(ks, kv) in &knots {
                let blend = super::math::smoothstep(ks, ks + 60.0, s);
                if blend <= 0.0 {
                    break;
                }
                k = prev + (kv - prev) * blend;
                prev = kv;
            }
            k
        };
        let n = ((s_end - s_start) / STEP).ceil() as usize + 2;
        let mut knots = Vec::with_capacity(n);
        let (mut x, mut y, mut theta) = (0.0f64, 0.0f64, 0.0f64);
        const SUB: usize = 8;
        for i in 0..n {
            let s_i = s_start + i as f32 * STEP;
            knots.push(Knot {
                x: x as f32,
                y: y as f32,
                tx: theta.cos() as f32,
                ty: theta.sin() as f32,
                kappa: target(s_i),
            });
            let h = (STEP / SUB as f32) as f64;
            for j in 0..SUB {
                let k = target(s_i + (j as f32 + 0.5) * h as f32) as f64;
                let mid = theta + 0.5 * k * h;
                x += h * mid.cos();
                y += h * mid.sin();
                theta += k * h;
            }
        }
        Self { s_start, knots }
    }

    /// First tabulated arc length.
    pub fn s_start(&self) -> f32 {
        self.s_start
    }

    /// Last tabulated arc length.
    pub fn s_end(&self) -> f32 {
        self.s_start + (self.knots.len().saturating_sub(1)) as f32 * STEP
    }

    /// Position, tangent and curvature at arc length `s` (straight extrapolation outside).
    #[inline(always)]
    pub fn sample(&self, s: f32) -> CenterSample {
        let last = self.knots.len() - 1;
        let u = (s - self.s_start) / STEP;
        if u <= 0.0 || u >= last as f32 {
            let i = if u <= 0.0 { 0 } else { last };
            let delta = s - (self.s_start + i as f32 * STEP);
            let k = self.knots[i];
            return CenterSample {
                x: k.x + k.tx * delta,
                y: k.y + k.ty * delta,
                tx: k.tx,
                ty: k.ty,
                kappa: 0.0,
            };
        }
        // 0 < u < last here, so the conversion needs no saturation (`as usize` would test
        // for it); `min` keeps the pair inside the table all the same.
        let i = (u as u32 as usize).min(last - 1);
        let f = u - i as f32;
        let [k0, k1] = [self.knots[i], self.knots[i + 1]];
        // Linear between samples 1 m apart: the chord deviates from the arc by well under a
        // millimetre for the gentle curvatures used, and the tangent is interpolated
        // separately so that Frenet offsets stay continuous.
        CenterSample {
            x: k0.x + (k1.x - k0.x) * f,
            y: k0.y + (k1.y - k0.y) * f,
            tx: k0.tx + (k1.tx - k0.tx) * f,
            ty: k0.ty + (k1.ty - k0.ty) * f,
            kappa: k0.kappa + (k1.kappa - k0.kappa) * f,
        }
    }

    /// World position of the Frenet point (s, d); d is measured to the left.
    #[inline]
    pub fn to_world(&self, s: f32, d: f32) -> (f32, f32) {
        let c = self.sample(s);
        (c.x - d * c.ty, c.y + d * c.tx)
    }

    /// Heading (radians, counter-clockwise from +x) of the road at `s`.
    pub fn heading(&self, s: f32) -> f32 {
        let c = self.sample(s);
        c.ty.atan2(c.tx)
    }

    /// Frenet coordinates (s, d) of the world point (x, y), by Newton iteration from the
    /// arc-length guess `s_guess` (which must be within a few tens of metres).
    #[inline]
    pub fn to_frenet(&self, x: f32, y: f32, s_guess: f32) -> (f32, f32) {
        let mut s = s_guess;
        let mut across = 0.0;
        for _ in 0..8 {
            let c = self.sample(s);
            let dx = x - c.x;
            let dy = y - c.y;
            let along = dx * c.tx + dy * c.ty;
            across = -dx * c.ty + dy * c.tx;
            let step = along / (1.0 - c.kappa * across).max(0.2);
            s += step;
            // Converged: the offset computed at the previous estimate is exact to far
            // below a millimetre.
            if step.abs() < 2e-4 {
                break;
            }
        }
        (s, across)
    }
}

/// Traffic-light colour seen by one approach.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightState {
    /// Go.
    Green,
    /// Stop if you comfortably can.
    Yellow,
    /// Stop.
    Red,
}

/// An intersection of the city street with a perpendicular cross street.
#[derive(Debug, Clone)]
pub struct Intersection {
    /// Arc length of the cross street's centre line.
    pub s: f32,
    /// Half width of the cross street's carriageway.
    pub half_width: f32,
    /// Main-road green time (seconds).
    pub main_green: f32,
    /// Cross-street green time (seconds).
    pub cross_green: f32,
    /// Phase offset (seconds).
    pub offset: f32,
}

/// Yellow time of every traffic light (seconds).
pub const YELLOW_S: f32 = 3.0;
/// All-red clearance time between the two directions (seconds).
pub const ALL_RED_S: f32 = 2.0;

impl Intersection {
    /// Length of the full light cycle (seconds).
    pub fn cycle(&self) -> f32 {
        self.main_green + self.cross_green + 2.0 * (YELLOW_S + ALL_RED_S)
    }

    /// Light for the main road (both directions) at time `t`.
    pub fn main_light(&self, t: f32) -> LightState {
        let m = (t + self.offset).rem_euclid(self.cycle());
        if m < self.main_green {
            LightState::Green
        } else if m < self.main_green + YELLOW_S {
            LightState::Yellow
        } else {
            LightState::Red
        }
    }

    /// Light for the cross street at time `t`.
    pub fn cross_light(&self, t: f32) -> LightState {
        let m = (t + self.offset).rem_euclid(self.cycle());
        let start = self.main_green + YELLOW_S + ALL_RED_S;
        if m >= start && m < start + self.cross_green {
            LightState::Green
        } else if m >= start + self.cross_green && m < start + self.cross_green + YELLOW_S {
            LightState::Yellow
        } else {
            LightState::Red
        }
    }

    /// Chooses the offset so that the main road shows green over the whole interval
    /// `[t0, t1]`, lengthening the green phase if needed.
    pub fn force_main_green(&mut self, t0: f32, t1: f32) {
        self.main_green = self.main_green.max(t1 - t0 + 4.0);
        // Green starts 2 s before t0.
        self.offset = (-(t0 - 2.0)).rem_euclid(self.cycle());
    }
}

/// What the ground is at a Frenet point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GroundRegion {
    /// Asphalt of a carriageway (main road, parking strip, shoulder, cross street).
    Road,
    /// The kerb stones at the edge of the sidewalk.
    Kerb,
    /// Paved sidewalk or plaza.
    Sidewalk,
    /// Grass and soil beside a highway.
    Terrain,
}

/// Coverage of lane markings at a ground point, box-filtered over the pixel footprint.
#[derive(Debug, Clone, Copy, Default)]
pub struct Marking {
    /// White paint coverage in [0, 1].
    pub white: f32,
    /// Yellow paint coverage in [0, 1].
    pub yellow: f32,
}

/// The road: centreline, cross-section and intersections.
#[derive(Debug, Clone)]
pub struct Road {
    /// City street or highway.
    pub domain: Domain,
    /// The centreline.
    pub centerline: Centerline,
    /// Width of one lane (m).
    pub lane_width: f32,
    /// Lanes in each direction.
    pub lanes: u32,
    /// |d| of the inner edge of the innermost lane (half the median).
    pub inner: f32,
    /// Width of the parking strip beside the outer lane (city) or of the shoulder (highway).
    pub outer_strip: f32,
    /// |d| where the carriageway ends (kerb line in the city, edge of the shoulder on the
    /// highway).
    pub road_half: f32,
    /// Width of the sidewalk (city).
    pub sidewalk: f32,
    /// Height of the raised sidewalk above the road (city; 0 on the highway).
    pub kerb_height: f32,
    /// Intersections sorted by s (city only).
    pub intersections: Vec<Intersection>,
    /// For each 10 m bucket of s, the index of the nearest intersection.
    nearest: Vec<u16>,
    /// Phase of the dash patterns.
    dash_phase: f32,
}

/// Width of the kerb stones (m).
pub const KERB_WIDTH: f32 = 0.3;
/// Length of a zebra crossing along the road (m).
pub const CROSSWALK: f32 = 3.0;

impl Road {
    /// A city street: two lanes per direction, parking strips, kerbs, sidewalks and
    /// intersections every 90-170 m.
    pub fn city(rng: &mut Rng, s_start: f32, s_end: f32) -> Self {
        let centerline = Centerline::generate(rng, s_start, s_end, 1.0 / 350.0);
        let lane_width = 3.5;
        let inner = 0.2;
        let outer_strip = 2.4;
        let road_half = inner + 2.0 * lane_width + outer_strip;
        let mut intersections = Vec::new();
        let mut s = s_start + rng.range(60.0, 120.0);
        while s < s_end - 20.0 {
            let main_green = rng.range(15.0, 25.0);
            let cross_green = rng.range(5.0, 8.0);
            let mut x = Intersection {
                s,
                half_width: 3.5,
                main_green,
                cross_green,
                offset: 0.0,
            };
            x.offset = rng.range(0.0, x.cycle());
            intersections.push(x);
            s += rng.range(90.0, 170.0);
        }
        let mut road = Self {
            domain: Domain::City,
            centerline,
            lane_width,
            lanes: 2,
            inner,
            outer_strip,
            road_half,
            sidewalk: 4.5,
            kerb_height: 0.15,
            intersections,
            nearest: Vec::new(),
            dash_phase: rng.range(0.0, 9.0),
        };
        road.index_intersections();
        road
    }

    /// A highway: three lanes per direction, a median with a guard rail, shoulders, guard
    /// rails and terrain.
    pub fn highway(rng: &mut Rng, s_start: f32, s_end: f32) -> Self {
        let centerline = Centerline::generate(rng, s_start, s_end, 1.0 / 900.0);
        let lane_width = 3.75;
        let inner = 1.0;
        let outer_strip = 2.5;
        let mut road = Self {
            domain: Domain::Highway,
            centerline,
            lane_width,
            lanes: 3,
            inner,
            outer_strip,
            road_half: inner + 3.0 * lane_width + outer_strip,
            sidewalk: 0.0,
            kerb_height: 0.0,
            intersections: Vec::new(),
            nearest: Vec::new(),
            dash_phase: rng.range(0.0, 18.0),
        };
        road.index_intersections();
        road
    }

    /// Moves every intersection by `ds` along the road, dropping those that leave it.
    pub fn shift_intersections(&mut self, ds: f32) {
        let (s0, s1) = (self.centerline.s_start(), self.centerline.s_end());
        for x in &mut self.intersections {
            x.s += ds;
        }
        self.intersections
            .retain(|x| x.s > s0 + 20.0 && x.s < s1 - 20.0);
        self.index_intersections();
    }

    /// Rebuilds the nearest-intersection lookup after `intersections` changed.
    pub fn index_intersections(&mut self) {
        let s0 = self.centerline.s_start();
        let buckets = ((self.centerline.s_end() - s0) / 10.0).ceil() as usize + 1;
        self.nearest = (0..buckets)
            .map(|b| {
                let s = s0 + b as f32 * 10.0 + 5.0;
                let mut best = 0usize;
                let mut best_d = f32::INFINITY;
                for (i, x) in self.intersections.iter().enumerate() {
                    let d = (x.s - s).abs();
                    if d < best_d {
                        best_d = d;
                        best = i;
                    }
                }
                best as u16
            })
            .collect();
    }

    /// Centre d of lane `lane` (0 = innermost) for traffic moving forward (`forward`, on
    /// the right, d < 0) or in the opposite direction (d > 0).
    pub fn lane_center(&self, lane: u32, forward: bool) -> f32 {
        let m = self.inner + self.lane_width * (lane as f32 + 0.5);
        if forward { -m } else { m }
    }

    /// Centre d of the parking strip (city) on the right (`forward`) or left side.
    pub fn parking_center(&self, forward: bool) -> f32 {
        let m = self.inner + self.lane_width * self.lanes as f32 + 0.5 * self.outer_strip;
        if forward { -m } else { m }
    }

    /// The intersection nearest to `s`, if any.
    #[inline]
    pub fn nearest_intersection(&self, s: f32) -> Option<&Intersection> {
        if self.intersections.is_empty() {
            return None;
        }
        let b = super::math::floor((s - self.centerline.s_start()) / 10.0);
        let b = (b.max(0.0) as usize).min(self.nearest.len().saturating_sub(1));
        self.intersections.get(*self.nearest.get(b)? as usize)
    }

    /// Signed distance from the nearest cross street's centre line, and its half width.
    #[inline]
    fn cross_offset(&self, s: f32) -> (f32, f32) {
        match self.nearest_intersection(s) {
            Some(x) => (s - x.s, x.half_width),
            None => (f32::INFINITY, 0.0),
        }
    }

    /// Whether (s, d) lies on the raised sidewalk level (city only).
    #[inline]
    pub fn is_raised(&self, s: f32, d: f32) -> bool {
        if self.kerb_height <= 0.0 || d.abs() < self.road_half {
            return false;
        }
        let (ds, hw) = self.cross_offset(s);
        ds.abs() >= hw
    }

    /// The ground region at (s, d).
    pub fn region(&self, s: f32, d: f32) -> GroundRegion {
        let ad = d.abs();
        if ad < self.road_half {
            return GroundRegion::Road;
        }
        match self.domain {
            Domain::City => {
                let (ds, hw) = self.cross_offset(s);
                if ds.abs() < hw {
                    GroundRegion::Road
                } else if ad < self.road_half + KERB_WIDTH || ds.abs() < hw + KERB_WIDTH {
                    GroundRegion::Kerb
                } else {
                    GroundRegion::Sidewalk
                }
            }
            _ => GroundRegion::Terrain,
        }
    }

    /// Lane-marking coverage at (s, d) with footprints `fs` (along) and `fd` (across).
    pub fn marking(&self, s: f32, d: f32, fs: f32, fd: f32) -> Marking {
        match self.domain {
            Domain::City => self.city_marking(s, d, fs, fd),
            _ => self.highway_marking(s, d, fs, fd),
        }
    }

    fn city_marking(&self, s: f32, d: f32, fs: f32, fd: f32) -> Marking {
        let ad = d.abs();
        let (ds, hw) = self.cross_offset(s);
        let mut m = Marking::default();
        let lanes_edge = self.inner + self.lane_width * self.lanes as f32;
        if ad < self.road_half {
            let ads = ds.abs();
            if ads < hw {
                return m;
            }
            // Zebra crossings on both sides of the cross street.
            if ads < hw + 1.0 + CROSSWALK + 1.0 {
                let across = filtered_band(ads, hw + 1.0, hw + 1.0 + CROSSWALK, fs);
                if across > 0.0 {
                    m.white += across
                        * filtered_pulse(d + 0.25, 1.0, 0.5, fd)
                        * filtered_band(ad, 0.0, lanes_edge, fd);
                }
            }
            // Stop lines: before the crossing for traffic approaching on each side.
            let stop_at = hw + 1.0 + CROSSWALK + 0.6;
            let approach = if d < 0.0 { -ds } else { ds };
            let stop = filtered_band(approach, stop_at, stop_at + 0.4, fs)
                * filtered_band(ad, self.inner, lanes_edge, fd);
            m.white += stop;
            if ads < hw + 1.0 + CROSSWALK + 1.0 {
                return m;
            }
            // Double yellow centre line.
            m.yellow += filtered_band(ad, 0.06, 0.18, fd);
            // Dashed lane dividers.
            for k in 1..self.lanes {
                let c = self.inner + self.lane_width * k as f32;
                let line = filtered_band(ad, c - 0.06, c + 0.06, fd);
                if line > 0.0 {
                    m.white += line * filtered_pulse(s + self.dash_phase, 9.0, 3.0, fs);
                }
            }
            // Solid edge line between the outer lane and the parking strip.
            m.white += filtered_band(ad, lanes_edge - 0.16, lanes_edge, fd);
            // Parking bay ticks.
            let ticks = filtered_band(ad, lanes_edge, lanes_edge + 0.5, fd);
            if ticks > 0.0 {
                m.white += ticks * filtered_pulse(s + 0.5 * self.dash_phase, 6.0, 0.12, fs);
            }
        } else if ds.abs() < hw {
            // On the cross street: crossings where the sidewalks continue, and a dashed
            // centre line beyond them.
            let inner_edge = self.road_half + 0.8;
            let crossing = filtered_band(ad, inner_edge, inner_edge + CROSSWALK, fd);
            if crossing > 0.0 {
                m.white += crossing
                    * filtered_pulse(s + 0.25, 1.0, 0.5, fs)
                    * filtered_band(ds, -hw + 0.3, hw - 0.3, fs);
            }
            let beyond = inner_edge + CROSSWALK + 1.0;
            let centre = filtered_band(ds, -0.06, 0.06, fs);
            if centre > 0.0 {
                m.white += centre
                    * filtered_pulse(ad - beyond, 6.0, 2.0, fd)
                    * filtered_band(ad, beyond, 1.0e6, fd);
            }
        }
        m.white = m.white.min(1.0);
        m.yellow = m.yellow.min(1.0);
        m
    }

    fn highway_marking(&self, s: f32, d: f32, fs: f32, fd: f32) -> Marking {
        let ad = d.abs();
        let mut m = Marking::default();
        let edge = self.inner + self.lane_width * self.lanes as f32;
        m.white += filtered_band(ad, self.inner, self.inner + 0.2, fd);
        m.white += filtered_band(ad, edge - 0.2, edge, fd);
        for k in 1..self.lanes {
            let c = self.inner + self.lane_width * k as f32;
            let line = filtered_band(ad, c - 0.075, c + 0.075, fd);
            if line > 0.0 {
                m.white += line * filtered_pulse(s + self.dash_phase, 18.0, 6.0, fs);
            }
        }
        m.white = m.white.min(1.0);
        m
    }

    /// Outward normal (world, horizontal) of the kerb face crossed between two ground
    /// points, given the Frenet point on the raised side.
    pub fn kerb_normal(&self, s: f32, d: f32) -> V3 {
        let c = self.centerline.sample(s);
        let (ds, hw) = self.cross_offset(s);
        let lateral_gap = d.abs() - self.road_half;
        let cross_gap = ds.abs() - hw;
        if lateral_gap < cross_gap {
            // Face of the kerb along the main road, pointing towards the road centre.
            let sign = if d > 0.0 { -1.0 } else { 1.0 };
            V3::new(-c.ty * sign, c.tx * sign, 0.0)
        } else {
            let sign = if ds > 0.0 { -1.0 } else { 1.0 };
            V3::new(c.tx * sign, c.ty * sign, 0.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frenet_round_trip_on_a_curved_road() {
        let mut rng = Rng::new(5);
        let c = Centerline::generate(&mut rng, -100.0, 2000.0, 1.0 / 300.0);
        for i in 0..200 {
            let s = -50.0 + i as f32 * 9.7;
            for &d in &[-30.0f32, -5.0, 0.0, 3.3, 25.0] {
                let (x, y) = c.to_world(s, d);
                let (s2, d2) = c.to_frenet(x, y, s + 7.0);
                assert!((s2 - s).abs() < 2e-3, "s {s} -> {s2}");
                assert!((d2 - d).abs() < 2e-3, "d {d} -> {d2}");
            }
        }
    }

    #[test]
    fn light_cycle_has_exclusive_greens() {
        let x = Intersection {
            s: 0.0,
            half_width: 3.5,
            main_green: 20.0,
            cross_green: 10.0,
            offset: 3.0,
        };
        for i in 0..800 {
            let t = i as f32 * 0.1;
            let both = x.main_light(t) != LightState::Red && x.cross_light(t) != LightState::Red;
            assert!(!both, "conflicting lights at {t}");
        }
        let mut y = x.clone();
        y.force_main_green(40.0, 60.0);
        for i in 0..200 {
            assert_eq!(y.main_light(40.0 + i as f32 * 0.1), LightState::Green);
        }
    }
}
