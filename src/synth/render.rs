//! The ray caster: per frame, the objects near the camera are culled and binned into
//! 16×16-pixel screen tiles by their projected bounds; each pixel's ray is intersected
//! analytically with the ground (road, raised sidewalks and kerb faces via Frenet
//! coordinates) and with the few primitives of its tile (boxes, cylinders, ellipsoids,
//! panels, and vehicles made of convex parts and wheels).

use super::camera::Camera;
use super::keys::{KEY_BACKDROP, KEY_GROUND, KEY_SKY, KEY_STATIC, KEY_VEHICLE};
use super::math::{Rgb, V3};
use super::scenery::{Shape, StaticKind, StaticObject};
use super::texture::value2;
use super::vehicle::{Convex, MAX_PLANES, Plane, VehicleModel, Wheel};
use super::world::{BACKDROP_MAX, World};
use crate::sequence::Domain;

/// Tile size in pixels.
pub const TILE: usize = 16;

/// What a primitive of a frame is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrimRef {
    /// Index into `Scenery::objects`.
    Static(u32),
    /// Index into `Traffic::vehicles`.
    Vehicle(u32),
}

/// A primitive placed for one frame, in camera-relative coordinates.
#[derive(Debug, Clone, Copy)]
pub struct Prim {
    /// What it is.
    pub what: PrimRef,
    /// Local origin relative to the camera's ground position.
    pub origin: V3,
    /// cos(yaw).
    pub c: f32,
    /// sin(yaw).
    pub s: f32,
    /// Smallest depth of the primitive's bounds (no hit can be nearer).
    pub near: f32,
    /// Screen rectangle of the geometry itself (binning may use a larger one that includes
    /// shadows); rays outside it cannot hit.
    pub rect: [f32; 4],
    /// The camera's ray origin in the primitive's local frame (the same for every ray).
    pub eye: V3,
    /// The part of the object's local x extent this primitive stands for: panels are split
    /// into pieces of at most [`PANEL_PIECE`] so that each piece gets tight screen bounds.
    pub x_range: (f32, f32),
}

/// Longest piece of a panel that is binned as one primitive (m).
const PANEL_PIECE: f32 = 4.0;

impl Prim {
    /// Object key for flow and occlusion tests.
    pub fn key(&self) -> u32 {
        match self.what {
            PrimRef::Static(i) => KEY_STATIC + i,
            PrimRef::Vehicle(i) => KEY_VEHICLE | i,
        }
    }
}

/// The nearest surface along a ray.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Ray parameter = depth along the optical axis (infinite for sky and backdrop).
    pub t: f32,
    /// Object key.
    pub key: u32,
    /// Index of the primitive in the frame's list (`u32::MAX` for ground, sky, backdrop).
    pub prim: u32,
    /// Part index for vehicles (wheels are `WHEEL_PART + k`), 1 for a kerb face, 0 otherwise.
    pub part: u8,
    /// Hit point: object-local for primitives, (s, d, z) for the ground, the ray direction
    /// for sky and backdrop.
    pub local: V3,
    /// Surface normal: object-local for primitives, world for the ground.
    pub normal: V3,
}

/// Part index offset of wheels.
pub const WHEEL_PART: u8 = 64;

impl Hit {
    fn sky(dir: V3) -> Self {
        Hit {
            t: f32::INFINITY,
            key: KEY_SKY,
            prim: u32::MAX,
            part: 0,
            local: dir,
            normal: V3::default(),
        }
    }
}

/// Ray parameters at which a camera ray meets the road plane and the raised-sidewalk plane
/// (infinite for rays that do not descend).
#[derive(Debug, Clone, Copy)]
pub struct PlaneHits {
    floor: f32,
    raised: f32,
}

/// Where a nearby ray of the same image row met the ground: the start of the next ray's
/// Frenet inversion.
#[derive(Debug, Clone, Copy)]
pub struct GroundHint {
    /// Expected arc length of the next ray's ground point.
    pub s: f32,
    /// Whether the nearby ray landed on the raised sidewalk level.
    pub raised: bool,
}

