//! Training's ELU, with the dropout VUNet applies after it, as one node of burn's autodiff
//! graph.
//!
//! burn's `elu` on its CPU backend is several nodes (a mask, a scalar `expf` per value, a
//! select) and the dropout after it one more, each a pass over the activations forward and
//! backward; in a stage-2 step of the CVAE `expf` alone took 5.6 % of the time. Here the
//! forward pass is one vectorised pass (the inference layers' `exp_non_positive`), and the
//! backward pass one more: ∂L/∂x = ∂L/∂y · m · (1 where x > 0, else eˣ), m being the dropout's
//! scaled mask.

use burn::backend::Flex;
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::tensor::Tensor;
use burn::tensor::TensorData;
use burn::tensor::activation::elu;
use burn_flex::FlexTensor;
use rayon::prelude::*;

use super::kernels::vectorised;
use super::training::{Trained, autodiff_primitive, burn_layers, plain};
use super::{CpuValues, exp_non_positive};

/// Values per parallel chunk of the element-wise passes.
const CHUNK: usize = 1 << 14;

/// ELU (α = 1) of `x`, times `mask` where given (a dropout's mask, already scaled by
/// 1/(1 − p), one value per element of `x`): one differentiable node on burn's autodiff CPU
/// device, burn's `elu` and a product inside
/// [`with_burn_layers`](super::training::with_burn_layers), plain values elsewhere.
pub fn elu_masked(x: Tensor<4>, mask: Option<Vec<f32>>) -> Tensor<4> {
    let dims = x.dims();
    if let Some(mask) = &mask {
        assert_eq!(
            mask.len(),
            dims.iter().product::<usize>(),
            "elu_masked: the mask's size is not the input's"
        );
    }
    if burn_layers() {
        let device = x.device();
        let out = elu(x, 1.0);
        return match mask {
            Some(mask) => out * Tensor::from_data(TensorData::new(mask, dims), &device),
            None => out,
        };
    }
    if !x.device().is_autodiff() {
        let values = forward(CpuValues::new(x.clone()).as_slice(), mask.as_deref());
        return Tensor::from_data(TensorData::new(values, dims), &x.device());
    }
    let (x, x_node) = autodiff_primitive(x).into_parts();
    let values = forward(
        CpuValues::new(plain::<4>(x.clone())).as_slice(),
        mask.as_deref(),
    );
    let output = FlexTensor::from_data(TensorData::new(values, dims));
    let tracked = match EluBackward
        .prepare::<NoCheckpointing>([x_node])
        .compute_bound()
        .stateful()
    {
        OpsKind::Tracked(prep) => prep.finish(EluState { x, dims, mask }, output),
        OpsKind::UnTracked(prep) => prep.finish(output),
    };
    Tensor::from_primitive::<Trained>(tracked)
}

/// elu(x)·mask, value by value.
fn forward(x: &[f32], mask: Option<&[f32]>) -> Vec<f32> {
    let mut out = x.to_vec();
    out.par_chunks_mut(CHUNK).enumerate().for_each(|(i, out)| {
        vectorised(
            #[inline(always)]
            || {
                for v in out.iter_mut() {
                    *v = if *v > 0.0 {
                        *v
                    } else {
                        exp_non_positive(*v) - 1.0
                    };
                }
                if let Some(mask) = mask {
                    for (v, m) in out.iter_mut().zip(&mask[i * CHUNK..]) {
                        *v *= m;
                    }
                }
            },
        );
    });
    out
}

/// ∂L/∂x for `grad` of the output: grad · mask · elu′(x).
fn backward(x: &[f32], grad: &[f32], mask: Option<&[f32]>) -> Vec<f32> {
    let mut dx = grad.to_vec();
    dx.par_chunks_mut(CHUNK).enumerate().for_each(|(i, dx)| {
        let x = &x[i * CHUNK..];
        vectorised(
            #[inline(always)]
            || {
                for (d, &v) in dx.iter_mut().zip(x) {
                    if v <= 0.0 {
                        *d *= exp_non_positive(v);
                    }
                }
                if let Some(mask) = mask {
                    for (d, m) in dx.iter_mut().zip(&mask[i * CHUNK..]) {
                        *d *= m;
                    }
                }
            },
        );
    });
    dx
}

/// The backward step of [`elu_masked`].
#[derive(Debug)]
struct EluBackward;

/// What the backward step keeps: the input (shared storage) and the mask.
#[derive(Debug, Clone)]
struct EluState {
    x: FlexTensor,
    dims: [usize; 4],
    mask: Option<Vec<f32>>,
}

impl Backward<Flex, 1> for EluBackward {
    type State = EluState;

    fn backward(self, ops: Ops<EluState, 1>, grads: &mut Gradients, _: &mut Checkpointer) {
        let [x_node] = ops.parents;
        let grad = CpuValues::new(plain::<4>(grads.consume::<Flex>(&ops.node)));
        let EluState { x, dims, mask } = ops.state;
        if let Some(node) = x_node {
            let x = CpuValues::new(plain::<4>(x));
            let dx = backward(x.as_slice(), grad.as_slice(), mask.as_deref());
            grads.register::<Flex>(node.id, FlexTensor::from_data(TensorData::new(dx, dims)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::training::tests::{random, relative_error};
    use super::super::training::with_burn_layers;
    use super::*;
    use crate::model::rng::NoiseRng;

    /// The output and the input gradient for the loss Σ out · r.
    fn run(x: &Tensor<4>, mask: &Option<Vec<f32>>, r: &Tensor<4>) -> (Tensor<4>, Tensor<4>) {
        let x = x.clone().require_grad();
        let out = elu_masked(x.clone(), mask.clone());
        let grads = (out.clone() * r.clone()).sum().backward();
        (out.detach(), x.grad(&grads).expect("input gradient"))
    }

    #[test]
    fn fused_elu_and_dropout_match_burns_autodiff() {
        let mut rng = NoiseRng::new(41);
        // Smaller and larger than a parallel chunk, with and without a dropout mask.
        for shape in [[2, 3, 5, 5], [8, 16, 16, 16]] {
            let n = shape.iter().product();
            let x = random(&mut rng, shape).mul_scalar(3.0);
            let r = random(&mut rng, shape);
            for mask in [None, Some(rng.dropout_mask(n, 0.1))] {
                let ours = run(&x, &mask, &r);
                let burn = with_burn_layers(|| run(&x, &mask, &r));
                for (name, error) in [
                    ("output", relative_error(&ours.0, &burn.0)),
                    ("input gradient", relative_error(&ours.1, &burn.1)),
                ] {
                    assert!(
                        error < 1e-5,
                        "{shape:?}, mask {}: {name} differs from burn's by {error:e}",
                        mask.is_some()
                    );
                }
            }
        }
    }
}
