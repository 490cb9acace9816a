//! Trivial baselines scored beside the model: what a frame score built from one obvious cue
//! reaches on the same boxes and the same protocol ([`Baseline`], [`baseline_frame_scores`]).
//!
//! A model is only worth its cost where it beats these. Each image-only baseline scores the
//! objects the model scored (the boxes of its score cache, so the box source and the model's
//! box filter are the same) and takes the frame's maximum, as the fusion does:
//!
//! * flow energy: mean squared flow magnitude in the box (native pixels), the motion the flow
//!   autoencoder has to reconstruct;
//! * looming: the box's rate of scale change over the cube, ½·ln(area_i / area_j) / (i − j)
//!   for the same track `j` ≤ `clip_hist` frames back (a box that grows approaches);
//! * frame difference: mean absolute RGB difference in the box between frames i−1 and i.
//!
//! The ego's deceleration (from ACTION `speed`, where the scenario has it) is a frame-level
//! reference that uses ego data, which the image-only method cannot see: it shows how much
//! of the anomaly the ego's own reaction gives away.
//!
//! Frames without scored objects get 0: no motion, no change.

use serde::Serialize;

use crate::sequence::{FlowField, Scenario};

use super::ScoreError;
use super::cache::{ObjectScore, ScoreTable};
use crate::flow::FlowProvider;

/// A baseline frame score.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Baseline {
    /// Mean squared flow magnitude in the box.
    FlowEnergy,
    /// Rate of the box's scale change over the cube.
    Looming,
    /// Mean absolute frame difference in the box.
    FrameDifference,
    /// The ego's deceleration (uses ego data).
    EgoDeceleration,
}

impl Baseline {
    /// Every baseline, image-only ones first.
    pub const ALL: [Baseline; 4] = [
        Baseline::FlowEnergy,
        Baseline::Looming,
        Baseline::FrameDifference,
        Baseline::EgoDeceleration,
    ];

    /// Name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Baseline::FlowEnergy => "flow energy",
            Baseline::Looming => "looming",
            Baseline::FrameDifference => "frame difference",
            Baseline::EgoDeceleration => "ego deceleration (ego data)",
        }
    }

    /// Whether it reads data the image-only method does not have.
    pub fn uses_ego_data(self) -> bool {
        self == Baseline::EgoDeceleration
    }
}

/// Raw frame scores (one per frame, unfiltered) of `baseline` for `scenario`, on the objects
/// of `table` (the scenario's score cache) with flows from `flows`; `None` when the scenario
/// lacks the data (no ACTION speeds for the ego's deceleration).
pub fn baseline_frame_scores(
    baseline: Baseline,
    scenario: &Scenario,
    table: &ScoreTable,
    flows: &mut FlowProvider,
) -> Result<Option<Vec<f64>>, ScoreError> {
    let frames = table.frames.len();
    if frames != scenario.len() {
        return Err(ScoreError::Invalid(format!(
            "{}: the score table has {frames} frames but the scenario {}",
            scenario.root().display(),
            scenario.len()
        )));
    }
    let object_max = |score: &mut dyn FnMut(usize, &ObjectScore) -> Result<f64, ScoreError>| {
        // A frame without scored objects scores 0, as the model's zero-error frames do.
        (0..frames)
            .map(|i| {
                let mut max: Option<f64> = None;
                for object in table.frame_objects(i) {
                    let s = score(i, object)?;
                    max = Some(max.map_or(s, |m| m.max(s)));
                }
                Ok(max.unwrap_or(0.0))
            })
            .collect::<Result<Vec<f64>, ScoreError>>()
    };
    let clip_hist = table.meta.clip_hist as usize;
    let scores = match baseline {
        Baseline::FlowEnergy => object_max(&mut |i, o| {
            Ok(flows
                .flow(i)?
                .map_or(0.0, |f| flow_energy(&f, o.bbox, scenario.resolution())))
        })?,
        Baseline::Looming => object_max(&mut |i, o| Ok(looming(table, i, o, clip_hist)))?,
        Baseline::FrameDifference => object_max(&mut |i, o| {
            if i == 0 {
                return Ok(0.0);
            }
            let (now, before) = (scenario.rgb(i)?, scenario.rgb(i - 1)?);
            Ok(frame_difference(&now, &before, o.bbox))
        })?,
        Baseline::EgoDeceleration => return ego_deceleration(scenario),
    };
    Ok(Some(scores))
}

/// Pixel range [start, end) of a box edge pair, clamped to `0..size`.
fn span(lo: f32, hi: f32, size: u32) -> (usize, usize) {
    let clamp = |v: f32| v.clamp(0.0, size as f32) as usize;
    (clamp(lo.floor()), clamp(hi.ceil()))
}

