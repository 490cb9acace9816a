//! Single-channel `f32` image planes: conversion from `image` buffers, the 2×2 area pyramid
//! step, Sobel gradients and a replicate-padded copy for fast bilinear sampling.

use image::{GrayImage, RgbImage, RgbaImage};

/// A frame the estimator accepts: anything that can give its size and a luminance plane.
///
/// Implemented for `image`'s 8-bit grey, RGB and RGBA buffers; RGB is converted with the
/// Rec. 601 luma weights (0.299, 0.587, 0.114), as OpenCV's grey conversion does.
pub trait FlowFrame {
    /// Width and height in pixels.
    fn frame_size(&self) -> (u32, u32);
    /// Row-major luminance, `width * height` values in 0..=255.
    fn luma(&self) -> Vec<f32>;
}

impl FlowFrame for GrayImage {
    fn frame_size(&self) -> (u32, u32) {
        self.dimensions()
    }

    fn luma(&self) -> Vec<f32> {
        self.as_raw().iter().map(|&v| f32::from(v)).collect()
    }
}

fn rgb_luma(r: u8, g: u8, b: u8) -> f32 {
    0.299 * f32::from(r) + 0.587 * f32::from(g) + 0.114 * f32::from(b)
}

impl FlowFrame for RgbImage {
    fn frame_size(&self) -> (u32, u32) {
        self.dimensions()
    }

    fn luma(&self) -> Vec<f32> {
        self.as_raw()
            .chunks_exact(3)
            .map(|p| rgb_luma(p[0], p[1], p[2]))
            .collect()
    }
}

impl FlowFrame for RgbaImage {
    fn frame_size(&self) -> (u32, u32) {
        self.dimensions()
    }

    fn luma(&self) -> Vec<f32> {
        self.as_raw()
            .chunks_exact(4)
            .map(|p| rgb_luma(p[0], p[1], p[2]))
            .collect()
    }
}

/// A dense row-major `f32` image without padding.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Plane {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f32>,
}

