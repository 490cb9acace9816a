//! CARLA's raw 24-bit depth encoding, used by AnoVox `DEPTH_IMG` / `DEPTH_CAM` PNGs.
//!
//! The depth in metres is `1000 · (R + 256·G + 65536·B) / (2²⁴ − 1)` (CARLA sensor
//! reference), so the far plane is 1000 m and one step is about 0.06 mm.

use image::{ImageBuffer, Luma, RgbImage};

/// A depth map in metres, one `f32` per pixel.
pub type DepthMap = ImageBuffer<Luma<f32>, Vec<f32>>;

/// CARLA's far plane: the depth that the largest 24-bit code stands for.
pub const FAR_PLANE_M: f64 = 1000.0;

const MAX_CODE: f64 = 16_777_215.0;

/// Encodes a depth in metres as CARLA's (R, G, B) bytes. Values outside [0, 1000] m are
/// clamped; NaN encodes as 0.
#[inline]
pub fn depth_to_rgb(metres: f32) -> [u8; 3] {
    // Rounded half away from zero by truncation, as `f64::round` does (which is a library
    // call on baseline x86-64 and was most of the cost of a depth image). Clamped first, so
    // the truncation is exact and so is `x - t`; NaN stays NaN and truncates to 0.
    let x = (f64::from(metres) / FAR_PLANE_M * MAX_CODE).clamp(-1.0, MAX_CODE + 1.0);
    let t = x as i64;
    let frac = x - t as f64;
    let rounded = t + i64::from(frac >= 0.5) - i64::from(frac <= -0.5);
    let code = rounded.clamp(0, MAX_CODE as i64) as u32;
    [
        (code & 0xff) as u8,
        ((code >> 8) & 0xff) as u8,
        (code >> 16) as u8,
    ]
}

/// Decodes CARLA's (R, G, B) bytes into metres.
pub fn rgb_to_depth(rgb: [u8; 3]) -> f32 {
    let code = u32::from(rgb[0]) | (u32::from(rgb[1]) << 8) | (u32::from(rgb[2]) << 16);
    (f64::from(code) * FAR_PLANE_M / MAX_CODE) as f32
}

/// Encodes a row-major depth buffer (metres) as a CARLA depth image. Returns `None` when
/// the buffer length is not `width · height`.
pub fn encode_depth_image(width: u32, height: u32, metres: &[f32]) -> Option<RgbImage> {
    if metres.len() != width as usize * height as usize {
        return None;
    }
    let mut bytes = vec![0u8; 3 * metres.len()];
    for (px, &m) in bytes.chunks_exact_mut(3).zip(metres) {
        px.copy_from_slice(&depth_to_rgb(m));
    }
    RgbImage::from_raw(width, height, bytes)
}

/// Decodes a CARLA depth image into metres.
pub fn decode_depth_image(image: &RgbImage) -> DepthMap {
    let metres = image.pixels().map(|p| rgb_to_depth(p.0)).collect();
    DepthMap::from_raw(image.width(), image.height(), metres)
        .expect("one depth value per pixel of the source image")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn code_extremes_map_to_zero_and_far_plane() {
        assert_eq!(rgb_to_depth([0, 0, 0]), 0.0);
        assert_eq!(rgb_to_depth([255, 255, 255]), 1000.0);
        assert_eq!(depth_to_rgb(1000.0), [255, 255, 255]);
        assert_eq!(depth_to_rgb(5000.0), [255, 255, 255]);
        assert_eq!(depth_to_rgb(-3.0), [0, 0, 0]);
        assert_eq!(depth_to_rgb(f32::NAN), [0, 0, 0]);
    }

    #[test]
    fn depth_codes_round_like_f64_round() {
        let reference = |m: f32| {
            let scaled = (f64::from(m) / FAR_PLANE_M * MAX_CODE).round();
            let code = if scaled.is_nan() {
                0
            } else {
                scaled.clamp(0.0, MAX_CODE) as u32
            };
            [code as u8, (code >> 8) as u8, (code >> 16) as u8]
        };
        let mut values = vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0, 1e30];
        // Depths spread over every binade up to 1001 m (by bit pattern), and the f32 depths
        // nearest to the ties between codes with their neighbours.
        let up_to = 1001.0f32.to_bits();
        values.extend((0..up_to).step_by(9973).map(f32::from_bits));
        for k in (0..16_777_215u32).step_by(251) {
            let tie = ((f64::from(k) + 0.5) * FAR_PLANE_M / MAX_CODE) as f32;
            values.extend([tie, tie.next_up(), tie.next_down()]);
        }
        for m in values {
            assert_eq!(depth_to_rgb(m), reference(m), "{m:e}");
        }
    }

    #[test]
    fn channel_order_is_r_low_byte_b_high_byte() {
        // 1000 * 65536 / (2^24 - 1): a pure blue code of 1 is 65536 steps.
        let blue_one = rgb_to_depth([0, 0, 1]);
        assert!((blue_one - 3.906_25).abs() < 1e-3, "{blue_one}");
        assert_eq!(depth_to_rgb(blue_one), [0, 0, 1]);
    }

    #[test]
    fn round_trip_is_within_one_code_step() {
        let step = (FAR_PLANE_M / MAX_CODE) as f32;
        for m in [0.0_f32, 0.01, 1.5, 7.25, 42.0, 123.456, 999.9] {
            let back = rgb_to_depth(depth_to_rgb(m));
            assert!((back - m).abs() <= step.max(m * 1e-6), "{m} -> {back}");
        }
    }

    #[test]
    fn image_round_trip_and_length_check() {
        let metres = vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let image = encode_depth_image(3, 2, &metres).expect("length matches");
        let back = decode_depth_image(&image);
        assert_eq!(back.dimensions(), (3, 2));
        assert!((back.get_pixel(2, 1).0[0] - 6.0).abs() < 1e-4);
        assert!(encode_depth_image(4, 2, &metres).is_none());
    }
}