/// Mean u² + v² in the box, the box scaled to the flow's grid when it has another size.
fn flow_energy(flow: &FlowField, bbox: [f32; 4], (width, height): (u32, u32)) -> f64 {
    let (sx, sy) = (
        flow.width as f32 / width.max(1) as f32,
        flow.height as f32 / height.max(1) as f32,
    );
    let (x0, x1) = span(bbox[0] * sx, bbox[2] * sx, flow.width);
    let (y0, y1) = span(bbox[1] * sy, bbox[3] * sy, flow.height);
    let mut sum = 0.0f64;
    for y in y0..y1 {
        let row = &flow.uv[2 * (y * flow.width as usize + x0)..2 * (y * flow.width as usize + x1)];
        for px in row.chunks_exact(2) {
            // Back to frame pixels, as the model's native units.
            let (u, v) = (px[0] / sx, px[1] / sy);
            sum += f64::from(u * u + v * v);
        }
    }
    let n = (x1 - x0) * (y1 - y0);
    if n == 0 { 0.0 } else { sum / n as f64 }
}

/// ½·ln(area ratio) per frame against the same track's box up to `clip_hist` frames back
/// (the earliest found); 0 for an object without a track or seen for the first time.
fn looming(table: &ScoreTable, index: usize, object: &ObjectScore, clip_hist: usize) -> f64 {
    let area = |b: [f32; 4]| f64::from((b[2] - b[0]).max(0.0) * (b[3] - b[1]).max(0.0));
    if object.track_id == 0 || area(object.bbox) <= 0.0 {
        return 0.0;
    }
    let earliest = (index.saturating_sub(clip_hist)..index).find_map(|j| {
        table
            .frame_objects(j)
            .iter()
            .find(|o| o.track_id == object.track_id && area(o.bbox) > 0.0)
            .map(|o| (j, o.bbox))
    });
    earliest.map_or(0.0, |(j, before)| {
        0.5 * (area(object.bbox) / area(before)).ln() / (index - j) as f64
    })
}

/// Mean absolute difference of the RGB values (in [0, 1]) in the box.
fn frame_difference(now: &image::RgbImage, before: &image::RgbImage, bbox: [f32; 4]) -> f64 {
    if now.dimensions() != before.dimensions() {
        return 0.0;
    }
    let (width, height) = now.dimensions();
    let (x0, x1) = span(bbox[0], bbox[2], width);
    let (y0, y1) = span(bbox[1], bbox[3], height);
    let (a, b) = (now.as_raw(), before.as_raw());
    let mut sum = 0u64;
    for y in y0..y1 {
        let row = 3 * y * width as usize;
        for i in row + 3 * x0..row + 3 * x1 {
            sum += u64::from(a[i].abs_diff(b[i]));
        }
    }
    let n = 3 * (x1 - x0) * (y1 - y0);
    if n == 0 {
        0.0
    } else {
        sum as f64 / (255.0 * n as f64)
    }
}

/// The ego's speed drop per frame (m/s) from ACTION `speed`; `None` without speeds.
fn ego_deceleration(scenario: &Scenario) -> Result<Option<Vec<f64>>, ScoreError> {
    let mut speeds = Vec::with_capacity(scenario.len());
    for i in 0..scenario.len() {
        match scenario.action(i)?.and_then(|a| a.speed_kmh()) {
            Some(v) => speeds.push(v / 3.6),
            None => return Ok(None),
        }
    }
    Ok(Some(
        (0..speeds.len())
            .map(|i| {
                if i == 0 {
                    0.0
                } else {
                    speeds[i - 1] - speeds[i]
                }
            })
            .collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flow_energy_is_the_mean_squared_magnitude_in_the_box() {
        let mut flow = FlowField::zeros(8, 8);
        // u = 3, v = 4 in the top-left 4×4 block, zero elsewhere.
        for y in 0..4 {
            for x in 0..4 {
                let i = 2 * (y * 8 + x);
                flow.uv[i] = 3.0;
                flow.uv[i + 1] = 4.0;
            }
        }
        assert_eq!(flow_energy(&flow, [0.0, 0.0, 4.0, 4.0], (8, 8)), 25.0);
        assert_eq!(flow_energy(&flow, [0.0, 0.0, 8.0, 4.0], (8, 8)), 12.5);
        // A half-resolution flow: the box is scaled to its grid and values to frame pixels.
        let mut half = FlowField::zeros(4, 4);
        half.uv.iter_mut().for_each(|v| *v = 1.0);
        assert_eq!(flow_energy(&half, [0.0, 0.0, 8.0, 8.0], (8, 8)), 8.0);
    }

    #[test]
    fn frame_difference_reads_only_the_box() {
        let before = image::RgbImage::new(4, 4);
        let mut now = image::RgbImage::new(4, 4);
        now.put_pixel(0, 0, image::Rgb([255, 255, 255]));
        assert_eq!(frame_difference(&now, &before, [0.0, 0.0, 1.0, 1.0]), 1.0);
        assert_eq!(frame_difference(&now, &before, [0.0, 0.0, 2.0, 2.0]), 0.25);
        assert_eq!(frame_difference(&now, &before, [2.0, 2.0, 4.0, 4.0]), 0.0);
    }
}
