//! The training losses of the three stages (spec §3.5, §4.5, §5) and the per-cube scores
//! S_r and S_p (spec §6).

use serde::{Deserialize, Serialize};

use burn::tensor::Tensor;

use super::hf2vad::Hf2VadOutput;
use super::memae::MemAeOutput;

/// Loss weights, reference values by default.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LossWeights {
    /// Flow reconstruction MSE (`lam_recon`, 1.0).
    pub recon: f64,
    /// Memory attention entropy (`lam_sparse`, 0.0002).
    pub sparse: f64,
    /// KL between posterior and prior means (`lam_kl`, 1.0).
    pub kl: f64,
    /// Frame intensity loss (`lam_frame`, 1.0).
    pub frame: f64,
    /// Frame gradient loss (`lam_grad`, 1.0).
    pub grad: f64,
    /// Exponent of the intensity loss (`intensity_loss_norm`, 2).
    pub intensity_norm: i32,
    /// Exponent of the gradient loss (`alpha`, 1).
    pub grad_alpha: f64,
}

impl Default for LossWeights {
    fn default() -> Self {
        Self {
            recon: 1.0,
            sparse: 0.0002,
            kl: 1.0,
            frame: 1.0,
            grad: 1.0,
            intensity_norm: 2,
            grad_alpha: 1.0,
        }
    }
}

/// Mean squared error over all elements.
pub fn mse(pred: Tensor<4>, target: Tensor<4>) -> Tensor<1> {
    (pred - target).square().mean()
}

/// Memory entropy: for each memory, the mean over rows of −Σ_slots w·log(w + 1e-12); summed
/// over the memories.
pub fn attention_entropy(attention: &[Tensor<2>; 3]) -> Tensor<1> {
    let per_memory = attention.iter().map(|w| {
        let h = (w.clone() * w.clone().add_scalar(1e-12).log())
            .neg()
            .sum_dim(1);
        h.mean()
    });
    per_memory
        .reduce(|a, b| a + b)
        .unwrap_or_else(|| unreachable!("three memories"))
}

/// Intensity loss: mean of |pred − target|^norm.
pub fn intensity_loss(pred: Tensor<4>, target: Tensor<4>, norm: i32) -> Tensor<1> {
    let d = pred - target;
    match norm {
        2 => d.square().mean(),
        1 => d.abs().mean(),
        n => d.powi_scalar(n).abs().mean(),
    }
}

/// First differences of the channel-summed image along `dim` (2 = y, 3 = x), zero-padded at
/// the start, as the reference's [−1, 1] filter of shape [1, C, 1, 2].
fn channel_summed_difference(x: Tensor<4>, dim: usize) -> Tensor<4> {
    let s = x.sum_dim(1);
    let len = s.dims()[dim];
    let mut pad_shape = s.dims();
    pad_shape[dim] = 1;
    let shifted = Tensor::cat(
        vec![
            Tensor::zeros(pad_shape, &s.device()),
            s.clone().narrow(dim, 0, len - 1),
        ],
        dim,
    );
    s - shifted
}

/// Gradient loss: mean over pixels of |Δx gt − Δx pred|^α + |Δy gt − Δy pred|^α, the
/// differences taken on the channel-summed images.
pub fn gradient_loss(pred: Tensor<4>, target: Tensor<4>, alpha: f64) -> Tensor<1> {
    let dx = (channel_summed_difference(target.clone(), 3)
        - channel_summed_difference(pred.clone(), 3))
    .abs();
    let dy = (channel_summed_difference(target, 2) - channel_summed_difference(pred, 2)).abs();
    if alpha == 1.0 {
        (dx + dy).mean()
    } else {
        (dx.powf_scalar(alpha) + dy.powf_scalar(alpha)).mean()
    }
}

/// KL between unit-variance Gaussians per scale: 0.5·Σ_{C,H,W}(μ_q − μ_p)², batch mean.
pub fn latent_kl(q: Tensor<4>, p: Tensor<4>) -> Tensor<1> {
    let [b, _, _, _] = q.dims();
    (q - p).square().sum().mul_scalar(0.5 / b as f64)
}

