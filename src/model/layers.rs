//! Building blocks shared by ML-MemAE-SC and the CVAE: PyTorch-semantics BatchNorm, plain
//! and transposed convolutions with the reference initialisations, the weight-normalised
//! `NormConv2d`, VUNet residual blocks, sub-pixel up/down sampling and the TensorFlow-order
//! space-to-depth / depth-to-space.

use burn::module::{Flag, Module, Param, RunningState};
use burn::nn::Initializer;
use burn::nn::PaddingConfig2d;
use burn::nn::conv::{Conv2d, Conv2dConfig, ConvTranspose2d, ConvTranspose2dConfig};
use burn::tensor::activation::relu;
use burn::tensor::module::batch_norm_train;
use burn::tensor::{Device, Tensor, TensorData};

use super::gemm_conv::{Activation, ConvGeometry, GemmConv2d, training};
use super::rng::NoiseRng;

/// A parameter holding `values` with `shape` on `device`.
pub(crate) fn param<const D: usize>(
    values: Vec<f32>,
    shape: [usize; D],
    device: &Device,
) -> Param<Tensor<D>> {
    Param::from_tensor(tensor(values, shape, device))
}

/// A tensor holding `values` with `shape` on `device`.
pub(crate) fn tensor<const D: usize>(
    values: Vec<f32>,
    shape: [usize; D],
    device: &Device,
) -> Tensor<D> {
    Tensor::from_data(TensorData::new(values, shape), device)
}

/// Gain of PyTorch's `kaiming_normal_` for a leaky ReLU of slope `a`.
fn leaky_gain(a: f64) -> f64 {
    (2.0 / (1.0 + a * a)).sqrt()
}

/// BatchNorm over channels with PyTorch's semantics: normalisation by the biased batch
/// variance, running variance updated with the **unbiased** one (burn's `BatchNorm` uses the
/// biased variance for both, which drifts from reference checkpoints).
///
/// Training behaviour (batch statistics, running-stat update) runs when the input lives on
/// an autodiff device and the `training` flag is on, as burn's own layers decide;
/// [`Module::freeze`] or [`Module::valid`] switch it to running statistics.
#[derive(Module, Debug)]
pub struct BatchNorm2d {
    /// Scale γ (`weight` in PyTorch).
    pub weight: Param<Tensor<1>>,
    /// Shift β (`bias` in PyTorch).
    pub bias: Param<Tensor<1>>,
    /// Running mean.
    pub running_mean: RunningState<Tensor<1>>,
    /// Running (unbiased) variance.
    pub running_var: RunningState<Tensor<1>>,
    /// Whether training behaviour is enabled.
    pub training: Param<Flag>,
    /// Running-stat momentum (0.1).
    pub momentum: f64,
    /// Variance epsilon (1e-5).
    pub eps: f64,
}

impl BatchNorm2d {
    /// The reference (`weights_init_kaiming`) initialisation: γ ~ N(1, 0.02), β = 0, running
    /// mean 0, running variance 1.
    pub fn new(channels: usize, device: &Device, rng: &mut NoiseRng) -> Self {
        Self {
            weight: param(rng.normal_vec(channels, 1.0, 0.02), [channels], device),
            bias: param(vec![0.0; channels], [channels], device),
            running_mean: RunningState::new(Tensor::zeros([channels], device)),
            running_var: RunningState::new(Tensor::ones([channels], device)),
            training: Param::from_bool(true),
            momentum: 0.1,
            eps: 1e-5,
        }
    }

