//! Flow accuracy metrics: end-point error over a whole field and inside object boxes after
//! the crop-and-resize that HF²-VAD applies to build its 32×32 inputs.

use serde::{Deserialize, Serialize};

use super::dis::check_flow_shape;
use super::error::FlowError;
use crate::box_crop::{crop_range, resize_crop, taps};
use crate::sequence::FlowField;

/// End-point error (Euclidean distance between estimated and true vectors) of a whole field.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EndpointError {
    /// Mean EPE over every pixel where both fields are finite (ground-truth validity
    /// ignored, like Sintel's "all"), in pixels.
    pub mean_all: f64,
    /// Mean EPE over the pixels the ground truth marks valid; `None` if there are none.
    pub mean_valid: Option<f64>,
    /// Number of pixels counted in `mean_all`.
    pub pixels: usize,
    /// Number of pixels counted in `mean_valid`.
    pub valid_pixels: usize,
}

/// Compares an estimate with ground truth on the same grid.
///
/// Pixels where either field holds a non-finite value are skipped; validity is taken from
/// `truth` (the estimate's own mask is ignored).
pub fn endpoint_error(estimate: &FlowField, truth: &FlowField) -> Result<EndpointError, FlowError> {
    check_flow_shape(truth, truth.width, truth.height, "ground-truth flow")?;
    check_flow_shape(estimate, truth.width, truth.height, "estimated flow")?;
    let (mut sum_all, mut n_all, mut sum_valid, mut n_valid) = (0.0f64, 0usize, 0.0f64, 0usize);
    let pixels = truth.width as usize * truth.height as usize;
    for i in 0..pixels {
        let du = estimate.uv[2 * i] - truth.uv[2 * i];
        let dv = estimate.uv[2 * i + 1] - truth.uv[2 * i + 1];
        let e = f64::from((du * du + dv * dv).sqrt());
        if !e.is_finite() {
            continue;
        }
        sum_all += e;
        n_all += 1;
        if truth.valid.as_ref().is_none_or(|m| m[i]) {
            sum_valid += e;
            n_valid += 1;
        }
    }
    Ok(EndpointError {
        mean_all: if n_all > 0 {
            sum_all / n_all as f64
        } else {
            0.0
        },
        mean_valid: (n_valid > 0).then(|| sum_valid / n_valid as f64),
        pixels: n_all,
        valid_pixels: n_valid,
    })
}

/// An axis-aligned box in pixels: `x1`, `y1` inclusive, `x2`, `y2` exclusive (the
/// convention of `sequence::BoxRecord`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PixelBox {
    /// Left edge.
    pub x1: f32,
    /// Top edge.
    pub y1: f32,
    /// Right edge (exclusive).
    pub x2: f32,
    /// Bottom edge (exclusive).
    pub y2: f32,
}

impl From<&crate::sequence::BoxRecord> for PixelBox {
    fn from(b: &crate::sequence::BoxRecord) -> Self {
        Self {
            x1: b.x1,
            y1: b.y1,
            x2: b.x2,
            y2: b.y2,
        }
    }
}

/// Crops `flow` to `bbox` and resizes the crop to `size × size` bilinearly without
/// rescaling the values, exactly as HF²-VAD builds its motion inputs
/// ([`crate::box_crop`], the same crop the model's cubes take).
///
/// The result is valid everywhere when `flow` has no mask; otherwise a resized pixel is
/// valid when all source pixels it blends are.
pub fn crop_resize_flow(
    flow: &FlowField,
    bbox: PixelBox,
    size: u32,
) -> Result<FlowField, FlowError> {
    check_flow_shape(flow, flow.width, flow.height, "flow to crop")?;
    let empty = || FlowError::EmptyBox {
        x1: bbox.x1,
        y1: bbox.y1,
        x2: bbox.x2,
        y2: bbox.y2,
        width: flow.width,
        height: flow.height,
    };
    let xs = crop_range(bbox.x1, bbox.x2, flow.width).ok_or_else(empty)?;
    let ys = crop_range(bbox.y1, bbox.y2, flow.height).ok_or_else(empty)?;
    if size == 0 {
        return Err(FlowError::InvalidParams {
            problem: "crop size must be at least 1".into(),
        });
    }
    let n = size as usize;
    let mut uv = vec![0f32; 2 * n * n];
    resize_crop(
        (xs, ys),
        flow.width,
        2,
        n,
        |i| flow.uv[i],
        |c, y, x, v| uv[2 * (y * n + x) + c] = v,
    );
    let valid = flow.valid.as_ref().map(|mask| {
        // A resized pixel is valid when every source pixel with a weight is.
        let w = flow.width as usize;
        let column_taps: Vec<_> = (0..n).map(|d| taps(d, xs.1 - xs.0, n)).collect();
        let mut out = Vec::with_capacity(n * n);
        for dy in 0..n {
            let (ya, yb, wy) = taps(dy, ys.1 - ys.0, n);
            let rows = [(ya, true), (yb, wy != 0.0)];
            for &(xa, xb, wx) in &column_taps {
                let columns = [(xa, true), (xb, wx != 0.0)];
                out.push(rows.iter().filter(|r| r.1).all(|&(row, _)| {
                    columns.iter().filter(|c| c.1).all(|&(column, _)| {
                        mask[(ys.0 as usize + row) * w + xs.0 as usize + column]
                    })
                }));
            }
        }
        out
    });
    Ok(FlowField {
        width: size,
        height: size,
        uv,
        valid,
    })
}

