//! Winograd's minimal filtering F(2×2, 3×3) for the lowered stride-1 3×3 convolutions
//! (Lavin & Gray, "Fast Algorithms for Convolutional Neural Networks", 2016).
//!
//! A 3×3 convolution spends 36 multiplies per channel pair on a 2×2 block of outputs; in the
//! Winograd domain it spends 16. Each 4×4 input patch d becomes V = Bᵀ·d·B, each kernel g
//! becomes U = G·g·Gᵀ once when the layer is lowered, the 16 positions ξ of the 4×4 domain
//! multiply as 16 independent GEMMs M_ξ = U_ξ·V_ξ (C_out × C_in by C_in × tiles), and
//! Y = Aᵀ·M·A folds every 4×4 back to its 2×2 outputs. Most of HF²-VAD's multiplies are in
//! such layers, so this cuts the model's arithmetic by about a third. B and A hold only 0 and
//! ±1 and G halves, so the result rounds about as the direct sum does (the tests hold it to
//! burn's `conv2d`).

use rayon::prelude::*;

use super::Activation;
use super::kernels::{activate_and_add, matmul, vectorised, with_scratch};

/// Positions of the 4×4 transformed domain.
const POSITIONS: usize = 16;

/// Input channels below which the 16 GEMMs would be too thin to pay for the transforms.
pub(super) const MIN_CHANNELS: usize = 8;

/// A 3×3 kernel bank in the Winograd domain.
#[derive(Debug, Clone)]
pub(super) struct WinogradKernel {
    /// U_ξ = G·g·Gᵀ at position ξ, as 16 row-major [C_out, C_in] matrices.
    u: Vec<f32>,
    cin: usize,
    cout: usize,
}

/// Where a tile's output goes and what is applied on the way.
pub(super) struct OutputStage<'a> {
    /// Bias per output channel.
    pub bias: &'a [f32],
    /// Activation after the bias.
    pub activation: Activation,
    /// Added after the activation, laid out as the output.
    pub residual: Option<&'a [f32]>,
    /// The tile's output, [samples, C_out, H, W].
    pub out: &'a mut [f32],
}

impl WinogradKernel {
    /// Transforms `weight` [C_out, C_in, 3, 3] (row-major, PyTorch's order).
    pub(super) fn new(weight: &[f32], cout: usize, cin: usize) -> Self {
        let mut u = vec![0.0f32; POSITIONS * cout * cin];
        for (pair, g) in weight.chunks_exact(9).enumerate() {
            // G·g: G = [[1, 0, 0], [½, ½, ½], [½, −½, ½], [0, 0, 1]] applied to g's columns.
            let mut gg = [[0.0f32; 3]; 4];
            for col in 0..3 {
                let (g0, g1, g2) = (g[col], g[3 + col], g[6 + col]);
                gg[0][col] = g0;
                gg[1][col] = 0.5 * (g0 + g1 + g2);
                gg[2][col] = 0.5 * (g0 - g1 + g2);
                gg[3][col] = g2;
            }
            // (G·g)·Gᵀ, the same combination along each row.
            for (row, r) in gg.iter().enumerate() {
                let transformed = [
                    r[0],
                    0.5 * (r[0] + r[1] + r[2]),
                    0.5 * (r[0] - r[1] + r[2]),
                    r[2],
                ];
                for (col, value) in transformed.into_iter().enumerate() {
                    u[(4 * row + col) * cout * cin + pair] = value;
                }
            }
        }
        Self { u, cin, cout }
    }

    /// Whether an H×W map tiles exactly into 2×2 output blocks.
    pub(super) fn fits(h: usize, w: usize) -> bool {
        h.is_multiple_of(2) && w.is_multiple_of(2)
    }

    /// Values one sample needs in the scratch: its transformed inputs and products.
    pub(super) fn values_per_sample(&self, h: usize, w: usize) -> usize {
        POSITIONS * (self.cin + self.cout) * (h / 2) * (w / 2)
    }

