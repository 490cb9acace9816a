//! The static world beside the road: buildings, street lamps, traffic lights and trees in
//! the city; guard rails, lamp posts, tree lines and bushes on the highway. Objects are
//! generated once per scenario from the seed and kept sorted by arc length so that a frame
//! can pick the ones near the camera with a binary search.

use super::math::V3;
use super::rng::Rng;
use super::road::Road;
use crate::sequence::Domain;

/// The geometric shape of a static object, in its local frame (x along its yaw, y to the
/// left, z up; origin at the centre of its footprint on the ground unless stated).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// An upright box `[-hx, hx] × [-hy, hy] × [z0, z1]`.
    Box {
        /// Half extents in x and y.
        hx: f32,
        /// Half extent in y.
        hy: f32,
        /// Bottom height.
        z0: f32,
        /// Top height.
        z1: f32,
    },
    /// A vertical cylinder of radius `r` from `z0` to `z1`.
    Cylinder {
        /// Radius.
        r: f32,
        /// Bottom height.
        z0: f32,
        /// Top height.
        z1: f32,
    },
    /// An ellipsoid with radii (rx, ry, rz) centred at height `zc`.
    Ellipsoid {
        /// Radius along x.
        rx: f32,
        /// Radius along y.
        ry: f32,
        /// Radius along z.
        rz: f32,
        /// Height of the centre.
        zc: f32,
    },
    /// A vertical two-sided rectangle in the local x-z plane, `[-hx, hx] × [0, h]`, whose
    /// material may cut parts of it away (guard-rail gaps, ragged tree-line tops).
    Panel {
        /// Half length.
        hx: f32,
        /// Maximum height.
        h: f32,
    },
}

/// What a static object is, which decides its label and material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StaticKind {
    /// A building with a facade style.
    Building {
        /// Index into the wall palette.
        palette: u8,
        /// Floor height (m).
        floor: f32,
        /// Window spacing (m).
        bay: f32,
        /// Window width as a fraction of the bay.
        window: f32,
        /// Which local side faces the road: +1 = +y, -1 = -y.
        facing: f32,
    },
    /// A metal pole (street lamp, traffic-light pole, arm).
    Pole,
    /// The lamp head of a street lamp (lit at night).
    LampHead,
    /// A traffic-light housing for the approach moving towards local -x; shows the light of
    /// intersection `intersection` for the main road.
    TrafficLight {
        /// Index of the intersection in `Road::intersections`.
        intersection: u16,
    },
    /// Tree trunk.
    Trunk,
    /// Tree crown or bush.
    Foliage,
    /// W-beam guard rail on posts.
    GuardRail,
    /// A continuous line of trees seen from the road (ragged top).
    TreeLine,
}

/// One static object of the world.
#[derive(Debug, Clone, Copy)]
pub struct StaticObject {
    /// Arc length of the object's centre (for culling).
    pub s: f32,
    /// Half of its extent along the road (for culling).
    pub reach: f32,
    /// World position of the local origin.
    pub pos: V3,
    /// Heading of the local x axis (radians).
    pub yaw: f32,
    /// Geometry.
    pub shape: Shape,
    /// Label and material.
    pub kind: StaticKind,
    /// Per-object random salt for textures.
    pub salt: u32,
}

impl StaticObject {
    /// AnoVox semantic id of the object.
    pub fn semantic(&self) -> u8 {
        match self.kind {
            StaticKind::Building { .. } => 3,
            StaticKind::Pole | StaticKind::LampHead => 6,
            StaticKind::TrafficLight { .. } => 7,
            StaticKind::Trunk | StaticKind::Foliage | StaticKind::TreeLine => 9,
            StaticKind::GuardRail => 28,
        }
    }

    /// Local bounding box `(min, max)` of the shape.
    pub fn local_bounds(&self) -> (V3, V3) {
        match self.shape {
            Shape::Box { hx, hy, z0, z1 } => (V3::new(-hx, -hy, z0), V3::new(hx, hy, z1)),
            Shape::Cylinder { r, z0, z1 } => (V3::new(-r, -r, z0), V3::new(r, r, z1)),
            Shape::Ellipsoid { rx, ry, rz, zc } => {
                (V3::new(-rx, -ry, zc - rz), V3::new(rx, ry, zc + rz))
            }
            Shape::Panel { hx, h } => (V3::new(-hx, -0.05, 0.0), V3::new(hx, 0.05, h)),
        }
    }
}

/// A point light of the static world (street lamps), for night scenes.
#[derive(Debug, Clone, Copy)]
pub struct LampLight {
    /// Arc length (for culling).
    pub s: f32,
    /// World position of the light.
    pub pos: V3,
}

