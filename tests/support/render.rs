//! Helpers of the render tests: a hand-made frame with two scored objects (maps, heatmap,
//! truth mask, flow) and score series, all generated on the fly.

use image::{GrayImage, Luma, Rgb, RgbImage};
use vadscope::render::SceneObject;
use vadscope::score::{Heatmap, ObjectMaps};
use vadscope::sequence::FlowField;

/// Patch side of the hand-made maps.
pub const P: usize = 8;

/// A frame of `w`×`h`: a sky-to-road gradient with a bright square.
pub fn frame(w: u32, h: u32) -> RgbImage {
    RgbImage::from_fn(w, h, |x, y| {
        let t = (y * 255 / h.max(1)) as u8;
        if x > w / 3 && x < w / 2 && y > h / 3 && y < h / 2 {
            Rgb([230, 210, 60])
        } else {
            Rgb([
                100u8.saturating_sub(t / 3),
                120 - t / 4,
                160u8.saturating_sub(t / 2),
            ])
        }
    })
}

/// Maps whose errors grow from left to right (`scale` times larger for the anomaly).
pub fn maps(scale: f32) -> ObjectMaps {
    let area = P * P;
    ObjectMaps {
        flow_error: (0..area)
            .map(|i| scale * (i % P) as f32 / P as f32)
            .collect(),
        frame_error: (0..area)
            .map(|i| 0.01 * scale * (i / P) as f32 / P as f32)
            .collect(),
        predicted: (0..3 * area).map(|i| (i * 7 % 256) as u8).collect(),
        recon_flow: (0..2 * area)
            .map(|i| if i < area { 2.0 } else { -1.0 })
            .collect(),
    }
}

/// Two boxes in a `w`×`h` frame: a normal one on the left, the anomaly in the middle.
pub fn boxes(w: u32, h: u32) -> [[f32; 4]; 2] {
    let (w, h) = (w as f32, h as f32);
    [
        [0.05 * w, 0.55 * h, 0.25 * w, 0.85 * h],
        [0.3 * w, 0.3 * h, 0.55 * w, 0.55 * h],
    ]
}

/// The two [`boxes`] of a `w`×`h` frame as scored objects (tracks 1 and 2, scores 10 and
/// 50) with `maps` (one per object; fewer leave the rest without maps).
pub fn objects(w: u32, h: u32, maps: &[ObjectMaps]) -> Vec<SceneObject<'_>> {
    boxes(w, h)
        .iter()
        .enumerate()
        .map(|(k, b)| SceneObject {
            bbox: *b,
            track_id: k as u64 + 1,
            score: Some(10.0 + 40.0 * k as f64),
            maps: maps.get(k),
        })
        .collect()
}

/// A heatmap of `w`×`h` that is 0 outside the boxes and rises inside them.
pub fn heatmap(w: u32, h: u32) -> Heatmap {
    let mut heat = Heatmap::new(w, h);
    for (k, b) in boxes(w, h).iter().enumerate() {
        for y in b[1] as u32..(b[3] as u32).min(h) {
            for x in b[0] as u32..(b[2] as u32).min(w) {
                heat.values[(y * w + x) as usize] =
                    (k as f32 + 1.0) * 40.0 * (x - b[0] as u32 + 1) as f32 / (b[2] - b[0]);
            }
        }
    }
    heat
}

/// The anomaly's ground-truth mask (the second box) at `w`×`h`.
pub fn mask(w: u32, h: u32) -> GrayImage {
    let b = boxes(w, h)[1];
    GrayImage::from_fn(w, h, |x, y| {
        let inside =
            (x as f32) >= b[0] && (x as f32) < b[2] && (y as f32) >= b[1] && (y as f32) < b[3];
        Luma([if inside { 255 } else { 0 }])
    })
}

/// A rotating flow field of `w`×`h`.
pub fn flow(w: u32, h: u32) -> FlowField {
    let mut uv = Vec::with_capacity(2 * (w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            uv.push((y as f32 - h as f32 / 2.0) / 8.0);
            uv.push((w as f32 / 2.0 - x as f32) / 8.0);
        }
    }
    FlowField {
        width: w,
        height: h,
        uv,
        valid: None,
    }
}

/// Score series of `n` frames: a slow wave, an anomaly burst in the middle third, truth
/// on the middle third, labels on the first half.
pub struct Series {
    /// Raw fused scores.
    pub fused: Vec<f64>,
    /// Filtered scores.
    pub filtered: Vec<f64>,
    /// z(S_r).
    pub z_r: Vec<f64>,
    /// z(S_p).
    pub z_p: Vec<f64>,
    /// Ground truth.
    pub truth: Vec<bool>,
    /// Analyst labels.
    pub labels: Vec<Option<bool>>,
}

/// The series of `n` frames.
pub fn series(n: usize) -> Series {
    let truth: Vec<bool> = (0..n).map(|i| 3 * i >= n && 3 * i < 2 * n).collect();
    let fused: Vec<f64> = (0..n)
        .map(|i| {
            let wave = 5.0 * ((i as f64) / 7.0).sin() + ((i * 7919) % 13) as f64 * 0.8;
            if truth[i] { wave + 40.0 } else { wave + 10.0 }
        })
        .collect();
    let filtered = vadscope::eval::median_filter(&fused, 17);
    Series {
        z_r: fused.iter().map(|v| v / 10.0).collect(),
        z_p: fused.iter().map(|v| v / 20.0 - 1.0).collect(),
        filtered,
        labels: (0..n).map(|i| (i < n / 2).then_some(truth[i])).collect(),
        fused,
        truth,
    }
}
