//! Inference convolutions for burn's CPU backend, lowered to a few large GEMMs.
//!
//! burn-flex runs a 3×3 convolution as one small GEMM per sample, transposes and re-packs the
//! weights on every call, and runs transposed convolutions as a direct loop. On HF²-VAD's
//! 4×4–32×32 maps that leaves most of the CPU's multiply throughput unused. Here a layer's
//! weights, with any per-channel affine (BatchNorm, VUNet's γ/β) already folded in, are laid
//! out once; a batch is unfolded (im2col) in tiles of whole samples, each tile is one GEMM
//! over all its samples, and the bias and activation are applied while the tile is written
//! back to NCHW. Transposed convolutions are the same GEMM followed by a scatter-add
//! (col2im), so no multiply is spent on the zeros a strided transpose inserts.
//!
//! These layers hold plain `f32` buffers, not trainable parameters: they serve inference on
//! non-autodiff devices only and are rebuilt from the module whenever weights change.
//!
//! Files: the layers here; their shared kernels (tiling, unfolding, write-back, GEMM
//! wrappers) in `kernels`; 3×3 Winograd in `winograd`; the training path's autodiff ops in
//! [`training`] (training-mode BatchNorm with its ReLU in `batch_norm`, ELU with its
//! dropout in `elu`); the memory modules' addressing product Q·Mᵀ in [`memory_scores`] (asked
//! for in the orientation burn asks for it, gemm copies the whole memory matrix on every
//! read).

mod batch_norm;
mod elu;
mod kernels;
mod memory_scores;
pub mod training;
mod winograd;

use burn::tensor::{Tensor, TensorData};
use burn_flex::{Flex, FlexTensor};

use kernels::{
    channels_first, im2col, matmul, run_tiles, samples_per_tile, vectorised, with_scratch,
    write_back,
};
pub use memory_scores::memory_scores;
use winograd::{OutputStage, WinogradKernel};

/// A nonlinearity fused into a layer: on its input while it is unfolded, or on its output
/// while it is written back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Activation {
    /// No activation.
    Identity,
    /// max(x, 0).
    Relu,
    /// ELU with α = 1: x for x > 0, else eˣ − 1.
    Elu,
}

impl Activation {
    /// Applies the activation to every value of `values`; the match sits outside the loops
    /// so each one vectorises.
    #[inline(always)]
    fn apply(self, values: &mut [f32]) {
        match self {
            Self::Identity => {}
            Self::Relu => values.iter_mut().for_each(|v| *v = v.max(0.0)),
            Self::Elu => values.iter_mut().for_each(|v| {
                *v = if *v > 0.0 {
                    *v
                } else {
                    exp_non_positive(*v) - 1.0
                }
            }),
        }
    }
}

/// eˣ for x ≤ 0 to within a few ulp, without a libm call so that loops over it vectorise:
/// x = n·ln 2 + r with |r| ≤ ln 2 / 2, eʳ by its degree-6 Taylor polynomial (error below
/// r⁷/7! ≈ 3·10⁻⁷ relative), 2ⁿ assembled in the exponent bits. Below −87 the result
/// (< 2⁻¹²⁵) is flushed to the smallest normal instead of going subnormal.
#[inline(always)]
fn exp_non_positive(x: f32) -> f32 {
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    // Adding and subtracting 1.5·2²³ rounds to the nearest integer without SSE4.1's roundss.
    const ROUND: f32 = 12_582_912.0;
    let x = x.max(-87.0);
    let n = (x * std::f32::consts::LOG2_E + ROUND) - ROUND;
    let r = x - n * LN2_HI - n * LN2_LO;
    let p = 1.0 / 720.0;
    let p = p * r + 1.0 / 120.0;
    let p = p * r + 1.0 / 24.0;
    let p = p * r + 1.0 / 6.0;
    let p = p * r + 0.5;
    let p = p * r + 1.0;
    let p = p * r + 1.0;
    let scale = f32::from_bits(((n as i32 + 127) as u32) << 23);
    p * scale
}

