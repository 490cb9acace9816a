//! Ray tests of vehicles in vehicle-local coordinates: a bounding-box test, then the convex
//! parts and the wheels. The terms that depend on the ray origin alone are computed once
//! per frame and vehicle for camera rays ([`VehicleEye`]).

use super::hit::WHEEL_PART;
use crate::synth::math::V3;
use crate::synth::vehicle::{Convex, MAX_PLANES, Plane, VehicleModel, Wheel};

/// Ray-vehicle intersection in vehicle-local coordinates: (t, part, local normal).
pub fn intersect_vehicle(m: &VehicleModel, o: V3, d: V3, t_max: f32) -> Option<(f32, u8, V3)> {
    vehicle_hit(m, &o, d, t_max)
}

/// [`intersect_vehicle`] for a ray from the origin of `eye`, with the same result.
pub fn intersect_vehicle_from(
    m: &VehicleModel,
    eye: &VehicleEye,
    d: V3,
    t_max: f32,
) -> Option<(f32, u8, V3)> {
    vehicle_hit(m, eye, d, t_max)
}

/// The terms of a vehicle's ray tests that depend on the ray origin alone. Every camera ray
/// of a frame starts at the camera, so [`VehicleEye`] computes them once per frame and
/// vehicle; any other origin ([`V3`]) computes them as the tests need them. Both evaluate the
/// same expressions, so the hits agree bit for bit.
trait RayOrigin {
    /// Corners of the box `[lo, hi]` relative to the origin.
    fn box_from(&self, lo: V3, hi: V3) -> (V3, V3);
    /// [`RayOrigin::box_from`] of the bounds of part `k`.
    fn part_box(&self, k: usize, part: &Convex) -> (V3, V3);
    /// `p.d - p.n · o` of plane `i` of part `k`.
    fn plane_dist(&self, k: usize, i: usize, p: &Plane) -> f32;
    /// [`RayOrigin::box_from`] of the box around wheel `k`.
    fn wheel_box(&self, k: usize, w: &Wheel) -> (V3, V3);
    /// The origin seen from wheel `k`.
    fn wheel(&self, k: usize, w: &Wheel) -> WheelEye;
}

/// The box around a wheel.
#[inline]
fn wheel_bounds(w: &Wheel) -> (V3, V3) {
    (
        V3::new(w.x - w.r, w.y0, 0.0),
        V3::new(w.x + w.r, w.y1, 2.0 * w.r),
    )
}

impl RayOrigin for V3 {
    #[inline]
    fn box_from(&self, lo: V3, hi: V3) -> (V3, V3) {
        (lo - *self, hi - *self)
    }

    #[inline]
    fn part_box(&self, _: usize, part: &Convex) -> (V3, V3) {
        self.box_from(part.lo, part.hi)
    }

    #[inline]
    fn plane_dist(&self, _: usize, _: usize, p: &Plane) -> f32 {
        p.d - p.n.dot(*self)
    }

    #[inline]
    fn wheel_box(&self, _: usize, w: &Wheel) -> (V3, V3) {
        let (lo, hi) = wheel_bounds(w);
        self.box_from(lo, hi)
    }

    #[inline]
    fn wheel(&self, _: usize, w: &Wheel) -> WheelEye {
        let ox = self.x - w.x;
        let oz = self.z - w.r;
        let outer = if w.y0 > 0.0 { w.y1 } else { w.y0 };
        WheelEye {
            ox,
            oy: self.y,
            oz,
            c: ox * ox + oz * oz - w.r * w.r,
            outer,
            outer_dist: outer - self.y,
        }
    }
}

/// The origin-dependent terms of a vehicle's ray tests for one origin (see [`RayOrigin`]).
#[derive(Debug, Clone, Default)]
pub struct VehicleEye {
    /// The origin, vehicle-local.
    o: V3,
    /// Per part: its bounds relative to the origin and the origin's distance inside each
    /// of its planes.
    parts: Vec<PartEye>,
    /// Per wheel: its box relative to the origin and the origin seen from the wheel.
    wheels: Vec<((V3, V3), WheelEye)>,
}

/// [`VehicleEye`] of one convex part.
#[derive(Debug, Clone, Copy)]
struct PartEye {
    bounds: (V3, V3),
    dist: [f32; MAX_PLANES],
}

