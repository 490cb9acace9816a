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
//! The memory modules' addressing product Q·Mᵀ ([`memory_scores`]) is here too: asked for in
//! the orientation burn asks for it, gemm copies the whole memory matrix on every read.

pub mod training;
mod winograd;

use std::cell::RefCell;

use burn::tensor::{Tensor, TensorData};
use burn_flex::{Flex, FlexTensor};
use rayon::prelude::*;

use winograd::{OutputStage, WinogradKernel};

/// About how many values one tile's unfolded input holds (4 MiB): large enough that the
/// GEMM amortises its packing, small enough to stay in a core's cache hierarchy.
const TILE_VALUES: usize = 1 << 20;

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

/// How many samples one tile takes: about [`TILE_VALUES`] unfolded values, and at least two
/// tiles per worker thread when the batch allows, so the workers share the batch evenly.
fn samples_per_tile(values_per_sample: usize, batch: usize) -> usize {
    let by_size = (TILE_VALUES / values_per_sample.max(1)).max(1);
    let by_threads = batch.div_ceil(2 * rayon::current_num_threads()).max(1);
    by_size.min(by_threads).min(batch.max(1))
}

/// Runs `tile` over `out` cut into chunks of `chunk` values: tiles in parallel with one
/// thread per GEMM when there are enough of them, else one tile at a time with a parallel
/// GEMM.
fn run_tiles<F>(out: &mut [f32], chunk: usize, tile: F)
where
    F: Fn((usize, &mut [f32]), gemm::Parallelism) + Sync,
{
    let tiles = out.len().div_ceil(chunk.max(1));
    if tiles >= 2 * rayon::current_num_threads() {
        out.par_chunks_mut(chunk)
            .enumerate()
            .for_each(|t| tile(t, gemm::Parallelism::None));
    } else {
        out.chunks_mut(chunk)
            .enumerate()
            .for_each(|t| tile(t, gemm::Parallelism::Rayon(0)));
    }
}

/// Runs `f` compiled for AVX-512, else AVX2, where the CPU has them. The crate is built for
/// baseline x86-64, where the unfolding, transform and write-back loops vectorise only four
/// lanes wide; gemm picks its kernels at run time the same way. Only element-wise work runs
/// here (nothing is reassociated), so every width gives the same values.
#[inline(always)]
fn vectorised<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx512f")]
        fn avx512<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        #[target_feature(enable = "avx2")]
        fn avx2<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F.
            return unsafe { avx512(f) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            return unsafe { avx2(f) };
        }
    }
    f()
}

