//! Ray tests of static objects in object-local coordinates: boxes (slab test), cylinders,
//! ellipsoids and panels with their cut-outs (guard-rail posts, tree-line crowns).

use crate::synth::math::{V3, floor, wrap};
use crate::synth::rng::unit1;
use crate::synth::scenery::{Shape, StaticKind, StaticObject};
use crate::synth::texture::value2;

/// Slab test of an axis-aligned box: (t, face normal).
#[inline]
fn slab(o: V3, d: V3, lo: V3, hi: V3, t_max: f32) -> Option<(f32, V3)> {
    let mut t0 = 1e-4f32;
    let mut t1 = t_max;
    let mut n = V3::default();
    for axis in 0..3 {
        let (oa, da, la, ha) = match axis {
            0 => (o.x, d.x, lo.x, hi.x),
            1 => (o.y, d.y, lo.y, hi.y),
            _ => (o.z, d.z, lo.z, hi.z),
        };
        if da.abs() < 1e-12 {
            if oa < la || oa > ha {
                return None;
            }
            continue;
        }
        let inv = 1.0 / da;
        let (mut ta, mut tb) = ((la - oa) * inv, (ha - oa) * inv);
        let mut sign = -1.0;
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
            sign = 1.0;
        }
        if ta > t0 {
            t0 = ta;
            n = match axis {
                0 => V3::new(sign, 0.0, 0.0),
                1 => V3::new(0.0, sign, 0.0),
                _ => V3::new(0.0, 0.0, sign),
            };
        }
        t1 = t1.min(tb);
        if t0 > t1 {
            return None;
        }
    }
    if n == V3::default() {
        None
    } else {
        Some((t0, n))
    }
}

/// Ray-static-object intersection in object-local coordinates; a panel is only hit within
/// `x_range`.
pub fn intersect_static(
    obj: &StaticObject,
    x_range: (f32, f32),
    o: V3,
    d: V3,
    t_max: f32,
) -> Option<(f32, u8, V3)> {
    match obj.shape {
        Shape::Box { hx, hy, z0, z1 } => {
            slab(o, d, V3::new(-hx, -hy, z0), V3::new(hx, hy, z1), t_max).map(|(t, n)| (t, 0, n))
        }
        Shape::Cylinder { r, z0, z1 } => {
            let a = d.x * d.x + d.y * d.y;
            if a > 1e-12 {
                let b = o.x * d.x + o.y * d.y;
                let c = o.x * o.x + o.y * o.y - r * r;
                let disc = b * b - a * c;
                if disc >= 0.0 {
                    let t = (-b - disc.sqrt()) / a;
                    let z = o.z + t * d.z;
                    if t > 1e-4 && t < t_max && z >= z0 && z <= z1 {
                        let p = o + d * t;
                        return Some((t, 0, V3::new(p.x / r, p.y / r, 0.0)));
                    }
                }
            }
            if d.z < 0.0 {
                let t = (z1 - o.z) / d.z;
                let p = o + d * t;
                if t > 1e-4 && t < t_max && p.x * p.x + p.y * p.y <= r * r {
                    return Some((t, 0, V3::new(0.0, 0.0, 1.0)));
                }
            }
            None
        }
        Shape::Ellipsoid { rx, ry, rz, zc } => {
            let os = V3::new(o.x / rx, o.y / ry, (o.z - zc) / rz);
            let ds = V3::new(d.x / rx, d.y / ry, d.z / rz);
            let a = ds.dot(ds);
            let b = os.dot(ds);
            let c = os.dot(os) - 1.0;
            let disc = b * b - a * c;
            if disc < 0.0 {
                return None;
            }
            let t = (-b - disc.sqrt()) / a;
            if t <= 1e-4 || t >= t_max {
                return None;
            }
            let p = o + d * t;
            let n = V3::new(p.x / (rx * rx), p.y / (ry * ry), (p.z - zc) / (rz * rz)).normalized();
            Some((t, 0, n))
        }
        Shape::Panel { h, .. } => {
            if d.y.abs() < 1e-9 {
                return None;
            }
            let t = -o.y / d.y;
            if t <= 1e-4 || t >= t_max {
                return None;
            }
            let x = o.x + t * d.x;
            let z = o.z + t * d.z;
            if x < x_range.0 || x > x_range.1 || z < 0.0 || z > h {
                return None;
            }
            if !panel_solid(obj, x, z) {
                return None;
            }
            Some((t, 0, V3::new(0.0, -d.y.signum(), 0.0)))
        }
    }
}

/// Cut-outs of panels: gaps between guard-rail posts, the ragged top of tree lines.
#[inline]
pub fn panel_solid(obj: &StaticObject, x: f32, z: f32) -> bool {
    match obj.kind {
        StaticKind::GuardRail => z >= 0.42 || wrap(x + 40.0, 2.0) < 0.14,
        StaticKind::TreeLine => {
            let Shape::Panel { h, .. } = obj.shape else {
                return true;
            };
            // A row of crowns: rounded bumps on every 3.5 m with random heights, on top of a
            // slowly varying canopy height.
            let salt = obj.salt;
            let canopy = h * (0.6 + 0.4 * value2(x / 9.0, 0.0, salt));
            let cell = floor(x / 3.5);
            let mut top: f32 = 0.0;
            for k in [cell - 1.0, cell, cell + 1.0] {
                let jitter = unit1(k as i32, salt);
                let centre = (k + 0.5 + 0.6 * (jitter - 0.5)) * 3.5;
                let radius = 2.2 + 1.2 * jitter;
                let dx = (x - centre) / radius;
                if dx.abs() < 1.0 {
                    let crown =
                        canopy * (0.8 + 0.25 * jitter) + radius * (1.0 - dx * dx).sqrt() - radius;
                    top = top.max(crown);
                }
            }
            z < top
        }
        _ => true,
    }
}
