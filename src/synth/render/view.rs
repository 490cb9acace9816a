//! [`FrameView`]: one frame ready for ray casting (camera, placed primitives and lights,
//! tile lists), and the tracing of a camera ray through it: the tile's primitives nearest
//! first, the ground (road plane, raised sidewalks and kerb faces via Frenet coordinates),
//! sky and backdrop.

use super::bounds::{TILE, bin};
use super::hit::{GroundHint, Hit, PlaneHits};
use super::intersect_static::intersect_static;
use super::intersect_vehicle::{VehicleEye, intersect_vehicle_from};
use super::lights::{Glow, Light, LightsInReach, ego_headlight, light_rects, place_lights};
use super::place::{bin_nearest_first, bin_vehicles, place_statics, place_vehicles};
use super::prim::{Prim, PrimRef};
use crate::sequence::Domain;
use crate::synth::camera::Camera;
use crate::synth::keys::{KEY_BACKDROP, KEY_GROUND, KEY_SKY};
use crate::synth::math::V3;
use crate::synth::traffic::EGO;
use crate::synth::world::{BACKDROP_MAX, World};

/// One frame ready for ray casting: camera, culled primitives and tile lists.
pub struct FrameView<'w> {
    /// The world.
    pub world: &'w World,
    /// Frame index.
    pub frame: usize,
    /// Camera.
    pub cam: Camera,
    /// Arc length of the camera (Frenet guess for the ground).
    pub cam_s: f32,
    /// Lateral offset of the camera from the centreline.
    cam_d: f32,
    /// Road tangent at the camera.
    road_tangent: (f32, f32),
    /// Road curvature at the camera.
    road_kappa: f32,
    /// Primitives of this frame.
    pub prims: Vec<Prim>,
    /// Per vehicle (by index into `Traffic::vehicles`), the terms of its ray tests for rays
    /// from the camera; empty for vehicles without a primitive.
    vehicle_eyes: Vec<VehicleEye>,
    tiles_x: usize,
    tiles_y: usize,
    tile_start: Vec<u32>,
    tile_items: Vec<u32>,
    vehicle_start: Vec<u32>,
    vehicle_items: Vec<u32>,
    /// Night lights of this frame.
    pub lights: Vec<Light>,
    /// The ego's headlights (lit at night).
    pub ego_headlight: Light,
    light_start: Vec<u32>,
    light_items: Vec<u32>,
    /// Glow sources.
    pub glows: Vec<Glow>,
    /// Ground-plane shadow offset per metre of height (sun), if the sun casts shadows.
    pub shadow_step: Option<(f32, f32)>,
}

impl<'w> FrameView<'w> {
    /// Places the camera, the objects and the lights of frame `frame` and bins them into
    /// tiles.
    pub fn new(world: &'w World, frame: usize) -> Self {
        let states = &world.traffic.states[frame];
        let ego = states[EGO];
        let cam = Camera::new(&world.intrinsics, ego.x, ego.y, ego.yaw);
        let w = cam.width as usize;
        let h = cam.height_px as usize;
        let tiles_x = w.div_ceil(TILE);
        let tiles_y = h.div_ceil(TILE);
        let highway = matches!(world.road.domain, Domain::Highway);
        let draw = if highway { 700.0 } else { 260.0 };
        let lighting = &world.lighting;
        let shadow_step = (lighting.sun.luminance() > 0.5).then(|| {
            let sd = lighting.sun_dir;
            let k = 1.0 / sd.z.max(0.2);
            (-sd.x * k, -sd.y * k)
        });

        let mut prims = Vec::new();
        let mut rects = Vec::new();
        place_statics(world, &cam, ego.s, draw, &mut prims, &mut rects);
        let vehicle_eyes = place_vehicles(
            world,
            states,
            &cam,
            draw,
            shadow_step,
            &mut prims,
            &mut rects,
        );
        let (vehicle_start, vehicle_items) = bin_vehicles(&rects, &prims, tiles_x, tiles_y);
        let (tile_start, tile_items) = bin_nearest_first(&rects, &prims, tiles_x, tiles_y);
        let (lights, glows) = place_lights(world, frame, &cam, ego.s, &prims);
        let (light_start, light_items) = bin(&light_rects(&cam, &lights), tiles_x, tiles_y);
        let road_here = world.road.centerline.sample(ego.s);
        FrameView {
            world,
            frame,
            cam,
            cam_s: ego.s,
            cam_d: ego.d,
            road_tangent: (road_here.tx, road_here.ty),
            road_kappa: road_here.kappa,
            prims,
            vehicle_eyes,
            tiles_x,
            tiles_y,
            tile_start,
            tile_items,
            vehicle_start,
            vehicle_items,
            lights,
            ego_headlight: ego_headlight(&cam),
            light_start,
            light_items,
            glows,
            shadow_step,
        }
    }

    /// Unit tangent of the road at the camera.
    #[inline]
    pub fn road_tangent(&self) -> (f32, f32) {
        self.road_tangent
    }