    /// Convolves `samples` samples whose channel planes `plane(sample, channel)` (each H×W)
    /// pass through `input_activation` first, writing through `stage`. With rayon parallelism
    /// the 16 GEMMs run side by side.
    pub(super) fn convolve<'p>(
        &self,
        plane: impl Fn(usize, usize) -> &'p [f32],
        input_activation: Activation,
        [samples, h, w]: [usize; 3],
        stage: OutputStage<'_>,
        parallelism: gemm::Parallelism,
    ) {
        let tiles = samples * (h / 2) * (w / 2);
        let (v_len, m_len) = (self.cin * tiles, self.cout * tiles);
        let padded_len = (h + 2) * (w + 2);
        let scratch_len = POSITIONS * (v_len + m_len) + padded_len + 4 * (w + 2);
        with_scratch(scratch_len, |scratch| {
            let (v, rest) = scratch.split_at_mut(POSITIONS * v_len);
            let (m, rest) = rest.split_at_mut(POSITIONS * m_len);
            let (padded, rows) = rest.split_at_mut(padded_len);
            vectorised(
                #[inline(always)]
                || {
                    padded.fill(0.0);
                    for sample in 0..samples {
                        for channel in 0..self.cin {
                            pad_plane(plane(sample, channel), input_activation, [h, w], padded);
                            transform_patches(
                                padded,
                                [h, w],
                                sample,
                                channel,
                                self.cin,
                                tiles,
                                v,
                                rows,
                            );
                        }
                    }
                },
            );
            let product = |(xi, m_xi): (usize, &mut [f32])| {
                let u_xi = &self.u[xi * self.cout * self.cin..][..self.cout * self.cin];
                let v_xi = &v[xi * v_len..][..v_len];
                // SAFETY: m_xi holds C_out·tiles values, u_xi C_out·C_in, v_xi C_in·tiles.
                unsafe {
                    matmul(
                        m_xi,
                        u_xi,
                        v_xi,
                        [self.cout, self.cin, tiles],
                        gemm::Parallelism::None,
                    )
                };
            };
            match parallelism {
                gemm::Parallelism::None => m.chunks_mut(m_len).enumerate().for_each(product),
                _ => m.par_chunks_mut(m_len).enumerate().for_each(product),
            }
            vectorised(
                #[inline(always)]
                || fold_products(m, [samples, self.cout, h, w], stage),
            );
        });
    }
}

/// Copies an H×W `plane` into the interior of the (H+2)×(W+2) `padded` map, whose one-value
/// border stays zero, applying `activation` on the way. Each padded row is stored as its even
/// columns followed by its odd ones, so that the 4×4 patches at stride 2 read contiguous runs.
#[inline(always)]
fn pad_plane(plane: &[f32], activation: Activation, [h, w]: [usize; 2], padded: &mut [f32]) {
    let (pw, tw) = (w + 2, w / 2);
    for (y, src) in plane.chunks_exact(w).take(h).enumerate() {
        // Padded column x is source column x − 1: even x hold the odd source columns.
        let (even, odd) = padded[(y + 1) * pw..][..pw].split_at_mut(tw + 1);
        for ((e, o), pair) in even[1..]
            .iter_mut()
            .zip(&mut odd[..tw])
            .zip(src.chunks_exact(2))
        {
            *o = pair[0];
            *e = pair[1];
        }
        activation.apply(&mut even[1..]);
        activation.apply(&mut odd[..tw]);
    }
}

