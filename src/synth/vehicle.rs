//! Vehicle bodies: several body types (sedan, hatchback, SUV, van, truck, bus) built from a
//! few convex parts and wheels in the vehicle's local frame (x forward, y left, z up, origin
//! at the centre of the footprint on the ground), plus their paint colours.

use super::math::{Rgb, V3};
use super::rng::Rng;

/// Maximum number of bounding planes of one convex part.
pub const MAX_PLANES: usize = 16;

/// A half-space `n · p <= d`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Plane {
    /// Outward unit normal.
    pub n: V3,
    /// Offset.
    pub d: f32,
}

/// What surface a convex part carries, which decides its texture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartKind {
    /// Painted lower body with lights, plate, bumpers, doors.
    Body,
    /// Glasshouse of a car: windows with painted pillars and roof.
    Cabin,
    /// Truck cab: painted with windscreen and side windows in the upper part.
    Cab,
    /// Truck cargo box with rear doors.
    Cargo,
    /// Dark chassis and rear bumper of a truck (carries the tail lights).
    Chassis,
    /// Bus body: window band, doors, rear window.
    BusBody,
}

/// A convex polyhedron given by up to [`MAX_PLANES`] half-spaces.
#[derive(Debug, Clone, Copy)]
pub struct Convex {
    /// Bounding planes; the first `count` are used.
    pub planes: [Plane; MAX_PLANES],
    /// Number of planes used.
    pub count: u8,
    /// Surface kind.
    pub kind: PartKind,
    /// Axis-aligned bounds (the box the part was cut from), for a quick rejection.
    pub lo: V3,
    /// Upper corner of the bounds.
    pub hi: V3,
}

impl Convex {
    /// An axis-aligned box.
    pub fn cuboid(min: V3, max: V3, kind: PartKind) -> Self {
        let mut c = Convex {
            planes: [Plane::default(); MAX_PLANES],
            count: 0,
            kind,
            lo: min,
            hi: max,
        };
        c.cut(V3::new(1.0, 0.0, 0.0), max);
        c.cut(V3::new(-1.0, 0.0, 0.0), min);
        c.cut(V3::new(0.0, 1.0, 0.0), max);
        c.cut(V3::new(0.0, -1.0, 0.0), min);
        c.cut(V3::new(0.0, 0.0, 1.0), max);
        c.cut(V3::new(0.0, 0.0, -1.0), min);
        c
    }

    /// Adds the half-space with outward direction `n` whose boundary passes through `p`.
    pub fn cut(&mut self, n: V3, p: V3) -> &mut Self {
        let n = n.normalized();
        if (self.count as usize) < MAX_PLANES {
            self.planes[self.count as usize] = Plane { n, d: n.dot(p) };
            self.count += 1;
        }
        self
    }

    /// Adds a cut mirrored in y as well (for left-right symmetric chamfers).
    pub fn cut_sym(&mut self, n: V3, p: V3) -> &mut Self {
        self.cut(n, p);
        self.cut(V3::new(n.x, -n.y, n.z), V3::new(p.x, -p.y, p.z))
    }

    /// Ray entry into the part: returns (t, index of the entry plane) for the ray
    /// `o + t·dir` with `t` in `(t_min, t_max)`.
    #[inline]
    pub fn intersect(&self, o: V3, dir: V3, t_min: f32, t_max: f32) -> Option<(f32, u8)> {
        self.intersect_at(|_, p| p.d - p.n.dot(o), dir, t_min, t_max)
    }

    /// [`Convex::intersect`] with the ray origin given by `dist(i, plane)`, the signed
    /// distance `plane.d - plane.n · o` of the origin inside plane `i` (which a caller that
    /// casts many rays from one origin computes once).
    #[inline]
    pub fn intersect_at(
        &self,
        dist: impl Fn(usize, &Plane) -> f32,
        dir: V3,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, u8)> {
        let mut t0 = t_min;
        let mut t1 = t_max;
        let mut entry = u8::MAX;
        for (i, p) in self.planes[..self.count as usize].iter().enumerate() {
            let denom = p.n.dot(dir);
            let dist = dist(i, p);
            if denom.abs() < 1e-12 {
                if dist < 0.0 {
                    return None;
                }
                continue;
            }
            let t = dist / denom;
            if denom < 0.0 {
                if t > t0 {
                    t0 = t;
                    entry = i as u8;
                }
            } else if t < t1 {
                t1 = t;
            }
            if t0 > t1 {
                return None;
            }
        }
        if entry == u8::MAX {
            None
        } else {
            Some((t0, entry))
        }
    }
}

