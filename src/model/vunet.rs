//! The CVAE of HF²-VAD (spec §4), a VUNet variant: two encoders (posterior f_phi on frames
//! plus flows, prior e_theta on flows), the posterior `ZConverter`, the autoregressive prior
//! bottleneck over 4 channel groups at the two coarsest scales, and the decoder with sigmoid
//! output.
//!
//! Features of an encoder are kept in a flat list, stage-major: stage s (1-based), block k
//! (1 or 2) sits at index `2(s−1) + k − 1`, the reference's `s{s}_{k}`.

use burn::module::Module;
use burn::tensor::activation::sigmoid;
use burn::tensor::{Device, Tensor};

use super::config::{IMG_CHANNELS, ModelConfig};
use super::layers::{
    Downsample, NormConv2d, ResBlock, SkipResBlock, Upsample, depth_to_space, space_to_depth,
    tensor,
};
use super::rng::NoiseRng;

/// Index of feature `s{stage}_{block}` in an encoder's feature list.
fn feature_index(stage: usize, block: usize) -> usize {
    2 * (stage - 1) + block - 1
}

/// One VUNet encoder: 1×1 input conv, then per stage an optional strided downsample and two
/// residual blocks.
#[derive(Module, Debug)]
pub struct VunetEncoder {
    /// 1×1 input conv to nf_start channels.
    pub in_op: NormConv2d,
    /// Residual blocks, stage-major (see the module doc).
    pub blocks: Vec<ResBlock>,
    /// Downsamplers into stages 2, 3, … (index s − 2).
    pub downs: Vec<Downsample>,
}

impl VunetEncoder {
    fn lowered(self) -> Self {
        Self {
            in_op: self.in_op.lowered(),
            blocks: self.blocks.into_iter().map(ResBlock::lowered).collect(),
            downs: self.downs.into_iter().map(Downsample::lowered).collect(),
        }
    }

    fn new(nf_in: usize, config: &ModelConfig, device: &Device, rng: &mut NoiseRng) -> Self {
        let in_op = NormConv2d::new(nf_in, config.nf_start, 1, 1, 0, device, rng);
        let mut blocks = Vec::new();
        let mut downs = Vec::new();
        for stage in 1..=config.n_stages() {
            if stage > 1 {
                downs.push(Downsample::new(
                    config.stage_width(stage - 1),
                    config.stage_width(stage),
                    device,
                    rng,
                ));
            }
            for _ in 0..2 {
                blocks.push(ResBlock::new(
                    config.stage_width(stage),
                    config.dropout,
                    device,
                    rng,
                ));
            }
        }
        Self {
            in_op,
            blocks,
            downs,
        }
    }

    /// Every residual-block output, stage-major.
    fn forward(&self, x: Tensor<4>, mut noise: Option<&mut NoiseRng>) -> Vec<Tensor<4>> {
        let mut h = self.in_op.forward(x);
        let mut features = Vec::with_capacity(self.blocks.len());
        for (i, block) in self.blocks.iter().enumerate() {
            if i >= 2 && i % 2 == 0 {
                h = self.downs[i / 2 - 1].forward(h);
            }
            h = block.forward(h, noise.as_deref_mut());
            features.push(h.clone());
        }
        features
    }
}

/// The posterior ZConverter: posterior means μ_q at the coarsest scale (4×4) and the next
/// (8×8), conditioned on f_phi.
#[derive(Module, Debug)]
pub struct ZConverter {
    /// 1×1 conv on f_phi's last feature.
    pub conv1x1: NormConv2d,
    /// Block 0 (4×4, skip f_phi s_n_2), block 1 (skip channel_norm), block 2 (8×8, skip
    /// f_phi s_{n−1}_2).
    pub blocks: Vec<SkipResBlock>,
    /// 1×1 conv 2C → C on `[f_phi s_n_1, z_4]`.
    pub channel_norm: NormConv2d,
    /// Sub-pixel upsampling 4×4 → 8×8.
    pub up: Upsample,
}

