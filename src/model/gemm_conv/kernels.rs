//! The kernels the lowered layers share: tiling of a batch, the unfolding (im2col) of an
//! input, the write-back of a GEMM product to NCHW with its bias and activation, per-thread
//! scratch, the AVX dispatch of the element-wise loops, and the two GEMM wrappers.

use std::cell::RefCell;

use rayon::prelude::*;

use super::{Activation, ConvGeometry};

/// About how many values one tile's unfolded input holds (4 MiB): large enough that the
/// GEMM amortises its packing, small enough to stay in a core's cache hierarchy.
const TILE_VALUES: usize = 1 << 20;

/// How many samples one tile takes: about [`TILE_VALUES`] unfolded values, and at least two
/// tiles per worker thread when the batch allows, so the workers share the batch evenly.
pub(super) fn samples_per_tile(values_per_sample: usize, batch: usize) -> usize {
    let by_size = (TILE_VALUES / values_per_sample.max(1)).max(1);
    let by_threads = batch.div_ceil(2 * rayon::current_num_threads()).max(1);
    by_size.min(by_threads).min(batch.max(1))
}

/// Runs `tile` over `out` cut into chunks of `chunk` values: tiles in parallel with one
/// thread per GEMM when there are enough of them, else one tile at a time with a parallel
/// GEMM.
pub(super) fn run_tiles<F>(out: &mut [f32], chunk: usize, tile: F)
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
pub(super) fn vectorised<R>(f: impl FnOnce() -> R) -> R {
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

pub(super) fn with_scratch(len: usize, f: impl FnOnce(&mut [f32])) {
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
pub(super) fn im2col(
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
pub(super) fn channels_first(input: &[f32], [b, c, l]: [usize; 3], out: &mut [f32]) {
    for (ch, dst) in out.chunks_mut(b * l).enumerate() {
        for sample in 0..b {
            dst[sample * l..][..l].copy_from_slice(&input[(sample * c + ch) * l..][..l]);
        }
    }
}

/// Writes `product` [C, B·L] + bias, activated, plus `residual` [B, C, L] where given, into
/// `out` [B, C, L].
#[inline(always)]
pub(super) fn write_back(
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
pub(super) fn activate_and_add(dst: &mut [f32], activation: Activation, residual: Option<&[f32]>) {
    activation.apply(dst);
    if let Some(residual) = residual {
        for (d, r) in dst.iter_mut().zip(residual) {
            *d += r;
        }
    }
}

/// `dst` [M, N] = `lhs` [M, K] · `rhs` [K, N], all row-major and contiguous.
///
/// # Safety
/// `dst` must hold M·N values, `lhs` M·K and `rhs` K·N.
pub(super) unsafe fn matmul(
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

/// `dst` [M, N] += `lhs` [M, K] · `rhs`ᵀ, with `rhs` stored row-major as [N, K] and `dst`
/// stored column-major (as row-major [N, M]): the weight gradients' product of two unfolded
/// operands that share their long axis K.
///
/// gemm computes a row-major product as its transpose, which makes the larger unfolded
/// operand (`rhs`, N·K values) the one it packs; into a column-major `dst` it packs `lhs`
/// (M·K) instead. For the layers' shapes that runs 1.5–2.7× faster (M 16–128, N 144–576,
/// K 512–8192, one thread, gemm 0.19).
///
/// # Safety
/// `dst` must hold M·N values, `lhs` M·K and `rhs` N·K.
pub(super) unsafe fn matmul_accumulate_transposed(
    dst: &mut [f32],
    lhs: &[f32],
    rhs: &[f32],
    [m, k, n]: [usize; 3],
    parallelism: gemm::Parallelism,
) {
    debug_assert!(dst.len() >= m * n && lhs.len() >= m * k && rhs.len() >= n * k);
    // SAFETY: the caller guarantees the buffer sizes; `dst` has column stride M and row
    // stride 1; `rhs` read with row stride 1 and column stride K is the [K, N] transpose of
    // its row-major [N, K] values.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            m as isize,
            1,
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
