//! Inverse-compositional patch search on the sparse grid of one pyramid level.
//!
//! Each patch of the previous frame `I0` looks for the displacement `u` minimising the
//! (optionally mean-normalised) sum of squared differences `Σ (I1(x + u) − I0(x))²` over the
//! patch. Because the template is fixed, the Gauss–Newton Hessian `Σ ∇I0 ∇I0ᵀ` is computed
//! once per patch and the update is `u ← u − H⁻¹ Σ ∇I0 · r`. Candidates (the coarser level's
//! vector, the neighbours' vectors, a temporal prior) are compared by SSD first.
//!
//! Two passes run over the grid: forward (left-to-right, top-to-bottom, taking the left and
//! upper neighbours as candidates) and backward (right and lower neighbours). The grid is cut
//! into a fixed number of horizontal stripes that run in parallel; a neighbour in another
//! stripe is read from the state at the start of the pass, so the result never depends on
//! the number of threads.

use rayon::prelude::*;

use super::grid::PatchGrid;
use super::plane::{PaddedPlane, Plane};
use super::simd;

/// Stripes per pass: fixed so that results do not depend on the thread count.
const STRIPES: usize = 8;

/// Levenberg–Marquardt style damping added to the Hessian diagonal, per patch pixel, in
/// (grey levels / pixel)². Textured patches have squared gradients of 10–1000 per pixel and
/// are barely slowed; patches of sensor noise (≈0.5 per pixel) hardly move. Measured on the
/// synthetic benchmark: 0 gives 30–50 % higher EPE in flat regions.
const STEP_DAMPING_PER_PIXEL: f32 = 10.0;

/// A patch stops once its step is shorter than √this (0.03 px of its level). Finer steps
/// mostly chase sensor noise: on the synthetic benchmark stopping here is 15 % faster than
/// iterating to 10⁻⁴ px and lowers the EPE slightly.
const CONVERGED_STEP_SQ: f32 = 1e-3;

/// When a Gauss–Newton step raises the cost, it is halved up to this many times before the
/// search stops. Coarse levels are aliased, so full steps often overshoot a minimum that a
/// shorter step reaches.
const STEP_HALVINGS: usize = 2;

/// What the search needs from one level, beyond the grid.
pub(crate) struct SearchInput<'a> {
    pub i0: &'a Plane,
    pub gx: &'a Plane,
    pub gy: &'a Plane,
    pub i1: &'a PaddedPlane,
    pub grid: &'a PatchGrid,
    /// Optional temporal candidate per patch (row-major over the grid).
    pub temporal: Option<&'a [Option<[f32; 2]>]>,
}

/// Search settings derived from the DIS parameters.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SearchSettings {
    pub forward_iterations: usize,
    pub backward_iterations: usize,
    pub mean_normalization: bool,
    pub spatial_propagation: bool,
}

/// Photometric cost of one displacement and the Gauss–Newton gradient there.
#[derive(Debug, Clone, Copy)]
struct Evaluation {
    ssd: f32,
    bx: f32,
    by: f32,
}

/// Per-patch constants of the Gauss–Newton search, computed once per level.
#[derive(Debug, Clone, Copy)]
struct PatchStats {
    /// Patch sums of the gradients (used by mean normalisation).
    sum_gx: f32,
    sum_gy: f32,
    /// Inverse of the damped Hessian: [h11, h12, h22].
    inv: [f32; 3],
}