/// A light source for night scenes, camera-relative.
#[derive(Debug, Clone, Copy)]
pub struct Light {
    /// Position.
    pub pos: V3,
    /// Intensity (radiance scale).
    pub colour: super::math::Rgb,
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

/// The ego's headlights (night), camera-relative.
pub fn ego_headlight(cam: &Camera) -> Light {
    Light {
        pos: V3::new(2.4 * cam.c, 2.4 * cam.s, 0.75),
        colour: Rgb::new(1.0, 0.95, 0.88) * 300.0,
        dir: V3::new(cam.c, cam.s, -0.03).normalized(),
        cos_outer: 0.6,
        range: 90.0,
    }
}

/// The night lights to evaluate at a surface point.
#[derive(Debug, Clone, Copy)]
pub struct LightsInReach<'a> {
    /// Indices into [`FrameView::lights`]: a tile's list in its order, perhaps without the
    /// lights that cannot reach the tile's surface points.
    pub lights: &'a [u32],
    /// Whether [`FrameView::ego_headlight`] may reach the point.
    pub ego_headlight: bool,
}

/// A bright light source drawn with a glow halo after shading.
#[derive(Debug, Clone, Copy)]
pub struct Glow {
    /// Camera-relative position.
    pub pos: V3,
    /// Colour and strength.
    pub colour: super::math::Rgb,
    /// Apparent size (m).
    pub size: f32,
}

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

/// Depth of the plane at which bounds that cross the camera plane are cut: nothing the camera
/// sees comes within a millimetre of it.
const CLIP_DEPTH: f32 = 1e-3;

