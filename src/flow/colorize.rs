//! Flow colouring with the Middlebury colour wheel (Baker et al., ICCV 2007).
//!
//! Direction picks the hue (right red, down yellow-orange, left cyan, up blue-violet) and
//! speed the saturation: zero motion is white, motion at the range limit is the pure wheel
//! colour, motion beyond it is the wheel colour darkened to 75 %. Unknown pixels (invalid or
//! non-finite) are black, or transparent in the RGBA variant.

use image::{Rgb, RgbImage, Rgba, RgbaImage};

use crate::sequence::FlowField;

/// How flow magnitudes map to saturation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum FlowColorRange {
    /// Full saturation at the largest magnitude among the known pixels of this field.
    #[default]
    Auto,
    /// Full saturation at this many pixels, so colours compare across frames. A value that
    /// is not finite and positive falls back to `Auto`.
    Fixed(f32),
}

/// Segment lengths of the Middlebury wheel: red→yellow, yellow→green, green→cyan,
/// cyan→blue, blue→magenta, magenta→red.
const SEGMENTS: [usize; 6] = [15, 6, 4, 11, 13, 6];
const WHEEL_LEN: usize = 55;

/// The 55 hue entries of the wheel, in 0..=255 per channel.
fn wheel() -> [[f32; 3]; WHEEL_LEN] {
    let mut out = [[0.0; 3]; WHEEL_LEN];
    let mut i = 0;
    for (segment, &len) in SEGMENTS.iter().enumerate() {
        for step in 0..len {
            let rise = (255 * step / len) as f32;
            let fall = 255.0 - rise;
            out[i] = match segment {
                0 => [255.0, rise, 0.0],
                1 => [fall, 255.0, 0.0],
                2 => [0.0, 255.0, rise],
                3 => [0.0, fall, 255.0],
                4 => [rise, 0.0, 255.0],
                _ => [255.0, 0.0, fall],
            };
            i += 1;
        }
    }
    out
}

/// Colour of one displacement (u, v) for a range of `max_px` pixels (`max_px > 0`).
pub fn flow_color(u: f32, v: f32, max_px: f32) -> [u8; 3] {
    if !(u.is_finite() && v.is_finite() && max_px.is_finite() && max_px > 0.0) {
        return [0, 0, 0];
    }
    color_with_wheel(&wheel(), u / max_px, v / max_px)
}

fn color_with_wheel(wheel: &[[f32; 3]; WHEEL_LEN], u: f32, v: f32) -> [u8; 3] {
    let radius = (u * u + v * v).sqrt();
    let angle = (-v).atan2(-u) / std::f32::consts::PI;
    let position = (angle + 1.0) * 0.5 * (WHEEL_LEN - 1) as f32;
    let k0 = (position.floor() as usize).min(WHEEL_LEN - 1);
    let k1 = (k0 + 1) % WHEEL_LEN;
    let f = position - k0 as f32;
    let mut out = [0u8; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let hue = ((1.0 - f) * wheel[k0][c] + f * wheel[k1][c]) / 255.0;
        let value = if radius <= 1.0 {
            1.0 - radius * (1.0 - hue)
        } else {
            0.75 * hue
        };
        *o = (255.0 * value).clamp(0.0, 255.0) as u8;
    }
    out
}

/// Displacement of pixel `i`, or `None` where unknown (invalid, non-finite or missing).
fn known(flow: &FlowField, i: usize) -> Option<(f32, f32)> {
    let u = *flow.uv.get(2 * i)?;
    let v = *flow.uv.get(2 * i + 1)?;
    let valid = flow
        .valid
        .as_ref()
        .is_none_or(|m| m.get(i).copied().unwrap_or(false));
    (valid && u.is_finite() && v.is_finite()).then_some((u, v))
}

/// The largest magnitude among known pixels, or 1 px when there is no motion at all, so that
/// a still scene renders white instead of dividing by zero.
pub fn auto_range(flow: &FlowField) -> f32 {
    let pixels = flow.width as usize * flow.height as usize;
    let max = (0..pixels)
        .filter_map(|i| known(flow, i))
        .map(|(u, v)| (u * u + v * v).sqrt())
        .fold(0.0f32, f32::max);
    if max > 0.0 { max } else { 1.0 }
}

fn resolve_range(flow: &FlowField, range: FlowColorRange) -> f32 {
    match range {
        FlowColorRange::Fixed(m) if m.is_finite() && m > 0.0 => m,
        _ => auto_range(flow),
    }
}

/// Renders a flow field as an RGB image of the same size.
pub fn colorize_flow(flow: &FlowField, range: FlowColorRange) -> RgbImage {
    let max = resolve_range(flow, range);
    let wheel = wheel();
    RgbImage::from_fn(flow.width, flow.height, |x, y| {
        let i = y as usize * flow.width as usize + x as usize;
        Rgb(known(flow, i).map_or([0, 0, 0], |(u, v)| {
            color_with_wheel(&wheel, u / max, v / max)
        }))
    })
}