/// [`PatchStats`] of every patch of the grid, row-major.
fn patch_stats<const PS: usize>(input: &SearchInput, mean_normalization: bool) -> Vec<PatchStats> {
    let grid = input.grid;
    let w = input.i0.width;
    (0..grid.len())
        .into_par_iter()
        .map(|i| {
            let (x0, y0) = (grid.xs[i % grid.cols()], grid.ys[i / grid.cols()]);
            let mut sums = [[0.0f32; PS]; 5];
            for r in 0..PS {
                let start = (y0 + r) * w + x0;
                let gx = &input.gx.data[start..start + PS];
                let gy = &input.gy.data[start..start + PS];
                for c in 0..PS {
                    let (a, b) = (gx[c], gy[c]);
                    sums[0][c] += a * a;
                    sums[1][c] += b * b;
                    sums[2][c] += a * b;
                    sums[3][c] += a;
                    sums[4][c] += b;
                }
            }
            let [mut hxx, mut hyy, mut hxy, sum_gx, sum_gy] = sums.map(|l| lane_sum(&l));
            if mean_normalization {
                let n = (PS * PS) as f32;
                hxx -= sum_gx * sum_gx / n;
                hyy -= sum_gy * sum_gy / n;
                hxy -= sum_gx * sum_gy / n;
            }
            // The ridge damps steps where the patch has little texture (flat areas, single
            // edges): such patches then keep their starting vector instead of following
            // noise. It changes step lengths only, not the minimum being searched for.
            let ridge = STEP_DAMPING_PER_PIXEL * (PS * PS) as f32;
            let (a, b, d) = (hxx + ridge, hxy, hyy + ridge);
            let det = (a * d - b * b).max(1e-12);
            PatchStats {
                sum_gx,
                sum_gy,
                inv: [d / det, -b / det, a / det],
            }
        })
        .collect()
}

/// The fixed template of one patch: views into the first frame and its gradients
/// starting at the patch origin (rows `stride` apart), plus the patch's constants.
struct Template<'a, const PS: usize> {
    x0: usize,
    y0: usize,
    t: &'a [f32],
    gx: &'a [f32],
    gy: &'a [f32],
    stride: usize,
    stats: PatchStats,
}

impl<'a, const PS: usize> Template<'a, PS> {
    #[inline(always)]
    fn new(input: &'a SearchInput, x0: usize, y0: usize, stats: PatchStats) -> Self {
        let w = input.i0.width;
        let start = y0 * w + x0;
        let len = (PS - 1) * w + PS;
        Self {
            x0,
            y0,
            t: &input.i0.data[start..start + len],
            gx: &input.gx.data[start..start + len],
            gy: &input.gy.data[start..start + len],
            stride: w,
            stats,
        }
    }

    /// SSD and gradient for displacement `u`. `WIDE` selects the AVX2 kernel for 8-pixel
    /// patches; it must only be set on the AVX2 path.
    #[inline(always)]
    fn evaluate<const WIDE: bool>(
        &self,
        i1: &PaddedPlane,
        u: [f32; 2],
        mean_normalization: bool,
    ) -> Evaluation {
        let px = self.x0 as f32 + u[0];
        let py = self.y0 as f32 + u[1];
        let fx0 = px.floor();
        let fy0 = py.floor();
        let pad = i1.pad as f32;
        let inside = fx0 >= -pad
            && fy0 >= -pad
            && fx0 + (PS as f32) <= (i1.width + i1.pad - 1) as f32
            && fy0 + (PS as f32) <= (i1.height + i1.pad - 1) as f32;
        let sums = if inside {
            let ax = px - fx0;
            let ay = py - fy0;
            let weights = [
                (1.0 - ax) * (1.0 - ay),
                ax * (1.0 - ay),
                (1.0 - ax) * ay,
                ax * ay,
            ];
            let base = i1.index(fx0 as isize, fy0 as isize);
            let window = &i1.data[base..base + PS * i1.stride + PS + 1];
            self.sums_window::<WIDE>(window, i1.stride, weights)
        } else {
            self.sums_clamped(i1, px, py)
        };
        self.finish(sums, mean_normalization)
    }

    /// Raw sums `[Σd, Σd², Σgx·d, Σgy·d]` over a patch inside `window`, on the AVX2 kernel
    /// when `WIDE` and the patch is 8 pixels.
    #[inline(always)]
    fn sums_window<const WIDE: bool>(
        &self,
        window: &[f32],
        stride: usize,
        weights: [f32; 4],
    ) -> [f32; 4] {
        #[cfg(target_arch = "x86_64")]
        if WIDE && PS == 8 {
            // SAFETY: WIDE is only set on the AVX2 path, which runs after
            // `simd::wide_vectors_available` confirmed AVX2 on this CPU.
            return unsafe { patch8::sums_avx2(window, stride, weights, self.rows8()) };
        }
        self.sums_bilinear(window, stride, weights)
    }