    /// Normalises `x` [B, C, H, W].
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        if x.device().is_autodiff() && self.training.is_enabled() {
            self.forward_train(x)
        } else {
            let device = x.device();
            burn::tensor::module::batch_norm(
                x,
                self.weight.val(),
                self.bias.val(),
                self.running_mean.value_sync().to_device(&device),
                self.running_var.value_sync().to_device(&device),
                self.eps,
            )
        }
    }

    /// max(BatchNorm(`x`), 0): in training, one fused node of the autodiff graph
    /// ([`training::batch_norm_relu`]); else the normalisation by the running statistics,
    /// then the ReLU.
    pub fn forward_relu(&self, x: Tensor<4>) -> Tensor<4> {
        if x.device().is_autodiff() && self.training.is_enabled() {
            let count = batch_values_per_channel(&x);
            let out = training::batch_norm_relu(x, self.weight.val(), self.bias.val(), self.eps);
            self.update_running(out.mean, out.variance, count);
            out.output
        } else {
            relu(self.forward(x))
        }
    }

    fn forward_train(&self, x: Tensor<4>) -> Tensor<4> {
        let count = batch_values_per_channel(&x);
        let out = batch_norm_train(x, self.weight.val(), self.bias.val(), self.eps);
        self.update_running(out.mean.detach(), out.variance.detach(), count);
        out.output
    }

    /// Folds a batch's `mean` and biased `variance` of `count` values per channel into the
    /// running statistics, as PyTorch does.
    fn update_running(&self, mean: Tensor<1>, variance: Tensor<1>, count: usize) {
        let device = mean.device();
        let count = count as f64;
        // PyTorch raises for a single value per channel; keeping the biased value there
        // avoids an infinite running variance instead.
        let bessel = if count > 1.0 {
            count / (count - 1.0)
        } else {
            1.0
        };
        let m = self.momentum;
        let running_mean = self.running_mean.value_sync().to_device(&device);
        let running_var = self.running_var.value_sync().to_device(&device);
        let running_mean = running_mean.mul_scalar(1.0 - m).add(mean.mul_scalar(m));
        let running_var = running_var
            .mul_scalar(1.0 - m)
            .add(variance.mul_scalar(m * bessel));
        self.running_mean.update(running_mean.detach());
        self.running_var.update(running_var.detach());
    }
}

/// B·H·W: the values each channel of `x` [B, C, H, W] has in a batch.
fn batch_values_per_channel(x: &Tensor<4>) -> usize {
    let [b, _, h, w] = x.dims();
    b * h * w
}

/// A 2D convolution with bias, initialised as the reference's ML-MemAE-SC convs:
/// kaiming-normal weights (a = 0.1, fan-in) and PyTorch's default uniform bias.
pub fn kaiming_conv(
    channels: [usize; 2],
    kernel: usize,
    stride: usize,
    padding: usize,
    device: &Device,
    rng: &mut NoiseRng,
) -> Conv2d {
    let [cin, cout] = channels;
    let fan_in = (cin * kernel * kernel) as f64;
    let mut conv = Conv2dConfig::new(channels, [kernel, kernel])
        .with_stride([stride, stride])
        .with_padding(PaddingConfig2d::Explicit(
            padding, padding, padding, padding,
        ))
        .with_initializer(Initializer::Zeros)
        .init(device);
    let std = leaky_gain(0.1) / fan_in.sqrt();
    conv.weight = param(
        rng.normal_vec(cout * cin * kernel * kernel, 0.0, std),
        [cout, cin, kernel, kernel],
        device,
    );
    let bound = 1.0 / fan_in.sqrt();
    conv.bias = Some(param(rng.uniform_vec(cout, -bound, bound), [cout], device));
    conv
}

/// The ×2 upsampling ConvTranspose2d of ML-MemAE-SC (k3, s2, p1, output padding 1), with
/// PyTorch's default init (which the reference keeps: its kaiming init skips ConvTranspose).
pub fn upsampling_conv(
    channels: [usize; 2],
    device: &Device,
    rng: &mut NoiseRng,
) -> ConvTranspose2d {
    let [cin, cout] = channels;
    let mut conv = ConvTranspose2dConfig::new(channels, [3, 3])
        .with_stride([2, 2])
        .with_padding([1, 1])
        .with_padding_out([1, 1])
        .with_initializer(Initializer::Zeros)
        .init(device);
    // PyTorch computes the fan-in of a transposed conv from weight dim 1 (its output channels).
    let bound = 1.0 / ((cout * 9) as f64).sqrt();
    conv.weight = param(
        rng.uniform_vec(cin * cout * 9, -bound, bound),
        [cin, cout, 3, 3],
        device,
    );
    conv.bias = Some(param(rng.uniform_vec(cout, -bound, bound), [cout], device));
    conv
}