/// All static objects and lamps, sorted by arc length.
#[derive(Debug, Clone, Default)]
pub struct Scenery {
    /// Objects sorted by `s`.
    pub objects: Vec<StaticObject>,
    /// Largest `reach` of any object, to widen range queries.
    pub max_reach: f32,
    /// Street lamps sorted by `s`.
    pub lamps: Vec<LampLight>,
}

struct Placer<'a> {
    road: &'a Road,
    objects: Vec<StaticObject>,
    lamps: Vec<LampLight>,
    salt: u32,
}

impl Placer<'_> {
    /// Places an object whose local origin is on the ground at Frenet (s, d), rotated by
    /// `yaw_offset` relative to the road heading.
    fn place(
        &mut self,
        s: f32,
        d: f32,
        yaw_offset: f32,
        shape: Shape,
        kind: StaticKind,
        reach: f32,
    ) {
        let (x, y) = self.road.centerline.to_world(s, d);
        self.salt = self.salt.wrapping_add(0x9e37_79b9);
        self.objects.push(StaticObject {
            s,
            reach,
            pos: V3::new(x, y, 0.0),
            yaw: self.road.centerline.heading(s) + yaw_offset,
            shape,
            kind,
            salt: super::rng::hash32(self.salt),
        });
    }

    fn lamp(&mut self, s: f32, d: f32, z: f32) {
        let (x, y) = self.road.centerline.to_world(s, d);
        self.lamps.push(LampLight {
            s,
            pos: V3::new(x, y, z),
        });
    }

    /// A street lamp on the sidewalk at (s, d) whose arm reaches towards the road.
    fn street_lamp(&mut self, s: f32, d: f32) {
        let side = d.signum();
        let pole = Shape::Cylinder {
            r: 0.09,
            z0: 0.0,
            z1: 7.5,
        };
        self.place(s, d, 0.0, pole, StaticKind::Pole, 0.2);
        let arm_len = 1.8;
        let arm = Shape::Box {
            hx: 0.05,
            hy: 0.5 * arm_len,
            z0: 7.3,
            z1: 7.42,
        };
        self.place(s, d - side * 0.5 * arm_len, 0.0, arm, StaticKind::Pole, 0.2);
        let head = Shape::Box {
            hx: 0.25,
            hy: 0.35,
            z0: 7.12,
            z1: 7.32,
        };
        self.place(s, d - side * arm_len, 0.0, head, StaticKind::LampHead, 0.3);
        self.lamp(s, d - side * arm_len, 7.0);
    }

    /// A tree with trunk and crown at (s, d).
    fn tree(&mut self, rng: &mut Rng, s: f32, d: f32, scale: f32) {
        let trunk_h = rng.range(2.2, 3.2) * scale;
        self.place(
            s,
            d,
            0.0,
            Shape::Cylinder {
                r: 0.13 * scale,
                z0: 0.0,
                z1: trunk_h + 0.8,
            },
            StaticKind::Trunk,
            0.3,
        );
        let r = rng.range(1.6, 2.6) * scale;
        let crowns = 1 + rng.below(2);
        for i in 0..crowns {
            let dx = if i == 0 {
                0.0
            } else {
                rng.range(-0.8, 0.8) * r
            };
            let dd = if i == 0 {
                0.0
            } else {
                rng.range(-0.5, 0.5) * r
            };
            let rz = r * rng.range(0.9, 1.25);
            self.place(
                s + dx,
                d + dd,
                rng.range(0.0, 3.0),
                Shape::Ellipsoid {
                    rx: r * rng.range(0.85, 1.1),
                    ry: r * rng.range(0.85, 1.1),
                    rz,
                    zc: trunk_h + rz * 0.85,
                },
                StaticKind::Foliage,
                r + 1.0,
            );
        }
    }
}

/// Wall colours of buildings (linear RGB), indexed by `StaticKind::Building::palette`.
pub const WALL_PALETTE: [[f32; 3]; 10] = [
    [0.42, 0.17, 0.11], // red brick
    [0.55, 0.48, 0.36], // sandstone
    [0.62, 0.60, 0.56], // light concrete
    [0.30, 0.30, 0.31], // dark grey
    [0.70, 0.66, 0.58], // cream render
    [0.36, 0.24, 0.16], // brown brick
    [0.48, 0.50, 0.52], // blue-grey
    [0.66, 0.52, 0.40], // ochre
    [0.20, 0.22, 0.25], // glass-and-steel dark
    [0.78, 0.77, 0.74], // white render
];