/// Geometry of a square-kernel convolution with symmetric zero padding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConvGeometry {
    /// Kernel side.
    pub kernel: usize,
    /// Stride (both axes).
    pub stride: usize,
    /// Zero padding on every side.
    pub padding: usize,
}

impl ConvGeometry {
    /// The 3×3 stride-1 convolution that keeps the map's size.
    pub(super) const SAME_3X3: Self = Self {
        kernel: 3,
        stride: 1,
        padding: 1,
    };

    /// Panics unless a `layer`'s weight of kernel `kh`×`kw` has this geometry's kernel: the
    /// lowering is set up once per layer from the model's own modules.
    fn expect_kernel(&self, [kh, kw]: [usize; 2], layer: &str) {
        assert!(
            kh == self.kernel && kw == self.kernel,
            "{layer}: a {kh}×{kw} kernel does not match the geometry's {}",
            self.kernel
        );
    }

    fn output_side(&self, input: usize) -> usize {
        (input + 2 * self.padding - self.kernel) / self.stride + 1
    }
}

/// A 2-D convolution with bias and a fused activation, ready for batched inference.
#[derive(Debug, Clone)]
pub struct GemmConv2d {
    /// Weights as a row-major [C_out, C_in·k·k] matrix (PyTorch's flattening order).
    weight: Vec<f32>,
    bias: Vec<f32>,
    cin: usize,
    cout: usize,
    geometry: ConvGeometry,
    activation: Activation,
    /// The kernels in the Winograd domain, for 3×3 stride-1 "same" layers wide enough.
    winograd: Option<WinogradKernel>,
}

impl GemmConv2d {
    /// Lowers `weight` [C_out, C_in, k, k] and `bias` [C_out].
    pub fn new(
        weight: Tensor<4>,
        bias: Tensor<1>,
        geometry: ConvGeometry,
        activation: Activation,
    ) -> Self {
        let [cout, cin, kh, kw] = weight.dims();
        geometry.expect_kernel([kh, kw], "GemmConv2d");
        let weight = values(weight);
        let winograd = (geometry == ConvGeometry::SAME_3X3 && cin >= winograd::MIN_CHANNELS)
            .then(|| WinogradKernel::new(&weight, cout, cin));
        Self {
            weight,
            bias: values(bias),
            cin,
            cout,
            geometry,
            activation,
            winograd,
        }
    }