/// A weight-normalised convolution (PyTorch `weight_norm(Conv2d)`): the effective weight is
/// `weight_g · weight_v / ‖weight_v‖`, the norm taken per output channel over (C_in, k, k).
#[derive(Module, Debug)]
pub struct WeightNormConv2d {
    /// Magnitude g, [C_out, 1, 1, 1].
    pub weight_g: Param<Tensor<4>>,
    /// Direction v, [C_out, C_in, k, k].
    pub weight_v: Param<Tensor<4>>,
    /// Bias, [C_out].
    pub bias: Param<Tensor<1>>,
    /// Stride.
    pub stride: usize,
    /// Zero padding on every side.
    pub padding: usize,
}

impl WeightNormConv2d {
    /// The effective convolution weight g·v/‖v‖.
    pub fn weight(&self) -> Tensor<4> {
        let v = self.weight_v.val();
        let norm = v.clone().square().sum_dim(1).sum_dim(2).sum_dim(3).sqrt();
        v * (self.weight_g.val() / norm)
    }

    fn geometry(&self) -> ConvGeometry {
        let [.., kernel] = self.weight_v.dims();
        ConvGeometry {
            kernel,
            stride: self.stride,
            padding: self.padding,
        }
    }
}

/// VUNet's `NormConv2d`: a weight-normalised convolution followed by a learned per-channel
/// affine, `gamma · conv(x) + beta`.
#[derive(Module, Debug)]
pub struct NormConv2d {
    /// Per-channel shift, [1, C, 1, 1].
    pub beta: Param<Tensor<4>>,
    /// Per-channel scale, [1, C, 1, 1].
    pub gamma: Param<Tensor<4>>,
    /// The weight-normalised convolution.
    pub conv: WeightNormConv2d,
    /// γ, β and the weight norm folded into one conv, set by [`NormConv2d::lowered`] for
    /// inference. Used only on non-autodiff devices; weights must not change afterwards.
    #[module(skip)]
    pub cache: Option<GemmConv2d>,
}

impl NormConv2d {
    /// PyTorch's default conv init (uniform ±1/√fan_in for v and bias), g = ‖v‖ as
    /// `weight_norm` sets it, γ = 1, β = 0. The reference's kaiming init does not reach these
    /// layers (spec §5), so this is what it trains from.
    pub fn new(
        cin: usize,
        cout: usize,
        kernel: usize,
        stride: usize,
        padding: usize,
        device: &Device,
        rng: &mut NoiseRng,
    ) -> Self {
        let fan = cin * kernel * kernel;
        let bound = 1.0 / (fan as f64).sqrt();
        let v = rng.uniform_vec(cout * fan, -bound, bound);
        let g: Vec<f32> = v
            .chunks(fan)
            .map(|row| row.iter().map(|x| x * x).sum::<f32>().sqrt())
            .collect();
        Self {
            beta: param(vec![0.0; cout], [1, cout, 1, 1], device),
            gamma: param(vec![1.0; cout], [1, cout, 1, 1], device),
            conv: WeightNormConv2d {
                weight_g: param(g, [cout, 1, 1, 1], device),
                weight_v: param(v, [cout, cin, kernel, kernel], device),
                bias: param(rng.uniform_vec(cout, -bound, bound), [cout], device),
                stride,
                padding,
            },
            cache: None,
        }
    }

