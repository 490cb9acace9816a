//! The DIS estimator: pyramid, coarse-to-fine loop and the public `DisFlow` entry point.

use rayon::prelude::*;

use super::densify::{DenseFlow, densify};
use super::error::FlowError;
use super::grid::PatchGrid;
use super::inverse_search::{SearchInput, SearchSettings, search};
use super::params::{DisParams, DisPreset};
use super::plane::{FlowFrame, PaddedPlane, Plane};
use super::variational::{RefineSettings, refine};
use crate::sequence::FlowField;

/// Replicated border around the second frame: patches whose samples stay within it take
/// the fast path without per-pixel bounds checks.
const BORDER: usize = 16;

/// Dense Inverse Search optical flow (Kroeger et al., ECCV 2016) with the variational
/// refinement of DeepFlow, organised like OpenCV's `DISOpticalFlow` so that presets compare
/// one to one.
///
/// The estimator holds only its parameters; it is cheap to clone and can be shared between
/// threads. Work inside [`DisFlow::estimate`] runs on the current rayon thread pool (wrap
/// the call in `ThreadPool::install` to choose the thread count); the result is the same for
/// any number of threads.
#[derive(Debug, Clone, PartialEq)]
pub struct DisFlow {
    params: DisParams,
}

impl DisFlow {
    /// An estimator with hand-tuned parameters; fails if they are not usable
    /// (see [`DisParams::validate`]).
    pub fn new(params: DisParams) -> Result<Self, FlowError> {
        params.validate()?;
        Ok(Self { params })
    }

    /// An estimator with the parameters of a preset.
    pub fn from_preset(preset: DisPreset) -> Self {
        Self {
            params: DisParams::from_preset(preset),
        }
    }

    /// The parameters in use.
    pub fn params(&self) -> &DisParams {
        &self.params
    }

    /// Estimates the flow from `prev` to `next`.
    ///
    /// The result lives on `prev`'s pixel grid and is in pixels: `prev(p) ≈ next(p + f(p))`,
    /// u to the right and v downwards, every pixel marked valid. `temporal_prior` (for
    /// example the previous pair's flow) is tried as an extra starting point of every patch
    /// search; its invalid or non-finite pixels are ignored.
    ///
    /// Errors: frames of different sizes, frames smaller than one patch, or a prior of
    /// another size. Constant frames give zero flow.
    pub fn estimate<F: FlowFrame + ?Sized>(
        &self,
        prev: &F,
        next: &F,
        temporal_prior: Option<&FlowField>,
    ) -> Result<FlowField, FlowError> {
        let (width, height) = prev.frame_size();
        let (next_width, next_height) = next.frame_size();
        if (width, height) != (next_width, next_height) {
            return Err(FlowError::FrameSizeMismatch {
                prev_width: width,
                prev_height: height,
                next_width,
                next_height,
            });
        }
        let ps = self.params.patch_size;
        if width < ps || height < ps {
            return Err(FlowError::FrameTooSmall {
                width,
                height,
                patch_size: ps,
            });
        }
        if let Some(prior) = temporal_prior {
            check_flow_shape(prior, width, height, "temporal prior")?;
        }
        let (w, h) = (width as usize, height as usize);
        let prev_plane = luma_plane(prev, w, h, "previous frame")?;
        let next_plane = luma_plane(next, w, h, "next frame")?;
        let (level_flow, scale) = self.estimate_planes(prev_plane, next_plane, temporal_prior);
        Ok(to_flow_field(&level_flow, w, h, scale))
    }

