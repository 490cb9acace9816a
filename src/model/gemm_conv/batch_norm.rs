//! Training-mode BatchNorm with its ReLU, as one node of burn's autodiff graph.
//!
//! burn's `batch_norm_train` is one node too, but its CPU backend builds it from generic
//! tensor operations: the statistics copy the input twice into channel-major order, and the
//! backward pass makes about fifteen whole-tensor passes and three more copies; the ReLU
//! after it is two nodes more. ML-MemAE-SC runs conv → BatchNorm → ReLU twice per encoder
//! and decoder block, so in a stage-1 step these element-wise passes cost about as much as
//! the convolutions' packing. Here each channel's statistics are two passes over its planes,
//! the output one more, and the backward pass two (the sums, then the input gradient), with
//! the ReLU's mask recomputed from the saved input rather than stored.
//!
//! Formulas (per channel, n = B·H·W values): x̂ = (x − μ)/√(σ² + ε) with the biased σ²,
//! y = max(γ·x̂ + β, 0); with ĝ = ∂L/∂y masked where y = 0,
//! ∂L/∂β = Σ ĝ, ∂L/∂γ = Σ ĝ·x̂, ∂L/∂x = γ/√(σ² + ε) · (ĝ − Σ ĝ/n − x̂·Σ ĝ·x̂/n).
//! Every sum runs in a fixed order (lanes within a plane, planes in sample order), so the
//! values do not depend on the thread count.

use burn::backend::Flex;
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::tensor::activation::relu;
use burn::tensor::module::batch_norm_train;
use burn::tensor::{Tensor, TensorData};
use burn_flex::FlexTensor;
use rayon::prelude::*;

use super::CpuValues;
use super::kernels::vectorised;
use super::training::{Trained, autodiff_primitive, burn_layers, plain};

/// The output of [`batch_norm_relu`] and the batch statistics a running average is updated
/// with.
#[derive(Debug)]
pub struct BatchNormReluOutput {
    /// max(BatchNorm(x), 0), [B, C, H, W].
    pub output: Tensor<4>,
    /// The batch mean per channel, [C] (not differentiable).
    pub mean: Tensor<1>,
    /// The biased batch variance per channel, [C] (not differentiable).
    pub variance: Tensor<1>,
}

/// max(γ·(x − μ)/√(σ² + ε) + β, 0) of `x` [B, C, H, W] with its batch statistics μ, σ²: one
/// differentiable node on burn's autodiff CPU device, burn's `batch_norm_train` and `relu`
/// inside [`with_burn_layers`](super::training::with_burn_layers).
///
/// Training mode only: the tensors must live on the autodiff CPU device (it panics
/// elsewhere); `BatchNorm2d::forward_relu` routes evaluation to the running statistics.
pub fn batch_norm_relu(
    x: Tensor<4>,
    gamma: Tensor<1>,
    beta: Tensor<1>,
    epsilon: f64,
) -> BatchNormReluOutput {
    if burn_layers() {
        let out = batch_norm_train(x, gamma, beta, epsilon);
        return BatchNormReluOutput {
            output: relu(out.output),
            mean: out.mean.detach(),
            variance: out.variance.detach(),
        };
    }
    let device = x.device();
    let dims = x.dims();
    let (x, x_node) = autodiff_primitive(x).into_parts();
    let (gamma, gamma_node) = autodiff_primitive(gamma).into_parts();
    let (beta, beta_node) = autodiff_primitive(beta).into_parts();
    let gamma = CpuValues::new(plain::<1>(gamma)).as_slice().to_vec();
    let beta = CpuValues::new(plain::<1>(beta)).as_slice().to_vec();
    let input = CpuValues::new(plain::<4>(x.clone()));
    let statistics = ChannelStatistics::of(input.as_slice(), dims, &gamma, &beta, epsilon);
    let output = statistics.forward(input.as_slice(), dims);
    let output = FlexTensor::from_data(TensorData::new(output, dims));
    let mean = Tensor::from_data(TensorData::new(statistics.mean.clone(), [dims[1]]), &device);
    let variance = Tensor::from_data(
        TensorData::new(statistics.variance.clone(), [dims[1]]),
        &device,
    );
    let nodes = [x_node, gamma_node, beta_node];
    let tracked = match BatchNormReluBackward
        .prepare::<NoCheckpointing>(nodes)
        .compute_bound()
        .stateful()
    {
        OpsKind::Tracked(prep) => prep.finish(
            BatchNormReluState {
                x,
                dims,
                statistics,
            },
            output,
        ),
        OpsKind::UnTracked(prep) => prep.finish(output),
    };
    BatchNormReluOutput {
        output: Tensor::from_primitive::<Trained>(tracked),
        mean,
        variance,
    }
}

/// Per-channel statistics of a batch and the affine map they give.
#[derive(Debug, Clone)]
struct ChannelStatistics {
    mean: Vec<f32>,
    /// The biased variance.
    variance: Vec<f32>,
    /// 1/√(σ² + ε).
    inv_std: Vec<f32>,
    /// γ/√(σ² + ε): y = max(x·scale + shift, 0).
    scale: Vec<f32>,
    /// β − μ·scale.
    shift: Vec<f32>,
}