/// Screen rectangle of the convex hull of a set of camera-relative points, or `None` if all
/// are behind the camera, and the smallest depth of the hull's visible part (exactly
/// [`CLIP_DEPTH`] for a hull that crosses the camera plane).
///
/// A hull that crosses the camera plane is cut at [`CLIP_DEPTH`] and bounded by what lies
/// in front: its own points there and the points where its edges meet the cutting plane
/// (every pair of a point in front and one behind, a superset of the hull's edges). Such
/// hulls are the walls, guard rails and parked cars right beside the camera; bounding them
/// by the whole image would make every pixel test them.
fn screen_rect(cam: &Camera, pts: &[V3]) -> Option<([f32; 4], f32)> {
    let mut r = [
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    let mut behind = 0;
    let mut near = f32::INFINITY;
    for p in pts {
        match cam.project_relative(*p) {
            Some(q) => {
                r[0] = r[0].min(q.u);
                r[1] = r[1].min(q.v);
                r[2] = r[2].max(q.u);
                r[3] = r[3].max(q.v);
                near = near.min(q.z);
            }
            None => behind += 1,
        }
    }
    if behind == pts.len() {
        return None;
    }
    if behind > 0 {
        return Some((clipped_rect(cam, pts), CLIP_DEPTH));
    }
    Some(([r[0] - 1.0, r[1] - 1.0, r[2] + 1.0, r[3] + 1.0], near))
}

/// [`screen_rect`] of a hull that crosses the camera plane: the bounds of its part in front
/// of the plane at [`CLIP_DEPTH`].
fn clipped_rect(cam: &Camera, pts: &[V3]) -> [f32; 4] {
    let depth = |p: V3| p.x * cam.c + p.y * cam.s;
    let mut r = [
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    let mut add = |p: V3| {
        // The projection of `Camera::project_relative` without its near limit; points on
        // the cutting plane may land far outside the image, which binning clamps.
        let z = depth(p).max(CLIP_DEPTH);
        let u = cam.cx + cam.fx * (p.x * cam.s - p.y * cam.c) / z;
        let v = cam.cy - cam.fy * (p.z - cam.height) / z;
        r[0] = r[0].min(u);
        r[1] = r[1].min(v);
        r[2] = r[2].max(u);
        r[3] = r[3].max(v);
    };
    for &a in pts {
        let za = depth(a);
        if za < CLIP_DEPTH {
            continue;
        }
        add(a);
        for &b in pts {
            let zb = depth(b);
            if zb < CLIP_DEPTH {
                add(a + (b - a) * ((za - CLIP_DEPTH) / (za - zb)));
            }
        }
    }
    [r[0] - 1.0, r[1] - 1.0, r[2] + 1.0, r[3] + 1.0]
}

/// Whether a screen rectangle overlaps a `w × h` image.
fn on_screen(r: &[f32; 4], w: usize, h: usize) -> bool {
    r[0] < w as f32 && r[1] < h as f32 && r[2] > 0.0 && r[3] > 0.0
}

fn box_corners(origin: V3, c: f32, s: f32, lo: V3, hi: V3) -> [V3; 8] {
    let mut out = [V3::default(); 8];
    for (i, o) in out.iter_mut().enumerate() {
        let p = V3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        *o = origin + p.rotate_z(c, s);
    }
    out
}

/// Builds compressed tile lists from per-item screen rectangles.
fn bin(rects: &[[f32; 4]], tiles_x: usize, tiles_y: usize) -> (Vec<u32>, Vec<u32>) {
    let n_tiles = tiles_x * tiles_y;
    let span = |r: &[f32; 4]| {
        // Left of or above the image (cut bounds can be): no tiles.
        if r[2] < 0.0 || r[3] < 0.0 {
            return (1, 1, 0, 0);
        }
        let tx0 = (r[0] / TILE as f32).floor().max(0.0) as usize;
        let ty0 = (r[1] / TILE as f32).floor().max(0.0) as usize;
        let tx1 = ((r[2] / TILE as f32).floor().max(0.0) as usize).min(tiles_x - 1);
        let ty1 = ((r[3] / TILE as f32).floor().max(0.0) as usize).min(tiles_y - 1);
        (tx0, ty0, tx1, ty1)
    };
    let mut counts = vec![0u32; n_tiles + 1];
    for r in rects {
        let (tx0, ty0, tx1, ty1) = span(r);
        for ty in ty0..=ty1 {
            for tx in tx0..=tx1 {
                counts[ty * tiles_x + tx + 1] += 1;
            }
        }
    }
    for i in 1..=n_tiles {
        counts[i] += counts[i - 1];
    }
    let mut fill = counts.clone();
    let mut items = vec![0u32; counts[n_tiles] as usize];
    for (k, r) in rects.iter().enumerate() {
        let (tx0, ty0, tx1, ty1) = span(r);
        for ty in ty0..=ty1 {
            for tx in tx0..=tx1 {
                let t = ty * tiles_x + tx;
                items[fill[t] as usize] = k as u32;
                fill[t] += 1;
            }
        }
    }
    (counts, items)
}

impl<'w> FrameView<'w> {
    /// Places the camera and the objects of frame `frame` and bins them into tiles.
    pub fn new(world: &'w World, frame: usize) -> Self {
        let states = &world.traffic.states[frame];
        let ego = states[super::traffic::EGO];
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
        let range = world.scenery.range(ego.s - 60.0, ego.s + draw);
        for i in range {
            let obj: &StaticObject = &world.scenery.objects[i];
            let origin = cam.relative(obj.pos);
            let (c, s) = (obj.yaw.cos(), obj.yaw.sin());
            let (lo, hi) = obj.local_bounds();
            // Guard rails and tree lines run for tens of metres; as one primitive their
            // bounds would cover a wide wedge of the image that they mostly miss.
            let pieces = match obj.shape {
                Shape::Panel { hx, .. } => (2.0 * hx / PANEL_PIECE).ceil().max(1.0) as usize,
                _ => 1,
            };
            let cut = |k: usize| lo.x + (hi.x - lo.x) * (k as f32 / pieces as f32);
            for k in 0..pieces {
                let x0 = if k == 0 { lo.x } else { cut(k) };
                let x1 = if k + 1 == pieces { hi.x } else { cut(k + 1) };
                let corners = box_corners(
                    origin,
                    c,
                    s,
                    V3::new(x0, lo.y, lo.z),
                    V3::new(x1, hi.y, hi.z),
                );
                // What crosses the camera plane is kept even when out of sight, as before the
                // bounds were cut: the frame's lights and glows are drawn from these.
                if let Some((r, near)) = screen_rect(&cam, &corners)
                    && (near == CLIP_DEPTH || on_screen(&r, w, h))
                {
                    prims.push(Prim {
                        what: PrimRef::Static(i as u32),
                        origin,
                        c,
                        s,
                        near,
                        rect: r,
                        eye: (cam.origin() - origin).unrotate_z(c, s),
                        x_range: (x0, x1),
                    });
                    rects.push(r);
                }
            }
        }
        let mut vehicle_eyes = vec![VehicleEye::default(); world.traffic.vehicles.len()];
        for (i, v) in world.traffic.vehicles.iter().enumerate() {
            if i == super::traffic::EGO {
                continue;
            }
            let st = &states[i];
            let origin = cam.relative(V3::new(st.x, st.y, 0.0));
            if st.beyond_street_end || origin.x.abs() > draw || origin.y.abs() > draw {
                continue;
            }
            let (c, s) = (st.yaw.cos(), st.yaw.sin());
            let (lo, hi) = v.model.bounds();
            let mut pts = box_corners(origin, c, s, lo, hi).to_vec();
            let body_rect = screen_rect(&cam, &pts)
                .map_or([f32::INFINITY, f32::INFINITY, 0.0, 0.0], |(r, _)| r);
            if let Some((kx, ky)) = shadow_step {
                let hgt = v.model.height;
                for p in box_corners(origin, c, s, lo, V3::new(hi.x, hi.y, 0.0))
                    .iter()
                    .take(4)
                {
                    pts.push(V3::new(p.x + kx * hgt, p.y + ky * hgt, 0.0));
                }
            }
            // The contact shadow reaches a little beyond the footprint.
            for p in box_corners(
                origin,
                c,
                s,
                lo - V3::new(0.6, 0.6, 0.0),
                V3::new(hi.x + 0.6, hi.y + 0.6, 0.0),
            )
            .iter()
            .take(4)
            {
                pts.push(*p);
            }
            let mut bounds = screen_rect(&cam, &pts);
            if bounds.is_some_and(|(_, near)| near == CLIP_DEPTH) {
                // Beside the camera the bounds are cut rather than the whole image, so they
                // must hold every ground point the vehicle darkens: raised sidewalks too, and
                // the whole contact shadow, which fades out 0.69 m beyond the footprint.
                let kerb = world.road.kerb_height;
                let on_ground = pts[8..].to_vec();
                for z in [0.0, kerb] {
                    let fringe = box_corners(
                        origin,
                        c,
                        s,
                        V3::new(lo.x - 0.7, lo.y - 0.7, z),
                        V3::new(hi.x + 0.7, hi.y + 0.7, z),
                    );
                    pts.extend_from_slice(&fringe[..4]);
                    pts.extend(on_ground.iter().map(|p| V3::new(p.x, p.y, z)));
                }
                bounds = screen_rect(&cam, &pts);
            }
            // Kept beside the camera even when out of sight (see the static objects): its
            // headlights still light the road ahead at night.
            if let Some((r, near)) = bounds
                && (near == CLIP_DEPTH || on_screen(&r, w, h))
            {
                let eye = (cam.origin() - origin).unrotate_z(c, s);
                vehicle_eyes[i] = VehicleEye::new(&v.model, eye);
                prims.push(Prim {
                    what: PrimRef::Vehicle(i as u32),
                    origin,
                    c,
                    s,
                    near,
                    rect: body_rect,
                    eye,
                    x_range: (lo.x, hi.x),
                });
                rects.push(r);
            }
        }
        // Vehicles again on their own, for shadow lookups from ground pixels.
        let vehicle_rects: Vec<[f32; 4]> = rects
            .iter()
            .zip(&prims)
            .map(|(r, p)| match p.what {
                PrimRef::Vehicle(_) => *r,
                PrimRef::Static(_) => [-10.0, -10.0, -5.0, -5.0],
            })
            .collect();
        let (vehicle_start, vehicle_items) = bin(&vehicle_rects, tiles_x, tiles_y);
        let road_here = world.road.centerline.sample(ego.s);
        let (tile_start, mut tile_items) = bin(&rects, tiles_x, tiles_y);
        // Nearest first, so that tracing can stop at the first primitive beyond its hit.
        for t in 0..tiles_x * tiles_y {
            let items = &mut tile_items[tile_start[t] as usize..tile_start[t + 1] as usize];
            items.sort_by(|&a, &b| {
                prims[a as usize]
                    .near
                    .total_cmp(&prims[b as usize].near)
                    .then(a.cmp(&b))
            });
        }
        let mut view = FrameView {
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
            lights: Vec::new(),
            ego_headlight: ego_headlight(&cam),
            light_start: vec![0; tiles_x * tiles_y + 1],
            light_items: Vec::new(),
            glows: Vec::new(),
            shadow_step,
        };
        super::shade::place_lights(&mut view);
        let light_rects: Vec<[f32; 4]> = view
            .lights
            .iter()
            .map(|l| {
                let (lo, hi) = l.reach_box();
                screen_rect(
                    &view.cam,
                    &box_corners(lo, 1.0, 0.0, V3::default(), hi - lo),
                )
                .map_or([-10.0, -10.0, -5.0, -5.0], |(r, _)| r)
            })
            .collect();
        let (ls, li) = bin(&light_rects, tiles_x, tiles_y);
        view.light_start = ls;
        view.light_items = li;
        view
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
        StaticKind::GuardRail => z >= 0.42 || super::math::wrap(x + 40.0, 2.0) < 0.14,
        StaticKind::TreeLine => {
            let Shape::Panel { h, .. } = obj.shape else {
                return true;
            };
            // A row of crowns: rounded bumps on every 3.5 m with random heights, on top of a
            // slowly varying canopy height.
            let salt = obj.salt;
            let canopy = h * (0.6 + 0.4 * value2(x / 9.0, 0.0, salt));
            let cell = super::math::floor(x / 3.5);
            let mut top: f32 = 0.0;
            for k in [cell - 1.0, cell, cell + 1.0] {
                let jitter = super::rng::unit1(k as i32, salt);
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