/// Posterior means and the latents that condition the prior.
#[derive(Debug, Clone)]
struct Posterior {
    means: [Tensor<4>; 2],
    samples: [Tensor<4>; 2],
}

impl ZConverter {
    fn lowered(self) -> Self {
        Self {
            conv1x1: self.conv1x1.lowered(),
            blocks: self.blocks.into_iter().map(SkipResBlock::lowered).collect(),
            channel_norm: self.channel_norm.lowered(),
            up: self.up.lowered(),
        }
    }

    fn new(config: &ModelConfig, device: &Device, rng: &mut NoiseRng) -> Self {
        let nf = config.nf_max;
        let blocks = (0..3)
            .map(|_| SkipResBlock::new(nf, config.dropout, device, rng))
            .collect();
        Self {
            blocks,
            conv1x1: NormConv2d::new(nf, nf, 1, 1, 0, device, rng),
            up: Upsample::new(nf, nf, device, rng),
            channel_norm: NormConv2d::new(2 * nf, nf, 1, 1, 0, device, rng),
        }
    }

    fn forward(
        &self,
        f: &[Tensor<4>],
        n: usize,
        eps: [Option<Tensor<4>>; 2],
        mut noise: Option<&mut NoiseRng>,
    ) -> Posterior {
        let [eps_4, eps_8] = eps;
        let last = f[feature_index(n, 2)].clone();
        let h = self.conv1x1.forward(last.clone());
        let h = self.blocks[0].forward(h, last, noise.as_deref_mut());
        let mean_4 = h.clone();
        let z_4 = match eps_4 {
            Some(e) => mean_4.clone() + e,
            None => mean_4.clone(),
        };
        let gz = self.channel_norm.forward(Tensor::cat(
            vec![f[feature_index(n, 1)].clone(), z_4.clone()],
            1,
        ));
        let h = self.blocks[1].forward(h, gz, noise.as_deref_mut());
        let h = self.up.forward(h);
        let mean_8 = self.blocks[2].forward(h, f[feature_index(n - 1, 2)].clone(), noise);
        let z_8 = match eps_8 {
            Some(e) => mean_8.clone() + e,
            None => mean_8.clone(),
        };
        Posterior {
            means: [mean_4, mean_8],
            samples: [z_4, z_8],
        }
    }
}

/// The prior p(z | flows) with its autoregressive channel groups, fused with the latents.
#[derive(Module, Debug)]
pub struct Bottleneck {
    /// 1×1 conv on e_theta's last feature.
    pub conv1x1: NormConv2d,
    /// Skip blocks `[s_n_2, s_n_1, s_{n−1}_2, s_{n−1}_1]`.
    pub blocks: Vec<SkipResBlock>,
    /// 1×1 convs 2C → C on `[e_theta s_?_1, z]`: `[s_n, s_{n−1}]`.
    pub channel_norm: Vec<NormConv2d>,
    /// Sub-pixel upsampling between the two scales.
    pub up: Upsample,
    /// First autoregressive block (no skip input).
    pub auto_first: ResBlock,
    /// Autoregressive blocks 1–3, each fed the previous latent group as skip.
    pub auto_rest: Vec<SkipResBlock>,
    /// 1×1 conv 4C → C after space-to-depth.
    pub param_converter: NormConv2d,
}

impl Bottleneck {
    fn lowered(self) -> Self {
        Self {
            conv1x1: self.conv1x1.lowered(),
            blocks: self.blocks.into_iter().map(SkipResBlock::lowered).collect(),
            channel_norm: self
                .channel_norm
                .into_iter()
                .map(NormConv2d::lowered)
                .collect(),
            up: self.up.lowered(),
            auto_first: self.auto_first.lowered(),
            auto_rest: self
                .auto_rest
                .into_iter()
                .map(SkipResBlock::lowered)
                .collect(),
            param_converter: self.param_converter.lowered(),
        }
    }

