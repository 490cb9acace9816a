//! Exact optical flow from scene geometry and motion.
//!
//! For every pixel p of frame t-1 the surface point it shows is moved with its object
//! (static world: not at all; vehicles: rigidly with their pose) and projected into frame t.
//! The flow is defined on the pixel grid of frame t-1: f(p) = q - p. It is valid where q lies
//! inside frame t and the ray through q in frame t sees the same object at the same depth
//! (not occluded); sky pixels get zero, invalid flow.

use rayon::prelude::*;

use super::gbuffer::GBuffer;
use super::keys::{KEY_BACKDROP, KEY_SKY, KEY_VEHICLE};
use super::math::V3;
use super::render::FrameView;
use super::world::World;
use crate::sequence::FlowField;

/// Relative depth tolerance of the occlusion test.
const DEPTH_TOL_REL: f32 = 0.01;
/// Absolute depth tolerance of the occlusion test (m).
const DEPTH_TOL_ABS: f32 = 0.03;

/// Decides visibility from the next frame's geometry buffer when that is unambiguous: the
/// four pixel centres around q all show the object and their depths, interpolated to q,
/// agree with the point's depth. Returns `None` when a ray must be cast.
#[inline]
fn quick_visibility(next: &GBuffer, u: f32, v: f32, key: u32, z: f32, tol: f32) -> Option<bool> {
    let (w, h) = (next.width, next.height);
    let x = u - 0.5;
    let y = v - 0.5;
    if x < 0.0 || y < 0.0 {
        return None;
    }
    let (x0, y0) = (x as usize, y as usize);
    if x0 + 1 >= w || y0 + 1 >= h {
        return None;
    }
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let i = y0 * w + x0;
    let idx = [i, i + 1, i + w, i + w + 1];
    if idx.iter().any(|&k| next.key[k] != key) {
        return None;
    }
    if key == KEY_BACKDROP {
        return Some(true);
    }
    let d = |k: usize| next.depth[idx[k]];
    let depth = (d(0) * (1.0 - fx) + d(1) * fx) * (1.0 - fy) + (d(2) * (1.0 - fx) + d(3) * fx) * fy;
    ((depth - z).abs() <= tol).then_some(true)
}

/// Flow from the frame of `prev` to the frame of `view`, whose geometry buffer is `next`.
pub fn exact_flow(world: &World, prev: &GBuffer, view: &FrameView, next: &GBuffer) -> FlowField {
    let w = prev.width;
    let h = prev.height;
    let states_now = &world.traffic.states[view.frame];
    let cam = &view.cam;
    let mut uv = vec![0.0f32; 2 * w * h];
    let mut valid = vec![false; w * h];
    uv.par_chunks_mut(2 * w)
        .zip(valid.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (uv_row, valid_row))| {
            for x in 0..w {
                let i = y * w + x;
                let key = prev.key[i];
                if key == KEY_SKY {
                    continue;
                }
                let point = prev.point[i];
                let projected = if key == KEY_BACKDROP {
                    cam.project_direction(point)
                } else if key & KEY_VEHICLE != 0 {
                    let vi = (key & !KEY_VEHICLE) as usize;
                    let st = &states_now[vi];
                    let world_p =
                        V3::new(st.x, st.y, 0.0) + point.rotate_z(st.yaw.cos(), st.yaw.sin());
                    cam.project(world_p)
                } else {
                    cam.project(point)
                };
                let Some(q) = projected else {
                    continue;
                };
                uv_row[2 * x] = q.u - (x as f32 + 0.5);
                uv_row[2 * x + 1] = q.v - (y as f32 + 0.5);
                if q.u < 0.0 || q.v < 0.0 || q.u >= w as f32 || q.v >= h as f32 {
                    continue;
                }
                let tol = DEPTH_TOL_REL * q.z + DEPTH_TOL_ABS;
                valid_row[x] = match quick_visibility(next, q.u, q.v, key, q.z, tol) {
                    Some(v) => v,
                    None => {
                        let seen = view.trace_point(q.u, q.v);
                        seen.key == key && (key == KEY_BACKDROP || (seen.t - q.z).abs() <= tol)
                    }
                };
            }
        });
    FlowField {
        width: w as u32,
        height: h as u32,
        uv,
        valid: Some(valid),
    }
}