    /// Applies the layer to `x` [B, C_in, H, W].
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.forward_fused(vec![x], Activation::Identity, false)
    }

    /// Applies the layer to the channel-wise concatenation of `parts` (each [B, C_p, H, W]),
    /// with `input_activation` applied to the input first and, with `add_first_part`, the
    /// first part added to the result as a residual (VUNet's blocks):
    /// `[parts[0] +] act(conv(input_activation(cat(parts))))`, without materialising the
    /// concatenation, the activated input or the sum as tensors of their own.
    pub fn forward_fused(
        &self,
        parts: Vec<Tensor<4>>,
        input_activation: Activation,
        add_first_part: bool,
    ) -> Tensor<4> {
        let device = parts[0].device();
        let [batch, _, h, w] = parts[0].dims();
        let input = ConvInput::new(parts, [h, w]);
        assert_eq!(input.channels, self.cin, "GemmConv2d: input channels");
        let g = self.geometry;
        let (oh, ow) = (g.output_side(h), g.output_side(w));
        let residual = add_first_part.then(|| {
            let (values, c) = &input.parts[0];
            assert!(
                *c == self.cout && [oh, ow] == [h, w],
                "GemmConv2d: a residual must have the output's shape"
            );
            values.as_slice()
        });
        let out_len = self.cout * oh * ow;
        if let Some(kernel) = self
            .winograd
            .as_ref()
            .filter(|_| WinogradKernel::fits(h, w))
        {
            let per_tile = samples_per_tile(kernel.values_per_sample(h, w), batch);
            let mut out = vec![0.0f32; batch * out_len];
            let run_tile = |(tile, out): (usize, &mut [f32]), parallelism: gemm::Parallelism| {
                let first = tile * per_tile;
                let samples = out.len() / out_len;
                let stage = OutputStage {
                    bias: &self.bias,
                    activation: self.activation,
                    residual: residual.map(|r| &r[first * out_len..(first + samples) * out_len]),
                    out,
                };
                kernel.convolve(
                    |sample, channel| input.plane(first + sample, channel),
                    input_activation,
                    [samples, h, w],
                    stage,
                    parallelism,
                );
            };
            run_tiles(&mut out, per_tile * out_len, run_tile);
            return tensor(out, [batch, self.cout, oh, ow], &device);
        }
        let k = self.cin * g.kernel * g.kernel;
        let per_tile = samples_per_tile(k * oh * ow, batch);
        let mut out = vec![0.0f32; batch * out_len];
        let run_tile = |(tile, out): (usize, &mut [f32]), parallelism: gemm::Parallelism| {
            let first = tile * per_tile;
            let samples = out.len() / out_len;
            let cols_n = samples * oh * ow;
            let staged = input.staged_len(samples, input_activation);
            with_scratch(staged + k * cols_n + self.cout * cols_n, |scratch| {
                let (staging, rest) = scratch.split_at_mut(staged);
                let (cols, product) = rest.split_at_mut(k * cols_n);
                vectorised(
                    #[inline(always)]
                    || {
                        let source = input.tile(first, samples, input_activation, staging);
                        im2col(source, [samples, self.cin, h, w], g, [oh, ow], cols);
                    },
                );
                // SAFETY: every slice is as long as the dimensions and strides describe.
                unsafe {
                    matmul(
                        product,
                        &self.weight,
                        cols,
                        [self.cout, k, cols_n],
                        parallelism,
                    )
                };
                let residual = residual.map(|r| &r[first * out_len..(first + samples) * out_len]);
                vectorised(
                    #[inline(always)]
                    || {
                        write_back(
                            product,
                            &self.bias,
                            self.activation,
                            residual,
                            [samples, self.cout, oh * ow],
                            out,
                        )
                    },
                );
            });
        };
        run_tiles(&mut out, per_tile * out_len, run_tile);
        tensor(out, [batch, self.cout, oh, ow], &device)
    }
}

/// A tensor's values on burn's CPU backend, read in place (copied only when the tensor is a
/// strided view): activations are often shared with a skip connection, where taking them
/// out with `into_data` would copy.
struct CpuValues(FlexTensor);

impl CpuValues {
    fn new<const D: usize>(t: Tensor<D>) -> Self {
        let flex = t
            .try_into_primitive::<Flex>()
            .expect("lowered layers run on burn's CPU backend");
        if flex.is_contiguous() && flex.layout().start_offset() == 0 {
            Self(flex)
        } else {
            Self(flex.to_contiguous())
        }
    }

    fn as_slice(&self) -> &[f32] {
        &self.0.storage::<f32>()[..self.0.layout().num_elements()]
    }
}

/// A convolution's input: one or more NCHW tensors concatenated along channels.
struct ConvInput {
    /// Each part's values and channel count.
    parts: Vec<(CpuValues, usize)>,
    /// Channels of all parts together.
    channels: usize,
    /// H·W.
    area: usize,
}

impl ConvInput {
    fn new(parts: Vec<Tensor<4>>, [h, w]: [usize; 2]) -> Self {
        let parts: Vec<(CpuValues, usize)> = parts
            .into_iter()
            .map(|part| {
                let [_, c, ph, pw] = part.dims();
                assert_eq!([ph, pw], [h, w], "GemmConv2d: parts differ in size");
                (CpuValues::new(part), c)
            })
            .collect();
        let channels = parts.iter().map(|(_, c)| c).sum();
        Self {
            parts,
            channels,
            area: h * w,
        }
    }