impl Scenery {
    /// Generates the scenery for `road` over arc lengths `[s_start, s_end]`.
    pub fn generate(rng: &mut Rng, road: &Road, s_start: f32, s_end: f32) -> Self {
        let mut placer = Placer {
            road,
            objects: Vec::new(),
            lamps: Vec::new(),
            salt: rng.next_u64() as u32,
        };
        match road.domain {
            Domain::Highway => highway_scenery(&mut placer, rng, s_start, s_end),
            _ => city_scenery(&mut placer, rng, s_start, s_end),
        }
        let Placer {
            mut objects,
            mut lamps,
            ..
        } = placer;
        objects.sort_by(|a, b| a.s.total_cmp(&b.s));
        lamps.sort_by(|a, b| a.s.total_cmp(&b.s));
        let max_reach = objects.iter().map(|o| o.reach).fold(0.0, f32::max);
        Self {
            objects,
            max_reach,
            lamps,
        }
    }

    /// Indices of objects whose extent may overlap `[s0, s1]`.
    pub fn range(&self, s0: f32, s1: f32) -> std::ops::Range<usize> {
        let lo = self.objects.partition_point(|o| o.s < s0 - self.max_reach);
        let hi = self.objects.partition_point(|o| o.s <= s1 + self.max_reach);
        lo..hi.max(lo)
    }
}

fn city_scenery(p: &mut Placer, rng: &mut Rng, s_start: f32, s_end: f32) {
    let road = p.road;
    let walk_edge = road.road_half + road.sidewalk;
    for side in [-1.0f32, 1.0] {
        let mut rng = rng.fork(if side < 0.0 { 11 } else { 12 });
        // Buildings: blocks between the cross streets.
        let mut s = s_start;
        while s < s_end {
            let frontage = rng.range(9.0, 30.0);
            let (gap_before, blocked) = match road.nearest_intersection(s + 0.5 * frontage) {
                Some(x) => {
                    let clear = x.half_width + 2.5;
                    let a = s;
                    let b = s + frontage;
                    (0.0, b > x.s - clear && a < x.s + clear)
                }
                None => (0.0, false),
            };
            if blocked {
                s += 2.0;
                continue;
            }
            let s_mid = s + gap_before + 0.5 * frontage;
            let setback = if rng.chance(0.7) {
                0.0
            } else {
                rng.range(0.5, 3.0)
            };
            let depth = rng.range(12.0, 24.0);
            let tall = rng.chance(0.25);
            let height = if tall {
                rng.range(25.0, 55.0)
            } else {
                rng.range(7.0, 22.0)
            };
            let floor = rng.range(3.0, 3.8);
            let bay = rng.range(2.2, 3.6);
            p.place(
                s_mid,
                side * (walk_edge + setback + 0.5 * depth),
                0.0,
                Shape::Box {
                    hx: 0.5 * frontage,
                    hy: 0.5 * depth,
                    z0: 0.0,
                    z1: height,
                },
                StaticKind::Building {
                    palette: rng.below(WALL_PALETTE.len()) as u8,
                    floor,
                    bay,
                    window: rng.range(0.4, 0.7),
                    facing: -side,
                },
                0.5 * frontage + 1.0,
            );
            let gap = if rng.chance(0.2) {
                rng.range(3.0, 9.0)
            } else {
                rng.range(0.0, 0.6)
            };
            s += frontage + gap;
        }
        // Street lamps and trees on the sidewalk.
        let mut s = s_start + rng.range(0.0, 20.0);
        while s < s_end {
            let near_x = road
                .nearest_intersection(s)
                .is_some_and(|x| (s - x.s).abs() < x.half_width + 6.0);
            if !near_x {
                p.street_lamp(s, side * (road.road_half + 0.6));
            }
            s += rng.range(26.0, 34.0);
        }
        let mut s = s_start + rng.range(0.0, 10.0);
        while s < s_end {
            let near_x = road
                .nearest_intersection(s)
                .is_some_and(|x| (s - x.s).abs() < x.half_width + 8.0);
            if !near_x && rng.chance(0.55) {
                let scale = rng.range(0.8, 1.1);
                p.tree(&mut rng, s, side * (road.road_half + 1.6), scale);
            }
            s += rng.range(10.0, 18.0);
        }
    }
    // Traffic lights: for each intersection one housing per approach, hanging from an arm
    // over the approaching lanes, and a pole at the corner.
    let lanes_mid = road.inner + road.lane_width * 0.5 * road.lanes as f32;
    for (i, x) in road.intersections.iter().enumerate() {
        for forward in [true, false] {
            let sign = if forward { -1.0 } else { 1.0 };
            // Corner before the crossing, as seen by the approaching driver.
            let s_pole = x.s + sign * (x.half_width + 1.0 + super::road::CROSSWALK + 1.5);
            let d_pole = sign * (road.road_half + 0.5);
            p.place(
                s_pole,
                d_pole,
                0.0,
                Shape::Cylinder {
                    r: 0.12,
                    z0: 0.0,
                    z1: 6.0,
                },
                StaticKind::Pole,
                0.3,
            );
            let arm_end = sign * (lanes_mid - 1.0);
            let arm_mid = 0.5 * (d_pole + arm_end);
            p.place(
                s_pole,
                arm_mid,
                0.0,
                Shape::Box {
                    hx: 0.07,
                    hy: 0.5 * (d_pole - arm_end).abs(),
                    z0: 5.75,
                    z1: 5.9,
                },
                StaticKind::Pole,
                0.3,
            );
            // The housing faces the approaching traffic: forward traffic looks along +s, so
            // the housing's lamp side (local -x) must face -s: yaw offset 0 for forward,
            // pi for the opposite direction.
            let yaw = if forward { 0.0 } else { std::f32::consts::PI };
            for d_house in [sign * lanes_mid, d_pole - sign * 0.25] {
                let z0 = if d_house == sign * lanes_mid {
                    4.6
                } else {
                    2.6
                };
                p.place(
                    s_pole,
                    d_house,
                    yaw,
                    Shape::Box {
                        hx: 0.18,
                        hy: 0.2,
                        z0,
                        z1: z0 + 1.1,
                    },
                    StaticKind::TrafficLight {
                        intersection: i as u16,
                    },
                    0.3,
                );
            }
        }
    }
}