/// A wheel: a cylinder whose axis is the local y axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wheel {
    /// Axle position along x.
    pub x: f32,
    /// Radius (the axle height).
    pub r: f32,
    /// Inner and outer y of the tyre (y0 < y1).
    pub y0: f32,
    /// Outer y.
    pub y1: f32,
}

/// Body type of a vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BodyType {
    /// Saloon car.
    Sedan,
    /// Short car with a steep tailgate.
    Hatchback,
    /// Tall car.
    Suv,
    /// Delivery van.
    Van,
    /// Box truck.
    Truck,
    /// City or coach bus.
    Bus,
}

impl BodyType {
    /// The CARLA semantic tag: 14 car, 15 truck, 16 bus.
    pub fn tag(self) -> u8 {
        match self {
            BodyType::Truck => 15,
            BodyType::Bus => 16,
            _ => 14,
        }
    }

    /// A CARLA-like blueprint name, for the ACTION/ANOMALY `vehicle_type_id`.
    pub fn blueprint(self) -> &'static str {
        match self {
            BodyType::Sedan => "vehicle.synth.sedan",
            BodyType::Hatchback => "vehicle.synth.hatchback",
            BodyType::Suv => "vehicle.synth.suv",
            BodyType::Van => "vehicle.synth.van",
            BodyType::Truck => "vehicle.synth.truck",
            BodyType::Bus => "vehicle.synth.bus",
        }
    }

    /// Whether this is a passenger car (the only type AnoVox uses for the braking lead).
    pub fn is_car(self) -> bool {
        matches!(self, BodyType::Sedan | BodyType::Hatchback | BodyType::Suv)
    }
}

/// A rectangle on a face of the body, `[y0, y1] × [z0, z1]` (mirrored to both sides).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LampRect {
    /// Inner |y|.
    pub y0: f32,
    /// Outer |y|.
    pub y1: f32,
    /// Bottom.
    pub z0: f32,
    /// Top.
    pub z1: f32,
}

/// The full geometric model of one vehicle.
#[derive(Debug, Clone)]
pub struct VehicleModel {
    /// Body type.
    pub body: BodyType,
    /// Length (m).
    pub length: f32,
    /// Width (m).
    pub width: f32,
    /// Height (m).
    pub height: f32,
    /// Convex parts.
    pub parts: Vec<Convex>,
    /// Wheels.
    pub wheels: Vec<Wheel>,
    /// Paint colour (linear).
    pub paint: Rgb,
    /// Tail/brake lights on the rear face.
    pub tail: LampRect,
    /// Headlights on the front face.
    pub head: LampRect,
    /// x of the rear face carrying the tail lights.
    pub rear_x: f32,
    /// x of the front face carrying the headlights.
    pub front_x: f32,
}

impl VehicleModel {
    /// Local bounding box `(min, max)`.
    pub fn bounds(&self) -> (V3, V3) {
        (
            V3::new(-0.5 * self.length - 0.05, -0.5 * self.width - 0.05, 0.0),
            V3::new(
                0.5 * self.length + 0.05,
                0.5 * self.width + 0.05,
                self.height + 0.05,
            ),
        )
    }

    /// Builds a vehicle of body type `body` with dimensions and paint drawn from `rng`.
    pub fn new(body: BodyType, rng: &mut Rng) -> Self {
        match body {
            BodyType::Sedan | BodyType::Hatchback | BodyType::Suv => car(body, rng),
            BodyType::Van => van(rng),
            BodyType::Truck => truck(rng),
            BodyType::Bus => bus(rng),
        }
    }
}