    fn new(config: &ModelConfig, device: &Device, rng: &mut NoiseRng) -> Self {
        let nf = config.nf_max;
        let p = config.dropout;
        Self {
            conv1x1: NormConv2d::new(nf, nf, 1, 1, 0, device, rng),
            blocks: (0..4)
                .map(|_| SkipResBlock::new(nf, p, device, rng))
                .collect(),
            channel_norm: (0..2)
                .map(|_| NormConv2d::new(2 * nf, nf, 1, 1, 0, device, rng))
                .collect(),
            up: Upsample::new(nf, nf, device, rng),
            auto_first: ResBlock::new(nf, p, device, rng),
            auto_rest: (0..3)
                .map(|_| SkipResBlock::new(nf, p, device, rng))
                .collect(),
            param_converter: NormConv2d::new(4 * nf, nf, 1, 1, 0, device, rng),
        }
    }

    /// Returns the fused decoder input (at the second-coarsest scale) and the prior means.
    fn forward(
        &self,
        e: &[Tensor<4>],
        n: usize,
        z: &[Tensor<4>; 2],
        mut noise: Option<&mut NoiseRng>,
    ) -> (Tensor<4>, [Tensor<4>; 2]) {
        let mut h = self.conv1x1.forward(e[feature_index(n, 2)].clone());
        let mut prior = Vec::with_capacity(2);
        for (scale, stage) in [n, n - 1].into_iter().enumerate() {
            h = self.blocks[2 * scale].forward(
                h,
                e[feature_index(stage, 2)].clone(),
                noise.as_deref_mut(),
            );
            // Group g of the latent is the sub-pixel (g div 2, g mod 2) after space-to-depth.
            let z_groups = space_to_depth(z[scale].clone()).chunk(4, 1);
            let first = self.auto_first.forward(h.clone(), noise.as_deref_mut());
            let mut param = self.param_converter.forward(space_to_depth(first));
            let mut groups = Vec::with_capacity(4);
            for (block, group) in self.auto_rest.iter().zip(z_groups) {
                groups.push(param.clone());
                param = block.forward(param, group, noise.as_deref_mut());
            }
            groups.push(param);
            prior.push(depth_to_space(Tensor::cat(groups, 1)));

            let gz = self.channel_norm[scale].forward(Tensor::cat(
                vec![e[feature_index(stage, 1)].clone(), z[scale].clone()],
                1,
            ));
            h = self.blocks[2 * scale + 1].forward(h, gz, noise.as_deref_mut());
            if scale == 0 {
                h = self.up.forward(h);
            }
        }
        let mut prior = prior.into_iter();
        let (Some(p_4), Some(p_8)) = (prior.next(), prior.next()) else {
            unreachable!("the loop above runs exactly two scales");
        };
        (h, [p_4, p_8])
    }
}

/// The decoder: sub-pixel upsampling and skip blocks fed by f_phi, 1×1 conv, sigmoid.
#[derive(Module, Debug)]
pub struct Decoder {
    /// Upsamplers into stages n−2, …, 1 (the last halves the width).
    pub ups: Vec<Upsample>,
    /// Skip blocks, for stage n−2 down to 1: `[s_?_2, s_?_1]`.
    pub blocks: Vec<SkipResBlock>,
    /// 1×1 conv to the 3 frame channels.
    pub final_layer: NormConv2d,
}

impl Decoder {
    fn lowered(self) -> Self {
        Self {
            ups: self.ups.into_iter().map(Upsample::lowered).collect(),
            blocks: self.blocks.into_iter().map(SkipResBlock::lowered).collect(),
            final_layer: self.final_layer.lowered(),
        }
    }

