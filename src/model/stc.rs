//! Spatio-temporal cubes (spec §2.3): for every box of frame i, the same rectangle cropped
//! from frames i−t…i and from the flows stored at frames i−t+1…i, each resized to P×P
//! bilinearly (flow values unchanged).
//!
//! Details as the reference:
//! * the box of the **last** frame crops every frame and flow; its corners are rounded up
//!   and the crop covers columns ⌈x1⌉…⌈x2⌉−1 and rows ⌈y1⌉…⌈y2⌉−1 (clamped to the image);
//! * at the start of a scenario, indices before 0 repeat frame 0 (and its flow), and a
//!   flow missing at frame 0 counts as zero motion (the reference's pair (0, 0));
//! * resizing samples like OpenCV's `INTER_LINEAR` (half-pixel centres, edge clamping;
//!   [`crate::box_crop`]); frames are rounded back to bytes as OpenCV does for 8-bit images.
//!
//! A flow field of another resolution than its frame is sampled with the box scaled to its
//! grid and its values converted to frame pixels.

use std::sync::Arc;

use image::RgbImage;

use crate::box_crop::{Crop, crop_range, resize_crop};
use crate::sequence::{BoxRecord, FlowField};

use super::config::{FlowUnits, ModelConfig};
use super::error::ModelError;

/// How cubes are cut: history, patch side and the units their flows are given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CubeGeometry {
    /// Past frames per cube t (the cube holds t + 1 frames and t flows).
    pub clip_hist: usize,
    /// Side P of the square patches.
    pub patch: usize,
    /// Flows in patch pixels ([`FlowUnits::Patch`]) instead of native pixels.
    pub patch_units: bool,
    /// Native pixels rescaled to a frame this wide ([`FlowUnits::FrameWidth`]).
    pub frame_width: Option<u32>,
}

impl CubeGeometry {
    /// The cubes `config`'s model reads.
    pub fn of(config: &ModelConfig) -> Self {
        Self {
            clip_hist: config.clip_hist,
            patch: config.patch_size,
            patch_units: config.conventions.flow_units == FlowUnits::Patch,
            frame_width: match config.conventions.flow_units {
                FlowUnits::FrameWidth { width } => Some(width),
                _ => None,
            },
        }
    }
}

/// One cube: frames and flows of one box, channel-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Cube {
    /// RGB bytes [3·(t+1), P, P], frame i−t first, frame i (the target) last.
    pub frames: Vec<u8>,
    /// Flows [2·t, P, P], flow stored at frame i−t+1 first; (u, v) each. Native pixels
    /// multiplied by `flow_scale`.
    pub flows: Vec<f32>,
    /// Factors (u, v) that turned native pixels into the units of `flows`: (1, 1), or
    /// P / crop size for flows in patch units.
    pub flow_scale: [f32; 2],
    /// Index of the box within its frame's box list.
    pub box_index: usize,
    /// The box that cropped the cube.
    pub bbox: BoxRecord,
}

/// Frame indices of the cube of frame `index`: `index−t … index`, clamped at 0.
pub fn frame_indices(index: usize, clip_hist: usize) -> Vec<usize> {
    (0..=clip_hist)
        .map(|k| (index + k).saturating_sub(clip_hist))
        .collect()
}

/// Indices of the flows of the cube of frame `index`: stored at `index−t+1 … index`,
/// clamped at 0.
pub fn flow_indices(index: usize, clip_hist: usize) -> Vec<usize> {
    (1..=clip_hist)
        .map(|k| (index + k).saturating_sub(clip_hist))
        .collect()
}

/// Cube crop of `frame` into `out` (3 planes of P×P), rounding to bytes.
fn crop_frame(frame: &RgbImage, crop: Crop, patch: usize, out: &mut [u8]) {
    let raw = frame.as_raw();
    resize_crop(
        crop,
        frame.width(),
        3,
        patch,
        |i| raw[i] as f32,
        |c, y, x, v| out[(c * patch + y) * patch + x] = (v + 0.5).floor().clamp(0.0, 255.0) as u8,
    );
}