    /// Channel `channel` of sample `sample`, counted across the parts.
    fn plane(&self, sample: usize, mut channel: usize) -> &[f32] {
        for (values, c) in &self.parts {
            if channel < *c {
                return &values.as_slice()[(sample * c + channel) * self.area..][..self.area];
            }
            channel -= c;
        }
        panic!("GemmConv2d: channel beyond the input's");
    }

    /// Values a tile of `samples` needs staged: none when it can read the single part as it
    /// is.
    fn staged_len(&self, samples: usize, activation: Activation) -> usize {
        if self.parts.len() == 1 && activation == Activation::Identity {
            0
        } else {
            samples * self.channels * self.area
        }
    }

    /// Samples `first..first + samples` as one [samples, C, H, W] block with `activation`
    /// applied: a slice of the input itself where possible, else staged in `staging`.
    #[inline(always)]
    fn tile<'a>(
        &'a self,
        first: usize,
        samples: usize,
        activation: Activation,
        staging: &'a mut [f32],
    ) -> &'a [f32] {
        let sample_len = self.channels * self.area;
        if staging.is_empty() {
            return &self.parts[0].0.as_slice()[first * sample_len..(first + samples) * sample_len];
        }
        for (sample, dst) in staging.chunks_mut(sample_len).enumerate() {
            let mut offset = 0;
            for (values, c) in &self.parts {
                let len = c * self.area;
                let src = &values.as_slice()[(first + sample) * len..][..len];
                let dst = &mut dst[offset..offset + len];
                dst.copy_from_slice(src);
                activation.apply(dst);
                offset += len;
            }
        }
        staging
    }
}

/// A transposed 2-D convolution with bias, as a GEMM followed by col2im.
#[derive(Debug, Clone)]
pub struct GemmConvTranspose2d {
    /// Weights as a row-major [C_out·k·k, C_in] matrix.
    weight: Vec<f32>,
    bias: Vec<f32>,
    cin: usize,
    cout: usize,
    geometry: ConvGeometry,
    /// Extra rows and columns at the bottom and right of the output.
    out_padding: usize,
}

impl GemmConvTranspose2d {
    /// Lowers a transposed convolution with `weight` [C_in, C_out, k, k] (burn's and
    /// PyTorch's layout) and `bias` [C_out].
    pub fn new(
        weight: Tensor<4>,
        bias: Tensor<1>,
        geometry: ConvGeometry,
        out_padding: usize,
    ) -> Self {
        let [cin, cout, kh, kw] = weight.dims();
        geometry.expect_kernel([kh, kw], "GemmConvTranspose2d");
        let weight = weight.reshape([cin, cout * kh * kw]).transpose();
        Self {
            weight: values(weight),
            bias: values(bias),
            cin,
            cout,
            geometry,
            out_padding,
        }
    }

    fn output_side(&self, input: usize) -> usize {
        let g = self.geometry;
        (input - 1) * g.stride + g.kernel + self.out_padding - 2 * g.padding
    }