/// A ray origin relative to a wheel: the terms of [`intersect_wheel`] that do not depend on
/// the direction.
#[derive(Debug, Clone, Copy, Default)]
struct WheelEye {
    /// Origin x relative to the axle.
    ox: f32,
    /// Origin y.
    oy: f32,
    /// Origin z relative to the axle.
    oz: f32,
    /// `ox² + oz² - r²`.
    c: f32,
    /// y of the outer side wall.
    outer: f32,
    /// `outer - oy`.
    outer_dist: f32,
}

impl VehicleEye {
    /// The terms of every ray test of `m` for rays from the vehicle-local point `o`.
    pub fn new(m: &VehicleModel, o: V3) -> Self {
        let parts = m
            .parts
            .iter()
            .enumerate()
            .map(|(k, part)| {
                let mut dist = [0.0; MAX_PLANES];
                for (i, (d, p)) in dist.iter_mut().zip(&part.planes).enumerate() {
                    *d = o.plane_dist(k, i, p);
                }
                PartEye {
                    bounds: o.part_box(k, part),
                    dist,
                }
            })
            .collect();
        let wheels = m
            .wheels
            .iter()
            .enumerate()
            .map(|(k, w)| (o.wheel_box(k, w), o.wheel(k, w)))
            .collect();
        Self { o, parts, wheels }
    }
}

impl RayOrigin for VehicleEye {
    #[inline]
    fn box_from(&self, lo: V3, hi: V3) -> (V3, V3) {
        self.o.box_from(lo, hi)
    }

    #[inline]
    fn part_box(&self, k: usize, _: &Convex) -> (V3, V3) {
        self.parts[k].bounds
    }

    #[inline]
    fn plane_dist(&self, k: usize, i: usize, _: &Plane) -> f32 {
        self.parts[k].dist[i]
    }

    #[inline]
    fn wheel_box(&self, k: usize, _: &Wheel) -> (V3, V3) {
        self.wheels[k].0
    }

    #[inline]
    fn wheel(&self, k: usize, _: &Wheel) -> WheelEye {
        self.wheels[k].1
    }
}

#[inline]
fn vehicle_hit(m: &VehicleModel, o: &impl RayOrigin, d: V3, t_max: f32) -> Option<(f32, u8, V3)> {
    let inv = V3::new(1.0 / d.x, 1.0 / d.y, 1.0 / d.z);
    // With every component of `inv` finite no product in the box test is NaN, and plain
    // comparisons answer exactly as `f32::min`/`max` do, at a fraction of their cost.
    let finite = inv.x.is_finite() && inv.y.is_finite() && inv.z.is_finite();
    let overlap = |(lo, hi): (V3, V3), t_max: f32| {
        if finite {
            overlaps_finite(inv, lo, hi, t_max)
        } else {
            overlaps(inv, lo, hi, t_max)
        }
    };
    let (lo, hi) = m.bounds();
    if !overlap(o.box_from(lo, hi), t_max) {
        return None;
    }
    let mut best: Option<(f32, u8, V3)> = None;
    let mut limit = t_max;
    for (k, part) in m.parts.iter().enumerate() {
        if !overlap(o.part_box(k, part), limit) {
            continue;
        }
        if let Some((t, plane)) = part.intersect_at(|i, p| o.plane_dist(k, i, p), d, 1e-4, limit) {
            limit = t;
            best = Some((t, k as u8, part.planes[plane as usize].n));
        }
    }
    for (k, w) in m.wheels.iter().enumerate() {
        if !overlap(o.wheel_box(k, w), limit) {
            continue;
        }
        if let Some((t, n)) = intersect_wheel(w, &o.wheel(k, w), d, limit) {
            limit = t;
            best = Some((t, WHEEL_PART + k as u8, n));
        }
    }
    best
}

