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

use std::cell::RefCell;

use burn::tensor::{Tensor, TensorData};
use rayon::prelude::*;

/// About how many values one tile's unfolded input holds (4 MiB): large enough that the
/// GEMM amortises its packing, small enough to stay in a core's cache hierarchy.
const TILE_VALUES: usize = 1 << 20;

/// The nonlinearity fused into a layer's write-back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Activation {
    /// No activation.
    Identity,
    /// max(x, 0).
    Relu,
}

impl Activation {
    fn apply(self, x: f32) -> f32 {
        match self {
            Self::Identity => x,
            Self::Relu => x.max(0.0),
        }
    }
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
        assert!(
            kh == geometry.kernel && kw == geometry.kernel,
            "GemmConv2d: a {kh}×{kw} kernel does not match the geometry's {}",
            geometry.kernel
        );
        Self {
            weight: values(weight),
            bias: values(bias),
            cin,
            cout,
            geometry,
            activation,
        }
    }

    /// Applies the layer to `x` [B, C_in, H, W].
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let device = x.device();
        let [batch, cin, h, w] = x.dims();
        assert_eq!(cin, self.cin, "GemmConv2d: input channels");
        let g = self.geometry;
        let (oh, ow) = (g.output_side(h), g.output_side(w));
        let input = values(x);
        let k = self.cin * g.kernel * g.kernel;
        let (in_len, out_len) = (cin * h * w, self.cout * oh * ow);
        let per_tile = samples_per_tile(k * oh * ow, batch);
        let mut out = vec![0.0f32; batch * out_len];
        let run_tile = |(tile, out): (usize, &mut [f32]), parallelism: gemm::Parallelism| {
            let first = tile * per_tile;
            let samples = out.len() / out_len;
            let cols_n = samples * oh * ow;
            with_scratch(k * cols_n + self.cout * cols_n, |scratch| {
                let (cols, product) = scratch.split_at_mut(k * cols_n);
                im2col(
                    &input[first * in_len..(first + samples) * in_len],
                    [samples, cin, h, w],
                    g,
                    [oh, ow],
                    cols,
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
                write_back(
                    product,
                    &self.bias,
                    self.activation,
                    [samples, self.cout, oh * ow],
                    out,
                );
            });
        };
        run_tiles(&mut out, per_tile * out_len, run_tile);
        tensor(out, [batch, self.cout, oh, ow], &device)
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
        assert!(
            kh == geometry.kernel && kw == geometry.kernel,
            "GemmConvTranspose2d: a {kh}×{kw} kernel does not match the geometry's {}",
            geometry.kernel
        );
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
        let device = x.device();
        let [batch, cin, h, w] = x.dims();
        assert_eq!(cin, self.cin, "GemmConvTranspose2d: input channels");
        let (oh, ow) = (self.output_side(h), self.output_side(w));
        let input = values(x);
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
                channels_first(
                    &input[first * in_len..(first + samples) * in_len],
                    [samples, cin, h * w],
                    gathered,
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
                self.col2im(product, [samples, h, w], [oh, ow], out);
            });
        };
        run_tiles(&mut out, per_tile * out_len, run_tile);
        tensor(out, [batch, self.cout, oh, ow], &device)
    }

    /// Adds every column of `product` [C_out·k·k, B·H·W] into the output positions its kernel
    /// tap reaches, on top of the bias.
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
fn im2col(
    input: &[f32],
    [b, c, h, w]: [usize; 4],
    g: ConvGeometry,
    [oh, ow]: [usize; 2],
    cols: &mut [f32],
) {
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
                let dst = &mut dst[ox_lo..ox_hi];
                if g.stride == 1 {
                    dst.copy_from_slice(&src[first..first + dst.len()]);
                } else {
                    for (d, s) in dst.iter_mut().zip(src[first..].iter().step_by(g.stride)) {
                        *d = *s;
                    }
                }
            }
        }
    }
}

/// Copies `input` [B, C, L] into `out` [C, B·L].
fn channels_first(input: &[f32], [b, c, l]: [usize; 3], out: &mut [f32]) {
    for (ch, dst) in out.chunks_mut(b * l).enumerate() {
        for sample in 0..b {
            dst[sample * l..][..l].copy_from_slice(&input[(sample * c + ch) * l..][..l]);
        }
    }
}

/// Writes `product` [C, B·L] + bias, activated, into `out` [B, C, L].
fn write_back(
    product: &[f32],
    bias: &[f32],
    activation: Activation,
    [b, c, l]: [usize; 3],
    out: &mut [f32],
) {
    for sample in 0..b {
        for ch in 0..c {
            let src = &product[ch * b * l + sample * l..][..l];
            let dst = &mut out[(sample * c + ch) * l..][..l];
            let bias = bias[ch];
            for (d, s) in dst.iter_mut().zip(src) {
                *d = activation.apply(s + bias);
            }
        }
    }
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

    fn random<const D: usize>(rng: &mut NoiseRng, shape: [usize; D]) -> Tensor<D> {
        let n = shape.iter().product();
        tensor(rng.normal_vec(n, 0.0, 1.0), shape, &Device::flex())
    }

    fn max_abs_diff(a: Tensor<4>, b: Tensor<4>) -> f32 {
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
            for activation in [Activation::Identity, Activation::Relu] {
                let expected = match activation {
                    Activation::Identity => expected.clone(),
                    Activation::Relu => burn::tensor::activation::relu(expected.clone()),
                };
                let layer = GemmConv2d::new(weight.clone(), bias.clone(), geometry, activation);
                let diff = max_abs_diff(layer.forward(x.clone()), expected);
                assert!(diff < 1e-4, "batch {batch} k{kernel} s{stride}: {diff}");
            }
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