impl Plane {
    /// A plane of zeros.
    pub fn zeros(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: vec![0.0; width * height],
        }
    }

    /// Wraps a buffer whose length the caller has checked to be `width * height`.
    pub fn from_vec(width: usize, height: usize, data: Vec<f32>) -> Self {
        debug_assert_eq!(data.len(), width * height);
        Self {
            width,
            height,
            data,
        }
    }

    /// Row `y` as a slice.
    #[inline]
    pub fn row(&self, y: usize) -> &[f32] {
        &self.data[y * self.width..(y + 1) * self.width]
    }

    /// The next coarser pyramid level: the binomial filter [1, 3, 3, 1] / 8 in each
    /// direction (a 2×2 mean after a [1, 2, 1] / 4 blur), then every second pixel. Pixel
    /// centres map as `x_coarse = (x_fine + 0.5) / 2 − 0.5`; an odd last row or column only
    /// contributes through the filter. A plain 2×2 mean aliases fine texture so strongly
    /// that sub-pixel motion at coarse levels is lost (measured: 3× the EPE at 1/32 scale).
    pub fn downsample2(&self) -> Plane {
        let (w, h) = (self.width, self.height);
        let (cw, ch) = (w / 2, h / 2);
        if cw == 0 || ch == 0 {
            return Plane::zeros(cw, ch);
        }
        // Horizontal pass: output column x blends input columns 2x−1 ..= 2x+2.
        let mut half = vec![0.0f32; cw * h];
        for (y, out) in half.chunks_exact_mut(cw).enumerate() {
            let row = self.row(y);
            let at = |i: isize| row[i.clamp(0, w as isize - 1) as usize];
            let edge = |x: usize| {
                let i = 2 * x as isize;
                0.125 * (at(i - 1) + 3.0 * at(i) + 3.0 * at(i + 1) + at(i + 2))
            };
            // Interior outputs 1 ..= (w − 3) / 2 read columns 1 ..= w − 1 without clamping.
            let last_interior = w.saturating_sub(3) / 2;
            out[0] = edge(0);
            for (x, o) in out.iter_mut().enumerate().take(last_interior + 1).skip(1) {
                let s = &row[2 * x - 1..2 * x + 3];
                *o = 0.125 * (s[0] + 3.0 * s[1] + 3.0 * s[2] + s[3]);
            }
            for (x, o) in out.iter_mut().enumerate().skip((last_interior + 1).max(1)) {
                *o = edge(x);
            }
        }
        let mut data = vec![0.0f32; cw * ch];
        for (y, out) in data.chunks_exact_mut(cw).enumerate() {
            let i = 2 * y as isize;
            let r = |k: isize| {
                let k = k.clamp(0, h as isize - 1) as usize;
                &half[k * cw..(k + 1) * cw]
            };
            let (a, b, c, d) = (r(i - 1), r(i), r(i + 1), r(i + 2));
            for x in 0..cw {
                out[x] = 0.125 * (a[x] + 3.0 * b[x] + 3.0 * c[x] + d[x]);
            }
        }
        Plane::from_vec(cw, ch, data)
    }

    /// Horizontal and vertical derivatives by the 3×3 Sobel operator divided by 8, i.e. in
    /// grey levels per pixel, with replicated borders.
    pub fn sobel_gradients(&self) -> (Plane, Plane) {
        let (w, h) = (self.width, self.height);
        let mut gx = Plane::zeros(w, h);
        let mut gy = Plane::zeros(w, h);
        if w == 0 || h == 0 {
            return (gx, gy);
        }
        for y in 0..h {
            let up = self.row(y.saturating_sub(1));
            let mid = self.row(y);
            let down = self.row((y + 1).min(h - 1));
            let out_x = &mut gx.data[y * w..(y + 1) * w];
            let out_y = &mut gy.data[y * w..(y + 1) * w];
            for x in 0..w {
                let l = x.saturating_sub(1);
                let r = (x + 1).min(w - 1);
                let dx_up = up[r] - up[l];
                let dx_mid = mid[r] - mid[l];
                let dx_down = down[r] - down[l];
                out_x[x] = 0.125 * (dx_up + 2.0 * dx_mid + dx_down);
                let sum_down = down[l] + 2.0 * down[x] + down[r];
                let sum_up = up[l] + 2.0 * up[x] + up[r];
                out_y[x] = 0.125 * (sum_down - sum_up);
            }
        }
        (gx, gy)
    }

    /// Bilinear sample at a continuous position, replicating the border.
    #[inline]
    pub fn sample_clamped(&self, x: f32, y: f32) -> f32 {
        let max_x = (self.width - 1) as f32;
        let max_y = (self.height - 1) as f32;
        let x = x.clamp(0.0, max_x);
        let y = y.clamp(0.0, max_y);
        // Non-negative after clamping, so truncation is the floor (and cheaper than
        // `floor`, a library call on baseline x86-64).
        let x0 = x as usize;
        let y0 = y as usize;
        let fx = x - x0 as f32;
        let fy = y - y0 as f32;
        let x1 = (x0 + 1).min(self.width - 1);
        let y1 = (y0 + 1).min(self.height - 1);
        let top = self.row(y0);
        let bottom = self.row(y1);
        let t = top[x0] + fx * (top[x1] - top[x0]);
        let b = bottom[x0] + fx * (bottom[x1] - bottom[x0]);
        t + fy * (b - t)
    }
}

/// A plane with a replicated border of `pad` pixels on every side, so that bilinear
/// sampling of a whole patch needs no per-pixel bounds check while the patch stays within
/// the border.
#[derive(Debug, Clone)]
pub(crate) struct PaddedPlane {
    pub width: usize,
    pub height: usize,
    pub pad: usize,
    pub stride: usize,
    pub data: Vec<f32>,
}