    /// The template views in the form of the AVX2 kernel.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn rows8(&self) -> patch8::Tables<'_> {
        patch8::Tables {
            t: self.t,
            gx: self.gx,
            gy: self.gy,
            stride: self.stride,
        }
    }

    /// Applies mean normalisation to raw sums `[Σd, Σd², Σgx·d, Σgy·d]`.
    #[inline(always)]
    fn finish(&self, sums: [f32; 4], mean_normalization: bool) -> Evaluation {
        let [sum_r, mut ssd, mut bx, mut by] = sums;
        if mean_normalization {
            let n = (PS * PS) as f32;
            ssd -= sum_r * sum_r / n;
            bx -= self.stats.sum_gx * sum_r / n;
            by -= self.stats.sum_gy * sum_r / n;
        }
        Evaluation { ssd, bx, by }
    }

    /// Raw sums with the patch fully inside `window` (the samples from the top-left
    /// corner, rows `stride` apart) and constant bilinear weights `[w00, w01, w10, w11]`.
    #[inline(always)]
    fn sums_bilinear(&self, window: &[f32], stride: usize, weights: [f32; 4]) -> [f32; 4] {
        let [w00, w01, w10, w11] = weights;
        let mut acc = [[0.0f32; PS]; 4];
        for r in 0..PS {
            let top = &window[r * stride..r * stride + PS + 1];
            let bottom = &window[(r + 1) * stride..(r + 1) * stride + PS + 1];
            let at = r * self.stride;
            let (t, gx, gy) = (
                &self.t[at..at + PS],
                &self.gx[at..at + PS],
                &self.gy[at..at + PS],
            );
            for c in 0..PS {
                let p = w00 * top[c] + w01 * top[c + 1] + w10 * bottom[c] + w11 * bottom[c + 1];
                let d = p - t[c];
                acc[0][c] += d;
                acc[1][c] += d * d;
                acc[2][c] += gx[c] * d;
                acc[3][c] += gy[c] * d;
            }
        }
        acc.map(|lanes| lane_sum(&lanes))
    }

    /// Raw sums for a patch reaching beyond the padding: per-pixel clamped sampling.
    #[cold]
    #[allow(clippy::needless_range_loop)] // `c` indexes four accumulators and three tables
    fn sums_clamped(&self, i1: &PaddedPlane, px: f32, py: f32) -> [f32; 4] {
        let mut acc = [[0.0f32; PS]; 4];
        for r in 0..PS {
            for c in 0..PS {
                let at = r * self.stride + c;
                let p = i1.sample(px + c as f32, py + r as f32);
                let d = p - self.t[at];
                acc[0][c] += d;
                acc[1][c] += d * d;
                acc[2][c] += self.gx[at] * d;
                acc[3][c] += self.gy[at] * d;
            }
        }
        acc.map(|lanes| lane_sum(&lanes))
    }

    /// Picks the best of the candidates, then runs Gauss–Newton steps from it while the
    /// cost keeps falling (halving a step that overshoots), never moving further than one
    /// patch size from the chosen start.
    #[inline(always)]
    fn refine<const WIDE: bool>(
        &self,
        i1: &PaddedPlane,
        candidates: &[Option<[f32; 2]>],
        iterations: usize,
        mean_normalization: bool,
    ) -> [f32; 2] {
        let mut best: Option<([f32; 2], Evaluation)> = None;
        for cand in candidates.iter().flatten() {
            let e = self.evaluate::<WIDE>(i1, *cand, mean_normalization);
            if best.is_none_or(|(_, b)| e.ssd < b.ssd) {
                best = Some((*cand, e));
            }
        }
        let Some((start, mut eval)) = best else {
            return [0.0, 0.0];
        };
        let mut u = start;
        let limit_sq = (PS * PS) as f32;
        'outer: for _ in 0..iterations {
            let inv = self.stats.inv;
            let mut step_x = inv[0] * eval.bx + inv[1] * eval.by;
            let mut step_y = inv[1] * eval.bx + inv[2] * eval.by;
            let mut tries = 0;
            loop {
                let next = [u[0] - step_x, u[1] - step_y];
                let (ox, oy) = (next[0] - start[0], next[1] - start[1]);
                let moved_sq = ox * ox + oy * oy;
                // Moving further than a patch from the start is no refinement any more.
                if moved_sq.is_nan() || moved_sq > limit_sq {
                    break 'outer;
                }
                let e = self.evaluate::<WIDE>(i1, next, mean_normalization);
                if e.ssd < eval.ssd {
                    u = next;
                    eval = e;
                    break;
                }
                tries += 1;
                if tries > STEP_HALVINGS {
                    break 'outer;
                }
                step_x *= 0.5;
                step_y *= 0.5;
            }
            if step_x * step_x + step_y * step_y < CONVERGED_STEP_SQ {
                break;
            }
        }
        u
    }
}

