//! The combined HF²-VAD model: ML-MemAE-SC reconstructs each flow of a cube, the CVAE
//! predicts the last frame from the earlier frames and the reconstructed flows.

use burn::module::Module;
use burn::tensor::{Device, Tensor};

use super::config::{FLOW_CHANNELS, IMG_CHANNELS, ModelConfig};
use super::error::ModelError;
use super::memae::MlMemAeSc;
use super::rng::NoiseRng;
use super::vunet::{Latents, Vunet, VunetOutput};

/// ML-MemAE-SC plus the CVAE. The config is not part of the module; keep it beside (the
/// checkpoint does).
#[derive(Module, Debug)]
pub struct Hf2Vad {
    /// The flow autoencoder, shared by all flows of a cube.
    pub memae: MlMemAeSc,
    /// The frame-predicting CVAE.
    pub vunet: Vunet,
    /// Past frames t (the cube has t + 1 frames and t flows).
    pub clip_hist: usize,
    /// Whether ML-MemAE-SC takes all t flows in one pass ([`ModelConfig::joint_flows`]).
    pub joint_flows: bool,
}

/// Everything one HF²-VAD pass produces.
#[derive(Debug, Clone)]
pub struct Hf2VadOutput {
    /// Reconstructed flows, [B, 2·t, H, W], flow j in channels 2j..2j+2.
    pub of_recon: Tensor<4>,
    /// Attention of mem1, mem2, mem3 over all flow passes, flow-major: row `j·B + b` is flow
    /// j of sample b ([t·B, slots] each, as the reference concatenates them); [B, slots]
    /// when the flows are reconstructed jointly.
    pub attention: [Tensor<2>; 3],
    /// The CVAE outputs (predicted frame, posterior/prior means, features).
    pub cvae: VunetOutput,
}

impl Hf2Vad {
    /// A freshly initialised model for `config` (validated first), seeded by `rng`.
    pub fn new(
        config: &ModelConfig,
        device: &Device,
        rng: &mut NoiseRng,
    ) -> Result<Self, ModelError> {
        config.validate()?;
        Ok(Self {
            memae: MlMemAeSc::new(config, device, rng),
            vunet: Vunet::new(config, device, rng),
            clip_hist: config.clip_hist,
            joint_flows: config.joint_flows,
        })
    }

    /// Reconstructs every flow of `flows` [B, 2·t, H, W] with ML-MemAE-SC.
    ///
    /// Jointly reconstructed flows go through as they are, one pass of B. Otherwise, with
    /// BatchNorm in eval mode the t flows go through as one batch of t·B; with batch
    /// statistics active (stage-3 fine-tuning) they go one pass per flow, as the reference,
    /// so that each pass normalises and updates the running stats with its own flow.
    pub fn reconstruct_flows(&self, flows: Tensor<4>) -> (Tensor<4>, [Tensor<2>; 3]) {
        let [b, _, h, w] = flows.dims();
        let t = self.clip_hist;
        if self.joint_flows {
            let out = self.memae.forward(flows);
            return (out.recon, out.attention);
        }
        if self.memae.batch_statistics(&flows.device()) {
            let mut recons = Vec::with_capacity(t);
            let mut atts: [Vec<Tensor<2>>; 3] = [Vec::new(), Vec::new(), Vec::new()];
            for j in 0..t {
                let out =
                    self.memae
                        .forward(flows.clone().narrow(1, FLOW_CHANNELS * j, FLOW_CHANNELS));
                recons.push(out.recon);
                for (acc, a) in atts.iter_mut().zip(out.attention) {
                    acc.push(a);
                }
            }
            (Tensor::cat(recons, 1), atts.map(|a| Tensor::cat(a, 0)))
        } else {
            let stacked = flows
                .reshape([b, t, FLOW_CHANNELS, h, w])
                .swap_dims(0, 1)
                .reshape([t * b, FLOW_CHANNELS, h, w]);
            let out = self.memae.forward(stacked);
            let recon = out
                .recon
                .reshape([t, b, FLOW_CHANNELS, h, w])
                .swap_dims(0, 1)
                .reshape([b, t * FLOW_CHANNELS, h, w]);
            (recon, out.attention)
        }
    }

    /// The full model on `frames` [B, 3·(t+1), H, W] (frame i−t … frame i, the target last)
    /// and `flows` [B, 2·t, H, W], in the model's own input conventions.
    pub fn forward(
        &self,
        frames: Tensor<4>,
        flows: Tensor<4>,
        latents: &Latents,
        noise: Option<&mut NoiseRng>,
    ) -> Hf2VadOutput {
        let (of_recon, attention) = self.reconstruct_flows(flows);
        let appearance = frames.narrow(1, 0, IMG_CHANNELS * self.clip_hist);
        let cvae = self
            .vunet
            .forward(appearance, of_recon.clone(), latents, noise);
        Hf2VadOutput {
            of_recon,
            attention,
            cvae,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_model_has_the_configured_parameter_count() {
        use burn::store::ModuleSnapshot;
        let config = ModelConfig::parity();
        let model = Hf2Vad::new(&config, &Device::flex(), &mut NoiseRng::new(1)).expect("model");
        // BatchNorm running statistics are stored tensors but not trainable parameters.
        let trainable: usize = model
            .collect(None, None, false)
            .iter()
            .filter(|t| !t.name.contains(".running_"))
            .map(|t| t.shape.num_elements())
            .sum();
        assert_eq!(trainable, config.parameter_count());
    }

    #[test]
    fn batched_and_per_flow_reconstruction_agree() {
        let config = ModelConfig::parity();
        let device = Device::flex();
        let model = Hf2Vad::new(&config, &device, &mut NoiseRng::new(2)).expect("model");
        let flows = Tensor::<4>::from_data(
            burn::tensor::TensorData::new(
                NoiseRng::new(3).normal_vec(2 * 8 * 32 * 32, 0.0, 2.0),
                [2, 8, 32, 32],
            ),
            &device,
        );
        let (batched, att) = model.reconstruct_flows(flows.clone());
        for j in 0..4 {
            let single = model.memae.forward(flows.clone().narrow(1, 2 * j, 2));
            let diff = (batched.clone().narrow(1, 2 * j, 2) - single.recon)
                .abs()
                .max()
                .into_scalar::<f32>();
            assert!(diff < 1e-5, "flow {j}: {diff}");
            let diff = (att[2].clone().narrow(0, 2 * j, 2) - single.attention[2].clone())
                .abs()
                .max()
                .into_scalar::<f32>();
            assert!(diff < 1e-6, "attention of flow {j}: {diff}");
        }
    }
}