fn highway_scenery(p: &mut Placer, rng: &mut Rng, s_start: f32, s_end: f32) {
    let road = p.road;
    let seg = 16.0;
    // Guard rails: the median rail (two-sided) and the outer rails, in straight pieces
    // that follow the curve.
    let mut s = s_start;
    while s < s_end {
        for d in [0.0f32, -(road.road_half + 0.4), road.road_half + 0.4] {
            p.place(
                s + 0.5 * seg,
                d,
                0.0,
                Shape::Panel {
                    hx: 0.5 * seg + 0.02,
                    h: 0.8,
                },
                StaticKind::GuardRail,
                0.5 * seg + 1.0,
            );
        }
        s += seg;
    }
    // Lamp posts in the median.
    let mut s = s_start + rng.range(0.0, 40.0);
    while s < s_end {
        p.place(
            s,
            0.0,
            0.0,
            Shape::Cylinder {
                r: 0.12,
                z0: 0.0,
                z1: 11.0,
            },
            StaticKind::Pole,
            0.3,
        );
        for side in [-1.0f32, 1.0] {
            p.place(
                s,
                side * 1.2,
                0.0,
                Shape::Box {
                    hx: 0.05,
                    hy: 1.2,
                    z0: 10.8,
                    z1: 10.92,
                },
                StaticKind::Pole,
                0.3,
            );
            p.place(
                s,
                side * 2.4,
                0.0,
                Shape::Box {
                    hx: 0.28,
                    hy: 0.4,
                    z0: 10.6,
                    z1: 10.82,
                },
                StaticKind::LampHead,
                0.3,
            );
            p.lamp(s, side * 2.4, 10.5);
        }
        s += rng.range(48.0, 60.0);
    }
    for side in [-1.0f32, 1.0] {
        let mut rng = rng.fork(if side < 0.0 { 21 } else { 22 });
        // Tree lines: ragged panels in two layers at different distances (parallax).
        for (layer, (d0, d1)) in [(0u32, (14.0f32, 24.0f32)), (1, (30.0, 45.0))] {
            let mut s = s_start;
            let d_base = rng.range(d0, d1);
            while s < s_end {
                let len = rng.range(25.0, 60.0);
                if rng.chance(0.8) || layer == 1 {
                    let d = road.road_half + d_base + rng.range(-2.0, 2.0);
                    p.place(
                        s + 0.5 * len,
                        side * d,
                        0.0,
                        Shape::Panel {
                            hx: 0.5 * len,
                            h: rng.range(9.0, 16.0) + layer as f32 * 3.0,
                        },
                        StaticKind::TreeLine,
                        0.5 * len + 1.0,
                    );
                }
                s += len * rng.range(0.85, 1.0);
            }
        }
        // Single trees and bushes on the verge.
        let mut s = s_start + rng.range(0.0, 15.0);
        while s < s_end {
            let d = road.road_half + rng.range(4.0, 12.0);
            if rng.chance(0.6) {
                let scale = rng.range(0.9, 1.4);
                p.tree(&mut rng, s, side * d, scale);
            } else {
                let r = rng.range(0.8, 1.8);
                p.place(
                    s,
                    side * d,
                    rng.range(0.0, 3.0),
                    Shape::Ellipsoid {
                        rx: r * 1.4,
                        ry: r,
                        rz: r * 0.8,
                        zc: r * 0.45,
                    },
                    StaticKind::Foliage,
                    r * 1.4 + 0.5,
                );
            }
            s += rng.range(8.0, 30.0);
        }
    }
}
