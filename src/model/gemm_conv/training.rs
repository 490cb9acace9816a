//! Training's convolutions through the same lowering as inference, with their own backward
//! pass, as custom operations of burn's autodiff backend.
//!
//! burn's differentiable convolution on its CPU backend runs one small GEMM per sample,
//! re-packs the weights on every call and computes the input gradient with a direct
//! transposed-convolution loop; a training step of the compact model spent most of its time
//! there. Here the forward pass is [`GemmConv2d`] / [`GemmConvTranspose2d`] (tiles of whole
//! samples, one GEMM each) and the backward pass is built from the same pieces:
//!
//! - a convolution's input gradient is the transposed convolution of the output gradient
//!   with the same weights (GEMM + col2im), and a transposed convolution's is the
//!   convolution of its output gradient (im2col + GEMM);
//! - either weight gradient is one GEMM per tile between one operand laid out channels-first
//!   and the other unfolded: [`weight_gradient`];
//! - the bias gradient is the output gradient summed per channel.
//!
//! The operations register with burn's autodiff graph ([`Backward`]), so burn's optimiser,
//! records and checkpoints stay as they are; only these nodes change. Why custom operations
//! rather than a backend decorator: the lowering needs whole-batch tensors of one layer at a
//! time, which is exactly one node of the graph, and everything else (weight normalisation,
//! the memories, losses) keeps burn's exact gradients.
//!
//! Training-mode BatchNorm with the ReLU after it is one such node too
//! ([`batch_norm_relu`], in `batch_norm`), and so is ELU with the dropout after it
//! ([`elu_masked`], in `elu`). [`with_burn_layers`] runs a closure with burn's own
//! convolutions, BatchNorm and activations instead, so the two paths can be compared side
//! by side (tests, the training benchmark).

use std::cell::Cell;

use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::{Autodiff, BackendTypes, Flex};
use burn::tensor::module::{conv_transpose2d as burn_conv_transpose2d, conv2d as burn_conv2d};
use burn::tensor::ops::{ConvOptions, ConvTransposeOptions};
use burn::tensor::{Tensor, TensorData};
use burn_flex::FlexTensor;
use rayon::prelude::*;

pub use super::batch_norm::{BatchNormReluOutput, batch_norm_relu};
pub use super::elu::elu_masked;
use super::kernels::{
    channels_first, im2col, matmul_accumulate_transposed, samples_per_tile, vectorised,
    with_scratch,
};
use super::{Activation, ConvGeometry, CpuValues, GemmConv2d, GemmConvTranspose2d};

/// burn's autodiff over its CPU backend, as the training device ([`Device::autodiff`] without
/// gradient checkpointing) holds its tensors.
///
/// [`Device::autodiff`]: burn::tensor::Device::autodiff
pub(super) type Trained = Autodiff<Flex, NoCheckpointing>;