    /// Applies the layer to `x` [B, C_in, H, W].
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        if let Some(cache) = self.lowered_for(&x, false, 0.0) {
            return cache.forward(x);
        }
        // γ·(W∗x + b) + β = (γW)∗x + (γb + β): folding the affine into the weights, which
        // are small, spares two passes over the activations forward and four backward.
        let (weight, bias) = self.folded_weights();
        training::conv2d(x, weight, bias, self.conv.geometry())
    }

    /// The weights and bias of the one convolution equal to the layer: γ·g·v/‖v‖ and
    /// γ·b + β (differentiable).
    fn folded_weights(&self) -> (Tensor<4>, Tensor<1>) {
        let gamma = self.gamma.val();
        let [_, cout, _, _] = gamma.dims();
        let gamma_col = gamma.clone().reshape([cout, 1, 1, 1]);
        let weight = self.conv.weight() * gamma_col;
        let bias = self.conv.bias.val() * gamma.reshape([cout]) + self.beta.val().reshape([cout]);
        (weight, bias)
    }

    /// The layer with γ, β and the weight norm folded into one plain convolution, lowered
    /// for batched inference (same outputs).
    pub fn lower(&self) -> GemmConv2d {
        let (weight, bias) = self.folded_weights();
        GemmConv2d::new(weight, bias, self.conv.geometry(), Activation::Identity)
    }

    /// The layer with its folded form cached for inference (see [`NormConv2d::cache`]).
    pub fn lowered(self) -> Self {
        let cache = Some(self.lower());
        Self { cache, ..self }
    }

    /// The lowered layer, where it may replace this one for `x`: on a non-autodiff device,
    /// and where no dropout with probability `dropout` (drawn when `noisy`) comes between
    /// the block's activation and this convolution.
    fn lowered_for(&self, x: &Tensor<4>, noisy: bool, dropout: f64) -> Option<&GemmConv2d> {
        let no_dropout = !noisy || dropout == 0.0;
        self.cache
            .as_ref()
            .filter(|_| no_dropout && !x.device().is_autodiff())
    }
}

/// ELU (α = 1) of `x`, then inverted dropout with a mask from `noise` (the dropout is the
/// identity when `noise` is `None`, in eval, or `prob` is 0): one fused node in training
/// ([`training::elu_masked`]).
fn elu_dropout(x: Tensor<4>, prob: f64, noise: Option<&mut NoiseRng>) -> Tensor<4> {
    let mask = match noise {
        Some(rng) if prob > 0.0 => Some(rng.dropout_mask(x.dims().iter().product(), prob)),
        _ => None,
    };
    training::elu_masked(x, mask)
}

/// VUNet residual block without skip input: `x + conv3×3(dropout(elu(x)))`.
#[derive(Module, Debug)]
pub struct ResBlock {
    /// The 3×3 convolution C→C.
    pub conv2d: NormConv2d,
    /// Dropout probability.
    pub dropout: f64,
}

impl ResBlock {
    /// The block with its convolution lowered for inference.
    pub fn lowered(self) -> Self {
        Self {
            conv2d: self.conv2d.lowered(),
            ..self
        }
    }

    /// A block of `channels` channels.
    pub fn new(channels: usize, dropout: f64, device: &Device, rng: &mut NoiseRng) -> Self {
        Self {
            conv2d: NormConv2d::new(channels, channels, 3, 1, 1, device, rng),
            dropout,
        }
    }

    /// Applies the block; `noise` drives dropout (None in eval).
    pub fn forward(&self, x: Tensor<4>, noise: Option<&mut NoiseRng>) -> Tensor<4> {
        if let Some(conv) = self.conv2d.lowered_for(&x, noise.is_some(), self.dropout) {
            return conv.forward_fused(vec![x], Activation::Elu, true);
        }
        let h = elu_dropout(x.clone(), self.dropout, noise);
        x + self.conv2d.forward(h)
    }
}

/// VUNet residual block with a skip input `a`:
/// `x + conv3×3(dropout(elu(concat[x, pre(elu(a))])))`, the 3×3 conv mapping 2C→C.
#[derive(Module, Debug)]
pub struct SkipResBlock {
    /// The 3×3 convolution 2C→C.
    pub conv2d: NormConv2d,
    /// The 1×1 convolution on the activated skip input.
    pub pre: NormConv2d,
    /// Dropout probability.
    pub dropout: f64,
}

