//! The model's per-object planes as small images: the predicted patch, colorized error
//! maps, the reconstructed flow, and the matching crops of the actual frame and flow, all
//! P×P as the cube saw them.

use image::{Rgb, RgbImage};

use crate::flow::flow_color;
use crate::sequence::FlowField;

use super::canvas::sample_taps;
use super::colormap::Colormap;

/// Side P of square planes of `len` values per channel (`len` = channels·P²).
pub(crate) fn patch_side(len: usize, channels: usize) -> u32 {
    ((len / channels.max(1)) as f64).sqrt() as u32
}

/// Planar RGB bytes (3·P²) as a P×P image.
pub(crate) fn planar_rgb(planes: &[u8]) -> RgbImage {
    let p = patch_side(planes.len(), 3);
    let area = (p * p) as usize;
    RgbImage::from_fn(p.max(1), p.max(1), |x, y| {
        let i = (y * p + x) as usize;
        if i < area {
            Rgb([planes[i], planes[area + i], planes[2 * area + i]])
        } else {
            Rgb([0, 0, 0])
        }
    })
}

/// A P×P map colorized over `range`.
pub(crate) fn colorized_map(map: &[f32], colormap: Colormap, (low, high): (f32, f32)) -> RgbImage {
    let p = patch_side(map.len(), 1).max(1);
    let span = if high > low { high - low } else { 1.0 };
    RgbImage::from_fn(p, p, |x, y| {
        let v = map.get((y * p + x) as usize).copied().unwrap_or(0.0);
        Rgb(colormap.colorize((v - low) / span))
    })
}

/// Planar (u, v) flow (2·P²) colorized on the colour wheel at `max_px`.
pub(crate) fn planar_flow(planes: &[f32], max_px: f32) -> RgbImage {
    let p = patch_side(planes.len(), 2).max(1);
    let area = (p * p) as usize;
    RgbImage::from_fn(p, p, |x, y| {
        let i = (y * p + x) as usize;
        match (planes.get(i), planes.get(area + i)) {
            (Some(&u), Some(&v)) => Rgb(flow_color(u, v, max_px)),
            _ => Rgb([0, 0, 0]),
        }
    })
}

/// The crop of a box [x1, y1, x2, y2] as the cube takes it (columns ⌈x1⌉…⌈x2⌉−1, rows
/// ⌈y1⌉…⌈y2⌉−1, clipped), or `None` when it is empty.
pub(crate) fn crop_range(bbox: [f32; 4], (w, h): (u32, u32)) -> Option<(u32, u32, u32, u32)> {
    let side = |lo: f32, hi: f32, size: u32| {
        let a = lo.ceil().clamp(0.0, size as f32) as u32;
        let b = hi.ceil().clamp(0.0, size as f32) as u32;
        (b > a).then_some((a, b))
    };
    let (x0, x1) = side(bbox[0], bbox[2], w)?;
    let (y0, y1) = side(bbox[1], bbox[3], h)?;
    Some((x0, y0, x1, y1))
}

/// The box's crop of `frame` resized bilinearly to `p`×`p`.
pub(crate) fn frame_crop(frame: &RgbImage, bbox: [f32; 4], p: u32) -> Option<RgbImage> {
    let (x0, y0, x1, y1) = crop_range(bbox, frame.dimensions())?;
    let xs = sample_taps(x1 - x0, p);
    let ys = sample_taps(y1 - y0, p);
    Some(RgbImage::from_fn(p, p, |x, y| {
        let (a, b, fx) = xs[x as usize];
        let (c, d, fy) = ys[y as usize];
        let at = |xx: usize, yy: usize| frame.get_pixel(x0 + xx as u32, y0 + yy as u32).0;
        Rgb(std::array::from_fn(|ch| {
            let top = f32::from(at(a, c)[ch]) * (1.0 - fx) + f32::from(at(b, c)[ch]) * fx;
            let bottom = f32::from(at(a, d)[ch]) * (1.0 - fx) + f32::from(at(b, d)[ch]) * fx;
            (top * (1.0 - fy) + bottom * fy).round() as u8
        }))
    }))
}

/// The box's crop of `flow` (frame-sized grid) resized to `p`×`p`, planar u then v.
pub(crate) fn flow_crop(
    flow: &FlowField,
    bbox: [f32; 4],
    frame: (u32, u32),
    p: u32,
) -> Option<Vec<f32>> {
    if flow.uv.len() < 2 * flow.width as usize * flow.height as usize {
        return None;
    }
    let gx = flow.width as f32 / frame.0.max(1) as f32;
    let gy = flow.height as f32 / frame.1.max(1) as f32;
    let scaled = [bbox[0] * gx, bbox[1] * gy, bbox[2] * gx, bbox[3] * gy];
    let (x0, y0, x1, y1) = crop_range(scaled, (flow.width, flow.height))?;
    let xs = sample_taps(x1 - x0, p);
    let ys = sample_taps(y1 - y0, p);
    let area = (p * p) as usize;
    let mut out = vec![0.0f32; 2 * area];
    for (y, &(c, d, fy)) in ys.iter().enumerate() {
        for (x, &(a, b, fx)) in xs.iter().enumerate() {
            for ch in 0..2 {
                let at = |xx: usize, yy: usize| {
                    let i = (y0 as usize + yy) * flow.width as usize + x0 as usize + xx;
                    flow.uv[2 * i + ch]
                };
                let top = at(a, c) * (1.0 - fx) + at(b, c) * fx;
                let bottom = at(a, d) * (1.0 - fx) + at(b, d) * fx;
                let scale = if ch == 0 { 1.0 / gx } else { 1.0 / gy };
                out[ch * area + y * p as usize + x] = (top * (1.0 - fy) + bottom * fy) * scale;
            }
        }
    }
    Some(out)
}

/// The colour range of error maps: `fixed` when given, else 0 to the largest of `errors`
/// (1 when none is above 0); and whether it is that automatic range.
pub(crate) fn error_range(
    fixed: Option<(f32, f32)>,
    errors: impl IntoIterator<Item = f32>,
) -> ((f32, f32), bool) {
    match fixed {
        Some(range) => (range, false),
        None => ((0.0, max_or(errors, 1.0)), true),
    }
}

/// Largest finite value of `values`, or `fallback` when there is none above 0.
pub(crate) fn max_or(values: impl IntoIterator<Item = f32>, fallback: f32) -> f32 {
    let max = values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(0.0f32, f32::max);
    if max > 0.0 { max } else { fallback }
}
