//! The light sources of a frame: street lamps, headlights (the ego's included) and the
//! glows of lamps, brake lights and traffic lights, placed camera-relative from the frame's
//! primitives; each light's reach and the screen rectangle it is binned by.

use super::bounds::{box_corners, screen_rect};
use super::prim::{Prim, PrimRef};
use crate::synth::camera::Camera;
use crate::synth::math::{Rgb, V3};
use crate::synth::road::LightState;
use crate::synth::scenery::{Shape, StaticKind};
use crate::synth::traffic::Role;
use crate::synth::world::World;

/// A light source for night scenes, camera-relative.
#[derive(Debug, Clone, Copy)]
pub struct Light {
    /// Position.
    pub pos: V3,
    /// Intensity (radiance scale).
    pub colour: Rgb,
    /// Spot direction (unit), or zero for an omni light.
    pub dir: V3,
    /// Cosine of the spot's half angle.
    pub cos_outer: f32,
    /// Range after which the light is ignored.
    pub range: f32,
}

impl Light {
    /// Corners (low, high) of a box holding every point this light reaches: its range
    /// sphere, cut to the spot's cone. Tiles are binned by it, so it must never be too
    /// small; a headlight's box is a fraction of its range cube.
    pub fn reach_box(&self) -> (V3, V3) {
        let r = self.range;
        if self.dir == V3::default() {
            let e = V3::new(r, r, r);
            return (self.pos - e, self.pos + e);
        }
        let sin_outer = (1.0 - self.cos_outer * self.cos_outer).max(0.0).sqrt();
        // Largest component along an axis of a unit vector within the cone: 1 when the
        // axis lies inside it, else the cosine of the axis's angle to the cone's edge.
        let reach = |d: f32| {
            if d >= self.cos_outer {
                1.0
            } else {
                d * self.cos_outer + (1.0 - d * d).max(0.0).sqrt() * sin_outer
            }
        };
        // Rounding slack, so that the box stays conservative.
        let slack = 1e-3 * r + 1e-2;
        let side = |d: f32, p: f32| {
            (
                p - r * reach(-d).max(0.0) - slack,
                p + r * reach(d).max(0.0) + slack,
            )
        };
        let (x0, x1) = side(self.dir.x, self.pos.x);
        let (y0, y1) = side(self.dir.y, self.pos.y);
        let (z0, z1) = side(self.dir.z, self.pos.z);
        (V3::new(x0, y0, z0), V3::new(x1, y1, z1))
    }

    /// Whether the light may reach a point of the box `lo..=hi`: `false` only where it adds
    /// nothing to any point of the box (outside its reach box or beyond its range).
    pub fn may_reach(&self, lo: V3, hi: V3) -> bool {
        let (near, far) = self.reach_box();
        if near.x > hi.x || near.y > hi.y || near.z > hi.z {
            return false;
        }
        if far.x < lo.x || far.y < lo.y || far.z < lo.z {
            return false;
        }
        let gap = |p: f32, a: f32, b: f32| (a - p).max(p - b).max(0.0);
        let g = V3::new(
            gap(self.pos.x, lo.x, hi.x),
            gap(self.pos.y, lo.y, hi.y),
            gap(self.pos.z, lo.z, hi.z),
        );
        // Shading compares a rounded squared distance with the squared range: the margin
        // keeps this test on the safe side of that rounding.
        g.dot(g) <= self.range * self.range * 1.001
    }
}

/// The night lights to evaluate at a surface point.
#[derive(Debug, Clone, Copy)]
pub struct LightsInReach<'a> {
    /// Indices into [`FrameView::lights`](super::FrameView::lights): a tile's list in its
    /// order, perhaps without the lights that cannot reach the tile's surface points.
    pub lights: &'a [u32],
    /// Whether [`FrameView::ego_headlight`](super::FrameView::ego_headlight) may reach the
    /// point.
    pub ego_headlight: bool,
}

/// A bright light source drawn with a glow halo after shading.
#[derive(Debug, Clone, Copy)]
pub struct Glow {
    /// Camera-relative position.
    pub pos: V3,
    /// Colour and strength.
    pub colour: Rgb,
    /// Apparent size (m).
    pub size: f32,
}

/// The ego's headlights (night), camera-relative.
pub(super) fn ego_headlight(cam: &Camera) -> Light {
    Light {
        pos: V3::new(2.4 * cam.c, 2.4 * cam.s, 0.75),
        colour: Rgb::new(1.0, 0.95, 0.88) * 300.0,
        dir: V3::new(cam.c, cam.s, -0.03).normalized(),
        cos_outer: 0.6,
        range: 90.0,
    }
}

