//! The inference entry point used by scoring: a batch of cubes in (vadscope conventions:
//! RGB frames in [0, 1], flows in native pixels), per cube out: reconstructed flows,
//! predicted frame, S_r, S_p and the per-element squared-error maps.
//!
//! The input conventions of the weights (BGR, scaled flows) are applied on the way in and
//! undone on the way out, so callers never see them. Scores and error maps stay in the
//! model's units, the units of its training statistics.

use burn::module::Module;
use burn::tensor::{Device, Tensor};

use super::checkpoint::{Checkpoint, CheckpointMeta, load_checkpoint};
use super::config::{ColorOrder, FLOW_CHANNELS, IMG_CHANNELS, ModelConfig};
use super::error::ModelError;
use super::hf2vad::Hf2Vad;
use super::layers::tensor;
use super::rng::NoiseRng;
use super::stats::TrainingStats;
use super::vunet::Latents;

/// How the CVAE latents are chosen at inference.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InferenceLatents {
    /// Posterior means (deterministic; default).
    Mean,
    /// The reference's test mode: z at the coarsest scale sampled, seeded per call.
    ReferenceSampled {
        /// Seed of the noise.
        seed: u64,
    },
}

/// The model's output for one cube. Maps are channel-major [C, P, P] flattened.
#[derive(Debug, Clone, PartialEq)]
pub struct CubeResult {
    /// Reconstructed flows in native pixels, [2·t, P, P] (flow j in channels 2j, 2j+1).
    pub recon_flows: Vec<f32>,
    /// Predicted last frame, RGB in (0, 1), [3, P, P].
    pub predicted_frame: Vec<f32>,
    /// S_r: sum of the flow error map.
    pub s_r: f32,
    /// S_p: sum of the frame error map.
    pub s_p: f32,
    /// Squared flow-reconstruction error per element in model units, [2·t, P, P].
    pub flow_error: Vec<f32>,
    /// Squared frame-prediction error per element, channels in RGB order, [3, P, P].
    pub frame_error: Vec<f32>,
}

/// A loaded model ready to score cubes.
#[derive(Debug, Clone)]
pub struct Detector {
    model: Hf2Vad,
    meta: CheckpointMeta,
    device: Device,
    latents: InferenceLatents,
    max_batch: usize,
}

impl Detector {
    /// A detector around `model` (moved to inference mode on `device`).
    pub fn new(model: Hf2Vad, meta: CheckpointMeta, device: &Device) -> Result<Self, ModelError> {
        meta.config.validate()?;
        let mut model = model.valid().to_device(device);
        model.memae = model.memae.lowered();
        model.vunet = model.vunet.lowered();
        Ok(Self {
            model,
            meta,
            device: device.clone(),
            latents: InferenceLatents::Mean,
            max_batch: 64,
        })
    }

    /// Loads a vadscope checkpoint on burn's CPU backend.
    pub fn from_checkpoint(path: &std::path::Path) -> Result<Self, ModelError> {
        let device = Device::flex();
        let Checkpoint { model, meta } = load_checkpoint(path, &device)?;
        Self::new(model, meta, &device)
    }

    /// Chooses how latents are drawn (default: posterior means).
    pub fn with_latents(mut self, latents: InferenceLatents) -> Self {
        self.latents = latents;
        self
    }

    /// Sets the largest batch sent through the model at once (default 64).
    pub fn with_max_batch(mut self, max_batch: usize) -> Self {
        self.max_batch = max_batch.max(1);
        self
    }

    /// Replaces the training statistics the scores are normalised with (e.g. those of a
    /// model still in training, measured on a sample of its cubes).
    pub fn with_training_stats(mut self, stats: TrainingStats) -> Self {
        self.meta.stats = Some(stats);
        self
    }

    /// The model config.
    pub fn config(&self) -> &ModelConfig {
        &self.meta.config
    }

    /// The training statistics stored with the model, if any.
    pub fn training_stats(&self) -> Option<&TrainingStats> {
        self.meta.stats.as_ref()
    }

    /// The underlying network.
    pub fn model(&self) -> &Hf2Vad {
        &self.model
    }

    /// Scores cubes: `frames` holds B cubes of [3·(t+1), P, P] (frame i−t first, RGB in
    /// [0, 1]), `flows` B cubes of [2·t, P, P] (native pixels), both channel-major.
    pub fn infer(&self, frames: &[f32], flows: &[f32]) -> Result<Vec<CubeResult>, ModelError> {
        let c = &self.meta.config;
        let area = c.patch_size * c.patch_size;
        let frame_len = c.cube_frame_channels() * area;
        let flow_len = c.cube_flow_channels() * area;
        if !frames.len().is_multiple_of(frame_len) || !flows.len().is_multiple_of(flow_len) {
            return Err(ModelError::InvalidInput(format!(
                "cube buffers of {} frame and {} flow values are not whole cubes of {frame_len} \
                 and {flow_len}",
                frames.len(),
                flows.len()
            )));
        }
        let cubes = frames.len() / frame_len;
        if flows.len() / flow_len != cubes {
            return Err(ModelError::InvalidInput(format!(
                "{cubes} cubes of frames but {} of flows",
                flows.len() / flow_len
            )));
        }
        if let Some(i) = frames.iter().chain(flows).position(|v| !v.is_finite()) {
            return Err(ModelError::InvalidInput(format!(
                "non-finite input value at position {i}"
            )));
        }
        let mut results = Vec::with_capacity(cubes);
        for start in (0..cubes).step_by(self.max_batch) {
            let n = self.max_batch.min(cubes - start);
            results.extend(self.infer_batch(
                &frames[start * frame_len..(start + n) * frame_len],
                &flows[start * flow_len..(start + n) * flow_len],
                n,
                start as u64,
            ));
        }
        Ok(results)
    }