/// Sum of lanes in a fixed order. For 8 lanes it is the pairwise tree of the AVX2
/// reduction (`(l0+l4)+(l2+l6)` plus `(l1+l5)+(l3+l7)`), so both paths round alike.
#[inline(always)]
fn lane_sum<const N: usize>(lanes: &[f32; N]) -> f32 {
    if N == 8 {
        let q: [f32; 4] = std::array::from_fn(|i| lanes[i] + lanes[i + 4]);
        (q[0] + q[2]) + (q[1] + q[3])
    } else {
        lanes.iter().sum()
    }
}

/// Runs both passes on the grid and returns one vector per patch (row-major).
///
/// `initial` holds one starting vector per patch.
pub(crate) fn search(
    input: &SearchInput,
    initial: Vec<[f32; 2]>,
    settings: SearchSettings,
) -> Vec<[f32; 2]> {
    match input.grid.patch_size {
        4 => search_sized::<4>(input, initial, settings),
        8 => search_sized::<8>(input, initial, settings),
        12 => search_sized::<12>(input, initial, settings),
        _ => search_sized::<16>(input, initial, settings),
    }
}

fn search_sized<const PS: usize>(
    input: &SearchInput,
    initial: Vec<[f32; 2]>,
    settings: SearchSettings,
) -> Vec<[f32; 2]> {
    let stats = patch_stats::<PS>(input, settings.mean_normalization);
    let after_forward = run_pass::<PS>(input, &stats, &initial, settings, Direction::Forward);
    run_pass::<PS>(input, &stats, &after_forward, settings, Direction::Backward)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Direction {
    Forward,
    Backward,
}

/// Everything one pass shares between its stripes.
struct Pass<'a> {
    input: &'a SearchInput<'a>,
    /// Per-patch constants.
    stats: &'a [PatchStats],
    /// Vectors at the start of the pass (read for neighbours in other stripes).
    start: &'a [[f32; 2]],
    settings: SearchSettings,
    direction: Direction,
    rows_per_stripe: usize,
}

fn run_pass<const PS: usize>(
    input: &SearchInput,
    stats: &[PatchStats],
    start: &[[f32; 2]],
    settings: SearchSettings,
    direction: Direction,
) -> Vec<[f32; 2]> {
    let grid = input.grid;
    let mut out = start.to_vec();
    let pass = Pass {
        input,
        stats,
        start,
        settings,
        direction,
        rows_per_stripe: grid.rows().div_ceil(STRIPES).max(1),
    };
    let wide = simd::wide_vectors_available();
    out.par_chunks_mut(pass.rows_per_stripe * grid.cols())
        .enumerate()
        .for_each(|(stripe, block)| {
            if wide {
                // SAFETY: `wide_vectors_available` confirmed AVX2 on this CPU.
                #[cfg(target_arch = "x86_64")]
                unsafe {
                    process_stripe_avx2::<PS>(&pass, stripe, block)
                }
            } else {
                process_stripe::<PS, false>(&pass, stripe, block);
            }
        });
    out
}

/// [`process_stripe`] compiled for AVX2: one 8-wide vector per patch row.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn process_stripe_avx2<const PS: usize>(pass: &Pass, stripe: usize, block: &mut [[f32; 2]]) {
    process_stripe::<PS, true>(pass, stripe, block);
}