impl PaddedPlane {
    /// Copies `plane` into the middle of a buffer and replicates its edge pixels outwards.
    pub fn new(plane: &Plane, pad: usize) -> Self {
        let (w, h) = (plane.width, plane.height);
        let stride = w + 2 * pad;
        let mut data = vec![0.0; stride * (h + 2 * pad)];
        for py in 0..h + 2 * pad {
            let src = plane.row(py.saturating_sub(pad).min(h - 1));
            let dst = &mut data[py * stride..(py + 1) * stride];
            dst[..pad].fill(src[0]);
            dst[pad..pad + w].copy_from_slice(src);
            dst[pad + w..].fill(src[w - 1]);
        }
        Self {
            width: w,
            height: h,
            pad,
            stride,
            data,
        }
    }

    /// Index into `data` of image pixel (x, y); both may be negative down to `-pad`.
    #[inline]
    pub fn index(&self, x: isize, y: isize) -> usize {
        (y + self.pad as isize) as usize * self.stride + (x + self.pad as isize) as usize
    }

    /// Bilinear sample at a continuous position; positions beyond the padding are clamped,
    /// which extends the replicated border indefinitely.
    #[inline]
    pub fn sample(&self, x: f32, y: f32) -> f32 {
        // Padded coordinates are non-negative after clamping, so truncation is the floor.
        let pad = self.pad as f32;
        let x = x.clamp(-pad, (self.width + self.pad - 2) as f32) + pad;
        let y = y.clamp(-pad, (self.height + self.pad - 2) as f32) + pad;
        let (x0, y0) = (x as usize, y as usize);
        let fx = x - x0 as f32;
        let fy = y - y0 as f32;
        let i = y0 * self.stride + x0;
        let top = self.data[i] + fx * (self.data[i + 1] - self.data[i]);
        let j = i + self.stride;
        let bottom = self.data[j] + fx * (self.data[j + 1] - self.data[j]);
        top + fy * (bottom - top)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(width: usize, height: usize) -> Plane {
        let data = (0..height)
            .flat_map(|y| (0..width).map(move |x| 3.0 * x as f32 + 5.0 * y as f32))
            .collect();
        Plane::from_vec(width, height, data)
    }

    #[test]
    fn sobel_of_a_ramp_is_its_slope_inside() {
        let (gx, gy) = ramp(9, 7).sobel_gradients();
        for y in 1..6 {
            for x in 1..8 {
                assert!((gx.data[y * 9 + x] - 3.0).abs() < 1e-5);
                assert!((gy.data[y * 9 + x] - 5.0).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn downsample_keeps_the_pixel_centre_mapping_of_a_ramp() {
        let fine = ramp(13, 11);
        let coarse = fine.downsample2();
        assert_eq!((coarse.width, coarse.height), (6, 5));
        // Where the filter support lies inside the image, coarse pixel (x, y) takes the
        // ramp's value at fine position (2x + 0.5, 2y + 0.5).
        for y in 1..4 {
            for x in 1..5 {
                let expected = 3.0 * (2.0 * x as f32 + 0.5) + 5.0 * (2.0 * y as f32 + 0.5);
                assert!((coarse.data[y * 6 + x] - expected).abs() < 1e-4);
            }
        }
    }

    #[test]
    fn downsample_of_a_constant_is_that_constant_everywhere() {
        let flat = Plane::from_vec(7, 5, vec![42.0; 35]);
        let coarse = flat.downsample2();
        assert!(coarse.data.iter().all(|&v| (v - 42.0).abs() < 1e-5));
    }

    #[test]
    fn padded_sampling_matches_clamped_sampling_everywhere() {
        let plane = ramp(6, 5);
        let padded = PaddedPlane::new(&plane, 3);
        for &(x, y) in &[
            (0.0, 0.0),
            (2.3, 1.7),
            (-2.5, 4.9),
            (7.5, -1.2),
            (40.0, 40.0),
        ] {
            let a = padded.sample(x, y);
            let b = plane.sample_clamped(x, y);
            assert!((a - b).abs() < 1e-4, "({x}, {y}): {a} vs {b}");
        }
    }
}
