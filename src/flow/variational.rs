//! Variational refinement of a dense flow (the DeepFlow energy, as used by DIS).
//!
//! Minimises, for an increment `(du, dv)` on top of the current flow `(U, V)`,
//!
//! ```text
//! E = ∫ δ Ψ(θ₀ (I_z + I_x du + I_y dv)²)
//!     + γ Ψ(θ_x (I_xz + I_xx du + I_xy dv)² + θ_y (I_yz + I_xy du + I_yy dv)²)
//!     + α Ψ(|∇(U + du)|² + |∇(V + dv)|²)
//! ```
//!
//! with `Ψ(s²) = √(s² + ε²)` and the normalisations `θ₀ = 1 / (|∇I|² + ζ²)`,
//! `θ_x = 1 / (|∇I_x|² + ζ²)`, `θ_y = 1 / (|∇I_y|² + ζ²)`. The second frame is warped once by
//! the current flow; each fixed-point iteration freezes the robust weights `Ψ'` at the
//! current increment, and the resulting linear system is relaxed by red-black successive
//! over-relaxation. Pixels of one colour only depend on pixels of the other, so rows of a
//! colour update in parallel with the same result for any thread count. Both colours are
//! stored apart ("checkerboard split") so that a row's neighbours are contiguous.

use rayon::prelude::*;

use super::densify::DenseFlow;
use super::plane::{PaddedPlane, Plane};
use super::simd;

/// ε² of the robust penaliser (ε = 0.001).
const EPSILON_SQ: f32 = 1e-6;
/// ζ² of the data-term normalisation, for intensities in grey levels (ζ = 3). DeepFlow
/// and OpenCV use ζ = 0.1; on 0–255 images that lets sensor noise in flat regions drive the
/// flow, and on the synthetic benchmark ζ = 3 lowers the vehicle-patch EPE of the `quality`
/// preset by 10 % at equal all-pixel EPE.
const ZETA_SQ: f32 = 9.0;

/// Refinement settings derived from the DIS parameters.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RefineSettings {
    pub fixed_point_iterations: usize,
    pub sor_iterations: usize,
    pub omega: f32,
    pub alpha: f32,
    pub gamma: f32,
    pub delta: f32,
}

/// Fields of the data-term storage: image derivatives after warping. They are zero where
/// the flow points out of the frame, which removes the data term there (every data
/// coefficient is a product of derivatives).
const IX: usize = 0;
const IY: usize = 1;
const IZ: usize = 2;
const IXX: usize = 3;
const IXY: usize = 4;
const IYY: usize = 5;
const IXZ: usize = 6;
const IYZ: usize = 7;
const TERM_FIELDS: usize = 8;

/// Fields of the flow storage: the flow being refined and the increment.
const U: usize = 0;
const V: usize = 1;
const DU: usize = 2;
const DV: usize = 3;
const FLOW_FIELDS: usize = 4;

/// Fields of the smoothness storage: robust weight of the edge to the right neighbour and to
/// the lower neighbour (zero where there is none).
const W_EAST: usize = 0;
const W_SOUTH: usize = 1;
const SMOOTH_FIELDS: usize = 2;

/// Fields of the per-pixel SOR system (the edge weights are read from the smoothness
/// storage).
const A12: usize = 0;
const C1: usize = 1;
const C2: usize = 2;
const INV_D1: usize = 3;
const INV_D2: usize = 4;
const COEF_FIELDS: usize = 5;

/// Per-pixel values of a `width × height` grid split by checkerboard colour
/// (`(x + y) % 2`). Each colour holds `height + 2` row blocks (one zero pad row above and
/// below); a row block holds `fields` slices of `stride = ⌈width / 2⌉ + 2` values, pixel `x`
/// at slot `x / 2 + 1`. Slots outside the image stay zero, so that neighbours beyond the
/// border read as zero.
///
/// For pixel slot `k` of colour `c` in row `y`, with `shift = (y + c) % 2`, the neighbours
/// (all of the other colour) are: left at slot `k − 1 + shift`, right at `k + shift`, up and
/// down at slot `k` of rows `y − 1` and `y + 1`.
struct Checker {
    width: usize,
    height: usize,
    stride: usize,
    fields: usize,
    colours: [Vec<f32>; 2],
}

impl Checker {
    fn new(width: usize, height: usize, fields: usize) -> Self {
        let stride = width.div_ceil(2) + 2;
        let len = (height + 2) * fields * stride;
        Self {
            width,
            height,
            stride,
            fields,
            colours: [vec![0.0; len], vec![0.0; len]],
        }
    }

    fn block(&self) -> usize {
        self.fields * self.stride
    }

    /// Row block of colour `c` for image row `y` (`y = -1` and `y = height` are the pads).
    fn row(&self, c: usize, y: isize) -> &[f32] {
        let b = self.block();
        let start = (y + 1) as usize * b;
        &self.colours[c][start..start + b]
    }