/// Mean EPE between estimate and ground truth inside `bbox`, after both are cropped and
/// resized to `size × size` as HF²-VAD sees them (see [`crop_resize_flow`]).
///
/// Resized pixels count where the truth is valid (all of them when the truth has no mask);
/// `None` when no resized pixel is valid.
pub fn box_endpoint_error(
    estimate: &FlowField,
    truth: &FlowField,
    bbox: PixelBox,
    size: u32,
) -> Result<Option<f64>, FlowError> {
    check_flow_shape(estimate, truth.width, truth.height, "estimated flow")?;
    let a = crop_resize_flow(estimate, bbox, size)?;
    let b = crop_resize_flow(truth, bbox, size)?;
    Ok(endpoint_error(&a, &b)?.mean_valid)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(width: u32, height: u32, f: impl Fn(u32, u32) -> [f32; 2]) -> FlowField {
        let mut out = FlowField::zeros(width, height);
        for y in 0..height {
            for x in 0..width {
                let i = 2 * (y * width + x) as usize;
                let [u, v] = f(x, y);
                out.uv[i] = u;
                out.uv[i + 1] = v;
            }
        }
        out
    }

    #[test]
    fn epe_counts_all_and_valid_pixels_separately() {
        let truth = FlowField {
            valid: Some(vec![true, false, true, false]),
            ..field(2, 2, |_, _| [0.0, 0.0])
        };
        let est = field(2, 2, |x, _| if x == 0 { [3.0, 4.0] } else { [0.0, 1.0] });
        let e = endpoint_error(&est, &truth).unwrap();
        assert!((e.mean_all - 3.0).abs() < 1e-9);
        assert_eq!(e.mean_valid, Some(5.0));
        assert_eq!((e.pixels, e.valid_pixels), (4, 2));
    }

    #[test]
    fn epe_rejects_mismatched_sizes_and_malformed_buffers() {
        let a = FlowField::zeros(4, 3);
        assert!(matches!(
            endpoint_error(&a, &FlowField::zeros(3, 4)),
            Err(FlowError::FlowSizeMismatch { .. })
        ));
        let mut bad = FlowField::zeros(4, 3);
        bad.uv.pop();
        assert!(matches!(
            endpoint_error(&bad, &a),
            Err(FlowError::MalformedFlow { .. })
        ));
    }

    #[test]
    fn crop_resize_keeps_values_and_interpolates_linearly() {
        // u = x, v = 2y: the crop of columns 10..20 resized to 5 samples lands on the
        // centres 10.5, 12.5, ... and keeps the values unscaled.
        let flow = field(40, 30, |x, y| [x as f32, 2.0 * y as f32]);
        let bbox = PixelBox {
            x1: 9.2,
            y1: 4.0,
            x2: 19.5,
            y2: 14.0,
        };
        let crop = crop_resize_flow(&flow, bbox, 5).unwrap();
        assert_eq!((crop.width, crop.height), (5, 5));
        for j in 0..5 {
            let [u, v] = crop.at(j, j);
            assert!((u - (10.5 + 2.0 * j as f32)).abs() < 1e-4, "{u}");
            assert!((v - 2.0 * (4.5 + 2.0 * j as f32)).abs() < 1e-4, "{v}");
        }
    }

    #[test]
    fn box_epe_of_a_constant_offset_is_that_offset() {
        let truth = field(50, 40, |x, y| [x as f32 * 0.1, y as f32 * -0.05]);
        let est = field(50, 40, |x, y| {
            [x as f32 * 0.1 + 0.3, y as f32 * -0.05 - 0.4]
        });
        let bbox = PixelBox {
            x1: 5.0,
            y1: 5.0,
            x2: 25.0,
            y2: 20.0,
        };
        let e = box_endpoint_error(&est, &truth, bbox, 32).unwrap().unwrap();
        assert!((e - 0.5).abs() < 1e-5, "{e}");
        // Invalid truth pixels do not count; a box without valid truth has no score.
        let mut masked = truth.clone();
        masked.valid = Some(vec![false; 50 * 40]);
        assert_eq!(box_endpoint_error(&est, &masked, bbox, 32).unwrap(), None);
        let outside = PixelBox {
            x1: 60.0,
            y1: 5.0,
            x2: 70.0,
            y2: 20.0,
        };
        assert!(matches!(
            box_endpoint_error(&est, &truth, outside, 32),
            Err(FlowError::EmptyBox { .. })
        ));
    }
}