/// Whether the ray `o + t·d` (with `inv` = 1/d componentwise) passes through the box
/// `[o + lo, o + hi]` for some `t` in `(0, t_max)` (`lo`, `hi` relative to the origin).
#[inline]
fn overlaps(inv: V3, lo: V3, hi: V3, t_max: f32) -> bool {
    let (ax, bx) = (lo.x * inv.x, hi.x * inv.x);
    let (ay, by) = (lo.y * inv.y, hi.y * inv.y);
    let (az, bz) = (lo.z * inv.z, hi.z * inv.z);
    // min/max that also behave when a component of d is zero (infinite inv): a NaN from
    // 0·inf makes the comparison fail towards "overlap", which only costs a precise test.
    let t0 = ax.min(bx).max(ay.min(by)).max(az.min(bz)).max(0.0);
    let t1 = ax.max(bx).min(ay.max(by)).min(az.max(bz)).min(t_max);
    t0 <= t1
}

/// [`overlaps`] for a finite `inv`, where no NaN can arise: plain comparisons (one
/// instruction each) instead of `f32::min`/`max`, whose NaN handling costs several. Where
/// they differ, on the sign of a zero, the answer is the same.
#[inline]
fn overlaps_finite(inv: V3, lo: V3, hi: V3, t_max: f32) -> bool {
    #[inline]
    fn min(a: f32, b: f32) -> f32 {
        if a < b { a } else { b }
    }
    #[inline]
    fn max(a: f32, b: f32) -> f32 {
        if a > b { a } else { b }
    }
    let (ax, bx) = (lo.x * inv.x, hi.x * inv.x);
    let (ay, by) = (lo.y * inv.y, hi.y * inv.y);
    let (az, bz) = (lo.z * inv.z, hi.z * inv.z);
    let t0 = max(max(max(min(ax, bx), min(ay, by)), min(az, bz)), 0.0);
    let t1 = min(min(min(max(ax, bx), max(ay, by)), max(az, bz)), t_max);
    t0 <= t1
}

fn intersect_wheel(w: &Wheel, o: &WheelEye, d: V3, t_max: f32) -> Option<(f32, V3)> {
    let mut best: Option<(f32, V3)> = None;
    let a = d.x * d.x + d.z * d.z;
    if a > 1e-12 {
        let b = o.ox * d.x + o.oz * d.z;
        let disc = b * b - a * o.c;
        if disc >= 0.0 {
            let t = (-b - disc.sqrt()) / a;
            let y = o.oy + t * d.y;
            if t > 1e-4 && t < t_max && y >= w.y0 && y <= w.y1 {
                let px = o.ox + t * d.x;
                let pz = o.oz + t * d.z;
                best = Some((t, V3::new(px / w.r, 0.0, pz / w.r)));
            }
        }
    }
    // The outer side wall.
    let outer = o.outer;
    if d.y.abs() > 1e-9 {
        let t = o.outer_dist / d.y;
        let px = o.ox + t * d.x;
        let pz = o.oz + t * d.z;
        let facing = (outer > 0.0 && d.y < 0.0) || (outer < 0.0 && d.y > 0.0);
        if facing && t > 1e-4 && t < best.map_or(t_max, |b| b.0) && px * px + pz * pz <= w.r * w.r {
            best = Some((t, V3::new(0.0, outer.signum(), 0.0)));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;

    #[test]
    fn finite_box_test_answers_as_the_nan_tolerant_one() {
        let mut rng = Rng::new(3);
        let mut v = |a: f32, b: f32| V3::new(rng.range(a, b), rng.range(a, b), rng.range(a, b));
        let mut hits = 0;
        for _ in 0..100_000 {
            let (o, p, q) = (v(-6.0, 6.0), v(-3.0, 3.0), v(-3.0, 3.0));
            let (lo, hi) = (
                V3::new(p.x.min(q.x), p.y.min(q.y), p.z.min(q.z)),
                V3::new(p.x.max(q.x), p.y.max(q.y), p.z.max(q.z)),
            );
            // Rays roughly towards the box, ending before or after it.
            let d = (lo + hi) * 0.5 - o + v(-2.0, 2.0);
            let t_max = v(0.2, 1.5).x;
            let inv = V3::new(1.0 / d.x, 1.0 / d.y, 1.0 / d.z);
            let (lo, hi) = (lo - o, hi - o);
            let slow = overlaps(inv, lo, hi, t_max);
            assert_eq!(overlaps_finite(inv, lo, hi, t_max), slow, "{o:?} {d:?}");
            hits += usize::from(slow);
        }
        // Both answers occur often.
        assert!((20_000..80_000).contains(&hits), "{hits}");
    }
}