/// Renders a flow field as an RGBA image; unknown pixels are fully transparent.
pub fn colorize_flow_rgba(flow: &FlowField, range: FlowColorRange) -> RgbaImage {
    let max = resolve_range(flow, range);
    let wheel = wheel();
    RgbaImage::from_fn(flow.width, flow.height, |x, y| {
        let i = y as usize * flow.width as usize + x as usize;
        Rgba(known(flow, i).map_or([0, 0, 0, 0], |(u, v)| {
            let [r, g, b] = color_with_wheel(&wheel, u / max, v / max);
            [r, g, b, 255]
        }))
    })
}

/// A square legend: the pixel at offset (dx, dy) from the centre shows the colour of the
/// displacement (dx, dy) for a range equal to the radius. Outside the disc (and one pixel of
/// margin) it is white.
pub fn color_wheel_legend(size: u32) -> RgbImage {
    let wheel = wheel();
    let centre = (size as f32 - 1.0) * 0.5;
    let radius = (centre - 1.0).max(1.0);
    RgbImage::from_fn(size, size, |x, y| {
        let (u, v) = ((x as f32 - centre) / radius, (y as f32 - centre) / radius);
        if u * u + v * v > 1.0 {
            Rgb([255, 255, 255])
        } else {
            Rgb(color_with_wheel(&wheel, u, v))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wheel_has_55_entries_starting_red() {
        let w = wheel();
        assert_eq!(w[0], [255.0, 0.0, 0.0]);
        assert_eq!(w[15], [255.0, 255.0, 0.0]);
        assert_eq!(w[21], [0.0, 255.0, 0.0]);
        assert_eq!(w[25], [0.0, 255.0, 255.0]);
        assert_eq!(w[36], [0.0, 0.0, 255.0]);
        assert_eq!(w[49], [255.0, 0.0, 255.0]);
    }

    #[test]
    fn directions_map_to_the_conventional_hues() {
        // Zero motion is white.
        assert_eq!(flow_color(0.0, 0.0, 1.0), [255, 255, 255]);
        // Full-range rightward motion is red.
        let right = flow_color(1.0, 0.0, 1.0);
        assert!(
            right[0] == 255 && right[1] < 10 && right[2] < 10,
            "{right:?}"
        );
        // Leftward motion is cyan.
        let left = flow_color(-1.0, 0.0, 1.0);
        assert!(left[0] < 10 && left[1] > 200 && left[2] > 200, "{left:?}");
        // Upward motion is blue-violet: blue dominates.
        let up = flow_color(0.0, -1.0, 1.0);
        assert!(up[2] == 255 && up[1] < 10, "{up:?}");
        // Downward motion is yellow-green: red and green high, blue low.
        let down = flow_color(0.0, 1.0, 1.0);
        assert!(down[0] > 100 && down[1] > 200 && down[2] < 10, "{down:?}");
        // Beyond the range the colour darkens.
        let beyond = flow_color(2.0, 0.0, 1.0);
        assert_eq!(beyond, [191, 0, 0]);
    }

    #[test]
    fn unknown_and_malformed_pixels_are_black_and_nothing_panics() {
        let mut flow = FlowField::zeros(3, 2);
        flow.uv[0] = f32::NAN;
        flow.uv[2] = 4.0;
        flow.valid = Some(vec![true, true, false, true, true, true]);
        let img = colorize_flow(&flow, FlowColorRange::Auto);
        assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
        assert_eq!(img.get_pixel(2, 0).0, [0, 0, 0]);
        assert_eq!(img.get_pixel(1, 0).0, [255, 0, 0]);
        assert_eq!(img.get_pixel(0, 1).0, [255, 255, 255]);
        let rgba = colorize_flow_rgba(&flow, FlowColorRange::Fixed(8.0));
        assert_eq!(rgba.get_pixel(2, 0).0[3], 0);
        assert_eq!(rgba.get_pixel(1, 0).0[3], 255);
        // A buffer shorter than the declared size renders as unknown, not a panic.
        flow.uv.truncate(4);
        flow.valid = None;
        let img = colorize_flow(&flow, FlowColorRange::Fixed(f32::NAN));
        assert_eq!(img.get_pixel(2, 1).0, [0, 0, 0]);
    }

    #[test]
    fn legend_centre_is_white_and_rim_is_saturated() {
        let legend = color_wheel_legend(65);
        assert_eq!(legend.get_pixel(32, 32).0, [255, 255, 255]);
        let rim = legend.get_pixel(63, 32).0;
        assert!(rim[0] == 255 && rim[1] < 10 && rim[2] < 10, "{rim:?}");
    }
}