    /// The coarse-to-fine loop on validated luminance planes. Returns the flow of the finest
    /// level processed and that level's scale.
    fn estimate_planes(
        &self,
        prev: Plane,
        next: Plane,
        prior: Option<&FlowField>,
    ) -> (DenseFlow, usize) {
        let p = &self.params;
        let ps = p.patch_size as usize;
        let (w, h) = (prev.width, prev.height);
        let (finest, coarsest) = scale_range(w, h, ps, p.finest_scale as usize);
        let mut prev_levels = vec![prev];
        let mut next_levels = vec![next];
        for s in 1..=coarsest {
            let a = prev_levels[s - 1].downsample2();
            let b = next_levels[s - 1].downsample2();
            prev_levels.push(a);
            next_levels.push(b);
        }
        let gd = p.gradient_descent_iterations as usize;
        let search_settings = SearchSettings {
            forward_iterations: gd.div_ceil(2),
            backward_iterations: gd / 2,
            mean_normalization: p.mean_normalization,
            spatial_propagation: p.spatial_propagation,
        };
        let refine_settings = RefineSettings {
            fixed_point_iterations: p.refinement_iterations as usize,
            sor_iterations: p.sor_iterations as usize,
            omega: p.sor_omega,
            alpha: p.alpha,
            gamma: p.gamma,
            delta: p.delta,
        };
        let mut flow: Option<DenseFlow> = None;
        for s in (finest..=coarsest).rev() {
            let i0 = &prev_levels[s];
            let i1 = PaddedPlane::new(&next_levels[s], BORDER);
            let (gx, gy) = i0.sobel_gradients();
            let grid = PatchGrid::new(i0.width, i0.height, ps, p.patch_stride as usize);
            let initial = initial_patch_flow(&grid, flow.as_ref());
            let temporal = prior.map(|f| temporal_candidates(&grid, f, s));
            let input = SearchInput {
                i0,
                gx: &gx,
                gy: &gy,
                i1: &i1,
                grid: &grid,
                temporal: temporal.as_deref(),
            };
            let patch_flow = search(&input, initial, search_settings);
            let mut dense = densify(i0, &i1, &grid, &patch_flow);
            refine(i0, &i1, &mut dense, &refine_settings);
            flow = Some(dense);
        }
        match flow {
            Some(level_flow) => (level_flow, finest),
            None => (DenseFlow::zeros(w, h), 0),
        }
    }
}

impl Default for DisFlow {
    fn default() -> Self {
        Self::from_preset(DisPreset::default())
    }
}

/// Finest and coarsest pyramid level for a `w × h` frame: OpenCV's rule for the coarsest
/// (`min(round(log2(max(w, h) / (4·ps))), ⌊log2(min(w, h) / ps)⌋)`), both limited to levels
/// that still hold one patch.
pub(crate) fn scale_range(w: usize, h: usize, ps: usize, finest: usize) -> (usize, usize) {
    let mut max_scale = 0;
    while (w >> (max_scale + 1)) >= ps && (h >> (max_scale + 1)) >= ps {
        max_scale += 1;
    }
    let finest = finest.min(max_scale);
    let by_long = ((w.max(h) as f64 / (4 * ps) as f64).log2() + 0.5).floor();
    let by_short = (w.min(h) as f64 / ps as f64).log2().floor();
    let coarsest = by_long.min(by_short).max(0.0) as usize;
    (finest, coarsest.clamp(finest, max_scale))
}

/// Converts a frame to a luminance plane, replacing non-finite values (possible only with
/// foreign `FlowFrame` implementations) by zero.
fn luma_plane<F: FlowFrame + ?Sized>(
    frame: &F,
    w: usize,
    h: usize,
    which: &'static str,
) -> Result<Plane, FlowError> {
    let mut data = frame.luma();
    if data.len() != w * h {
        return Err(FlowError::MalformedFlow {
            problem: format!(
                "{which}: luminance has {} values for a {w}×{h} frame",
                data.len()
            ),
        });
    }
    for v in &mut data {
        if !v.is_finite() {
            *v = 0.0;
        }
    }
    Ok(Plane::from_vec(w, h, data))
}

/// Checks that a flow field is `width × height` and its buffers match that size.
pub(crate) fn check_flow_shape(
    flow: &FlowField,
    width: u32,
    height: u32,
    what: &'static str,
) -> Result<(), FlowError> {
    if (flow.width, flow.height) != (width, height) {
        return Err(FlowError::FlowSizeMismatch {
            what,
            expected_width: width,
            expected_height: height,
            width: flow.width,
            height: flow.height,
        });
    }
    let pixels = width as usize * height as usize;
    if flow.uv.len() != 2 * pixels {
        return Err(FlowError::MalformedFlow {
            problem: format!("{what}: {} uv values for {pixels} pixels", flow.uv.len()),
        });
    }
    if flow.valid.as_ref().is_some_and(|v| v.len() != pixels) {
        return Err(FlowError::MalformedFlow {
            problem: format!("{what}: validity mask does not have {pixels} entries"),
        });
    }
    Ok(())
}