    fn infer_batch(&self, frames: &[f32], flows: &[f32], n: usize, offset: u64) -> Vec<CubeResult> {
        let c = &self.meta.config;
        let p = c.patch_size;
        let bgr = c.conventions.color_order == ColorOrder::Bgr;
        let [fx, fy] = c.conventions.flow_units.factors();
        let (frames, flows) = to_model_conventions(c, frames, flows);

        let frames = tensor(frames, [n, c.cube_frame_channels(), p, p], &self.device);
        let flows_t = tensor(flows, [n, c.cube_flow_channels(), p, p], &self.device);
        let latents = match self.latents {
            InferenceLatents::Mean => Latents::Mean,
            InferenceLatents::ReferenceSampled { seed } => {
                let mut rng = NoiseRng::new(seed.wrapping_add(offset));
                Latents::reference_test(c, n, &self.device, &mut rng)
            }
        };
        let target = frames
            .clone()
            .narrow(1, IMG_CHANNELS * c.clip_hist, IMG_CHANNELS);
        let out = self.model.forward(frames, flows_t.clone(), &latents, None);
        let flow_err = (out.of_recon.clone() - flows_t).square();
        let frame_err = (out.cvae.frame_pred.clone() - target).square();

        let recon = to_vec(out.of_recon);
        let pred = to_vec(out.cvae.frame_pred);
        let flow_err = to_vec(flow_err);
        let frame_err = to_vec(frame_err);

        let flow_len = c.cube_flow_channels() * p * p;
        let frame_len = IMG_CHANNELS * p * p;
        let inverse = [1.0 / fx, 1.0 / fy];
        (0..n)
            .map(|i| {
                let fl = &flow_err[i * flow_len..(i + 1) * flow_len];
                let fr = &frame_err[i * frame_len..(i + 1) * frame_len];
                let (predicted_frame, frame_error) = if bgr {
                    (
                        swap_colour_order(&pred[i * frame_len..(i + 1) * frame_len], p * p),
                        swap_colour_order(fr, p * p),
                    )
                } else {
                    (
                        pred[i * frame_len..(i + 1) * frame_len].to_vec(),
                        fr.to_vec(),
                    )
                };
                CubeResult {
                    recon_flows: scale_flows(
                        &recon[i * flow_len..(i + 1) * flow_len],
                        inverse,
                        p * p,
                    ),
                    predicted_frame,
                    s_r: sum(fl),
                    s_p: sum(fr),
                    flow_error: fl.to_vec(),
                    frame_error,
                }
            })
            .collect()
    }
}

/// Converts channel-major cube buffers from vadscope's conventions (RGB, native-pixel
/// flows) to those of the model described by `config`.
pub fn to_model_conventions(
    config: &ModelConfig,
    frames: &[f32],
    flows: &[f32],
) -> (Vec<f32>, Vec<f32>) {
    let area = config.patch_size * config.patch_size;
    let frames = match config.conventions.color_order {
        ColorOrder::Bgr => swap_colour_order(frames, area),
        ColorOrder::Rgb => frames.to_vec(),
    };
    (
        frames,
        scale_flows(flows, config.conventions.flow_units.factors(), area),
    )
}

/// Sum in f64 (order-independent enough for scores of 1e5-element maps), returned as f32.
fn sum(values: &[f32]) -> f32 {
    values.iter().map(|&v| v as f64).sum::<f64>() as f32
}

fn to_vec<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    // The model computes in f32 on every backend we build, so the conversion cannot fail.
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap_or_default()
}

/// Swaps channels 0 and 2 of every 3-channel image of `area` pixels in `values` (RGB ↔ BGR).
fn swap_colour_order(values: &[f32], area: usize) -> Vec<f32> {
    let mut out = values.to_vec();
    for image in out.chunks_mut(IMG_CHANNELS * area) {
        let (r, rest) = image.split_at_mut(area);
        r.swap_with_slice(&mut rest[area..2 * area]);
    }
    out
}

/// Multiplies u by `factors[0]` and v by `factors[1]` in every 2-channel flow of `area` pixels.
fn scale_flows(values: &[f32], factors: [f32; 2], area: usize) -> Vec<f32> {
    if factors == [1.0, 1.0] {
        return values.to_vec();
    }
    values
        .chunks(area)
        .enumerate()
        .flat_map(|(i, plane)| {
            let f = factors[i % FLOW_CHANNELS];
            plane.iter().map(move |v| v * f)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_swap_exchanges_red_and_blue_planes() {
        // Two images of one pixel each: RGB (1, 2, 3) and (4, 5, 6).
        let swapped = swap_colour_order(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], 1);
        assert_eq!(swapped, vec![3.0, 2.0, 1.0, 6.0, 5.0, 4.0]);
    }

    #[test]
    fn flow_scaling_acts_per_component() {
        let scaled = scale_flows(&[1.0, 1.0, 2.0, 2.0, 3.0, 3.0, 4.0, 4.0], [2.0, 0.5], 2);
        assert_eq!(scaled, vec![2.0, 2.0, 1.0, 1.0, 6.0, 6.0, 2.0, 2.0]);
    }
}