impl SkipResBlock {
    /// The block with its convolutions lowered for inference.
    pub fn lowered(self) -> Self {
        Self {
            conv2d: self.conv2d.lowered(),
            pre: self.pre.lowered(),
            ..self
        }
    }

    /// A block of `channels` channels.
    pub fn new(channels: usize, dropout: f64, device: &Device, rng: &mut NoiseRng) -> Self {
        Self {
            conv2d: NormConv2d::new(2 * channels, channels, 3, 1, 1, device, rng),
            pre: NormConv2d::new(channels, channels, 1, 1, 0, device, rng),
            dropout,
        }
    }

    /// Applies the block to `x` with skip input `a`; `noise` drives dropout (None in eval).
    pub fn forward(&self, x: Tensor<4>, a: Tensor<4>, noise: Option<&mut NoiseRng>) -> Tensor<4> {
        if let (Some(conv), Some(pre)) = (
            self.conv2d.lowered_for(&x, noise.is_some(), self.dropout),
            self.pre.lowered_for(&a, false, 0.0),
        ) {
            let a = pre.forward_fused(vec![a], Activation::Elu, false);
            return conv.forward_fused(vec![x, a], Activation::Elu, true);
        }
        let a = self.pre.forward(training::elu_masked(a, None));
        let h = Tensor::cat(vec![x.clone(), a], 1);
        let h = elu_dropout(h, self.dropout, noise);
        x + self.conv2d.forward(h)
    }
}

/// Sub-pixel ×2 upsampling: NormConv2d 3×3 C_in → 4·C_out, then depth-to-space.
#[derive(Module, Debug)]
pub struct Upsample {
    /// The 3×3 convolution to 4·C_out channels.
    pub up: NormConv2d,
}

impl Upsample {
    /// The upsampler with its convolution lowered for inference.
    pub fn lowered(self) -> Self {
        Self {
            up: self.up.lowered(),
        }
    }

    /// An upsampler from `cin` to `cout` channels.
    pub fn new(cin: usize, cout: usize, device: &Device, rng: &mut NoiseRng) -> Self {
        Self {
            up: NormConv2d::new(cin, 4 * cout, 3, 1, 1, device, rng),
        }
    }

    /// Doubles the resolution of `x`.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        depth_to_space(self.up.forward(x))
    }
}

/// Strided ×2 downsampling: NormConv2d 3×3, stride 2, padding 1.
#[derive(Module, Debug)]
pub struct Downsample {
    /// The strided convolution.
    pub down: NormConv2d,
}

impl Downsample {
    /// The downsampler with its convolution lowered for inference.
    pub fn lowered(self) -> Self {
        Self {
            down: self.down.lowered(),
        }
    }

    /// A downsampler from `cin` to `cout` channels.
    pub fn new(cin: usize, cout: usize, device: &Device, rng: &mut NoiseRng) -> Self {
        Self {
            down: NormConv2d::new(cin, cout, 3, 2, 1, device, rng),
        }
    }

    /// Halves the resolution of `x`.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.down.forward(x)
    }
}

/// Depth-to-space with block 2 in TensorFlow ("DCR") order, as the reference:
/// `out[c, 2h+i, 2w+j] = in[(2i+j)·C' + c, h, w]` with C' = C/4.
pub fn depth_to_space(x: Tensor<4>) -> Tensor<4> {
    let [n, c, h, w] = x.dims();
    let c_out = c / 4;
    x.reshape([n, 2, 2, c_out, h, w])
        .permute([0, 3, 4, 1, 5, 2])
        .reshape([n, c_out, 2 * h, 2 * w])
}