/// Searches every patch of one stripe in the pass's raster order.
#[inline(always)]
fn process_stripe<const PS: usize, const WIDE: bool>(
    pass: &Pass,
    stripe: usize,
    block: &mut [[f32; 2]],
) {
    let input = pass.input;
    let grid = input.grid;
    let (rows, cols) = (grid.rows(), grid.cols());
    let settings = pass.settings;
    let first_row = stripe * pass.rows_per_stripe;
    let block_rows = block.len() / cols;
    let forward = pass.direction == Direction::Forward;
    let iterations = if forward {
        settings.forward_iterations
    } else {
        settings.backward_iterations
    };
    for local_step in 0..block_rows {
        let local = if forward {
            local_step
        } else {
            block_rows - 1 - local_step
        };
        let row = first_row + local;
        for col_step in 0..cols {
            let col = if forward {
                col_step
            } else {
                cols - 1 - col_step
            };
            let mut candidates: [Option<[f32; 2]>; 4] = [None; 4];
            candidates[0] = Some(block[local * cols + col]);
            if settings.spatial_propagation {
                let (side_col, side_ok, vert_row, vert_ok) = if forward {
                    (col.wrapping_sub(1), col > 0, row.wrapping_sub(1), row > 0)
                } else {
                    (col + 1, col + 1 < cols, row + 1, row + 1 < rows)
                };
                if side_ok {
                    candidates[1] = Some(block[local * cols + side_col]);
                }
                if vert_ok {
                    let in_stripe = vert_row >= first_row && vert_row < first_row + block_rows;
                    candidates[2] = Some(if in_stripe {
                        block[(vert_row - first_row) * cols + col]
                    } else {
                        pass.start[vert_row * cols + col]
                    });
                }
            }
            if forward {
                candidates[3] = input.temporal.and_then(|t| t[row * cols + col]);
            }
            let template = Template::<PS>::new(
                input,
                grid.xs[col],
                grid.ys[row],
                pass.stats[row * cols + col],
            );
            block[local * cols + col] = template.refine::<WIDE>(
                input.i1,
                &candidates,
                iterations,
                settings.mean_normalization,
            );
        }
    }
}

/// The AVX2 kernel for 8×8 patches: one 256-bit vector per patch row.
#[cfg(target_arch = "x86_64")]
mod patch8 {
    use std::arch::x86_64::{
        __m256, _mm_add_ps, _mm_add_ss, _mm_cvtss_f32, _mm_movehl_ps, _mm_shuffle_ps,
        _mm256_add_ps, _mm256_castps256_ps128, _mm256_extractf128_ps, _mm256_loadu_ps,
        _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps, _mm256_sub_ps,
    };