    fn new(config: &ModelConfig, device: &Device, rng: &mut NoiseRng) -> Self {
        let mut nf = config.nf_max;
        let mut ups = Vec::new();
        let mut blocks = Vec::new();
        for stage in (1..=config.n_stages() - 2).rev() {
            let out = if stage == 1 { nf / 2 } else { nf };
            ups.push(Upsample::new(nf, out, device, rng));
            nf = out;
            for _ in 0..2 {
                blocks.push(SkipResBlock::new(nf, config.dropout, device, rng));
            }
        }
        Self {
            ups,
            blocks,
            final_layer: NormConv2d::new(nf, IMG_CHANNELS, 1, 1, 0, device, rng),
        }
    }

    fn forward(
        &self,
        x: Tensor<4>,
        f: &[Tensor<4>],
        mut noise: Option<&mut NoiseRng>,
    ) -> Tensor<4> {
        let mut h = x;
        let stages = self.ups.len();
        for (i, up) in self.ups.iter().enumerate() {
            let stage = stages - i;
            h = up.forward(h);
            for (j, block) in [2, 1].into_iter().enumerate() {
                h = self.blocks[2 * i + j].forward(
                    h,
                    f[feature_index(stage, block)].clone(),
                    noise.as_deref_mut(),
                );
            }
        }
        sigmoid(self.final_layer.forward(h))
    }
}

/// How the CVAE chooses its latents.
// Built once per forward pass, so the size gap between variants costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub enum Latents {
    /// Posterior means everywhere: deterministic; vadscope's default at inference.
    Mean,
    /// z = μ_q + ε at both scales, and the prior is conditioned on these samples
    /// (the reference's `mode="train"`). Noise shapes: [B, nf_max, 4, 4] and [B, nf_max, 8, 8].
    Sampled {
        /// ε at the coarsest scale.
        eps_4: Tensor<4>,
        /// ε at the second scale.
        eps_8: Tensor<4>,
    },
    /// The reference's `mode="test"`: the ZConverter samples z_4 = μ_q4 + ε (which shifts
    /// μ_q8), and the prior is conditioned on the posterior means.
    ReferenceTest {
        /// ε at the coarsest scale.
        eps_4: Tensor<4>,
    },
}

impl Latents {
    /// Standard-normal noise for [`Latents::Sampled`], drawn from `rng`.
    pub fn sampled(
        config: &ModelConfig,
        batch: usize,
        device: &Device,
        rng: &mut NoiseRng,
    ) -> Self {
        let [s4, s8] = config.latent_sides();
        let c = config.nf_max;
        Self::Sampled {
            eps_4: tensor(
                rng.normal_vec(batch * c * s4 * s4, 0.0, 1.0),
                [batch, c, s4, s4],
                device,
            ),
            eps_8: tensor(
                rng.normal_vec(batch * c * s8 * s8, 0.0, 1.0),
                [batch, c, s8, s8],
                device,
            ),
        }
    }

    /// Standard-normal noise for [`Latents::ReferenceTest`], drawn from `rng`.
    pub fn reference_test(
        config: &ModelConfig,
        batch: usize,
        device: &Device,
        rng: &mut NoiseRng,
    ) -> Self {
        let [s4, _] = config.latent_sides();
        let c = config.nf_max;
        Self::ReferenceTest {
            eps_4: tensor(
                rng.normal_vec(batch * c * s4 * s4, 0.0, 1.0),
                [batch, c, s4, s4],
                device,
            ),
        }
    }
}

impl ModelConfig {
    /// Sides of the two latent grids (4 and 8 whatever the patch size).
    pub fn latent_sides(&self) -> [usize; 2] {
        let coarsest = self.patch_size >> (self.n_stages() - 1);
        [coarsest, 2 * coarsest]
    }
}