/// The street lamps, headlights and glow sources of frame `frame`, seen from `cam` at arc
/// length `cam_s`, whose primitives are `prims`.
pub(super) fn place_lights(
    world: &World,
    frame: usize,
    cam: &Camera,
    cam_s: f32,
    prims: &[Prim],
) -> (Vec<Light>, Vec<Glow>) {
    let l = &world.lighting;
    let states = &world.traffic.states[frame];
    let mut lights = Vec::new();
    let mut glows = Vec::new();
    if l.night {
        let lamps = &world.scenery.lamps;
        let lo = lamps.partition_point(|m| m.s < cam_s - 40.0);
        for lamp in lamps[lo..].iter().take_while(|m| m.s < cam_s + 300.0) {
            let pos = cam.relative(lamp.pos);
            lights.push(Light {
                pos,
                colour: Rgb::new(1.0, 0.72, 0.42) * 26.0,
                dir: V3::new(0.0, 0.0, -1.0),
                cos_outer: 0.2,
                range: 20.0,
            });
            glows.push(Glow {
                pos,
                colour: Rgb::new(1.0, 0.75, 0.45) * 2.5,
                size: 0.5,
            });
        }
    }
    for prim in prims {
        let PrimRef::Vehicle(i) = prim.what else {
            continue;
        };
        let v = &world.traffic.vehicles[i as usize];
        let st = &states[i as usize];
        let m = &v.model;
        let parked = v.role == Role::Parked;
        let lamp_y = 0.5 * (m.tail.y0 + m.tail.y1);
        let lamp_z = 0.5 * (m.tail.z0 + m.tail.z1);
        // Lamps only glow towards the side they face.
        let facing_camera = prim.c * prim.origin.x + prim.s * prim.origin.y < 0.0;
        if !parked && !facing_camera && (l.night || st.brake_lights) {
            let strength = if st.brake_lights { 1.6 } else { 0.5 };
            for side in [-1.0f32, 1.0] {
                let p = prim.origin
                    + V3::new(m.rear_x - 0.02, side * lamp_y, lamp_z).rotate_z(prim.c, prim.s);
                glows.push(Glow {
                    pos: p,
                    colour: Rgb::new(1.0, 0.06, 0.03) * strength,
                    size: 0.25,
                });
            }
        }
        if l.night && !parked {
            let hy = 0.5 * (m.head.y0 + m.head.y1);
            let hz = 0.5 * (m.head.z0 + m.head.z1);
            // Only nearby headlights light up the scene noticeably.
            if prim.origin.x * prim.origin.x + prim.origin.y * prim.origin.y < 70.0 * 70.0 {
                let fwd = V3::new(prim.c, prim.s, -0.06).normalized();
                let front =
                    prim.origin + V3::new(m.front_x + 0.3, 0.0, hz).rotate_z(prim.c, prim.s);
                lights.push(Light {
                    pos: front,
                    colour: Rgb::new(1.0, 0.95, 0.85) * 220.0,
                    dir: fwd,
                    cos_outer: 0.86,
                    range: 35.0,
                });
            }
            for side in [-1.0f32, 1.0] {
                if !facing_camera {
                    continue;
                }
                let p =
                    prim.origin + V3::new(m.front_x + 0.02, side * hy, hz).rotate_z(prim.c, prim.s);
                glows.push(Glow {
                    pos: p,
                    colour: Rgb::new(1.0, 0.95, 0.85) * 5.0,
                    size: 0.3,
                });
            }
        }
    }
    // Active traffic-light lamps glow.
    for prim in prims {
        let PrimRef::Static(i) = prim.what else {
            continue;
        };
        let obj = &world.scenery.objects[i as usize];
        if let StaticKind::TrafficLight { intersection } = obj.kind
            && let Shape::Box { hx, z0, .. } = obj.shape
        {
            let state = world.traffic.lights[frame]
                .get(intersection as usize)
                .copied()
                .unwrap_or(LightState::Green);
            let (z, colour) = lamp_of(state, z0);
            let p = prim.origin + V3::new(-hx - 0.02, 0.0, z).rotate_z(prim.c, prim.s);
            glows.push(Glow {
                pos: p,
                colour: colour * if l.night { 1.5 } else { 0.4 },
                size: 0.22,
            });
        }
    }
    (lights, glows)
}

/// Height and colour of the lit lamp of a traffic-light housing whose bottom is at `z0`.
pub fn lamp_of(state: LightState, z0: f32) -> (f32, Rgb) {
    match state {
        LightState::Red => (z0 + 0.88, Rgb::new(1.0, 0.04, 0.02)),
        LightState::Yellow => (z0 + 0.55, Rgb::new(1.0, 0.5, 0.02)),
        LightState::Green => (z0 + 0.22, Rgb::new(0.05, 1.0, 0.45)),
    }
}

/// The screen rectangle each light is binned by: that of its reach box (off screen where
/// the box lies behind the camera).
pub(super) fn light_rects(cam: &Camera, lights: &[Light]) -> Vec<[f32; 4]> {
    lights
        .iter()
        .map(|l| {
            let (lo, hi) = l.reach_box();
            screen_rect(cam, &box_corners(lo, 1.0, 0.0, V3::default(), hi - lo))
                .map_or([-10.0, -10.0, -5.0, -5.0], |(r, _)| r)
        })
        .collect()
}