    /// Applies the layer to `x` [B, C_in, H, W].
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let [_, _, h, w] = x.dims();
        let size = [self.output_side(h), self.output_side(w)];
        self.forward_to(x, size)
    }

    /// Applies the layer to `x` with an output of `[oh, ow]`, any size the kernel's reach
    /// allows: a convolution's input gradient is this product cut to the input's size,
    /// which its output padding does not fix per axis.
    fn forward_to(&self, x: Tensor<4>, [oh, ow]: [usize; 2]) -> Tensor<4> {
        let device = x.device();
        let [batch, cin, h, w] = x.dims();
        assert_eq!(cin, self.cin, "GemmConvTranspose2d: input channels");
        let input = CpuValues::new(x);
        let input = input.as_slice();
        let kk = self.geometry.kernel * self.geometry.kernel;
        let rows = self.cout * kk;
        let (in_len, out_len) = (cin * h * w, self.cout * oh * ow);
        let per_tile = samples_per_tile(rows.max(cin) * h * w, batch);
        let mut out = vec![0.0f32; batch * out_len];
        let run_tile = |(tile, out): (usize, &mut [f32]), parallelism: gemm::Parallelism| {
            let first = tile * per_tile;
            let samples = out.len() / out_len;
            let cols_n = samples * h * w;
            with_scratch(cin * cols_n + rows * cols_n, |scratch| {
                let (gathered, product) = scratch.split_at_mut(cin * cols_n);
                vectorised(
                    #[inline(always)]
                    || {
                        channels_first(
                            &input[first * in_len..(first + samples) * in_len],
                            [samples, cin, h * w],
                            gathered,
                        )
                    },
                );
                // SAFETY: every slice is as long as the dimensions and strides describe.
                unsafe {
                    matmul(
                        product,
                        &self.weight,
                        gathered,
                        [rows, cin, cols_n],
                        parallelism,
                    )
                };
                vectorised(
                    #[inline(always)]
                    || self.col2im(product, [samples, h, w], [oh, ow], out),
                );
            });
        };
        run_tiles(&mut out, per_tile * out_len, run_tile);
        tensor(out, [batch, self.cout, oh, ow], &device)
    }

    /// Adds every column of `product` [C_out·k·k, B·H·W] into the output positions its kernel
    /// tap reaches, on top of the bias.
    #[inline(always)]
    fn col2im(
        &self,
        product: &[f32],
        [b, h, w]: [usize; 3],
        [oh, ow]: [usize; 2],
        out: &mut [f32],
    ) {
        let g = self.geometry;
        let cols_n = b * h * w;
        for (plane_index, plane) in out.chunks_mut(oh * ow).enumerate() {
            let (sample, co) = (plane_index / self.cout, plane_index % self.cout);
            plane.fill(self.bias[co]);
            for ky in 0..g.kernel {
                for kx in 0..g.kernel {
                    let row = (co * g.kernel + ky) * g.kernel + kx;
                    let src = &product[row * cols_n + sample * h * w..][..h * w];
                    for iy in 0..h {
                        let Some(oy) = (iy * g.stride + ky).checked_sub(g.padding) else {
                            continue;
                        };
                        if oy >= oh {
                            continue;
                        }
                        let dst = &mut plane[oy * ow..][..ow];
                        for (ix, &v) in src[iy * w..][..w].iter().enumerate() {
                            if let Some(ox) = (ix * g.stride + kx).checked_sub(g.padding)
                                && ox < ow
                            {
                                dst[ox] += v;
                            }
                        }
                    }
                }
            }
        }
    }
}

fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .try_into_vec::<f32>()
        .expect("model tensors are f32")
}

fn tensor<const D: usize>(
    values: Vec<f32>,
    shape: [usize; D],
    device: &burn::tensor::Device,
) -> Tensor<D> {
    Tensor::from_data(TensorData::new(values, shape), device)
}

#[cfg(test)]
mod tests {
    use burn::tensor::Device;
    use burn::tensor::module::{conv_transpose2d, conv2d};
    use burn::tensor::ops::{ConvOptions, ConvTransposeOptions};

    use super::*;
    use crate::model::rng::NoiseRng;

    pub(super) fn random<const D: usize>(rng: &mut NoiseRng, shape: [usize; D]) -> Tensor<D> {
        let n = shape.iter().product();
        tensor(rng.normal_vec(n, 0.0, 1.0), shape, &Device::flex())
    }

    pub(super) fn max_abs_diff(a: Tensor<4>, b: Tensor<4>) -> f32 {
        assert_eq!(a.dims(), b.dims());
        (a - b).abs().max().into_scalar::<f32>()
    }