    /// Number of pixels of colour `c` in row `y`.
    fn count(&self, c: usize, y: usize) -> usize {
        (self.width - shift(c, y)).div_ceil(2)
    }

    /// Mutable row blocks of colour `c` for image rows `0..height`, in parallel.
    fn rows_mut(&mut self, c: usize) -> impl IndexedParallelIterator<Item = (usize, &mut [f32])> {
        let (b, h) = (self.block(), self.height);
        self.colours[c]
            .par_chunks_mut(b)
            .skip(1)
            .take(h)
            .enumerate()
    }
}

/// Column of the first pixel of colour `c` in row `y`.
#[inline]
fn shift(c: usize, y: usize) -> usize {
    (y + c) & 1
}

/// Field `f` of a row block.
#[inline]
fn field(block: &[f32], stride: usize, f: usize) -> &[f32] {
    &block[f * stride..(f + 1) * stride]
}

/// The `n` values of field `f` of a row block starting at slot `off`.
#[inline(always)]
fn span(block: &[f32], stride: usize, f: usize, off: usize, n: usize) -> &[f32] {
    &block[f * stride + off..f * stride + off + n]
}

/// Refines `flow` in place on the level images `i0` and `i1`.
pub(crate) fn refine(i0: &Plane, i1: &PaddedPlane, flow: &mut DenseFlow, s: &RefineSettings) {
    let (w, h) = (i0.width, i0.height);
    if s.fixed_point_iterations == 0 || w < 2 || h < 2 {
        return;
    }
    let terms = data_terms(i0, i1, flow);
    let mut state = Checker::new(w, h, FLOW_FIELDS);
    for c in 0..2 {
        split_into(&mut state, c, &[(U, &flow.u), (V, &flow.v)]);
    }
    let mut smooth = Checker::new(w, h, SMOOTH_FIELDS);
    let mut coefficients = Checker::new(w, h, COEF_FIELDS);
    for _ in 0..s.fixed_point_iterations {
        for c in 0..2 {
            smoothness_weights(&state, c, s.alpha, &mut smooth);
        }
        for c in 0..2 {
            sor_coefficients(
                &terms,
                &state,
                &smooth,
                c,
                (s.delta, s.gamma),
                &mut coefficients,
            );
        }
        for _ in 0..s.sor_iterations {
            for c in 0..2 {
                sor_sweep(&mut state, &coefficients, &smooth, c, s.omega);
            }
        }
    }
    add_increment(&state, flow);
}

/// Copies full-layout planes into fields of colour `c`.
fn split_into(out: &mut Checker, c: usize, planes: &[(usize, &Plane)]) {
    let stride = out.stride;
    let w = out.width;
    out.rows_mut(c).for_each(|(y, block)| {
        let first = shift(c, y);
        for &(f, plane) in planes {
            let dst = &mut block[f * stride..(f + 1) * stride];
            let src = plane.row(y);
            for (slot, x) in (first..w).step_by(2).enumerate() {
                dst[slot + 1] = src[x];
            }
        }
    });
}

/// Adds the increment to the full-layout flow.
fn add_increment(state: &Checker, flow: &mut DenseFlow) {
    let (w, stride) = (state.width, state.stride);
    flow.u
        .data
        .par_chunks_mut(w)
        .zip(flow.v.data.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (u_row, v_row))| {
            for c in 0..2 {
                let block = state.row(c, y as isize);
                let (du, dv) = (field(block, stride, DU), field(block, stride, DV));
                for (slot, x) in (shift(c, y)..w).step_by(2).enumerate() {
                    u_row[x] += du[slot + 1];
                    v_row[x] += dv[slot + 1];
                }
            }
        });
}

/// Horizontal and vertical derivatives with the five-point stencil
/// `(f(x−2) − 8 f(x−1) + 8 f(x+1) − f(x+2)) / 12`, replicating the border.
fn gradients_5pt(p: &Plane) -> (Plane, Plane) {
    let (w, h) = (p.width, p.height);
    let mut gx = Plane::zeros(w, h);
    let mut gy = Plane::zeros(w, h);
    let wide = simd::wide_vectors_available();
    gx.data
        .par_chunks_mut(w)
        .zip(gy.data.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (gx_row, gy_row))| {
            #[cfg(target_arch = "x86_64")]
            if wide {
                // SAFETY: `wide_vectors_available` confirmed AVX2 on this CPU.
                return unsafe { gradient_row_avx2(p, y, gx_row, gy_row) };
            }
            gradient_row(p, y, gx_row, gy_row);
        });
    (gx, gy)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn gradient_row_avx2(p: &Plane, y: usize, gx: &mut [f32], gy: &mut [f32]) {
    gradient_row(p, y, gx, gy);
}

