//! The memory modules' addressing product Q·Mᵀ on burn's CPU backend, in the orientation
//! that lets gemm read the memory matrix in place.

use burn::tensor::Tensor;

use super::{CpuValues, tensor};

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

#[cfg(test)]
mod tests {
    use super::super::tests::random;
    use super::*;
    use crate::model::rng::NoiseRng;

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
}