    #[test]
    fn convolution_matches_burn_for_kernels_strides_and_batch_sizes() {
        let mut rng = NoiseRng::new(11);
        for (batch, cin, cout, side, kernel, stride, padding) in [
            (1, 2, 8, 9, 3, 1, 1),
            (3, 5, 7, 8, 3, 2, 1),
            (13, 4, 6, 5, 1, 1, 0),
            (2, 3, 4, 7, 3, 2, 0),
            (40, 6, 5, 4, 3, 1, 1),
            (3, 4, 3, 6, 5, 1, 2),
            (2, 3, 2, 1, 3, 2, 1),
        ] {
            let x = random(&mut rng, [batch, cin, side, side + 1]);
            let weight = random(&mut rng, [cout, cin, kernel, kernel]);
            let bias = random(&mut rng, [cout]);
            let geometry = ConvGeometry {
                kernel,
                stride,
                padding,
            };
            let options = ConvOptions::new([stride; 2], [padding; 2], [1, 1], 1);
            let expected = conv2d(x.clone(), weight.clone(), Some(bias.clone()), options);
            for activation in [Activation::Identity, Activation::Relu, Activation::Elu] {
                let expected = match activation {
                    Activation::Identity => expected.clone(),
                    Activation::Relu => burn::tensor::activation::relu(expected.clone()),
                    Activation::Elu => burn::tensor::activation::elu(expected.clone(), 1.0),
                };
                let layer = GemmConv2d::new(weight.clone(), bias.clone(), geometry, activation);
                let diff = max_abs_diff(layer.forward(x.clone()), expected);
                assert!(diff < 1e-4, "batch {batch} k{kernel} s{stride}: {diff}");
            }
        }
    }

    #[test]
    fn fused_input_activation_concatenation_and_residual_match_burn() {
        let mut rng = NoiseRng::new(13);
        for (batch, side) in [(1, 4), (7, 6)] {
            let x = random(&mut rng, [batch, 3, side, side]);
            let a = random(&mut rng, [batch, 2, side, side]);
            let weight = random(&mut rng, [3, 5, 3, 3]);
            let bias = random(&mut rng, [3]);
            let geometry = ConvGeometry::SAME_3X3;
            let options = ConvOptions::new([1, 1], [1, 1], [1, 1], 1);
            let activated =
                burn::tensor::activation::elu(Tensor::cat(vec![x.clone(), a.clone()], 1), 1.0);
            let expected =
                x.clone() + conv2d(activated, weight.clone(), Some(bias.clone()), options);
            let layer = GemmConv2d::new(weight, bias, geometry, Activation::Identity);
            let ours = layer.forward_fused(vec![x, a], Activation::Elu, true);
            let diff = max_abs_diff(ours, expected);
            assert!(diff < 1e-4, "batch {batch}: {diff}");
        }
    }

    #[test]
    fn exponential_of_non_positive_values_is_within_a_few_ulp() {
        for i in 0..=86_000 {
            let x = -(i as f32) * 1e-3;
            let (ours, exact) = (exp_non_positive(x), x.exp());
            assert!(
                (ours - exact).abs() <= 4e-7 * exact,
                "exp({x}) = {ours}, expected {exact}"
            );
        }
        assert!(exp_non_positive(-200.0) < 1e-37);
    }

    #[test]
    fn transposed_convolution_matches_burn() {
        let mut rng = NoiseRng::new(12);
        for (batch, cin, cout, side, out_padding) in
            [(1, 8, 4, 4, 1), (9, 6, 3, 5, 1), (2, 4, 4, 3, 0)]
        {
            let x = random(&mut rng, [batch, cin, side, side]);
            let weight = random(&mut rng, [cin, cout, 3, 3]);
            let bias = random(&mut rng, [cout]);
            let geometry = ConvGeometry {
                kernel: 3,
                stride: 2,
                padding: 1,
            };
            let options = ConvTransposeOptions::new([2, 2], [1, 1], [out_padding; 2], [1, 1], 1);
            let expected = conv_transpose2d(x.clone(), weight.clone(), Some(bias.clone()), options);
            let layer = GemmConvTranspose2d::new(weight, bias, geometry, out_padding);
            let diff = max_abs_diff(layer.forward(x), expected);
            assert!(diff < 1e-4, "batch {batch} side {side}: {diff}");
        }
    }
}