/// Common car paints (linear RGB) with rough real-world frequencies.
const CAR_PAINTS: [([f32; 3], f32); 12] = [
    ([0.70, 0.70, 0.69], 0.22),    // white
    ([0.015, 0.015, 0.017], 0.18), // black
    ([0.38, 0.39, 0.40], 0.15),    // silver
    ([0.11, 0.11, 0.115], 0.12),   // dark grey
    ([0.02, 0.035, 0.11], 0.07),   // dark blue
    ([0.40, 0.025, 0.02], 0.07),   // red
    ([0.05, 0.14, 0.42], 0.05),    // blue
    ([0.03, 0.10, 0.05], 0.03),    // green
    ([0.42, 0.34, 0.22], 0.04),    // beige
    ([0.60, 0.42, 0.03], 0.02),    // yellow
    ([0.55, 0.16, 0.02], 0.02),    // orange
    ([0.18, 0.05, 0.07], 0.03),    // burgundy
];

fn pick_paint(rng: &mut Rng) -> Rgb {
    let mut u = rng.unit();
    for (c, w) in CAR_PAINTS {
        if u < w {
            return Rgb::new(c[0], c[1], c[2]);
        }
        u -= w;
    }
    Rgb::new(0.7, 0.7, 0.69)
}

fn car(body: BodyType, rng: &mut Rng) -> VehicleModel {
    let (length, width, height, belt, clearance) = match body {
        BodyType::Hatchback => (
            rng.range(3.9, 4.3),
            rng.range(1.72, 1.8),
            rng.range(1.42, 1.52),
            0.92,
            0.28,
        ),
        BodyType::Suv => (
            rng.range(4.5, 4.9),
            rng.range(1.85, 1.95),
            rng.range(1.65, 1.8),
            1.05,
            0.38,
        ),
        _ => (
            rng.range(4.5, 4.95),
            rng.range(1.78, 1.88),
            rng.range(1.40, 1.48),
            0.90,
            0.28,
        ),
    };
    let hl = 0.5 * length;
    let hw = 0.5 * width;
    let mut lower = Convex::cuboid(
        V3::new(-hl, -hw, clearance),
        V3::new(hl, hw, belt),
        PartKind::Body,
    );
    // Sloping bonnet front and boot lid, rounded corners, tumblehome and bumper undercuts.
    lower
        .cut(V3::new(0.45, 0.0, 1.0), V3::new(hl - 0.35, 0.0, belt))
        .cut(V3::new(-0.9, 0.0, 1.0), V3::new(-hl + 0.18, 0.0, belt))
        .cut_sym(V3::new(1.0, 1.0, 0.0), V3::new(hl - 0.22, hw, 0.0))
        .cut_sym(V3::new(-1.0, 1.0, 0.0), V3::new(-hl + 0.16, hw, 0.0))
        .cut_sym(V3::new(0.0, 1.0, 1.4), V3::new(0.0, hw, belt - 0.08))
        .cut(V3::new(1.0, 0.0, -1.2), V3::new(hl, 0.0, clearance + 0.12))
        .cut(V3::new(-1.0, 0.0, -1.2), V3::new(-hl, 0.0, clearance + 0.1));
    let (front_base, front_top, rear_base, rear_top) = match body {
        BodyType::Hatchback => (hl - 1.15, hl - 1.95, -hl + 0.12, -hl + 0.35),
        BodyType::Suv => (hl - 1.25, hl - 1.95, -hl + 0.1, -hl + 0.25),
        _ => (hl - 1.35, hl - 2.2, -hl + 0.95, -hl + 1.55),
    };
    let top = height;
    let cabin_w = hw - 0.07;
    let mut cabin = Convex::cuboid(
        V3::new(rear_base, -cabin_w, belt - 0.02),
        V3::new(front_base, cabin_w, top),
        PartKind::Cabin,
    );
    let rise = top - belt;
    cabin
        .cut(
            V3::new(rise, 0.0, front_base - front_top),
            V3::new(front_base, 0.0, belt),
        )
        .cut(
            V3::new(-rise, 0.0, rear_top - rear_base),
            V3::new(rear_base, 0.0, belt),
        )
        .cut_sym(V3::new(0.0, 1.0, 0.32), V3::new(0.0, cabin_w, belt));
    let wheelbase = length * rng.range(0.58, 0.62);
    let r = if body == BodyType::Suv { 0.37 } else { 0.32 };
    let wheels = wheels_at(&[0.5 * wheelbase, -0.5 * wheelbase], r, hw);
    VehicleModel {
        body,
        length,
        width,
        height,
        parts: vec![lower, cabin],
        wheels,
        paint: pick_paint(rng),
        tail: LampRect {
            y0: hw - 0.45,
            y1: hw - 0.1,
            z0: belt - 0.25,
            z1: belt - 0.08,
        },
        head: LampRect {
            y0: hw - 0.5,
            y1: hw - 0.14,
            z0: clearance + 0.32,
            z1: clearance + 0.46,
        },
        rear_x: -hl,
        front_x: hl,
    }
}