thread_local! {
    /// Per-thread scratch for unfolded inputs and GEMM products, reused across layers so
    /// that large buffers are not allocated and faulted in for every tile.
    static SCRATCH: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

fn with_scratch(len: usize, f: impl FnOnce(&mut [f32])) {
    SCRATCH.with(|cell| {
        let mut buffer = cell.borrow_mut();
        if buffer.len() < len {
            buffer.resize(len, 0.0);
        }
        f(&mut buffer[..len]);
    });
}

/// Unfolds `input` [B, C, H, W] into `cols` [C·k·k, B·OH·OW] (row (c, ky, kx), column
/// (b, oy, ox)), zero where the kernel reaches into the padding.
#[inline(always)]
fn im2col(
    input: &[f32],
    [b, c, h, w]: [usize; 4],
    g: ConvGeometry,
    [oh, ow]: [usize; 2],
    cols: &mut [f32],
) {
    if g.stride == 1 && [oh, ow] == [h, w] {
        return im2col_same(input, [b, c, h, w], g, cols);
    }
    let cols_n = b * oh * ow;
    for (row, dst_row) in cols.chunks_mut(cols_n).enumerate() {
        let ch = row / (g.kernel * g.kernel);
        let (ky, kx) = ((row / g.kernel) % g.kernel, row % g.kernel);
        // Output columns whose input column ox·s + kx − p lies inside the image.
        let ox_lo = g.padding.saturating_sub(kx).div_ceil(g.stride).min(ow);
        let ox_hi = ((w + g.padding).saturating_sub(kx))
            .div_ceil(g.stride)
            .clamp(ox_lo, ow);
        for sample in 0..b {
            let plane = &input[(sample * c + ch) * h * w..][..h * w];
            for oy in 0..oh {
                let dst = &mut dst_row[(sample * oh + oy) * ow..][..ow];
                let iy = (oy * g.stride + ky)
                    .checked_sub(g.padding)
                    .filter(|&y| y < h);
                let Some(iy) = iy else {
                    dst.fill(0.0);
                    continue;
                };
                dst[..ox_lo].fill(0.0);
                dst[ox_hi..].fill(0.0);
                if ox_lo == ox_hi {
                    continue;
                }
                let src = &plane[iy * w..][..w];
                let first = ox_lo * g.stride + kx - g.padding;
                for (d, s) in dst[ox_lo..ox_hi]
                    .iter_mut()
                    .zip(src[first..].iter().step_by(g.stride))
                {
                    *d = *s;
                }
            }
        }
    }
}

/// [`im2col`] for stride-1 convolutions that keep the map's size (k = 2p + 1): each row of
/// `cols` is the input plane shifted by (ky − p)·W + (kx − p) in flattened order, so it is
/// one long copy per plane, after which the columns that wrapped around a row edge are
/// zeroed. Rows of a few values each would spend more on per-copy overhead than on data.
#[inline(always)]
fn im2col_same(input: &[f32], [b, c, h, w]: [usize; 4], g: ConvGeometry, cols: &mut [f32]) {
    let area = h * w;
    for (row, dst_row) in cols.chunks_mut(b * area).enumerate() {
        let ch = row / (g.kernel * g.kernel);
        let (ky, kx) = ((row / g.kernel) % g.kernel, row % g.kernel);
        let shift = (ky * w + kx) as isize - (g.padding * w + g.padding) as isize;
        // dst[j] = src[j + shift] for j in lo..hi; outside, the kernel row is in the padding.
        let lo = (-shift).clamp(0, area as isize) as usize;
        let hi = (area as isize - shift).clamp(lo as isize, area as isize) as usize;
        // Columns of each output row whose input column falls off the left or right edge.
        let wrapped = if kx < g.padding {
            0..(g.padding - kx).min(w)
        } else {
            w - (kx - g.padding).min(w)..w
        };
        for sample in 0..b {
            let plane = &input[(sample * c + ch) * area..][..area];
            let dst = &mut dst_row[sample * area..][..area];
            dst[..lo].fill(0.0);
            dst[hi..].fill(0.0);
            let from = (lo as isize + shift) as usize;
            dst[lo..hi].copy_from_slice(&plane[from..from + (hi - lo)]);
            if !wrapped.is_empty() {
                for line in dst.chunks_mut(w) {
                    line[wrapped.clone()].fill(0.0);
                }
            }
        }
    }
}

/// Copies `input` [B, C, L] into `out` [C, B·L].
#[inline(always)]
fn channels_first(input: &[f32], [b, c, l]: [usize; 3], out: &mut [f32]) {
    for (ch, dst) in out.chunks_mut(b * l).enumerate() {
        for sample in 0..b {
            dst[sample * l..][..l].copy_from_slice(&input[(sample * c + ch) * l..][..l]);
        }
    }
}

/// Writes `product` [C, B·L] + bias, activated, plus `residual` [B, C, L] where given, into
/// `out` [B, C, L].
#[inline(always)]
fn write_back(
    product: &[f32],
    bias: &[f32],
    activation: Activation,
    residual: Option<&[f32]>,
    [b, c, l]: [usize; 3],
    out: &mut [f32],
) {
    for sample in 0..b {
        for ch in 0..c {
            let src = &product[ch * b * l + sample * l..][..l];
            let at = (sample * c + ch) * l;
            let dst = &mut out[at..][..l];
            let bias = bias[ch];
            for (d, s) in dst.iter_mut().zip(src) {
                *d = s + bias;
            }
            activate_and_add(dst, activation, residual.map(|r| &r[at..][..l]));
        }
    }
}

/// Applies `activation` to `dst`, then adds `residual` (laid out as `dst`) where given: the
/// end of every lowered convolution's write-back.
#[inline(always)]
fn activate_and_add(dst: &mut [f32], activation: Activation, residual: Option<&[f32]>) {
    activation.apply(dst);
    if let Some(residual) = residual {
        for (d, r) in dst.iter_mut().zip(residual) {
            *d += r;
        }
    }
}

/// The addressing scores Q·Mᵀ of a memory read on burn's CPU backend: `query` [N, D] against
/// the memory `slots` [S, D], as [N, S].
///
/// burn requests the row-major [N, S] product, which gemm computes transposed as M·Qᵀ with M
/// as the packed left operand: the whole memory matrix (128 MB at the paper's 16×16 level) is
/// copied on every read, which for a few queries costs several times the product itself. The
/// column-major [S, N] product keeps M as gemm's right operand, read in place along its
/// rows; gemm packs it only for large N, where the copy is amortised over many queries.
pub fn memory_scores(query: Tensor<2>, slots: Tensor<2>) -> Tensor<2> {
    let device = query.device();
    let [n, d] = query.dims();
    let [s, slot_dim] = slots.dims();
    assert_eq!(d, slot_dim, "memory_scores: query and slot widths differ");
    let query = CpuValues::new(query);
    let slots = CpuValues::new(slots);
    let (q, m) = (query.as_slice(), slots.as_slice());
    let mut by_slot = vec![0.0f32; s * n];
    // SAFETY: `by_slot` holds N·S values at column stride N; `q` is N rows of D values and
    // `m` S rows of D values, as the strides describe.
    unsafe {
        gemm::gemm(
            n,
            s,
            d,
            by_slot.as_mut_ptr(),
            n as isize,
            1,
            false,
            q.as_ptr(),
            1,
            d as isize,
            m.as_ptr(),
            d as isize,
            1,
            0.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::Rayon(0),
        );
    }
    let mut scores = vec![0.0f32; n * s];
    for (j, column) in by_slot.chunks_exact(n).enumerate() {
        for (b, &v) in column.iter().enumerate() {
            scores[b * s + j] = v;
        }
    }
    tensor(scores, [n, s], &device)
}

/// `dst` [M, N] = `lhs` [M, K] · `rhs` [K, N], all row-major and contiguous.
///
/// # Safety
/// `dst` must hold M·N values, `lhs` M·K and `rhs` K·N.
unsafe fn matmul(
    dst: &mut [f32],
    lhs: &[f32],
    rhs: &[f32],
    [m, k, n]: [usize; 3],
    parallelism: gemm::Parallelism,
) {
    debug_assert!(dst.len() >= m * n && lhs.len() >= m * k && rhs.len() >= k * n);
    // SAFETY: the caller guarantees the buffer sizes; strides describe row-major matrices.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            1,
            n as isize,
            false,
            lhs.as_ptr(),
            1,
            k as isize,
            rhs.as_ptr(),
            1,
            n as isize,
            0.0,
            1.0,
            false,
            false,
            false,
            parallelism,
        );
    }
}