/// Space-to-depth with block 2, the inverse of [`depth_to_space`]:
/// `out[(2i+j)·C + c, h, w] = in[c, 2h+i, 2w+j]`.
pub fn space_to_depth(x: Tensor<4>) -> Tensor<4> {
    let [n, c, h, w] = x.dims();
    x.reshape([n, c, h / 2, 2, w / 2, 2])
        .permute([0, 3, 5, 1, 2, 4])
        .reshape([n, 4 * c, h / 2, w / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values(t: Tensor<4>) -> Vec<f32> {
        t.into_data().try_to_vec::<f32>().expect("f32 tensor")
    }

    #[test]
    fn fused_training_batch_norm_updates_the_running_statistics_as_burns_path() {
        let device = Device::flex().autodiff();
        let mut rng = NoiseRng::new(3);
        let x = tensor(
            rng.normal_vec(4 * 3 * 5 * 5, 2.0, 3.0),
            [4, 3, 5, 5],
            &device,
        );
        let fused = BatchNorm2d::new(3, &device, &mut NoiseRng::new(4));
        let reference = BatchNorm2d::new(3, &device, &mut NoiseRng::new(4));
        let out = fused.forward_relu(x.clone());
        let expected = training::with_burn_layers(|| relu(reference.forward(x)));
        let close = |a: Vec<f32>, b: Vec<f32>| a.iter().zip(&b).all(|(a, b)| (a - b).abs() < 1e-5);
        assert!(close(values(out.inner()), values(expected.inner())));
        let stats = |bn: &BatchNorm2d| {
            let read = |t: Tensor<1>| t.into_data().try_to_vec::<f32>().expect("f32");
            [
                read(bn.running_mean.value_sync()),
                read(bn.running_var.value_sync()),
            ]
        };
        let [mean, var] = stats(&fused);
        let [expected_mean, expected_var] = stats(&reference);
        assert!(close(mean.clone(), expected_mean), "running mean");
        assert!(close(var.clone(), expected_var), "running variance");
        // Moved from (0, 1) by momentum 0.1 towards (2, 9·100/99).
        assert!(mean.iter().all(|m| (m - 0.2).abs() < 0.1), "{mean:?}");
        assert!(var.iter().all(|v| (v - 1.8).abs() < 0.3), "{var:?}");
    }

    #[test]
    fn depth_to_space_uses_the_tensorflow_channel_order() {
        let device = Device::flex();
        // 8 channels of 1×1: channel k holds value k.
        let x = tensor((0..8).map(|v| v as f32).collect(), [1, 8, 1, 1], &device);
        let y = depth_to_space(x.clone());
        assert_eq!(y.dims(), [1, 2, 2, 2]);
        // out[c, i, j] = in[(2i + j)·2 + c]
        assert_eq!(
            values(y.clone()),
            vec![0.0, 2.0, 4.0, 6.0, 1.0, 3.0, 5.0, 7.0]
        );
        assert_eq!(values(space_to_depth(y)), values(x));
    }

    #[test]
    fn weight_norm_rescales_each_output_channel_to_g() {
        let device = Device::flex();
        let mut rng = NoiseRng::new(1);
        let mut layer = NormConv2d::new(3, 2, 3, 1, 1, &device, &mut rng);
        layer.conv.weight_g = param(vec![2.0, 0.5], [2, 1, 1, 1], &device);
        let w = values(layer.conv.weight());
        for (row, g) in w.chunks(27).zip([2.0f32, 0.5]) {
            let norm = row.iter().map(|x| x * x).sum::<f32>().sqrt();
            assert!((norm - g).abs() < 1e-5, "norm {norm} vs g {g}");
        }
    }

    #[test]
    fn lowered_conv_matches_the_layer() {
        let device = Device::flex();
        let mut rng = NoiseRng::new(2);
        let mut layer = NormConv2d::new(4, 3, 3, 2, 1, &device, &mut rng);
        layer.gamma = param(vec![0.5, 2.0, -1.0], [1, 3, 1, 1], &device);
        layer.beta = param(vec![0.1, -0.2, 0.3], [1, 3, 1, 1], &device);
        let x = tensor(
            rng.normal_vec(2 * 4 * 8 * 8, 0.0, 1.0),
            [2, 4, 8, 8],
            &device,
        );
        let a = values(layer.forward(x.clone()));
        let b = values(layer.lowered().forward(x));
        let max = a
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f32::max);
        assert!(max < 1e-5, "max diff {max}");
    }
}