    /// Template, x-gradient and y-gradient of one patch from its origin, rows `stride`
    /// apart.
    pub(super) struct Tables<'a> {
        pub t: &'a [f32],
        pub gx: &'a [f32],
        pub gy: &'a [f32],
        pub stride: usize,
    }

    /// Loads 8 values starting at `slice[at]`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(slice: &[f32], at: usize) -> __m256 {
        let eight: &[f32; 8] = slice[at..at + 8]
            .try_into()
            .expect("a range of 8 is 8 long");
        // SAFETY: `eight` is a valid, initialised array of 8 floats; loadu has no alignment
        // requirement.
        unsafe { _mm256_loadu_ps(eight.as_ptr()) }
    }

    /// Sum of the 8 lanes as `((l0+l4)+(l2+l6)) + ((l1+l5)+(l3+l7))`, the order of the
    /// portable `lane_sum`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn hsum(v: __m256) -> f32 {
        let q = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
        let h = _mm_add_ps(q, _mm_movehl_ps(q, q));
        _mm_cvtss_f32(_mm_add_ss(h, _mm_shuffle_ps::<0b01>(h, h)))
    }

    /// `[Σd, Σd², Σgx·d, Σgy·d]` with `d = bilinear sample − template`, exactly as the
    /// portable `sums_bilinear` computes them.
    ///
    /// `window` starts at the top-left sample and holds 9 rows `stride` apart, 9 values each.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn sums_avx2(
        window: &[f32],
        stride: usize,
        weights: [f32; 4],
        tables: Tables,
    ) -> [f32; 4] {
        let [w00, w01, w10, w11] = weights.map(|w| _mm256_set1_ps(w));
        let mut acc = [_mm256_setzero_ps(); 4];
        let mut top = load(window, 0);
        let mut top_next = load(window, 1);
        for r in 0..8 {
            let bottom = load(window, (r + 1) * stride);
            let bottom_next = load(window, (r + 1) * stride + 1);
            let p = _mm256_add_ps(
                _mm256_add_ps(
                    _mm256_add_ps(_mm256_mul_ps(w00, top), _mm256_mul_ps(w01, top_next)),
                    _mm256_mul_ps(w10, bottom),
                ),
                _mm256_mul_ps(w11, bottom_next),
            );
            let at = r * tables.stride;
            let d = _mm256_sub_ps(p, load(tables.t, at));
            acc[0] = _mm256_add_ps(acc[0], d);
            acc[1] = _mm256_add_ps(acc[1], _mm256_mul_ps(d, d));
            acc[2] = _mm256_add_ps(acc[2], _mm256_mul_ps(load(tables.gx, at), d));
            acc[3] = _mm256_add_ps(acc[3], _mm256_mul_ps(load(tables.gy, at), d));
            top = bottom;
            top_next = bottom_next;
        }
        acc.map(|v| hsum(v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth but rich texture: sums of sines at several frequencies and orientations.
    fn texture(x: f32, y: f32) -> f32 {
        128.0
            + 40.0 * (0.21 * x + 0.13 * y).sin()
            + 30.0 * (0.17 * y - 0.09 * x).cos()
            + 20.0 * (0.29 * x + 0.23 * y).sin()
    }

    fn shifted_pair(w: usize, h: usize, shift: [f32; 2]) -> (Plane, Plane) {
        let a = (0..h)
            .flat_map(|y| (0..w).map(move |x| texture(x as f32, y as f32)))
            .collect();
        let b = (0..h)
            .flat_map(|y| (0..w).map(move |x| texture(x as f32 - shift[0], y as f32 - shift[1])))
            .collect();
        (Plane::from_vec(w, h, a), Plane::from_vec(w, h, b))
    }

    #[test]
    fn finds_a_subpixel_shift_from_zero() {
        let (i0, i1) = shifted_pair(48, 40, [1.3, -0.7]);
        let (gx, gy) = i0.sobel_gradients();
        let padded = PaddedPlane::new(&i1, 16);
        let grid = PatchGrid::new(48, 40, 8, 4);
        let input = SearchInput {
            i0: &i0,
            gx: &gx,
            gy: &gy,
            i1: &padded,
            grid: &grid,
            temporal: None,
        };
        let settings = SearchSettings {
            forward_iterations: 8,
            backward_iterations: 8,
            mean_normalization: true,
            spatial_propagation: true,
        };
        let flow = search(&input, vec![[0.0, 0.0]; grid.len()], settings);
        // Border patches see replicated pixels where the texture moved out of view. The
        // tolerance covers the bias of bilinear sampling, which moves the SSD minimum of this
        // texture by up to ~0.06 px.
        for (i, u) in flow.iter().enumerate() {
            let (row, col) = (i / grid.cols(), i % grid.cols());
            if row == 0 || col == 0 || row + 1 == grid.rows() || col + 1 == grid.cols() {
                continue;
            }
            assert!(
                (u[0] - 1.3).abs() < 0.1 && (u[1] + 0.7).abs() < 0.1,
                "patch ({row}, {col}): {u:?}"
            );
        }
    }

    #[test]
    fn wide_and_portable_kernels_agree_bit_for_bit() {
        let (i0, i1) = shifted_pair(40, 36, [0.6, -1.3]);
        let (gx, gy) = i0.sobel_gradients();
        let padded = PaddedPlane::new(&i1, 16);
        let grid = PatchGrid::new(40, 36, 8, 4);
        let input = SearchInput {
            i0: &i0,
            gx: &gx,
            gy: &gy,
            i1: &padded,
            grid: &grid,
            temporal: None,
        };
        let stats = patch_stats::<8>(&input, true);
        let index = grid.ys.iter().position(|&y| y == 8).unwrap() * grid.cols()
            + grid.xs.iter().position(|&x| x == 12).unwrap();
        let template = Template::<8>::new(&input, 12, 8, stats[index]);
        for u in [[0.0, 0.0], [0.37, -1.21], [-3.9, 2.45], [30.0, -25.0]] {
            let portable = template.evaluate::<false>(&padded, u, true);
            if simd::wide_vectors_available() {
                // `evaluate::<true>` needs AVX2, checked just above.
                let wide = template.evaluate::<true>(&padded, u, true);
                assert_eq!(portable.ssd.to_bits(), wide.ssd.to_bits(), "{u:?}");
                assert_eq!(portable.bx.to_bits(), wide.bx.to_bits(), "{u:?}");
                assert_eq!(portable.by.to_bits(), wide.by.to_bits(), "{u:?}");
            }
            assert!(portable.ssd.is_finite());
        }
    }
}