/// `dst` [M, N] += `lhs` [M, K] · `rhs`ᵀ, with `rhs` stored row-major as [N, K]: the
/// weight gradients' product of two unfolded operands that share their long axis K.
///
/// # Safety
/// `dst` must hold M·N values, `lhs` M·K and `rhs` N·K.
unsafe fn matmul_accumulate_transposed(
    dst: &mut [f32],
    lhs: &[f32],
    rhs: &[f32],
    [m, k, n]: [usize; 3],
    parallelism: gemm::Parallelism,
) {
    debug_assert!(dst.len() >= m * n && lhs.len() >= m * k && rhs.len() >= n * k);
    // SAFETY: the caller guarantees the buffer sizes; `rhs` read with row stride 1 and
    // column stride K is the [K, N] transpose of its row-major [N, K] values.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            1,
            n as isize,
            true,
            lhs.as_ptr(),
            1,
            k as isize,
            rhs.as_ptr(),
            k as isize,
            1,
            1.0,
            1.0,
            false,
            false,
            false,
            parallelism,
        );
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
    fn memory_scores_match_burns_product_for_few_and_many_queries() {
        let mut rng = NoiseRng::new(14);
        // 200 queries is past gemm's threshold for packing the memory; 1 takes its GEMV.
        for (queries, slots, width) in [(1, 37, 64), (4, 50, 100), (200, 23, 48)] {
            let query = random(&mut rng, [queries, width]);
            let memory = random(&mut rng, [slots, width]);
            let expected = query.clone().matmul(memory.clone().transpose());
            let ours = memory_scores(query, memory);
            assert_eq!(ours.dims(), [queries, slots]);
            let diff = (ours - expected).abs().max().into_scalar::<f32>();
            assert!(diff < 1e-4, "{queries} queries × {slots} slots: {diff}");
        }
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