/// Writes V = Bᵀ·d·B of every 4×4 patch of the padded map of one `channel` of `sample` into
/// `v` [16, C_in, tiles], with Bᵀ = [[1, 0, −1, 0], [0, 1, 1, 0], [0, −1, 1, 0],
/// [0, 1, 0, −1]]: first down the columns of a band of four rows (into `rows`), then along
/// each of the four resulting rows, whose even and odd columns lie apart (see [`pad_plane`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn transform_patches(
    padded: &[f32],
    [h, w]: [usize; 2],
    sample: usize,
    channel: usize,
    cin: usize,
    tiles: usize,
    v: &mut [f32],
    rows: &mut [f32],
) {
    let (pw, tw) = (w + 2, w / 2);
    let v_len = cin * tiles;
    for ty in 0..h / 2 {
        let band = &padded[2 * ty * pw..][..4 * pw];
        let (r0, rest) = band.split_at(pw);
        let (r1, rest) = rest.split_at(pw);
        let (r2, r3) = rest.split_at(pw);
        let (c0, rest) = rows.split_at_mut(pw);
        let (c1, rest) = rest.split_at_mut(pw);
        let (c2, c3) = rest.split_at_mut(pw);
        let (c3, r3) = (&mut c3[..pw], &r3[..pw]);
        for x in 0..pw {
            c0[x] = r0[x] - r2[x];
            c1[x] = r1[x] + r2[x];
            c2[x] = r2[x] - r1[x];
            c3[x] = r1[x] - r3[x];
        }
        let first_tile = channel * tiles + (sample * (h / 2) + ty) * tw;
        for (i, c) in [&*c0, &*c1, &*c2, &*c3].into_iter().enumerate() {
            let (even, odd) = c.split_at(tw + 1);
            let (even, odd) = (&even[..tw + 1], &odd[..tw + 1]);
            let at = |j: usize| (4 * i + j) * v_len + first_tile;
            let (head, tail) = v.split_at_mut(at(1));
            let v0 = &mut head[at(0)..][..tw];
            let (head, tail) = tail.split_at_mut(at(2) - at(1));
            let v1 = &mut head[..tw];
            let (head, tail) = tail.split_at_mut(at(3) - at(2));
            let v2 = &mut head[..tw];
            let v3 = &mut tail[..tw];
            // The patch at tx spans padded columns 2tx..2tx+4: even[tx], odd[tx],
            // even[tx + 1], odd[tx + 1].
            for tx in 0..tw {
                let (d0, d1, d2, d3) = (even[tx], odd[tx], even[tx + 1], odd[tx + 1]);
                v0[tx] = d0 - d2;
                v1[tx] = d1 + d2;
                v2[tx] = d2 - d1;
                v3[tx] = d1 - d3;
            }
        }
    }
}

/// Folds the products `m` [16, C_out, tiles] back to 2×2 output blocks, Y = Aᵀ·M·A with
/// Aᵀ = [[1, 1, 1, 0], [0, 1, −1, −1]], and writes them through `stage`. Each band of
/// blocks is folded as whole rows of tiles, first across the 4×4 domain's rows, then its
/// columns, and only the finished outputs are interleaved into the plane.
#[inline(always)]
fn fold_products(m: &[f32], [samples, cout, h, w]: [usize; 4], stage: OutputStage<'_>) {
    let (th, tw) = (h / 2, w / 2);
    let tiles = samples * th * tw;
    let m_len = cout * tiles;
    let area = h * w;
    let mut folded = vec![0.0f32; 12 * tw];
    for (plane_index, plane) in stage.out.chunks_exact_mut(area).enumerate() {
        let (sample, co) = (plane_index / cout, plane_index % cout);
        let bias = stage.bias[co];
        for ty in 0..th {
            let first = co * tiles + (sample * th + ty) * tw;
            let row = |xi: usize| &m[xi * m_len + first..][..tw];
            let (sums, outputs) = folded.split_at_mut(8 * tw);
            let (top_sums, bottom_sums) = sums.split_at_mut(4 * tw);
            for (j, (top, bottom)) in top_sums
                .chunks_exact_mut(tw)
                .zip(bottom_sums.chunks_exact_mut(tw))
                .enumerate()
            {
                fold_axis([row(j), row(4 + j), row(8 + j), row(12 + j)], top, bottom);
            }
            let (top_out, bottom_out) = outputs.split_at_mut(2 * tw);
            for (sums, out) in [(&*top_sums, top_out), (&*bottom_sums, bottom_out)] {
                let (left, right) = out.split_at_mut(tw);
                let column = |j: usize| &sums[j * tw..][..tw];
                fold_axis(
                    [column(0), column(1), column(2), column(3)],
                    left,
                    &mut right[..tw],
                );
            }
            let (top, bottom) = plane[2 * ty * w..][..2 * w].split_at_mut(w);
            let (top_out, bottom_out) = outputs.split_at(2 * tw);
            interleave(top, &top_out[..tw], &top_out[tw..2 * tw], bias);
            interleave(bottom, &bottom_out[..tw], &bottom_out[tw..2 * tw], bias);
        }
        let residual = stage.residual.map(|r| &r[plane_index * area..][..area]);
        activate_and_add(plane, stage.activation, residual);
    }
}

/// Aᵀ along one axis, element by element: `first` = x₀ + x₁ + x₂, `second` = x₁ − x₂ − x₃.
#[inline(always)]
fn fold_axis([x0, x1, x2, x3]: [&[f32]; 4], first: &mut [f32], second: &mut [f32]) {
    let n = first.len();
    let (x0, x1, x2, x3, second) = (&x0[..n], &x1[..n], &x2[..n], &x3[..n], &mut second[..n]);
    for i in 0..n {
        first[i] = x0[i] + x1[i] + x2[i];
        second[i] = x1[i] - x2[i] - x3[i];
    }
}