fn wheels_at(axles: &[f32], r: f32, hw: f32) -> Vec<Wheel> {
    let mut out = Vec::new();
    for &x in axles {
        out.push(Wheel {
            x,
            r,
            y0: hw - 0.26,
            y1: hw - 0.03,
        });
        out.push(Wheel {
            x,
            r,
            y0: -hw + 0.03,
            y1: -hw + 0.26,
        });
    }
    out
}

fn van(rng: &mut Rng) -> VehicleModel {
    let length = rng.range(4.9, 5.6);
    let width = rng.range(1.95, 2.05);
    let height = rng.range(1.95, 2.3);
    let hl = 0.5 * length;
    let hw = 0.5 * width;
    let belt = 1.05;
    let mut lower = Convex::cuboid(
        V3::new(-hl, -hw, 0.33),
        V3::new(hl, hw, belt),
        PartKind::Body,
    );
    lower
        .cut(V3::new(0.6, 0.0, 1.0), V3::new(hl - 0.45, 0.0, belt))
        .cut_sym(V3::new(1.0, 1.0, 0.0), V3::new(hl - 0.2, hw, 0.0))
        .cut_sym(V3::new(-1.0, 1.0, 0.0), V3::new(-hl + 0.08, hw, 0.0))
        .cut(V3::new(1.0, 0.0, -1.0), V3::new(hl, 0.0, 0.45));
    let front_base = hl - 0.75;
    let mut upper = Convex::cuboid(
        V3::new(-hl, -hw + 0.02, belt - 0.02),
        V3::new(front_base, hw - 0.02, height),
        PartKind::Cabin,
    );
    upper
        .cut(
            V3::new(height - belt, 0.0, 0.75),
            V3::new(front_base, 0.0, belt),
        )
        .cut_sym(V3::new(0.0, 1.0, 0.12), V3::new(0.0, hw - 0.02, belt))
        .cut(V3::new(-0.3, 0.0, 1.0), V3::new(-hl + 0.1, 0.0, height));
    let wheelbase = length * 0.6;
    VehicleModel {
        body: BodyType::Van,
        length,
        width,
        height,
        parts: vec![lower, upper],
        wheels: wheels_at(&[0.5 * wheelbase, -0.5 * wheelbase], 0.35, hw),
        paint: if rng.chance(0.6) {
            Rgb::new(0.72, 0.72, 0.71)
        } else {
            pick_paint(rng)
        },
        tail: LampRect {
            y0: hw - 0.22,
            y1: hw - 0.04,
            z0: 0.7,
            z1: 1.25,
        },
        head: LampRect {
            y0: hw - 0.5,
            y1: hw - 0.15,
            z0: 0.75,
            z1: 0.9,
        },
        rear_x: -hl,
        front_x: hl,
    }
}