impl ChannelStatistics {
    fn of(x: &[f32], [b, c, h, w]: [usize; 4], gamma: &[f32], beta: &[f32], eps: f64) -> Self {
        let area = h * w;
        let n = (b * area) as f64;
        let per_channel: Vec<(f32, f32)> = (0..c)
            .into_par_iter()
            .map(|ch| {
                let planes = || (0..b).map(move |s| &x[(s * c + ch) * area..][..area]);
                let mean = planes().map(|p| lane_sums(p, p, |v, _| v)).sum::<f64>() / n;
                let m = mean as f32;
                let variance = planes()
                    .map(|p| lane_sums(p, p, |v, _| (v - m) * (v - m)))
                    .sum::<f64>()
                    / n;
                (m, variance as f32)
            })
            .collect();
        let (mean, variance): (Vec<f32>, Vec<f32>) = per_channel.into_iter().unzip();
        let inv_std: Vec<f32> = variance
            .iter()
            .map(|&v| (1.0 / (f64::from(v) + eps).sqrt()) as f32)
            .collect();
        let scale: Vec<f32> = gamma.iter().zip(&inv_std).map(|(g, s)| g * s).collect();
        let shift = beta
            .iter()
            .zip(&mean)
            .zip(&scale)
            .map(|((b, m), s)| b - m * s)
            .collect();
        Self {
            mean,
            variance,
            inv_std,
            scale,
            shift,
        }
    }

    /// max(x·scale + shift, 0) per channel.
    fn forward(&self, x: &[f32], [_, c, h, w]: [usize; 4]) -> Vec<f32> {
        let area = h * w;
        let mut out = vec![0.0f32; x.len()];
        out.par_chunks_mut(area)
            .zip(x.par_chunks(area))
            .enumerate()
            .for_each(|(plane, (out, x))| {
                let (scale, shift) = (self.scale[plane % c], self.shift[plane % c]);
                vectorised(
                    #[inline(always)]
                    || {
                        for (o, &v) in out.iter_mut().zip(x) {
                            *o = (v * scale + shift).max(0.0);
                        }
                    },
                );
            });
        out
    }

    /// The gradients of x, γ and β for `grad` of the output.
    fn backward(&self, x: &[f32], grad: &[f32], [b, c, h, w]: [usize; 4]) -> Gradient {
        let area = h * w;
        let n = (b * area) as f32;
        // Σ ĝ and Σ ĝ·x̂ per channel, ĝ being the gradient where the output is positive.
        let sums: Vec<(f32, f32)> = (0..c)
            .into_par_iter()
            .map(|ch| {
                let (scale, shift) = (self.scale[ch], self.shift[ch]);
                let (mean, inv_std) = (self.mean[ch], self.inv_std[ch]);
                let masked = move |v: f32, g: f32| if v * scale + shift > 0.0 { g } else { 0.0 };
                let (mut sum, mut dot) = (0.0f64, 0.0f64);
                for s in 0..b {
                    let at = (s * c + ch) * area;
                    let (x, g) = (&x[at..][..area], &grad[at..][..area]);
                    sum += lane_sums(x, g, masked);
                    dot += lane_sums(x, g, |v, g| masked(v, g) * (v - mean) * inv_std);
                }
                (sum as f32, dot as f32)
            })
            .collect();
        let (beta, gamma): (Vec<f32>, Vec<f32>) = sums.iter().copied().unzip();
        let mut input = vec![0.0f32; x.len()];
        input
            .par_chunks_mut(area)
            .zip(x.par_chunks(area).zip(grad.par_chunks(area)))
            .enumerate()
            .for_each(|(plane, (dx, (x, g)))| {
                let ch = plane % c;
                let (scale, shift) = (self.scale[ch], self.shift[ch]);
                let (mean, inv_std) = (self.mean[ch], self.inv_std[ch]);
                let (mean_grad, mean_dot) = (beta[ch] / n, gamma[ch] / n);
                vectorised(
                    #[inline(always)]
                    || {
                        for ((d, &v), &gv) in dx.iter_mut().zip(x).zip(g) {
                            let masked = if v * scale + shift > 0.0 { gv } else { 0.0 };
                            let normalised = (v - mean) * inv_std;
                            *d = scale * (masked - mean_grad - normalised * mean_dot);
                        }
                    },
                );
            });
        Gradient { input, gamma, beta }
    }
}

/// The gradients [`ChannelStatistics::backward`] gives.
struct Gradient {
    input: Vec<f32>,
    gamma: Vec<f32>,
    beta: Vec<f32>,
}

/// Lanes of a plane's sum: eight running sums, added in a fixed order at the end, so the sum
/// vectorises without reassociating (and so without depending on the instruction set).
const LANES: usize = 8;

