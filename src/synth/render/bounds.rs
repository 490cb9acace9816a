//! Screen bounds and tiles: the screen rectangle of a set of camera-relative points (cut
//! at the camera plane where they cross it), and the compressed per-tile lists that items
//! with such rectangles are binned into.

use crate::synth::camera::Camera;
use crate::synth::math::V3;

/// Tile size in pixels.
pub const TILE: usize = 16;

/// Depth of the plane at which bounds that cross the camera plane are cut: nothing the camera
/// sees comes within a millimetre of it.
pub(super) const CLIP_DEPTH: f32 = 1e-3;

/// Screen rectangle of the convex hull of a set of camera-relative points, or `None` if all
/// are behind the camera, and the smallest depth of the hull's visible part (exactly
/// [`CLIP_DEPTH`] for a hull that crosses the camera plane).
///
/// A hull that crosses the camera plane is cut at [`CLIP_DEPTH`] and bounded by what lies
/// in front: its own points there and the points where its edges meet the cutting plane
/// (every pair of a point in front and one behind, a superset of the hull's edges). Such
/// hulls are the walls, guard rails and parked cars right beside the camera; bounding them
/// by the whole image would make every pixel test them.
pub(super) fn screen_rect(cam: &Camera, pts: &[V3]) -> Option<([f32; 4], f32)> {
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
pub(super) fn on_screen(r: &[f32; 4], w: usize, h: usize) -> bool {
    r[0] < w as f32 && r[1] < h as f32 && r[2] > 0.0 && r[3] > 0.0
}

/// The eight corners of the box `lo..=hi` of an object at `origin` turned by the yaw with
/// cosine `c` and sine `s`.
pub(super) fn box_corners(origin: V3, c: f32, s: f32, lo: V3, hi: V3) -> [V3; 8] {
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
pub(super) fn bin(rects: &[[f32; 4]], tiles_x: usize, tiles_y: usize) -> (Vec<u32>, Vec<u32>) {
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