/// Row `y` of [`gradients_5pt`].
#[inline(always)]
fn gradient_row(p: &Plane, y: usize, gx: &mut [f32], gy: &mut [f32]) {
    const K: f32 = 1.0 / 12.0;
    let (w, h) = (p.width, p.height);
    let r = |d: isize| p.row((y as isize + d).clamp(0, h as isize - 1) as usize);
    let (m2, m1, p1, p2) = (r(-2), r(-1), r(1), r(2));
    for (x, g) in gy.iter_mut().enumerate() {
        *g = K * ((m2[x] - p2[x]) + 8.0 * (p1[x] - m1[x]));
    }
    let row = p.row(y);
    if w > 4 {
        for (x, g) in gx[2..w - 2].iter_mut().enumerate() {
            // Output x + 2 reads columns x ..= x + 4.
            *g = K * ((row[x] - row[x + 4]) + 8.0 * (row[x + 3] - row[x + 1]));
        }
    }
    let at = |x: isize| row[x.clamp(0, w as isize - 1) as usize];
    for x in (0..w.min(2)).chain(w.saturating_sub(2).max(2)..w) {
        let xi = x as isize;
        gx[x] = K * ((at(xi - 2) - at(xi + 2)) + 8.0 * (at(xi + 1) - at(xi - 1)));
    }
}

/// Warps `i1` by the flow and computes the linearised data terms of every pixel.
fn data_terms(i0: &Plane, i1: &PaddedPlane, flow: &DenseFlow) -> Checker {
    let (w, h) = (i0.width, i0.height);
    let wide = simd::wide_vectors_available();
    let mut warped = Plane::zeros(w, h);
    let mut mask = Plane::zeros(w, h);
    warped
        .data
        .par_chunks_mut(w)
        .zip(mask.data.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (row, mask_row))| {
            #[cfg(target_arch = "x86_64")]
            if wide {
                // SAFETY: `wide_vectors_available` confirmed AVX2 on this CPU.
                return unsafe { warp_row_avx2(i1, flow, y, row, mask_row) };
            }
            warp_row(i1, flow, y, row, mask_row);
        });
    let (i0x, i0y) = gradients_5pt(i0);
    let (i1x, i1y) = gradients_5pt(&warped);
    let first = FirstOrder {
        i0,
        warped: &warped,
        mask: &mask,
        gradients: [&i0x, &i0y, &i1x, &i1y],
    };
    let mut terms = Checker::new(w, h, TERM_FIELDS);
    let block = terms.block();
    let stride = terms.stride;
    let [red, black] = &mut terms.colours;
    red.par_chunks_mut(block)
        .zip(black.par_chunks_mut(block))
        .skip(1)
        .take(h)
        .enumerate()
        .for_each_init(
            || vec![0.0f32; TERM_FIELDS * w],
            |scratch, (y, (red_row, black_row))| {
                let rows = [red_row, black_row];
                #[cfg(target_arch = "x86_64")]
                if wide {
                    // SAFETY: `wide_vectors_available` confirmed AVX2 on this CPU.
                    return unsafe { terms_row_avx2(&first, y, stride, rows, scratch) };
                }
                terms_row(&first, y, stride, rows, scratch);
            },
        );
    terms
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn warp_row_avx2(
    i1: &PaddedPlane,
    flow: &DenseFlow,
    y: usize,
    out: &mut [f32],
    mask: &mut [f32],
) {
    warp_row(i1, flow, y, out, mask);
}

/// Row `y` of the second frame warped back by the flow, and whether each pixel's target
/// lies inside the frame.
#[inline(always)]
fn warp_row(i1: &PaddedPlane, flow: &DenseFlow, y: usize, out: &mut [f32], mask: &mut [f32]) {
    let (w, h) = (flow.width(), flow.height());
    let (max_x, max_y) = ((w - 1) as f32, (h - 1) as f32);
    let (u, v) = (flow.u.row(y), flow.v.row(y));
    for x in 0..w {
        let px = x as f32 + u[x];
        let py = y as f32 + v[x];
        out[x] = i1.sample(px, py);
        let inside = px >= 0.0 && py >= 0.0 && px <= max_x && py <= max_y;
        mask[x] = if inside { 1.0 } else { 0.0 };
    }
}