fn truck(rng: &mut Rng) -> VehicleModel {
    let length = rng.range(7.5, 10.0);
    let width = 2.5;
    let height = rng.range(3.4, 3.9);
    let hl = 0.5 * length;
    let hw = 0.5 * width;
    let cab_len = 2.3;
    let mut cab = Convex::cuboid(
        V3::new(hl - cab_len, -hw + 0.02, 0.6),
        V3::new(hl, hw - 0.02, 3.0),
        PartKind::Cab,
    );
    cab.cut(V3::new(1.0, 0.0, 0.5), V3::new(hl - 0.25, 0.0, 3.0))
        .cut_sym(V3::new(1.0, 1.0, 0.0), V3::new(hl - 0.12, hw - 0.02, 0.0));
    let cargo = Convex::cuboid(
        V3::new(-hl, -hw, 1.05),
        V3::new(hl - cab_len - 0.15, hw, height),
        PartKind::Cargo,
    );
    let chassis = Convex::cuboid(
        V3::new(-hl + 0.05, -hw + 0.25, 0.55),
        V3::new(hl - 0.3, hw - 0.25, 1.05),
        PartKind::Chassis,
    );
    let bumper = Convex::cuboid(
        V3::new(-hl - 0.05, -hw + 0.05, 0.5),
        V3::new(-hl + 0.1, hw - 0.05, 0.72),
        PartKind::Chassis,
    );
    let r = 0.5;
    let wheels = wheels_at(&[hl - 1.3, -hl + 2.9, -hl + 1.6], r, hw);
    let cargo_colours = [
        Rgb::new(0.75, 0.75, 0.74),
        Rgb::new(0.62, 0.62, 0.6),
        Rgb::new(0.05, 0.12, 0.35),
        Rgb::new(0.45, 0.05, 0.03),
        Rgb::new(0.08, 0.2, 0.08),
    ];
    VehicleModel {
        body: BodyType::Truck,
        length,
        width,
        height,
        parts: vec![cab, cargo, chassis, bumper],
        wheels,
        paint: *rng.pick(&cargo_colours).unwrap_or(&cargo_colours[0]),
        tail: LampRect {
            y0: hw - 0.5,
            y1: hw - 0.12,
            z0: 0.53,
            z1: 0.69,
        },
        head: LampRect {
            y0: hw - 0.55,
            y1: hw - 0.2,
            z0: 0.85,
            z1: 1.05,
        },
        rear_x: -hl - 0.05,
        front_x: hl,
    }
}

fn bus(rng: &mut Rng) -> VehicleModel {
    let length = rng.range(11.0, 12.5);
    let width = 2.55;
    let height = rng.range(3.0, 3.3);
    let hl = 0.5 * length;
    let hw = 0.5 * width;
    let mut body = Convex::cuboid(
        V3::new(-hl, -hw, 0.32),
        V3::new(hl, hw, height),
        PartKind::BusBody,
    );
    body.cut_sym(V3::new(0.0, 1.0, 1.0), V3::new(0.0, hw, height - 0.12))
        .cut(V3::new(1.0, 0.0, 1.0), V3::new(hl, 0.0, height - 0.15))
        .cut(V3::new(-1.0, 0.0, 1.0), V3::new(-hl, 0.0, height - 0.12))
        .cut_sym(V3::new(1.0, 1.0, 0.0), V3::new(hl - 0.1, hw, 0.0))
        .cut_sym(V3::new(-1.0, 1.0, 0.0), V3::new(-hl + 0.1, hw, 0.0));
    let bus_colours = [
        Rgb::new(0.65, 0.45, 0.02),
        Rgb::new(0.5, 0.04, 0.03),
        Rgb::new(0.7, 0.7, 0.7),
        Rgb::new(0.04, 0.15, 0.4),
    ];
    VehicleModel {
        body: BodyType::Bus,
        length,
        width,
        height,
        parts: vec![body],
        wheels: wheels_at(&[hl - 2.6, -hl + 3.2], 0.5, hw),
        paint: *rng.pick(&bus_colours).unwrap_or(&bus_colours[0]),
        tail: LampRect {
            y0: hw - 0.3,
            y1: hw - 0.08,
            z0: 0.55,
            z1: 1.25,
        },
        head: LampRect {
            y0: hw - 0.55,
            y1: hw - 0.15,
            z0: 0.6,
            z1: 0.8,
        },
        rear_x: -hl,
        front_x: hl,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_hits_the_rear_of_a_car_from_behind() {
        let mut rng = Rng::new(1);
        let m = VehicleModel::new(BodyType::Sedan, &mut rng);
        let o = V3::new(-20.0, 0.0, 0.6);
        let dir = V3::new(1.0, 0.0, 0.0);
        let (t, plane) = m.parts[0].intersect(o, dir, 0.0, 100.0).expect("hit");
        assert!((o.x + t - m.rear_x).abs() < 1e-3);
        assert!(m.parts[0].planes[plane as usize].n.x < -0.99);
        // A ray passing above the car misses every part.
        let high = V3::new(-20.0, 0.0, 3.0);
        assert!(
            m.parts
                .iter()
                .all(|p| p.intersect(high, dir, 0.0, 100.0).is_none())
        );
    }
}