/// Starting vector of every patch: the coarser level's flow at the patch centre, doubled.
fn initial_patch_flow(grid: &PatchGrid, coarse: Option<&DenseFlow>) -> Vec<[f32; 2]> {
    let Some(coarse) = coarse else {
        return vec![[0.0, 0.0]; grid.len()];
    };
    let mut out = Vec::with_capacity(grid.len());
    for row in 0..grid.rows() {
        for col in 0..grid.cols() {
            let (cx, cy) = grid.centre(row, col);
            let (x, y) = ((cx + 0.5) * 0.5 - 0.5, (cy + 0.5) * 0.5 - 0.5);
            out.push([
                2.0 * coarse.u.sample_clamped(x, y),
                2.0 * coarse.v.sample_clamped(x, y),
            ]);
        }
    }
    out
}

/// The temporal prior at every patch centre of level `scale`, in that level's pixels.
fn temporal_candidates(grid: &PatchGrid, prior: &FlowField, scale: usize) -> Vec<Option<[f32; 2]>> {
    let factor = (1u32 << scale) as f32;
    let (w, h) = (prior.width as usize, prior.height as usize);
    let mut out = Vec::with_capacity(grid.len());
    for row in 0..grid.rows() {
        for col in 0..grid.cols() {
            let (cx, cy) = grid.centre(row, col);
            let x = ((cx + 0.5) * factor - 0.5)
                .round()
                .clamp(0.0, (w - 1) as f32) as usize;
            let y = ((cy + 0.5) * factor - 0.5)
                .round()
                .clamp(0.0, (h - 1) as f32) as usize;
            let i = y * w + x;
            let (u, v) = (prior.uv[2 * i], prior.uv[2 * i + 1]);
            let usable =
                u.is_finite() && v.is_finite() && prior.valid.as_ref().is_none_or(|m| m[i]);
            out.push(usable.then_some([u / factor, v / factor]));
        }
    }
    out
}

/// Source index pair and weight of every output position when a level of `src` samples is
/// up-sampled by `factor` with pixel-centre alignment (`x_src = (x + 0.5) / factor − 0.5`,
/// clamped to the source).
fn upsample_taps(out_len: usize, src: usize, factor: f32) -> Vec<(usize, usize, f32)> {
    (0..out_len)
        .map(|x| {
            let pos = ((x as f32 + 0.5) / factor - 0.5).clamp(0.0, (src - 1) as f32);
            let i0 = (pos as usize).min(src - 1);
            (i0, (i0 + 1).min(src - 1), pos - i0 as f32)
        })
        .collect()
}

/// The flow of pyramid level `scale`, up-sampled bilinearly to the full `w × h` grid with
/// values multiplied by `2^scale`, as the shared interleaved `FlowField`. Non-finite values
/// become zero so that callers never see NaN.
fn to_flow_field(level: &DenseFlow, w: usize, h: usize, scale: usize) -> FlowField {
    let factor = (1u32 << scale) as f32;
    let (lw, lh) = (level.width(), level.height());
    let cols = upsample_taps(w, lw, factor);
    let rows = upsample_taps(h, lh, factor);
    let mut uv = vec![0.0f32; 2 * w * h];
    uv.par_chunks_mut(2 * w).enumerate().for_each(|(y, out)| {
        let (y0, y1, fy) = rows[y];
        let blend = |p: &Plane| -> Vec<f32> {
            let (a, b) = (p.row(y0), p.row(y1));
            a.iter()
                .zip(b)
                .map(|(a, b)| factor * (a + fy * (b - a)))
                .collect()
        };
        let (u, v) = (blend(&level.u), blend(&level.v));
        for (pair, &(x0, x1, fx)) in out.chunks_exact_mut(2).zip(&cols) {
            let clean = |a: f32| if a.is_finite() { a } else { 0.0 };
            pair[0] = clean(u[x0] + fx * (u[x1] - u[x0]));
            pair[1] = clean(v[x0] + fx * (v[x1] - v[x0]));
        }
    });
    FlowField {
        width: w as u32,
        height: h as u32,
        uv,
        valid: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_range_follows_the_opencv_rule() {
        assert_eq!(scale_range(800, 600, 8, 1), (1, 5));
        assert_eq!(scale_range(768, 512, 8, 2), (2, 5));
        assert_eq!(scale_range(8, 8, 8, 2), (0, 0));
        assert_eq!(scale_range(40, 20, 8, 2), (1, 1));
    }
}