/// Writes `even[i] + bias` and `odd[i] + bias` to `dst[2i]` and `dst[2i + 1]`.
#[inline(always)]
fn interleave(dst: &mut [f32], even: &[f32], odd: &[f32], bias: f32) {
    for ((pair, &e), &o) in dst.chunks_exact_mut(2).zip(even).zip(odd) {
        pair[0] = e + bias;
        pair[1] = o + bias;
    }
}

#[cfg(test)]
mod tests {
    use burn::tensor::Tensor;
    use burn::tensor::module::conv2d;
    use burn::tensor::ops::ConvOptions;

    use super::super::tests::{max_abs_diff, random};
    use super::super::{ConvGeometry, GemmConv2d};
    use super::*;
    use crate::model::rng::NoiseRng;

    #[test]
    fn winograd_layers_match_burns_direct_convolution() {
        let mut rng = NoiseRng::new(21);
        for (batch, cin, cout, h, w) in [
            (1, 8, 8, 4, 4),
            (3, 16, 24, 8, 6),
            (40, 8, 5, 2, 10),
            (2, 64, 32, 32, 32),
        ] {
            let x = random(&mut rng, [batch, cin, h, w]);
            let weight = random(&mut rng, [cout, cin, 3, 3]);
            let bias = random(&mut rng, [cout]);
            let layer = GemmConv2d::new(
                weight.clone(),
                bias.clone(),
                ConvGeometry::SAME_3X3,
                Activation::Relu,
            );
            assert!(
                layer.winograd.is_some(),
                "{cin} channels take the Winograd path"
            );
            let options = ConvOptions::new([1, 1], [1, 1], [1, 1], 1);
            let expected =
                burn::tensor::activation::relu(conv2d(x.clone(), weight, Some(bias), options));
            let diff = max_abs_diff(layer.forward(x), expected);
            assert!(diff < 1e-4, "batch {batch}, {cin}→{cout}, {h}×{w}: {diff}");
        }
    }

    #[test]
    fn winograd_fuses_input_activation_concatenation_and_residual() {
        let mut rng = NoiseRng::new(22);
        for batch in [1, 5] {
            let x = random(&mut rng, [batch, 8, 8, 8]);
            let a = random(&mut rng, [batch, 4, 8, 8]);
            let weight = random(&mut rng, [8, 12, 3, 3]);
            let bias = random(&mut rng, [8]);
            let options = ConvOptions::new([1, 1], [1, 1], [1, 1], 1);
            let activated =
                burn::tensor::activation::elu(Tensor::cat(vec![x.clone(), a.clone()], 1), 1.0);
            let expected =
                x.clone() + conv2d(activated, weight.clone(), Some(bias.clone()), options);
            let layer = GemmConv2d::new(weight, bias, ConvGeometry::SAME_3X3, Activation::Identity);
            assert!(layer.winograd.is_some());
            let ours = layer.forward_fused(vec![x, a], Activation::Elu, true);
            let diff = max_abs_diff(ours, expected);
            assert!(diff < 1e-4, "batch {batch}: {diff}");
        }
    }

    #[test]
    fn odd_maps_and_thin_inputs_keep_the_direct_path() {
        let mut rng = NoiseRng::new(23);
        let thin = GemmConv2d::new(
            random(&mut rng, [4, MIN_CHANNELS - 1, 3, 3]),
            random(&mut rng, [4]),
            ConvGeometry::SAME_3X3,
            Activation::Identity,
        );
        assert!(thin.winograd.is_none());
        let weight = random(&mut rng, [6, 8, 3, 3]);
        let bias = random(&mut rng, [6]);
        let x = random(&mut rng, [3, 8, 5, 6]);
        let layer = GemmConv2d::new(
            weight.clone(),
            bias.clone(),
            ConvGeometry::SAME_3X3,
            Activation::Identity,
        );
        assert!(!WinogradKernel::fits(5, 6));
        let options = ConvOptions::new([1, 1], [1, 1], [1, 1], 1);
        let diff = max_abs_diff(
            layer.forward(x.clone()),
            conv2d(x, weight, Some(bias), options),
        );
        assert!(diff < 1e-4, "{diff}");
    }
}