/// First-order quantities of a level, full layout.
struct FirstOrder<'a> {
    i0: &'a Plane,
    warped: &'a Plane,
    mask: &'a Plane,
    /// x- and y-derivatives of `i0`, then of `warped`.
    gradients: [&'a Plane; 4],
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn terms_row_avx2(
    first: &FirstOrder,
    y: usize,
    stride: usize,
    rows: [&mut [f32]; 2],
    scratch: &mut [f32],
) {
    terms_row(first, y, stride, rows, scratch);
}

/// Row `y` of every data-term field, computed in full layout in `scratch` (`TERM_FIELDS`
/// rows of the image width) and then split into both colours' row blocks.
#[inline(always)]
fn terms_row(
    first: &FirstOrder,
    y: usize,
    stride: usize,
    rows: [&mut [f32]; 2],
    scratch: &mut [f32],
) {
    let (w, h) = (first.i0.width, first.i0.height);
    let (up, down) = (y.saturating_sub(1), (y + 1).min(h - 1));
    let [i0x, i0y, i1x, i1y] = first.gradients;
    let (mask, warped, i0) = (first.mask.row(y), first.warped.row(y), first.i0.row(y));
    let mut fields = scratch.chunks_exact_mut(w);
    let mut next = || fields.next().expect("scratch holds every field");
    let (fix, fiy, fiz, fixx) = (next(), next(), next(), next());
    let (fixy, fiyy, fixz, fiyz) = (next(), next(), next(), next());
    // Derivatives of both frames are averaged (I_x, I_y); the gradient-constancy terms use
    // their central differences, replicating the border.
    let (a, b, c, d) = (i0x.row(y), i1x.row(y), i0y.row(y), i1y.row(y));
    for x in 0..w {
        fix[x] = 0.5 * (a[x] + b[x]);
        fiy[x] = 0.5 * (c[x] + d[x]);
        fiz[x] = warped[x] - i0[x];
        fixz[x] = b[x] - a[x];
        fiyz[x] = d[x] - c[x];
    }
    let (ix_up, ix_down) = ((i0x.row(up), i1x.row(up)), (i0x.row(down), i1x.row(down)));
    let (iy_up, iy_down) = ((i0y.row(up), i1y.row(up)), (i0y.row(down), i1y.row(down)));
    for x in 0..w {
        let (l, r) = (x.saturating_sub(1), (x + 1).min(w - 1));
        let d_ix_dy = 0.25 * ((ix_down.0[x] + ix_down.1[x]) - (ix_up.0[x] + ix_up.1[x]));
        let d_iy_dy = 0.25 * ((iy_down.0[x] + iy_down.1[x]) - (iy_up.0[x] + iy_up.1[x]));
        fixx[x] = 0.5 * (fix[r] - fix[l]);
        // I_xy averages d(I_x)/dy and d(I_y)/dx.
        fixy[x] = 0.5 * (d_ix_dy + 0.5 * (fiy[r] - fiy[l]));
        fiyy[x] = d_iy_dy;
    }
    for (c, row) in rows.into_iter().enumerate() {
        let first_x = shift(c, y);
        for (f, values) in scratch.chunks_exact(w).enumerate() {
            let dst = &mut row[f * stride + 1..(f + 1) * stride];
            for (dst, (v, m)) in dst
                .iter_mut()
                .zip(values[first_x..].iter().zip(&mask[first_x..]).step_by(2))
            {
                *dst = v * m;
            }
        }
    }
}

/// Robust smoothness weights `α Ψ'(|∇(U + du)|² + |∇(V + dv)|²)` of colour `c`, from
/// forward differences, stored as the weights of each pixel's east and south edges.
fn smoothness_weights(state: &Checker, c: usize, alpha: f32, out: &mut Checker) {
    let wide = simd::wide_vectors_available();
    out.rows_mut(c).for_each(|(y, block)| {
        let job = SmoothRow { state, c, y, alpha };
        #[cfg(target_arch = "x86_64")]
        if wide {
            // SAFETY: `wide_vectors_available` confirmed AVX2 on this CPU.
            return unsafe { smoothness_row_avx2(&job, block) };
        }
        smoothness_row(&job, block);
    });
}

/// One row of [`smoothness_weights`].
struct SmoothRow<'a> {
    state: &'a Checker,
    c: usize,
    y: usize,
    alpha: f32,
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn smoothness_row_avx2(job: &SmoothRow, block: &mut [f32]) {
    smoothness_row(job, block);
}

#[inline(always)]
fn smoothness_row(job: &SmoothRow, block: &mut [f32]) {
    let SmoothRow { state, c, y, alpha } = *job;
    let (w, h, stride) = (state.width, state.height, state.stride);
    let o = 1 - c;
    let sh = shift(c, y);
    let n = state.count(c, y);
    let own = state.row(c, y as isize);
    let same = state.row(o, y as isize);
    let below = state.row(o, y as isize + 1);
    let (u, du, v, dv) = (
        span(own, stride, U, 1, n),
        span(own, stride, DU, 1, n),
        span(own, stride, V, 1, n),
        span(own, stride, DV, 1, n),
    );
    let (u_e, du_e) = (
        span(same, stride, U, 1 + sh, n),
        span(same, stride, DU, 1 + sh, n),
    );
    let (v_e, dv_e) = (
        span(same, stride, V, 1 + sh, n),
        span(same, stride, DV, 1 + sh, n),
    );
    let (u_s, du_s, v_s, dv_s) = (
        span(below, stride, U, 1, n),
        span(below, stride, DU, 1, n),
        span(below, stride, V, 1, n),
        span(below, stride, DV, 1, n),
    );
    // No lower neighbour in the last row: its vertical differences count as zero.
    let has_south = if y + 1 < h { 1.0 } else { 0.0 };
    let (w_east, w_south) = block.split_at_mut(stride);
    let (w_east, w_south) = (&mut w_east[1..=n], &mut w_south[1..=n]);
    for i in 0..n {
        let (tu, tv) = (u[i] + du[i], v[i] + dv[i]);
        let ux = (u_e[i] + du_e[i]) - tu;
        let vx = (v_e[i] + dv_e[i]) - tv;
        let uy = has_south * ((u_s[i] + du_s[i]) - tu);
        let vy = has_south * ((v_s[i] + dv_s[i]) - tv);
        let weight = alpha / (ux * ux + vx * vx + uy * uy + vy * vy + EPSILON_SQ).sqrt();
        w_east[i] = weight;
        w_south[i] = has_south * weight;
    }
    // The last pixel of the row may sit in the last column: no east neighbour.
    if n > 0 && sh + 2 * (n - 1) == w - 1 {
        let i = n - 1;
        let (tu, tv) = (u[i] + du[i], v[i] + dv[i]);
        let uy = has_south * ((u_s[i] + du_s[i]) - tu);
        let vy = has_south * ((v_s[i] + dv_s[i]) - tv);
        w_east[i] = 0.0;
        w_south[i] = has_south * alpha / (uy * uy + vy * vy + EPSILON_SQ).sqrt();
    }
}

/// Freezes the robust data weights at the current increment and writes, for colour `c`,
/// the per-pixel system `[A11 + Σw, A12; A12, A22 + Σw] (du, dv) = (C1, C2) + Σ w_n
/// (du_n, dv_n)`.
fn sor_coefficients(
    terms: &Checker,
    state: &Checker,
    smooth: &Checker,
    c: usize,
    weights: (f32, f32),
    out: &mut Checker,
) {
    let wide = simd::wide_vectors_available();
    out.rows_mut(c).for_each(|(y, block)| {
        let job = CoefRow {
            terms,
            state,
            smooth,
            c,
            y,
            weights,
        };
        #[cfg(target_arch = "x86_64")]
        if wide {
            // SAFETY: `wide_vectors_available` confirmed AVX2 on this CPU.
            return unsafe { coefficients_row_avx2(&job, block) };
        }
        coefficients_row(&job, block);
    });
}

/// One row of [`sor_coefficients`].
struct CoefRow<'a> {
    terms: &'a Checker,
    state: &'a Checker,
    smooth: &'a Checker,
    c: usize,
    y: usize,
    weights: (f32, f32),
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn coefficients_row_avx2(job: &CoefRow, block: &mut [f32]) {
    coefficients_row(job, block);
}

#[inline(always)]
fn coefficients_row(job: &CoefRow, block: &mut [f32]) {
    let CoefRow {
        terms,
        state,
        smooth,
        c,
        y,
        weights: (delta, gamma),
    } = *job;
    let stride = state.stride;
    let o = 1 - c;
    let yi = y as isize;
    let sh = shift(c, y);
    let n = state.count(c, y);
    let mut out = block.chunks_exact_mut(stride).map(|f| &mut f[1..=n]);
    let mut next = || out.next().expect("a block holds every field");
    let (a12_o, c1_o, c2_o, d1_o, d2_o) = (next(), next(), next(), next(), next());

    let t = terms.row(c, yi);
    let own = state.row(c, yi);
    let term = |f: usize| span(t, stride, f, 1, n);
    let (ix, iy, iz) = (term(IX), term(IY), term(IZ));
    let (ixx, ixy, iyy, ixz, iyz) = (term(IXX), term(IXY), term(IYY), term(IXZ), term(IYZ));
    let (du, dv) = (span(own, stride, DU, 1, n), span(own, stride, DV, 1, n));
    let (same, above, below) = (state.row(o, yi), state.row(o, yi - 1), state.row(o, yi + 1));
    let (u, v) = (span(own, stride, U, 1, n), span(own, stride, V, 1, n));
    let (u_w, v_w) = (span(same, stride, U, sh, n), span(same, stride, V, sh, n));
    let (u_e, v_e) = (
        span(same, stride, U, 1 + sh, n),
        span(same, stride, V, 1 + sh, n),
    );
    let (u_n, v_n) = (span(above, stride, U, 1, n), span(above, stride, V, 1, n));
    let (u_s, v_s) = (span(below, stride, U, 1, n), span(below, stride, V, 1, n));
    let own_w = smooth.row(c, yi);
    let (w_e, w_s) = (
        span(own_w, stride, W_EAST, 1, n),
        span(own_w, stride, W_SOUTH, 1, n),
    );
    let w_w = span(smooth.row(o, yi), stride, W_EAST, sh, n);
    let w_n = span(smooth.row(o, yi - 1), stride, W_SOUTH, 1, n);

    // Eight pixels at a time through local arrays, so that the compiler sees independent
    // lanes and vectorises; the tail goes one by one through the same arithmetic.
    let full = n / LANES * LANES;
    for start in (0..full).step_by(LANES) {
        let ix8 = lanes(ix, start);
        let iy8 = lanes(iy, start);
        let iz8 = lanes(iz, start);
        let ixx8 = lanes(ixx, start);
        let ixy8 = lanes(ixy, start);
        let iyy8 = lanes(iyy, start);
        let ixz8 = lanes(ixz, start);
        let iyz8 = lanes(iyz, start);
        let du8 = lanes(du, start);
        let dv8 = lanes(dv, start);
        let u8 = lanes(u, start);
        let v8 = lanes(v, start);
        let u_w8 = lanes(u_w, start);
        let v_w8 = lanes(v_w, start);
        let u_e8 = lanes(u_e, start);
        let v_e8 = lanes(v_e, start);
        let u_n8 = lanes(u_n, start);
        let v_n8 = lanes(v_n, start);
        let u_s8 = lanes(u_s, start);
        let v_s8 = lanes(v_s, start);
        let w_e8 = lanes(w_e, start);
        let w_w8 = lanes(w_w, start);
        let w_s8 = lanes(w_s, start);
        let w_n8 = lanes(w_n, start);
        let mut out = [[0.0f32; LANES]; COEF_FIELDS];
        for l in 0..LANES {
            let r = pixel_system(
                [
                    ix8[l], iy8[l], iz8[l], ixx8[l], ixy8[l], iyy8[l], ixz8[l], iyz8[l], du8[l],
                    dv8[l],
                ],
                [
                    u8[l], v8[l], u_w8[l], v_w8[l], u_e8[l], v_e8[l], u_n8[l], v_n8[l], u_s8[l],
                    v_s8[l], w_e8[l], w_w8[l], w_s8[l], w_n8[l],
                ],
                delta,
                gamma,
            );
            for f in 0..COEF_FIELDS {
                out[f][l] = r[f];
            }
        }
        a12_o[start..start + LANES].copy_from_slice(&out[0]);
        c1_o[start..start + LANES].copy_from_slice(&out[1]);
        c2_o[start..start + LANES].copy_from_slice(&out[2]);
        d1_o[start..start + LANES].copy_from_slice(&out[3]);
        d2_o[start..start + LANES].copy_from_slice(&out[4]);
    }
    for i in full..n {
        let r = pixel_system(
            [
                ix[i], iy[i], iz[i], ixx[i], ixy[i], iyy[i], ixz[i], iyz[i], du[i], dv[i],
            ],
            [
                u[i], v[i], u_w[i], v_w[i], u_e[i], v_e[i], u_n[i], v_n[i], u_s[i], v_s[i], w_e[i],
                w_w[i], w_s[i], w_n[i],
            ],
            delta,
            gamma,
        );
        a12_o[i] = r[0];
        c1_o[i] = r[1];
        c2_o[i] = r[2];
        d1_o[i] = r[3];
        d2_o[i] = r[4];
    }
}

/// Pixels processed together by the lane loops.
const LANES: usize = 8;

/// `LANES` consecutive values of `a` from `start`.
#[inline(always)]
fn lanes(a: &[f32], start: usize) -> [f32; LANES] {
    a[start..start + LANES]
        .try_into()
        .expect("a range of LANES values")
}

/// The SOR system of one pixel, in the order of the coefficient fields.
///
/// `d` = [I_x, I_y, I_z, I_xx, I_xy, I_yy, I_xz, I_yz, du, dv];
/// `m` = [U, V, U_west, V_west, U_east, V_east, U_north, V_north, U_south, V_south,
/// w_east, w_west, w_south, w_north].
#[inline(always)]
fn pixel_system(d: [f32; 10], m: [f32; 14], delta: f32, gamma: f32) -> [f32; COEF_FIELDS] {
    let [ix, iy, iz, ixx, ixy, iyy, ixz, iyz, du, dv] = d;
    let th0 = 1.0 / (ix * ix + iy * iy + ZETA_SQ);
    let thx = 1.0 / (ixx * ixx + ixy * ixy + ZETA_SQ);
    let thy = 1.0 / (ixy * ixy + iyy * iyy + ZETA_SQ);
    let [
        u,
        v,
        u_w,
        v_w,
        u_e,
        v_e,
        u_n,
        v_n,
        u_s,
        v_s,
        w_e,
        w_w,
        w_s,
        w_n,
    ] = m;
    // Data terms with the robust weights frozen at the current increment.
    let rz = iz + ix * du + iy * dv;
    let psi_b = delta * th0 / (th0 * rz * rz + EPSILON_SQ).sqrt();
    let rx = ixz + ixx * du + ixy * dv;
    let ry = iyz + ixy * du + iyy * dv;
    let psi_g = gamma / (thx * rx * rx + thy * ry * ry + EPSILON_SQ).sqrt();
    let (gx, gy) = (psi_g * thx, psi_g * thy);
    let a11 = psi_b * ix * ix + gx * ixx * ixx + gy * ixy * ixy;
    let a12 = psi_b * ix * iy + gx * ixx * ixy + gy * ixy * iyy;
    let a22 = psi_b * iy * iy + gx * ixy * ixy + gy * iyy * iyy;
    let b1 = psi_b * ix * iz + gx * ixx * ixz + gy * ixy * iyz;
    let b2 = psi_b * iy * iz + gx * ixy * ixz + gy * iyy * iyz;
    // Smoothness: the pull of the neighbours' current flow.
    let su = w_e * (u_e - u) + w_w * (u_w - u) + w_s * (u_s - u) + w_n * (u_n - u);
    let sv = w_e * (v_e - v) + w_w * (v_w - v) + w_s * (v_s - v) + w_n * (v_n - v);
    let sum_w = w_e + w_w + w_s + w_n;
    // Σw > 0 unless α = 0; the floor keeps a pixel without any term at du = 0.
    let inv_d1 = 1.0 / (a11 + sum_w).max(1e-12);
    let inv_d2 = 1.0 / (a22 + sum_w).max(1e-12);
    [a12, su - b1, sv - b2, inv_d1, inv_d2]
}

/// One red-black half sweep: relaxes every pixel of colour `c` from the other colour.
fn sor_sweep(state: &mut Checker, coef: &Checker, smooth: &Checker, c: usize, omega: f32) {
    let wide = simd::wide_vectors_available();
    let (stride, block, h) = (state.stride, state.block(), state.height);
    let counts: Vec<usize> = (0..h).map(|y| state.count(c, y)).collect();
    let (own, other) = {
        let [red, black] = &mut state.colours;
        if c == 0 {
            (red, &*black)
        } else {
            (black, &*red)
        }
    };
    own.par_chunks_mut(block)
        .enumerate()
        .skip(1)
        .take(h)
        .for_each(|(padded_y, own_row)| {
            let y = padded_y - 1;
            let yi = y as isize;
            let job = SorRow {
                other,
                coef: coef.row(c, yi),
                smooth_own: smooth.row(c, yi),
                smooth_same: smooth.row(1 - c, yi),
                smooth_above: smooth.row(1 - c, yi - 1),
                padded_y,
                block,
                stride,
                shift: shift(c, y),
                n: counts[y],
                omega,
            };
            #[cfg(target_arch = "x86_64")]
            if wide {
                // SAFETY: `wide_vectors_available` confirmed AVX2 on this CPU.
                return unsafe { sor_row_avx2(&job, own_row) };
            }
            sor_row(&job, own_row);
        });
}

/// One row of [`sor_sweep`].
struct SorRow<'a> {
    /// All row blocks of the other colour.
    other: &'a [f32],
    /// Coefficient row block of this row.
    coef: &'a [f32],
    /// Smoothness row blocks: this row, the other colour's same row and row above.
    smooth_own: &'a [f32],
    smooth_same: &'a [f32],
    smooth_above: &'a [f32],
    padded_y: usize,
    block: usize,
    stride: usize,
    shift: usize,
    n: usize,
    omega: f32,
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn sor_row_avx2(job: &SorRow, own_row: &mut [f32]) {
    sor_row(job, own_row);
}

#[inline(always)]
fn sor_row(job: &SorRow, own_row: &mut [f32]) {
    let SorRow {
        other,
        coef,
        smooth_own,
        smooth_same,
        smooth_above,
        padded_y,
        block,
        stride,
        shift: sh,
        n,
        omega,
    } = *job;
    let other_row = |dy: usize| &other[(padded_y + dy - 1) * block..(padded_y + dy) * block];
    let (above, same, below) = (other_row(0), other_row(1), other_row(2));
    let (a12, c1, c2) = (
        span(coef, stride, A12, 1, n),
        span(coef, stride, C1, 1, n),
        span(coef, stride, C2, 1, n),
    );
    let (inv_d1, inv_d2) = (
        span(coef, stride, INV_D1, 1, n),
        span(coef, stride, INV_D2, 1, n),
    );
    let (wl, wr) = (
        span(smooth_same, stride, W_EAST, sh, n),
        span(smooth_own, stride, W_EAST, 1, n),
    );
    let (wu, wd) = (
        span(smooth_above, stride, W_SOUTH, 1, n),
        span(smooth_own, stride, W_SOUTH, 1, n),
    );
    let (du_l, dv_l) = (span(same, stride, DU, sh, n), span(same, stride, DV, sh, n));
    let (du_r, dv_r) = (
        span(same, stride, DU, 1 + sh, n),
        span(same, stride, DV, 1 + sh, n),
    );
    let (du_u, dv_u) = (span(above, stride, DU, 1, n), span(above, stride, DV, 1, n));
    let (du_d, dv_d) = (span(below, stride, DU, 1, n), span(below, stride, DV, 1, n));
    let (du, dv) = own_row[DU * stride..(DV + 1) * stride].split_at_mut(stride);
    let (du, dv) = (&mut du[1..=n], &mut dv[1..=n]);
    for i in 0..n {
        let nu = wl[i] * du_l[i] + wr[i] * du_r[i] + wu[i] * du_u[i] + wd[i] * du_d[i];
        let nv = wl[i] * dv_l[i] + wr[i] * dv_r[i] + wu[i] * dv_u[i] + wd[i] * dv_d[i];
        let new_du = du[i] + omega * ((c1[i] + nu - a12[i] * dv[i]) * inv_d1[i] - du[i]);
        du[i] = new_du;
        dv[i] += omega * ((c2[i] + nv - a12[i] * new_du) * inv_d2[i] - dv[i]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(x: f32, y: f32) -> f32 {
        128.0 + 40.0 * (0.21 * x + 0.13 * y).sin() + 30.0 * (0.17 * y - 0.09 * x).cos()
    }

    /// A `w × h` pair where the second frame is the first shifted by `shift`.
    fn pair(w: usize, h: usize, shift: [f32; 2]) -> (Plane, PaddedPlane) {
        let plane = |d: [f32; 2]| {
            Plane::from_vec(
                w,
                h,
                (0..h)
                    .flat_map(|y| (0..w).map(move |x| texture(x as f32 - d[0], y as f32 - d[1])))
                    .collect(),
            )
        };
        (plane([0.0, 0.0]), PaddedPlane::new(&plane(shift), 16))
    }

    fn settings() -> RefineSettings {
        RefineSettings {
            fixed_point_iterations: 5,
            sor_iterations: 5,
            omega: 1.6,
            alpha: 20.0,
            gamma: 10.0,
            delta: 5.0,
        }
    }

    fn mean_error(flow: &DenseFlow, truth: [f32; 2], margin: usize) -> f32 {
        let (w, h) = (flow.width(), flow.height());
        let mut sum = 0.0;
        let mut n = 0.0;
        for y in margin..h - margin {
            for x in margin..w - margin {
                let i = y * w + x;
                sum += (flow.u.data[i] - truth[0]).hypot(flow.v.data[i] - truth[1]);
                n += 1.0;
            }
        }
        sum / n
    }

    #[test]
    fn refinement_removes_pixel_noise_from_the_flow() {
        // Densification leaves pixel-scale errors; a constant offset, in contrast, is left
        // to the coarse-to-fine search (the smoothness term makes it very stiff).
        let truth = [0.8, -0.5];
        let (i0, i1) = pair(37, 29, truth);
        let mut flow = DenseFlow::zeros(37, 29);
        let wobble =
            |i: usize, k: usize| 0.3 * (((i * 7919 + k * 104_729) % 201) as f32 / 100.0 - 1.0);
        for (i, (u, v)) in flow.u.data.iter_mut().zip(&mut flow.v.data).enumerate() {
            *u = truth[0] + wobble(i, 1);
            *v = truth[1] + wobble(i, 2);
        }
        let before = mean_error(&flow, truth, 4);
        refine(&i0, &i1, &mut flow, &settings());
        let after = mean_error(&flow, truth, 4);
        assert!(after < 0.3 * before, "error {before} -> {after}");
        assert!(
            flow.u
                .data
                .iter()
                .chain(&flow.v.data)
                .all(|v| v.is_finite())
        );
    }

    #[test]
    fn the_exact_flow_is_a_fixed_point() {
        let truth = [1.2, 0.4];
        let (i0, i1) = pair(30, 24, truth);
        let mut flow = DenseFlow::zeros(30, 24);
        flow.u.data.fill(truth[0]);
        flow.v.data.fill(truth[1]);
        refine(&i0, &i1, &mut flow, &settings());
        assert!(mean_error(&flow, truth, 4) < 0.02);
    }

    #[test]
    fn constant_images_keep_a_constant_flow_and_stay_finite() {
        let i0 = Plane::from_vec(16, 9, vec![77.0; 144]);
        let i1 = PaddedPlane::new(&i0, 16);
        let mut flow = DenseFlow::zeros(16, 9);
        flow.u.data.fill(0.25);
        refine(&i0, &i1, &mut flow, &settings());
        assert!(flow.u.data.iter().all(|&u| (u - 0.25).abs() < 1e-6));
        assert!(flow.v.data.iter().all(|&v| v.abs() < 1e-6));
    }

    #[test]
    fn checker_split_and_merge_round_trip_every_pixel() {
        for (w, h) in [(5, 4), (6, 3), (9, 7)] {
            let plane = Plane::from_vec(w, h, (0..w * h).map(|i| i as f32).collect());
            let mut state = Checker::new(w, h, FLOW_FIELDS);
            for c in 0..2 {
                split_into(&mut state, c, &[(DU, &plane), (DV, &plane)]);
            }
            let mut flow = DenseFlow::zeros(w, h);
            add_increment(&state, &mut flow);
            assert_eq!(flow.u.data, plane.data, "{w}×{h}");
            assert_eq!(flow.v.data, plane.data, "{w}×{h}");
            // Slots outside the image stay zero.
            for c in 0..2 {
                for y in 0..h {
                    let n = state.count(c, y);
                    let row = state.row(c, y as isize);
                    assert_eq!(span(row, state.stride, DU, 0, 1)[0], 0.0);
                    assert!(
                        row[DU * state.stride + n + 1..DV * state.stride]
                            .iter()
                            .all(|&v| v == 0.0)
                    );
                }
            }
        }
    }
}