/// Stage-1 loss parts (ML-MemAE-SC alone on one flow).
#[derive(Debug, Clone)]
pub struct Stage1Loss {
    /// Flow MSE.
    pub recon: Tensor<1>,
    /// Attention entropy.
    pub entropy: Tensor<1>,
    /// `recon·w_recon + entropy·w_sparse`.
    pub total: Tensor<1>,
}

/// The stage-1 loss of one ML-MemAE-SC pass against its input `target`.
pub fn stage1_loss(out: &MemAeOutput, target: Tensor<4>, w: &LossWeights) -> Stage1Loss {
    let recon = mse(out.recon.clone(), target);
    let entropy = attention_entropy(&out.attention);
    let total = recon.clone().mul_scalar(w.recon) + entropy.clone().mul_scalar(w.sparse);
    Stage1Loss {
        recon,
        entropy,
        total,
    }
}

/// Stage-2 loss parts (CVAE).
#[derive(Debug, Clone)]
pub struct Stage2Loss {
    /// KL per scale (coarsest first).
    pub kl_scales: [Tensor<1>; 2],
    /// KL summed over the scales.
    pub kl: Tensor<1>,
    /// Intensity loss.
    pub frame: Tensor<1>,
    /// Gradient loss.
    pub grad: Tensor<1>,
    /// Weighted sum.
    pub total: Tensor<1>,
}

/// The stage-2 loss of a model pass; `target` is the last frame [B, 3, H, W].
pub fn stage2_loss(out: &Hf2VadOutput, target: Tensor<4>, w: &LossWeights) -> Stage2Loss {
    let [q4, q8] = out.cvae.q_means.clone();
    let [p4, p8] = out.cvae.p_means.clone();
    let kl_scales = [latent_kl(q4, p4), latent_kl(q8, p8)];
    let kl = kl_scales[0].clone() + kl_scales[1].clone();
    let pred = out.cvae.frame_pred.clone();
    let frame = intensity_loss(pred.clone(), target.clone(), w.intensity_norm);
    let grad = gradient_loss(pred, target, w.grad_alpha);
    let total = kl.clone().mul_scalar(w.kl)
        + frame.clone().mul_scalar(w.frame)
        + grad.clone().mul_scalar(w.grad);
    Stage2Loss {
        kl_scales,
        kl,
        frame,
        grad,
        total,
    }
}

/// Stage-3 loss parts (fine-tuning everything).
#[derive(Debug, Clone)]
pub struct Stage3Loss {
    /// The stage-2 part.
    pub cvae: Stage2Loss,
    /// Flow MSE over all flow channels.
    pub recon: Tensor<1>,
    /// Entropy of the attention of all flow passes.
    pub sparsity: Tensor<1>,
    /// `cvae.total + recon·w_recon + sparsity·w_sparse`.
    pub total: Tensor<1>,
}

/// The stage-3 loss of a model pass against the input `flows` and last frame `target`.
pub fn stage3_loss(
    out: &Hf2VadOutput,
    flows: Tensor<4>,
    target: Tensor<4>,
    w: &LossWeights,
) -> Stage3Loss {
    let cvae = stage2_loss(out, target, w);
    let recon = mse(out.of_recon.clone(), flows);
    let sparsity = attention_entropy(&out.attention);
    let total = cvae.total.clone()
        + recon.clone().mul_scalar(w.recon)
        + sparsity.clone().mul_scalar(w.sparse);
    Stage3Loss {
        cvae,
        recon,
        sparsity,
        total,
    }
}

/// Per-sample sum of squared errors over all non-batch dimensions, [B].
pub fn per_sample_sse(pred: Tensor<4>, target: Tensor<4>) -> Tensor<1> {
    let [b, c, h, w] = pred.dims();
    (pred - target)
        .square()
        .reshape([b, c * h * w])
        .sum_dim(1)
        .reshape([b])
}
