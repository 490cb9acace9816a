//! Placing the objects of a frame: the static objects and vehicles near the camera that it
//! may see, as primitives with the screen rectangles they are binned by (shadows and, beside
//! the camera, the ground they darken included), and the per-tile lists built from them.

use super::bounds::{CLIP_DEPTH, bin, box_corners, on_screen, screen_rect};
use super::intersect_vehicle::VehicleEye;
use super::prim::{PANEL_PIECE, Prim, PrimRef};
use crate::synth::camera::Camera;
use crate::synth::math::V3;
use crate::synth::scenery::{Shape, StaticObject};
use crate::synth::traffic::{EGO, VehicleState};
use crate::synth::world::World;

/// Adds the static objects from 60 m behind the camera (at arc length `cam_s`) to `draw`
/// metres ahead that are on screen or cross the camera plane to `prims`, panels in pieces,
/// with the rectangles they are binned by in `rects`.
pub(super) fn place_statics(
    world: &World,
    cam: &Camera,
    cam_s: f32,
    draw: f32,
    prims: &mut Vec<Prim>,
    rects: &mut Vec<[f32; 4]>,
) {
    let w = cam.width as usize;
    let h = cam.height_px as usize;
    let range = world.scenery.range(cam_s - 60.0, cam_s + draw);
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
            if let Some((r, near)) = screen_rect(cam, &corners)
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
}

/// Adds the vehicles within `draw` metres of the camera that are on screen (their shadows
/// included) or cross the camera plane to `prims`, with the rectangles they are binned by
/// in `rects`; `states` are the vehicles' states at the frame and `shadow_step` the sun's
/// shadow offset. Returns each vehicle's [`VehicleEye`] (empty for those not placed).
pub(super) fn place_vehicles(
    world: &World,
    states: &[VehicleState],
    cam: &Camera,
    draw: f32,
    shadow_step: Option<(f32, f32)>,
    prims: &mut Vec<Prim>,
    rects: &mut Vec<[f32; 4]>,
) -> Vec<VehicleEye> {
    let w = cam.width as usize;
    let h = cam.height_px as usize;
    let mut vehicle_eyes = vec![VehicleEye::default(); world.traffic.vehicles.len()];
    for (i, v) in world.traffic.vehicles.iter().enumerate() {
        if i == EGO {
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
        let body_rect =
            screen_rect(cam, &pts).map_or([f32::INFINITY, f32::INFINITY, 0.0, 0.0], |(r, _)| r);
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
        let mut bounds = screen_rect(cam, &pts);
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
            bounds = screen_rect(cam, &pts);
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
    vehicle_eyes
}

/// The tile lists of the vehicle primitives alone (of the primitives `prims` binned by
/// `rects`), for shadow lookups from ground pixels.
pub(super) fn bin_vehicles(
    rects: &[[f32; 4]],
    prims: &[Prim],
    tiles_x: usize,
    tiles_y: usize,
) -> (Vec<u32>, Vec<u32>) {
    let vehicle_rects: Vec<[f32; 4]> = rects
        .iter()
        .zip(prims)
        .map(|(r, p)| match p.what {
            PrimRef::Vehicle(_) => *r,
            PrimRef::Static(_) => [-10.0, -10.0, -5.0, -5.0],
        })
        .collect();
    let (vehicle_start, vehicle_items) = bin(&vehicle_rects, tiles_x, tiles_y);
    (vehicle_start, vehicle_items)
}

/// The tile lists of all primitives `prims` binned by `rects`, each tile's nearest first.
pub(super) fn bin_nearest_first(
    rects: &[[f32; 4]],
    prims: &[Prim],
    tiles_x: usize,
    tiles_y: usize,
) -> (Vec<u32>, Vec<u32>) {
    let (tile_start, mut tile_items) = bin(rects, tiles_x, tiles_y);
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
    (tile_start, tile_items)
}
