//! The crop-and-resize HF²-VAD applies to an object box, shared by the model's cubes
//! (`model::stc`), the flow metrics on box crops (`flow::metrics`) and the pixel heatmap
//! that paints the maps back (`score::fusion`), so all of them agree on the pixels: the box's edges are rounded up (columns ⌈x1⌉…⌈x2⌉−1, rows ⌈y1⌉…⌈y2⌉−1, clamped
//! to the image) and the crop is resized to P×P the way OpenCV's `INTER_LINEAR` samples
//! (half-pixel centres, edge clamping, source positions in double precision, weights and
//! blending in single precision, horizontal before vertical).

/// A crop: columns `[x0, x1)` and rows `[y0, y1)`, as `((x0, x1), (y0, y1))`.
pub type Crop = ((u32, u32), (u32, u32));

/// Pixel range [start, end) of a box edge pair after the reference's rounding, clamped to
/// `0..size`.
pub fn crop_range(lo: f32, hi: f32, size: u32) -> Option<(u32, u32)> {
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let start = lo.ceil().clamp(0.0, size as f32) as u32;
    let end = hi.ceil().clamp(0.0, size as f32) as u32;
    (end > start).then_some((start, end))
}

/// OpenCV `INTER_LINEAR` source position for output pixel `d` when resizing `len` → `out`:
/// (left index, right index, weight of the right one).
pub fn taps(d: usize, len: u32, out: usize) -> (usize, usize, f32) {
    let scale = len as f64 / out as f64;
    let f = (d as f64 + 0.5) * scale - 0.5;
    let mut s = f.floor();
    let mut w = f - s;
    if s < 0.0 {
        s = 0.0;
        w = 0.0;
    }
    let last = (len - 1) as f64;
    if s >= last {
        s = last;
        w = 0.0;
    }
    let s = s as usize;
    (s, (s + 1).min(len as usize - 1), w as f32)
}

/// Bilinear resize of the crop `[x0, x1) × [y0, y1)` of an interleaved `channels`-channel
/// image of `width` columns, read through `at(offset)`, into `out` planes of P×P.
pub fn resize_crop(
    crop: Crop,
    width: u32,
    channels: usize,
    patch: usize,
    at: impl Fn(usize) -> f32,
    mut put: impl FnMut(usize, usize, usize, f32),
) {
    let ((x0, x1), (y0, y1)) = crop;
    let xs: Vec<_> = (0..patch).map(|d| taps(d, x1 - x0, patch)).collect();
    for dy in 0..patch {
        let (ya, yb, wy) = taps(dy, y1 - y0, patch);
        let row_a = (y0 as usize + ya) * width as usize;
        let row_b = (y0 as usize + yb) * width as usize;
        for (dx, &(xa, xb, wx)) in xs.iter().enumerate() {
            let (ca, cb) = (x0 as usize + xa, x0 as usize + xb);
            for c in 0..channels {
                let p = |row: usize, col: usize| at((row + col) * channels + c);
                let top = p(row_a, ca) * (1.0 - wx) + p(row_a, cb) * wx;
                let bottom = p(row_b, ca) * (1.0 - wx) + p(row_b, cb) * wx;
                put(c, dy, dx, top * (1.0 - wy) + bottom * wy);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downscaling_matches_opencv_sampling_positions() {
        // 4 → 2: output pixel 0 samples source 0.5 (half-way between pixels 0 and 1).
        assert_eq!(taps(0, 4, 2), (0, 1, 0.5));
        assert_eq!(taps(1, 4, 2), (2, 3, 0.5));
        // 2 → 4: the first output pixel clamps to the left edge.
        assert_eq!(taps(0, 2, 4), (0, 1, 0.0));
        assert_eq!(taps(3, 2, 4), (1, 1, 0.0));
    }
}