thread_local! {
    /// Set while [`with_burn_layers`] runs on this thread.
    static BURN_LAYERS: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f` with burn's own convolutions, BatchNorm, ReLU and ELU in place of the lowered
/// and fused ones on this thread: the reference the training path is measured and tested
/// against.
pub fn with_burn_layers<R>(f: impl FnOnce() -> R) -> R {
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            BURN_LAYERS.with(|flag| flag.set(self.0));
        }
    }
    let _restore = Restore(BURN_LAYERS.with(|flag| flag.replace(true)));
    f()
}

/// Whether [`with_burn_layers`] runs on this thread.
pub(super) fn burn_layers() -> bool {
    BURN_LAYERS.with(Cell::get)
}

/// Which of the two layers a node is, with what it needs beyond its tensors.
#[derive(Debug, Clone, Copy)]
enum Layer {
    /// A convolution.
    Conv(ConvGeometry),
    /// A transposed convolution with extra rows and columns at the bottom and right.
    Transposed(ConvGeometry, usize),
}

impl Layer {
    fn geometry(self) -> ConvGeometry {
        match self {
            Self::Conv(g) | Self::Transposed(g, _) => g,
        }
    }

    /// The layer's output for `x` with `weight` and `bias`, through the lowering.
    fn forward(self, x: Tensor<4>, weight: Tensor<4>, bias: Tensor<1>) -> Tensor<4> {
        match self {
            Self::Conv(g) => GemmConv2d::new(weight, bias, g, Activation::Identity).forward(x),
            Self::Transposed(g, out_padding) => {
                GemmConvTranspose2d::new(weight, bias, g, out_padding).forward(x)
            }
        }
    }

    /// burn's own differentiable layer, for [`with_burn_layers`].
    fn burn_forward(self, x: Tensor<4>, weight: Tensor<4>, bias: Tensor<1>) -> Tensor<4> {
        let g = self.geometry();
        match self {
            Self::Conv(_) => {
                let options = ConvOptions::new([g.stride; 2], [g.padding; 2], [1, 1], 1);
                burn_conv2d(x, weight, Some(bias), options)
            }
            Self::Transposed(_, out_padding) => {
                let options = ConvTransposeOptions::new(
                    [g.stride; 2],
                    [g.padding; 2],
                    [out_padding; 2],
                    [1, 1],
                    1,
                );
                burn_conv_transpose2d(x, weight, Some(bias), options)
            }
        }
    }

    /// The gradient of the layer's input `x` for `grad` of its output.
    fn input_gradient(self, x_shape: [usize; 4], weight: Tensor<4>, grad: Tensor<4>) -> Tensor<4> {
        let [_, cin, h, w] = x_shape;
        let device = grad.device();
        let zero_bias = Tensor::zeros([cin], &device);
        match self {
            // Each output value took weight · a window of the input, so the input gradient
            // scatters weight · the output gradient back over the windows: the transposed
            // convolution with the same [C_out, C_in, k, k] weights, read as [C_in', C_out'].
            Self::Conv(g) => {
                GemmConvTranspose2d::new(weight, zero_bias, g, 0).forward_to(grad, [h, w])
            }
            Self::Transposed(g, _) => {
                GemmConv2d::new(weight, zero_bias, g, Activation::Identity).forward(grad)
            }
        }
    }

    /// The gradient of the layer's weights for input `x` and output gradient `grad`, in the
    /// weights' own layout.
    fn weight_gradient(self, x: &Tensor<4>, grad: &Tensor<4>) -> Vec<f32> {
        let g = self.geometry();
        match self {
            // dW[co, (ci, ky, kx)] = Σ_(b, oy, ox) G[b, co, oy, ox] · x[b, ci, oy·s + ky − p, …]
            Self::Conv(_) => weight_gradient(grad, x, g),
            // dW[ci, (co, ky, kx)] = Σ_(b, iy, ix) x[b, ci, iy, ix] · G[b, co, iy·s + ky − p, …]
            Self::Transposed(..) => weight_gradient(x, grad, g),
        }
    }
}

/// A convolution (`weight` [C_out, C_in, k, k], `bias` [C_out]) of `x` [B, C_in, H, W] through
/// the lowering, differentiable on burn's autodiff CPU device and plain elsewhere.
pub fn conv2d(
    x: Tensor<4>,
    weight: Tensor<4>,
    bias: Tensor<1>,
    geometry: ConvGeometry,
) -> Tensor<4> {
    apply(Layer::Conv(geometry), x, weight, bias)
}

/// A transposed convolution (`weight` [C_in, C_out, k, k], `bias` [C_out]) of `x`
/// [B, C_in, H, W] through the lowering, differentiable on burn's autodiff CPU device.
pub fn conv_transpose2d(
    x: Tensor<4>,
    weight: Tensor<4>,
    bias: Tensor<1>,
    geometry: ConvGeometry,
    out_padding: usize,
) -> Tensor<4> {
    apply(Layer::Transposed(geometry, out_padding), x, weight, bias)
}

/// `layer` on `x`: burn's own op inside [`with_burn_layers`], the plain lowering off
/// the autodiff device, else the lowering registered as a node of the autodiff graph.
fn apply(layer: Layer, x: Tensor<4>, weight: Tensor<4>, bias: Tensor<1>) -> Tensor<4> {
    if burn_layers() {
        return layer.burn_forward(x, weight, bias);
    }
    if !x.device().is_autodiff() {
        return layer.forward(x, weight, bias);
    }
    let (x, x_node) = autodiff_primitive(x).into_parts();
    let (weight, weight_node) = autodiff_primitive(weight).into_parts();
    let (bias, bias_node) = autodiff_primitive(bias).into_parts();
    let output = layer.forward(plain(x.clone()), plain(weight.clone()), plain(bias));
    let output = output
        .try_into_primitive::<Flex>()
        .expect("the lowered layers compute on burn's CPU backend");
    let nodes = [x_node, weight_node, bias_node];
    let tracked = match LoweredBackward
        .prepare::<NoCheckpointing>(nodes)
        .compute_bound()
        .stateful()
    {
        OpsKind::Tracked(prep) => prep.finish(LoweredState { layer, x, weight }, output),
        OpsKind::UnTracked(prep) => prep.finish(output),
    };
    Tensor::from_primitive::<Trained>(tracked)
}

/// `t`'s autodiff primitive on the training device.
pub(super) fn autodiff_primitive<const D: usize>(
    t: Tensor<D>,
) -> <Trained as BackendTypes>::FloatTensorPrimitive {
    t.try_into_primitive::<Trained>()
        .expect("training runs on burn's autodiff CPU device without gradient checkpointing")
}

/// A plain CPU tensor over `t`'s values (no copy).
pub(super) fn plain<const D: usize>(t: FlexTensor) -> Tensor<D> {
    Tensor::from_primitive::<Flex>(t)
}

/// The backward step of a lowered layer.
#[derive(Debug)]
struct LoweredBackward;

/// What the backward step keeps from the forward pass: the input and the weights (their
/// storage is shared, not copied).
#[derive(Debug, Clone)]
struct LoweredState {
    layer: Layer,
    x: FlexTensor,
    weight: FlexTensor,
}

impl Backward<Flex, 3> for LoweredBackward {
    type State = LoweredState;

    fn backward(self, ops: Ops<LoweredState, 3>, grads: &mut Gradients, _: &mut Checkpointer) {
        let [x_node, weight_node, bias_node] = ops.parents;
        let grad: Tensor<4> = plain(grads.consume::<Flex>(&ops.node));
        let LoweredState { layer, x, weight } = ops.state;
        let x: Tensor<4> = plain(x);
        let weight: Tensor<4> = plain(weight);
        if let Some(node) = bias_node {
            let bias = bias_gradient(&grad);
            let len = bias.len();
            let t = FlexTensor::from_data(TensorData::new(bias, [len]));
            grads.register::<Flex>(node.id, t);
        }
        if let Some(node) = weight_node {
            let shape = weight.dims();
            let values = layer.weight_gradient(&x, &grad);
            let t = FlexTensor::from_data(TensorData::new(values, shape));
            grads.register::<Flex>(node.id, t);
        }
        if let Some(node) = x_node {
            let t = layer
                .input_gradient(x.dims(), weight, grad)
                .try_into_primitive::<Flex>()
                .expect("gradients stay on burn's CPU backend");
            grads.register::<Flex>(node.id, t);
        }
    }
}

/// Σ over samples and positions of `grad` [B, C, H, W], per channel.
fn bias_gradient(grad: &Tensor<4>) -> Vec<f32> {
    let [b, c, h, w] = grad.dims();
    let values = CpuValues::new(grad.clone());
    let values = values.as_slice();
    let area = h * w;
    let mut sums = vec![0.0f32; c];
    for sample in 0..b {
        for (ch, sum) in sums.iter_mut().enumerate() {
            *sum += values[(sample * c + ch) * area..][..area]
                .iter()
                .sum::<f32>();
        }
    }
    sums
}

/// The product Σ_tiles `left`ᶜᶠ · im2col(`right`)ᵀ, [C_l, C_r·k·k]: `left` [B, C_l, OH, OW]
/// laid out channels-first ([C_l, B·OH·OW]) against `right` [B, C_r, H, W] unfolded with
/// geometry `g` to the same OH×OW positions. Tiles of samples run in parallel, each with its
/// own partial sum, when there are enough of them; else one at a time with a parallel GEMM.
fn weight_gradient(left: &Tensor<4>, right: &Tensor<4>, g: ConvGeometry) -> Vec<f32> {
    let [b, cl, oh, ow] = left.dims();
    let [rb, cr, h, w] = right.dims();
    assert_eq!(b, rb, "weight_gradient: batch sizes differ");
    assert_eq!(
        [g.output_side(h), g.output_side(w)],
        [oh, ow],
        "weight_gradient: the unfolded operand does not reach the left one's positions"
    );
    let (left, right) = (CpuValues::new(left.clone()), CpuValues::new(right.clone()));
    let (left, right) = (left.as_slice(), right.as_slice());
    let k = cr * g.kernel * g.kernel;
    let (l, area) = (oh * ow, h * w);
    let per_tile = samples_per_tile((k + cl) * l, b);
    let tiles = b.div_ceil(per_tile);
    let tile_product = |tile: usize, acc: &mut [f32], parallelism: gemm::Parallelism| {
        let first = tile * per_tile;
        let samples = per_tile.min(b - first);
        let cols_n = samples * l;
        with_scratch(cl * cols_n + k * cols_n, |scratch| {
            let (gathered, cols) = scratch.split_at_mut(cl * cols_n);
            vectorised(
                #[inline(always)]
                || {
                    channels_first(
                        &left[first * cl * l..(first + samples) * cl * l],
                        [samples, cl, l],
                        gathered,
                    );
                    im2col(
                        &right[first * cr * area..(first + samples) * cr * area],
                        [samples, cr, h, w],
                        g,
                        [oh, ow],
                        cols,
                    );
                },
            );
            // SAFETY: `acc` holds C_l·K values (column-major), `gathered` C_l·N and `cols`
            // K·N.
            unsafe {
                matmul_accumulate_transposed(acc, gathered, cols, [cl, cols_n, k], parallelism)
            };
        });
    };
    let len = cl * k;
    // The sums are column-major [C_l, K] (see `matmul_accumulate_transposed`).
    let by_column = if tiles >= 2 * rayon::current_num_threads() {
        // One partial sum per tile, added in tile order: the same values whichever thread
        // ran which tile.
        let mut partials = vec![0.0f32; tiles * len];
        partials
            .par_chunks_mut(len)
            .enumerate()
            .for_each(|(tile, acc)| tile_product(tile, acc, gemm::Parallelism::None));
        let mut chunks = partials.chunks(len);
        let mut sum = chunks.next().map(<[f32]>::to_vec).unwrap_or_default();
        for partial in chunks {
            sum.iter_mut().zip(partial).for_each(|(s, p)| *s += p);
        }
        sum
    } else {
        let mut acc = vec![0.0f32; len];
        for tile in 0..tiles {
            tile_product(tile, &mut acc, gemm::Parallelism::Rayon(0));
        }
        acc
    };
    let mut gradient = vec![0.0f32; len];
    for (column, values) in by_column.chunks_exact(cl).enumerate() {
        for (row, &v) in values.iter().enumerate() {
            gradient[row * k + column] = v;
        }
    }
    gradient
}

#[cfg(test)]
pub(super) mod tests {
    use burn::tensor::Device;

    use super::*;
    use crate::model::rng::NoiseRng;

    /// A tensor of standard normal values with `shape` on the autodiff CPU device.
    pub(in crate::model::gemm_conv) fn random<const D: usize>(
        rng: &mut NoiseRng,
        shape: [usize; D],
    ) -> Tensor<D> {
        let n = shape.iter().product();
        let device = Device::flex().autodiff();
        Tensor::from_data(TensorData::new(rng.normal_vec(n, 0.0, 1.0), shape), &device)
    }

    /// Largest absolute difference over the largest magnitude of `reference`.
    pub(in crate::model::gemm_conv) fn relative_error<const D: usize>(
        ours: &Tensor<D>,
        reference: &Tensor<D>,
    ) -> f32 {
        assert_eq!(ours.dims(), reference.dims());
        let scale = reference.clone().abs().max().into_scalar::<f32>();
        let diff = (ours.clone() - reference.clone())
            .abs()
            .max()
            .into_scalar::<f32>();
        diff / scale.max(1e-12)
    }

    /// The layer's output and the gradients of x, weight and bias (flattened) for the loss
    /// Σ out · r.
    fn output_and_gradients(
        layer: Layer,
        x: &Tensor<4>,
        weight: &Tensor<4>,
        bias: &Tensor<1>,
        r: &Tensor<4>,
    ) -> (Tensor<4>, Tensor<4>, Tensor<4>, Tensor<1>) {
        let x = x.clone().require_grad();
        let weight = weight.clone().require_grad();
        let bias = bias.clone().require_grad();
        let out = apply(layer, x.clone(), weight.clone(), bias.clone());
        let grads = (out.clone() * r.clone()).sum().backward();
        (
            out.detach(),
            x.grad(&grads).expect("input gradient"),
            weight.grad(&grads).expect("weight gradient"),
            bias.grad(&grads).expect("bias gradient"),
        )
    }

    fn assert_matches_burn(
        layer: Layer,
        x: Tensor<4>,
        weight: Tensor<4>,
        bias: Tensor<1>,
        case: &str,
    ) {
        let mut rng = NoiseRng::new(5);
        let shape = layer
            .forward(
                x.clone().inner(),
                weight.clone().inner(),
                bias.clone().inner(),
            )
            .dims();
        let r = random(&mut rng, shape);
        let ours = output_and_gradients(layer, &x, &weight, &bias, &r);
        let burn = with_burn_layers(|| output_and_gradients(layer, &x, &weight, &bias, &r));
        for (name, error) in [
            ("output", relative_error(&ours.0, &burn.0)),
            ("input gradient", relative_error(&ours.1, &burn.1)),
            ("weight gradient", relative_error(&ours.2, &burn.2)),
            ("bias gradient", relative_error(&ours.3, &burn.3)),
        ] {
            assert!(
                error < 1e-4,
                "{case}: {name} differs from burn's by {error:e}"
            );
        }
    }

    #[test]
    fn convolution_gradients_match_burns_autodiff() {
        let mut rng = NoiseRng::new(21);
        // Batches of one tile and of many (parallel partial sums), strides 1 and 2, 1×1,
        // 3×3 with and without padding, odd sides.
        for (batch, cin, cout, side, kernel, stride, padding) in [
            (2, 3, 4, 5, 3, 1, 1),
            (33, 6, 5, 8, 3, 1, 1),
            (3, 5, 7, 9, 3, 2, 1),
            (4, 4, 6, 7, 1, 1, 0),
            (2, 3, 2, 7, 3, 2, 0),
            (5, 20, 8, 6, 3, 1, 1),
        ] {
            let x = random(&mut rng, [batch, cin, side, side]);
            let weight = random(&mut rng, [cout, cin, kernel, kernel]);
            let bias = random(&mut rng, [cout]);
            let geometry = ConvGeometry {
                kernel,
                stride,
                padding,
            };
            let case =
                format!("conv b{batch} {cin}→{cout} side {side} k{kernel} s{stride} p{padding}");
            assert_matches_burn(Layer::Conv(geometry), x, weight, bias, &case);
        }
    }

    #[test]
    fn transposed_convolution_gradients_match_burns_autodiff() {
        let mut rng = NoiseRng::new(22);
        for (batch, cin, cout, side, out_padding) in
            [(2, 8, 4, 4, 1), (40, 6, 3, 5, 1), (3, 4, 4, 3, 0)]
        {
            let x = random(&mut rng, [batch, cin, side, side]);
            let weight = random(&mut rng, [cin, cout, 3, 3]);
            let bias = random(&mut rng, [cout]);
            let geometry = ConvGeometry {
                kernel: 3,
                stride: 2,
                padding: 1,
            };
            let case = format!("transposed b{batch} {cin}→{cout} side {side} op{out_padding}");
            assert_matches_burn(
                Layer::Transposed(geometry, out_padding),
                x,
                weight,
                bias,
                &case,
            );
        }
    }

    #[test]
    fn untracked_inputs_get_no_gradient_and_the_output_is_unchanged() {
        let mut rng = NoiseRng::new(23);
        let x = random(&mut rng, [3, 4, 6, 6]);
        let weight = random(&mut rng, [5, 4, 3, 3]).require_grad();
        let bias = random(&mut rng, [5]);
        let geometry = ConvGeometry::SAME_3X3;
        let out = conv2d(x.clone(), weight.clone(), bias.clone(), geometry);
        let grads = out.clone().sum().backward();
        assert!(x.grad(&grads).is_none());
        assert!(bias.grad(&grads).is_none());
        assert!(weight.grad(&grads).is_some());
        let plain = conv2d(x.inner(), weight.inner(), bias.inner(), geometry);
        assert!(relative_error(&out.inner(), &plain) < 1e-6);
    }
}