    /// Tile index of continuous image point (u, v).
    #[inline]
    pub fn tile_of(&self, u: f32, v: f32) -> usize {
        let tx = ((u.max(0.0) as usize) / TILE).min(self.tiles_x - 1);
        let ty = ((v.max(0.0) as usize) / TILE).min(self.tiles_y - 1);
        ty * self.tiles_x + tx
    }

    /// Primitive indices of a tile.
    #[inline]
    pub fn tile_prims(&self, tile: usize) -> &[u32] {
        &self.tile_items[self.tile_start[tile] as usize..self.tile_start[tile + 1] as usize]
    }

    /// Indices of the vehicle primitives of a tile (their shadows included).
    #[inline]
    pub fn tile_vehicles(&self, tile: usize) -> &[u32] {
        &self.vehicle_items
            [self.vehicle_start[tile] as usize..self.vehicle_start[tile + 1] as usize]
    }

    /// Every light that may reach a point of `tile`.
    #[inline]
    pub fn tile_lights(&self, tile: usize) -> LightsInReach<'_> {
        LightsInReach {
            lights: &self.light_items
                [self.light_start[tile] as usize..self.light_start[tile + 1] as usize],
            ego_headlight: true,
        }
    }

    /// The lights of `tile` that may reach a point of the box `lo..=hi` (around the surface
    /// points of the tile), their indices written to `buf`.
    pub fn lights_reaching<'b>(
        &self,
        tile: usize,
        lo: V3,
        hi: V3,
        buf: &'b mut Vec<u32>,
    ) -> LightsInReach<'b> {
        buf.clear();
        let all = self.tile_lights(tile).lights;
        buf.extend(
            all.iter()
                .filter(|&&i| self.lights[i as usize].may_reach(lo, hi)),
        );
        LightsInReach {
            lights: buf,
            ego_headlight: self.ego_headlight.may_reach(lo, hi),
        }
    }

    /// The nearest surface through continuous image point (u, v).
    #[inline]
    pub fn trace_point(&self, u: f32, v: f32) -> Hit {
        self.trace(self.cam.ray(u, v), u, v)
    }

    /// Frenet coordinates of the camera-relative ground point at ray parameter `t`, starting
    /// Newton's iteration at `guess` (or, if `None`, at a curvature-aware estimate from the
    /// road's tangent at the camera).
    #[inline]
    fn frenet_at(&self, dir: V3, t: f32, guess: Option<f32>) -> (f32, f32) {
        let (px, py) = (dir.x * t, dir.y * t);
        let s0 = guess.unwrap_or_else(|| {
            let (tx, ty) = self.road_tangent;
            let along = px * tx + py * ty;
            let across = -px * ty + py * tx + self.cam_d;
            self.cam_s + along * (1.0 + self.road_kappa * across)
        });
        self.world
            .road
            .centerline
            .to_frenet(self.cam.x + px, self.cam.y + py, s0)
    }

    /// Intersection with the ground: road plane, raised sidewalks and kerb faces.
    fn ground(&self, dir: V3, planes: PlaneHits, hint: Option<GroundHint>) -> Option<Hit> {
        if dir.z >= -1e-6 {
            return None;
        }
        let road = &self.world.road;
        let h = self.cam.height;
        let t0 = planes.floor;
        let make = |t: f32, s: f32, d: f32, z: f32, part: u8, normal: V3| Hit {
            t,
            key: KEY_GROUND,
            prim: u32::MAX,
            part,
            local: V3::new(s, d, z),
            normal,
        };
        let up = V3::new(0.0, 0.0, 1.0);
        let s_hint = hint.map(|g| g.s);
        if road.kerb_height <= 0.0 {
            let (s, d) = self.frenet_at(dir, t0, s_hint);
            return Some(make(t0, s, d, 0.0, 0, up));
        }
        let kh = road.kerb_height;
        let t1 = planes.raised;
        // A row's neighbours mostly lie on one level: the level of the previous pixel is
        // tried first, so that most pixels invert their Frenet coordinates once.
        let road_first = hint.is_none_or(|g| !g.raised);
        let mut at_floor = None;
        if road_first {
            let (s0, d0) = self.frenet_at(dir, t0, s_hint);
            // Between the raised plane and the road plane the ray moves this far sideways
            // at most (the distance to the centre line changes no faster than the point;
            // the margin covers the inversion's tolerance).
            let drift = (t0 - t1) * (dir.x * dir.x + dir.y * dir.y).sqrt() + 0.01;
            if d0.abs() + drift < road.road_half {
                // Inside the carriageway at both planes: the raised level cannot be hit.
                return Some(make(t0, s0, d0, 0.0, 0, up));
            }
            at_floor = Some((s0, d0));
        }
        // Along the ray, s grows by about the horizontal distance travelled along the road.
        let (tx, ty) = self.road_tangent;
        let ds_dt = dir.x * tx + dir.y * ty;
        let s1_hint = at_floor.map_or(s_hint, |(s0, _)| Some(s0 - (t0 - t1) * ds_dt));
        let (s1, d1) = self.frenet_at(dir, t1, s1_hint);
        if road.is_raised(s1, d1) {
            return Some(make(t1, s1, d1, kh, 0, up));
        }
        let (s0, d0) =
            at_floor.unwrap_or_else(|| self.frenet_at(dir, t0, Some(s1 + (t0 - t1) * ds_dt)));
        if !road.is_raised(s0, d0) {
            return Some(make(t0, s0, d0, 0.0, 0, up));
        }
        // The ray passes the kerb's height range over the road and lands on the raised
        // level: it hits the kerb face in between.
        let (mut lo, mut hi) = (t1, t0);
        for _ in 0..14 {
            let mid = 0.5 * (lo + hi);
            let (s, d) = self.frenet_at(dir, mid, Some(s1 + (mid - t1) * ds_dt));
            if road.is_raised(s, d) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let (s, d) = self.frenet_at(dir, hi, Some(s1 + (hi - t1) * ds_dt));
        let z = (h + dir.z * hi).clamp(0.0, kh);
        Some(make(hi, s, d, z, 1, road.kerb_normal(s, d)))
    }

    /// The nearest surface along camera ray `dir` through image point (u, v) (`dir` is
    /// `self.cam.ray(u, v)`).
    pub fn trace(&self, dir: V3, u: f32, v: f32) -> Hit {
        self.trace_in_tile(dir, u, v, self.tile_of(u, v), None)
    }

    /// [`FrameView::trace`] for a point known to lie in `tile`; `hint` tells where a nearby
    /// ray met the ground (it speeds up the Frenet inversion).
    pub fn trace_in_tile(
        &self,
        dir: V3,
        u: f32,
        v: f32,
        tile: usize,
        hint: Option<GroundHint>,
    ) -> Hit {
        self.trace_planes(dir, self.plane_hits(dir.z), u, v, tile, hint)
    }

    /// Where a camera ray with vertical component `dir_z` meets the road plane and the
    /// raised-sidewalk plane (the same for every ray of an image row).
    #[inline]
    pub fn plane_hits(&self, dir_z: f32) -> PlaneHits {
        let h = self.cam.height;
        if dir_z < -1e-6 {
            PlaneHits {
                floor: h / -dir_z,
                raised: (h - self.world.road.kerb_height) / -dir_z,
            }
        } else {
            PlaneHits {
                floor: f32::INFINITY,
                raised: f32::INFINITY,
            }
        }
    }

    /// [`FrameView::trace_in_tile`] with the ray's [`FrameView::plane_hits`] given.
    #[inline]
    pub fn trace_planes(
        &self,
        dir: V3,
        planes: PlaneHits,
        u: f32,
        v: f32,
        tile: usize,
        hint: Option<GroundHint>,
    ) -> Hit {
        // The ground lies between the raised-sidewalk plane and the road plane along the
        // ray; objects nearer than the former hide it, so it is only resolved when needed.
        let (t_floor, t_raised) = (planes.floor, planes.raised);
        let mut hit = Hit::sky(dir);
        hit.t = t_floor;
        for &pi in self.tile_prims(tile) {
            let prim = &self.prims[pi as usize];
            if prim.near >= hit.t {
                break;
            }
            let r = &prim.rect;
            if u < r[0] || u > r[2] || v < r[1] || v > r[3] {
                continue;
            }
            let ol = prim.eye;
            let dl = dir.unrotate_z(prim.c, prim.s);
            let found = match prim.what {
                PrimRef::Static(i) => intersect_static(
                    &self.world.scenery.objects[i as usize],
                    prim.x_range,
                    ol,
                    dl,
                    hit.t,
                ),
                PrimRef::Vehicle(i) => intersect_vehicle_from(
                    &self.world.traffic.vehicles[i as usize].model,
                    &self.vehicle_eyes[i as usize],
                    dl,
                    hit.t,
                ),
            };
            if let Some((t, part, n)) = found {
                hit = Hit {
                    t,
                    key: prim.key(),
                    prim: pi,
                    part,
                    local: ol + dl * t,
                    normal: n,
                };
            }
        }
        if (hit.key == KEY_SKY || hit.t >= t_raised)
            && let Some(g) = self.ground(dir, planes, hint)
            && (hit.key == KEY_SKY || g.t < hit.t)
        {
            return g;
        }
        if hit.key == KEY_SKY {
            hit.t = f32::INFINITY;
            if self.backdrop(dir) {
                hit.key = KEY_BACKDROP;
            }
        }
        hit
    }

    /// Whether direction `dir` above the horizon meets the distant skyline or hills.
    fn backdrop(&self, dir: V3) -> bool {
        let horiz = (dir.x * dir.x + dir.y * dir.y).sqrt();
        if dir.z < 0.0 || horiz <= 0.0 {
            return dir.z < 0.0;
        }
        let elevation = dir.z / horiz;
        elevation < BACKDROP_MAX && elevation < self.world.backdrop_at(dir.y.atan2(dir.x))
    }
}