/// Everything one CVAE pass produces.
#[derive(Debug, Clone)]
pub struct VunetOutput {
    /// Predicted frame in (0, 1), [B, 3, H, W].
    pub frame_pred: Tensor<4>,
    /// Posterior means μ_q at the coarsest and second scale.
    pub q_means: [Tensor<4>; 2],
    /// Prior means μ_p at the same scales.
    pub p_means: [Tensor<4>; 2],
    /// f_phi's last feature (`s{n}_2`).
    pub f_phi_last: Tensor<4>,
    /// e_theta's last feature (`s{n}_2`).
    pub e_theta_last: Tensor<4>,
    /// The bottleneck output (decoder input).
    pub bottleneck_out: Tensor<4>,
}

/// The CVAE (VUNet).
#[derive(Module, Debug)]
pub struct Vunet {
    /// Posterior encoder on `[past frames, flows]`.
    pub f_phi: VunetEncoder,
    /// Prior encoder on the flows.
    pub e_theta: VunetEncoder,
    /// Posterior ZConverter.
    pub zc: ZConverter,
    /// Prior and latent fusion.
    pub bottleneck: Bottleneck,
    /// Frame decoder.
    pub decoder: Decoder,
    /// Number of resolution stages.
    pub n_stages: usize,
}

impl Vunet {
    /// The CVAE with every weight-normalised conv folded into a plain conv and lowered to
    /// batched GEMMs, for inference on a non-autodiff device. The weights must not change
    /// afterwards (the lowered copies would go stale); training ignores them.
    pub fn lowered(self) -> Self {
        Self {
            f_phi: self.f_phi.lowered(),
            e_theta: self.e_theta.lowered(),
            zc: self.zc.lowered(),
            bottleneck: self.bottleneck.lowered(),
            decoder: self.decoder.lowered(),
            n_stages: self.n_stages,
        }
    }

    /// A freshly initialised CVAE (PyTorch default conv init, seeded by `rng`).
    pub fn new(config: &ModelConfig, device: &Device, rng: &mut NoiseRng) -> Self {
        let flows = config.cube_flow_channels();
        Self {
            f_phi: VunetEncoder::new(config.clip_hist * IMG_CHANNELS + flows, config, device, rng),
            e_theta: VunetEncoder::new(flows, config, device, rng),
            zc: ZConverter::new(config, device, rng),
            bottleneck: Bottleneck::new(config, device, rng),
            decoder: Decoder::new(config, device, rng),
            n_stages: config.n_stages(),
        }
    }

    /// Predicts the target frame from the past frames `appearance` [B, 3·clip_hist, H, W] and
    /// the (reconstructed) flows `motion` [B, 2·num_flows, H, W]. `noise` drives dropout
    /// (None: no dropout, as in eval mode).
    pub fn forward(
        &self,
        appearance: Tensor<4>,
        motion: Tensor<4>,
        latents: &Latents,
        mut noise: Option<&mut NoiseRng>,
    ) -> VunetOutput {
        let n = self.n_stages;
        let f = self.f_phi.forward(
            Tensor::cat(vec![appearance, motion.clone()], 1),
            noise.as_deref_mut(),
        );
        let eps = match latents {
            Latents::Mean => [None, None],
            Latents::Sampled { eps_4, eps_8 } => [Some(eps_4.clone()), Some(eps_8.clone())],
            Latents::ReferenceTest { eps_4 } => [Some(eps_4.clone()), None],
        };
        let posterior = self.zc.forward(&f, n, eps, noise.as_deref_mut());
        let e = self.e_theta.forward(motion, noise.as_deref_mut());
        let condition = match latents {
            Latents::Sampled { .. } => &posterior.samples,
            Latents::Mean | Latents::ReferenceTest { .. } => &posterior.means,
        };
        let (bottleneck_out, p_means) =
            self.bottleneck
                .forward(&e, n, condition, noise.as_deref_mut());
        let frame_pred = self.decoder.forward(bottleneck_out.clone(), &f, noise);
        VunetOutput {
            frame_pred,
            q_means: posterior.means,
            p_means,
            f_phi_last: f[feature_index(n, 2)].clone(),
            e_theta_last: e[feature_index(n, 2)].clone(),
            bottleneck_out,
        }
    }
}