/// Σ f(aᵢ, bᵢ) over two planes of the same length, in [`LANES`] partial sums.
#[inline(always)]
fn lane_sums(a: &[f32], b: &[f32], f: impl Fn(f32, f32) -> f32 + Copy) -> f64 {
    vectorised(
        #[inline(always)]
        || {
            let mut lanes = [0.0f32; LANES];
            let (a_lanes, b_lanes) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
            let tail: f64 = a_lanes
                .remainder()
                .iter()
                .zip(b_lanes.remainder())
                .map(|(&a, &b)| f64::from(f(a, b)))
                .sum();
            for (a, b) in a_lanes.zip(b_lanes) {
                for ((sum, &a), &b) in lanes.iter_mut().zip(a).zip(b) {
                    *sum += f(a, b);
                }
            }
            lanes.iter().map(|&s| f64::from(s)).sum::<f64>() + tail
        },
    )
}

/// The backward step of [`batch_norm_relu`].
#[derive(Debug)]
struct BatchNormReluBackward;

/// What the backward step keeps: the input (shared storage) and the statistics.
#[derive(Debug, Clone)]
struct BatchNormReluState {
    x: FlexTensor,
    dims: [usize; 4],
    statistics: ChannelStatistics,
}

impl Backward<Flex, 3> for BatchNormReluBackward {
    type State = BatchNormReluState;

    fn backward(
        self,
        ops: Ops<BatchNormReluState, 3>,
        grads: &mut Gradients,
        _: &mut Checkpointer,
    ) {
        let [x_node, gamma_node, beta_node] = ops.parents;
        let grad = CpuValues::new(plain::<4>(grads.consume::<Flex>(&ops.node)));
        let BatchNormReluState {
            x,
            dims,
            statistics,
        } = ops.state;
        let x = CpuValues::new(plain::<4>(x));
        let gradient = statistics.backward(x.as_slice(), grad.as_slice(), dims);
        let channels = dims[1];
        if let Some(node) = beta_node {
            let t = FlexTensor::from_data(TensorData::new(gradient.beta, [channels]));
            grads.register::<Flex>(node.id, t);
        }
        if let Some(node) = gamma_node {
            let t = FlexTensor::from_data(TensorData::new(gradient.gamma, [channels]));
            grads.register::<Flex>(node.id, t);
        }
        if let Some(node) = x_node {
            let t = FlexTensor::from_data(TensorData::new(gradient.input, dims));
            grads.register::<Flex>(node.id, t);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::training::tests::{random, relative_error};
    use super::super::training::with_burn_layers;
    use super::*;
    use crate::model::rng::NoiseRng;

    /// The output, the batch statistics and the gradients of x, γ and β for the loss
    /// Σ out · r.
    fn run(x: &Tensor<4>, gamma: &Tensor<1>, beta: &Tensor<1>, r: &Tensor<4>) -> [Vec<f32>; 6] {
        let x = x.clone().require_grad();
        let gamma = gamma.clone().require_grad();
        let beta = beta.clone().require_grad();
        let out = batch_norm_relu(x.clone(), gamma.clone(), beta.clone(), 1e-5);
        let grads = (out.output.clone() * r.clone()).sum().backward();
        let values = |t: TensorData| t.try_to_vec::<f32>().unwrap();
        [
            values(out.output.into_data()),
            values(out.mean.into_data()),
            values(out.variance.into_data()),
            values(x.grad(&grads).expect("input gradient").into_data()),
            values(gamma.grad(&grads).expect("γ gradient").into_data()),
            values(beta.grad(&grads).expect("β gradient").into_data()),
        ]
    }

    #[test]
    fn fused_batch_norm_relu_matches_burns_autodiff() {
        let mut rng = NoiseRng::new(31);
        // Planes of a multiple of the lanes and not, one sample and many, a shifted and
        // scaled input (as a convolution's output is).
        for (batch, channels, side) in [(4, 3, 4), (1, 5, 7), (9, 8, 5), (32, 4, 16)] {
            let shape = [batch, channels, side, side];
            let x = random(&mut rng, shape).mul_scalar(3.0).add_scalar(1.5);
            let gamma = random(&mut rng, [channels]);
            let beta = random(&mut rng, [channels]);
            let r = random(&mut rng, shape);
            let ours = run(&x, &gamma, &beta, &r);
            let burn = with_burn_layers(|| run(&x, &gamma, &beta, &r));
            for (i, name) in ["output", "mean", "variance", "x grad", "γ grad", "β grad"]
                .into_iter()
                .enumerate()
            {
                let tensor = |v: &[f32]| {
                    Tensor::<1>::from_data(TensorData::new(v.to_vec(), [v.len()]), &x.device())
                };
                let error = relative_error(&tensor(&ours[i]), &tensor(&burn[i]));
                assert!(
                    error < 1e-5,
                    "{shape:?}: {name} differs from burn's by {error:e}"
                );
            }
        }
    }

    #[test]
    fn sums_do_not_depend_on_the_thread_count() {
        let mut rng = NoiseRng::new(32);
        let shape = [16, 6, 9, 9];
        let (x, gamma, beta, r) = (
            random(&mut rng, shape),
            random(&mut rng, [6]),
            random(&mut rng, [6]),
            random(&mut rng, shape),
        );
        let on = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| run(&x, &gamma, &beta, &r))
        };
        assert_eq!(on(1), on(3));
    }
}