/// Cube crop of `flow` into `out` (2 planes of P×P); `scale` converts its values to frame
/// pixels.
fn crop_flow(flow: &FlowField, crop: Crop, patch: usize, scale: [f32; 2], out: &mut [f32]) {
    let uv = &flow.uv;
    resize_crop(
        crop,
        flow.width,
        2,
        patch,
        |i| uv[i],
        |c, y, x, v| out[(c * patch + y) * patch + x] = v * scale[c],
    );
}

/// Builds the cubes of frame `index`, one per box of `boxes` (the boxes of frame `index`)
/// that keeps a non-empty crop. `frame(k)` and `flow(k)` fetch frame k and the flow stored
/// at frame k (None if not stored).
pub fn cubes_at(
    index: usize,
    boxes: &[BoxRecord],
    geometry: CubeGeometry,
    frame: &mut dyn FnMut(usize) -> Result<Arc<RgbImage>, ModelError>,
    flow: &mut dyn FnMut(usize) -> Result<Option<Arc<FlowField>>, ModelError>,
) -> Result<Vec<Cube>, ModelError> {
    if boxes.is_empty() {
        return Ok(Vec::new());
    }
    let CubeGeometry {
        clip_hist, patch, ..
    } = geometry;
    let frames = frame_indices(index, clip_hist)
        .into_iter()
        .map(&mut *frame)
        .collect::<Result<Vec<_>, _>>()?;
    let (width, height) = frames[clip_hist].dimensions();
    if width == 0 || height == 0 {
        return Err(ModelError::Cube(format!("frame {index} is empty")));
    }
    if let Some((k, f)) = frames
        .iter()
        .enumerate()
        .find(|(_, f)| f.dimensions() != (width, height))
    {
        return Err(ModelError::Cube(format!(
            "frame {} is {}×{} but frame {index} is {width}×{height}",
            frame_indices(index, clip_hist)[k],
            f.width(),
            f.height()
        )));
    }
    let mut flows = Vec::with_capacity(clip_hist);
    for k in flow_indices(index, clip_hist) {
        match flow(k)? {
            Some(f)
                if f.width > 0
                    && f.height > 0
                    && f.uv.len() == 2 * f.width as usize * f.height as usize =>
            {
                flows.push(Some(f))
            }
            Some(_) => {
                return Err(ModelError::Cube(format!(
                    "flow stored at frame {k} is malformed"
                )));
            }
            None if k == 0 => flows.push(None),
            None => {
                return Err(ModelError::Cube(format!(
                    "no flow stored at frame {k} (needed by the cubes of frame {index})"
                )));
            }
        }
    }

    let area = patch * patch;
    let mut cubes = Vec::with_capacity(boxes.len());
    for (box_index, b) in boxes.iter().enumerate() {
        let (Some(xr), Some(yr)) = (
            crop_range(b.x1, b.x2, width),
            crop_range(b.y1, b.y2, height),
        ) else {
            continue;
        };
        let mut cube_frames = vec![0u8; 3 * (clip_hist + 1) * area];
        for (f, out) in frames.iter().zip(cube_frames.chunks_mut(3 * area)) {
            crop_frame(f, (xr, yr), patch, out);
        }
        // Patch units: the displacement as it appears in the P×P patch; frame-width units:
        // as it would appear in a frame of the reference width (one factor for both axes,
        // so the motion keeps its direction).
        let flow_scale = match (geometry.patch_units, geometry.frame_width) {
            (true, _) => [
                patch as f32 / (xr.1 - xr.0) as f32,
                patch as f32 / (yr.1 - yr.0) as f32,
            ],
            (false, Some(reference)) => [reference as f32 / width as f32; 2],
            (false, None) => [1.0, 1.0],
        };
        let mut cube_flows = vec![0f32; 2 * clip_hist * area];
        for (f, out) in flows.iter().zip(cube_flows.chunks_mut(2 * area)) {
            let Some(f) = f else { continue };
            let (sx, sy) = (
                f.width as f32 / width as f32,
                f.height as f32 / height as f32,
            );
            let fxr = crop_range(b.x1 * sx, b.x2 * sx, f.width);
            let fyr = crop_range(b.y1 * sy, b.y2 * sy, f.height);
            if let (Some(fxr), Some(fyr)) = (fxr, fyr) {
                let scale = [flow_scale[0] / sx, flow_scale[1] / sy];
                crop_flow(f, (fxr, fyr), patch, scale, out);
            }
        }
        cubes.push(Cube {
            frames: cube_frames,
            flows: cube_flows,
            flow_scale,
            box_index,
            bbox: *b,
        });
    }
    Ok(cubes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::FrameId;

    fn bbox(x1: f32, y1: f32, x2: f32, y2: f32) -> BoxRecord {
        BoxRecord::car(FrameId(0), 1, [x1, y1, x2, y2])
    }

    fn geometry(clip_hist: usize, patch: usize) -> CubeGeometry {
        CubeGeometry {
            clip_hist,
            patch,
            patch_units: false,
            frame_width: None,
        }
    }

    /// Frame k: red = column, green = row, blue = 10·k.
    fn frame(k: usize) -> Arc<RgbImage> {
        Arc::new(RgbImage::from_fn(64, 48, |x, y| {
            image::Rgb([x as u8, y as u8, 10 * k as u8])
        }))
    }

    /// Flow stored at frame k: u = k, v = −k everywhere.
    fn flow(k: usize) -> Arc<FlowField> {
        let mut f = FlowField::zeros(64, 48);
        for px in f.uv.chunks_mut(2) {
            px[0] = k as f32;
            px[1] = -(k as f32);
        }
        Arc::new(f)
    }

    #[test]
    fn indices_pad_at_the_scenario_start() {
        assert_eq!(frame_indices(2, 4), vec![0, 0, 0, 1, 2]);
        assert_eq!(frame_indices(9, 4), vec![5, 6, 7, 8, 9]);
        assert_eq!(flow_indices(2, 4), vec![0, 0, 1, 2]);
        assert_eq!(flow_indices(9, 4), vec![6, 7, 8, 9]);
    }

    #[test]
    fn cube_crops_the_last_frames_box_from_every_frame_and_flow() {
        let boxes = [bbox(10.2, 5.0, 42.0, 37.0), bbox(70.0, 0.0, 90.0, 10.0)];
        let cubes = cubes_at(
            6,
            &boxes,
            geometry(4, 32),
            &mut |k| Ok(frame(k)),
            &mut |k| Ok(Some(flow(k))),
        )
        .expect("cubes");
        // The second box lies outside the image: no cube.
        assert_eq!(cubes.len(), 1);
        let c = &cubes[0];
        assert_eq!(c.box_index, 0);
        // Crop columns 11..42 (31 px) and rows 5..37 (32 px: identity resize in y).
        let red = |t: usize, y: usize, x: usize| c.frames[((3 * t) * 32 + y) * 32 + x];
        let green = |t: usize, y: usize, x: usize| c.frames[((3 * t + 1) * 32 + y) * 32 + x];
        let blue = |t: usize| c.frames[(3 * t + 2) * 32 * 32];
        assert_eq!(red(0, 0, 0), 11);
        assert_eq!(red(0, 0, 31), 41);
        assert_eq!(green(4, 0, 0), 5);
        assert_eq!(green(4, 31, 0), 36);
        assert_eq!((blue(0), blue(4)), (20, 60), "frames 2 … 6");
        // Flows stored at frames 3 … 6, values unchanged by the resize.
        assert_eq!(c.flows[0], 3.0);
        assert_eq!(c.flows[32 * 32], -3.0);
        assert_eq!(c.flows[6 * 32 * 32 + 100], 6.0);
    }

    #[test]
    fn missing_flow_is_zero_at_frame_zero_and_an_error_elsewhere() {
        let boxes = [bbox(0.0, 0.0, 16.0, 16.0)];
        let cubes = cubes_at(1, &boxes, geometry(4, 8), &mut |k| Ok(frame(k)), &mut |k| {
            Ok((k > 0).then(|| flow(k)))
        })
        .expect("cubes");
        assert!(cubes[0].flows[..3 * 2 * 64].iter().all(|&v| v == 0.0));
        assert_eq!(cubes[0].flows[3 * 2 * 64], 1.0);
        let err = cubes_at(5, &boxes, geometry(4, 8), &mut |k| Ok(frame(k)), &mut |k| {
            Ok((k != 3).then(|| flow(k)))
        })
        .expect_err("missing flow");
        assert!(err.to_string().contains("frame 3"), "{err}");
    }

    /// A flow on a 32×24 grid (half the 64×48 frames) with u = 1, v = 2 everywhere.
    fn half_resolution_flow() -> Arc<FlowField> {
        let mut small = FlowField::zeros(32, 24);
        for px in small.uv.chunks_mut(2) {
            px[0] = 1.0;
            px[1] = 2.0;
        }
        Arc::new(small)
    }

    #[test]
    fn half_resolution_flow_is_cropped_on_its_grid_and_rescaled() {
        let small = half_resolution_flow();
        let cubes = cubes_at(
            4,
            &[bbox(8.0, 8.0, 40.0, 40.0)],
            geometry(4, 8),
            &mut |k| Ok(frame(k)),
            &mut |_| Ok(Some(small.clone())),
        )
        .expect("cubes");
        assert_eq!(cubes[0].flows[0], 2.0, "u in frame pixels");
        assert_eq!(cubes[0].flows[64], 4.0, "v in frame pixels");
        assert_eq!(cubes[0].flow_scale, [1.0, 1.0]);
    }

    #[test]
    fn patch_units_divide_the_motion_by_the_box_size() {
        // A 32×16 box into 8×8 patches: u × 8/32, v × 8/16, on top of the grid rescale.
        let small = half_resolution_flow();
        let geometry = CubeGeometry {
            patch_units: true,
            ..geometry(4, 8)
        };
        let cubes = cubes_at(
            4,
            &[bbox(8.0, 8.0, 40.0, 24.0)],
            geometry,
            &mut |k| Ok(frame(k)),
            &mut |_| Ok(Some(small.clone())),
        )
        .expect("cubes");
        assert_eq!(cubes[0].flow_scale, [0.25, 0.5]);
        assert_eq!(cubes[0].flows[0], 2.0 * 0.25, "u in patch pixels");
        assert_eq!(cubes[0].flows[64], 4.0 * 0.5, "v in patch pixels");
    }

    #[test]
    fn frame_width_units_rescale_the_motion_to_the_reference_width() {
        // Frames 64 wide, flows rescaled to a 128-wide frame: u and v doubled, on top of the
        // grid rescale (a 32×24 flow grid for 64×48 frames).
        let small = half_resolution_flow();
        let geometry = CubeGeometry {
            frame_width: Some(128),
            ..geometry(4, 8)
        };
        let cubes = cubes_at(
            4,
            &[bbox(8.0, 8.0, 40.0, 24.0)],
            geometry,
            &mut |k| Ok(frame(k)),
            &mut |_| Ok(Some(small.clone())),
        )
        .expect("cubes");
        assert_eq!(cubes[0].flow_scale, [2.0, 2.0]);
        assert_eq!(
            cubes[0].flows[0],
            2.0 * 2.0,
            "u in pixels of a 128-wide frame"
        );
        assert_eq!(
            cubes[0].flows[64],
            4.0 * 2.0,
            "v in pixels of a 128-wide frame"
        );
    }
}
