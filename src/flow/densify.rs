//! Densification: from one vector per patch to one vector per pixel.
//!
//! Every pixel takes the weighted mean of the vectors of all patches covering it, weighted
//! by `1 / max(1, |I1(x + u) − I0(x)|)`, so a patch whose vector does not explain this pixel
//! counts less. Rows are independent and run in parallel.

use rayon::prelude::*;

use super::grid::PatchGrid;
use super::plane::{PaddedPlane, Plane};
use super::simd;

/// Dense flow of a level, one plane per component.
#[derive(Debug, Clone)]
pub(crate) struct DenseFlow {
    pub u: Plane,
    pub v: Plane,
}

impl DenseFlow {
    /// Zero flow of the given size.
    pub fn zeros(width: usize, height: usize) -> Self {
        Self {
            u: Plane::zeros(width, height),
            v: Plane::zeros(width, height),
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.u.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.u.height
    }
}

/// Spreads the patch vectors `patch_flow` (row-major over `grid`) over every pixel.
pub(crate) fn densify(
    i0: &Plane,
    i1: &PaddedPlane,
    grid: &PatchGrid,
    patch_flow: &[[f32; 2]],
) -> DenseFlow {
    match grid.patch_size {
        4 => densify_sized::<4>(i0, i1, grid, patch_flow),
        8 => densify_sized::<8>(i0, i1, grid, patch_flow),
        12 => densify_sized::<12>(i0, i1, grid, patch_flow),
        _ => densify_sized::<16>(i0, i1, grid, patch_flow),
    }
}

fn densify_sized<const PS: usize>(
    i0: &Plane,
    i1: &PaddedPlane,
    grid: &PatchGrid,
    patch_flow: &[[f32; 2]],
) -> DenseFlow {
    let w = i0.width;
    let mut flow = DenseFlow::zeros(w, i0.height);
    let wide = simd::wide_vectors_available();
    flow.u
        .data
        .par_chunks_mut(w)
        .zip(flow.v.data.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (out_u, out_v))| {
            let job = RowJob {
                i0,
                i1,
                grid,
                patch_flow,
                y,
            };
            if wide {
                // SAFETY: `wide_vectors_available` confirmed AVX2 on this CPU.
                #[cfg(target_arch = "x86_64")]
                unsafe {
                    densify_row_avx2::<PS>(&job, out_u, out_v)
                }
            } else {
                densify_row::<PS>(&job, out_u, out_v);
            }
        });
    flow
}

/// One output row of the densification.
struct RowJob<'a> {
    i0: &'a Plane,
    i1: &'a PaddedPlane,
    grid: &'a PatchGrid,
    patch_flow: &'a [[f32; 2]],
    y: usize,
}

/// [`densify_row`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn densify_row_avx2<const PS: usize>(job: &RowJob, out_u: &mut [f32], out_v: &mut [f32]) {
    densify_row::<PS>(job, out_u, out_v);
}

#[inline(always)]
fn densify_row<const PS: usize>(job: &RowJob, out_u: &mut [f32], out_v: &mut [f32]) {
    let (i0, i1, grid, y) = (job.i0, job.i1, job.grid, job.y);
    let w = i0.width;
    let cols = grid.cols();
    let mut acc_w = vec![0.0f32; w];
    let mut acc_u = vec![0.0f32; w];
    let mut acc_v = vec![0.0f32; w];
    let i0_row = i0.row(y);
    for row in grid.rows_covering(y) {
        for (col, &x0) in grid.xs.iter().enumerate() {
            let uv = job.patch_flow[row * cols + col];
            let mut sampled = [0.0f32; PS];
            sample_row::<PS>(i1, x0, y, uv, &mut sampled);
            let sw = segment::<PS>(&mut acc_w, x0);
            let su = segment::<PS>(&mut acc_u, x0);
            let sv = segment::<PS>(&mut acc_v, x0);
            let reference: &[f32; PS] = i0_row[x0..x0 + PS]
                .try_into()
                .expect("grid keeps patches inside the row");
            for i in 0..PS {
                let weight = 1.0 / (sampled[i] - reference[i]).abs().max(1.0);
                sw[i] += weight;
                su[i] += weight * uv[0];
                sv[i] += weight * uv[1];
            }
        }
    }
    for x in 0..w {
        // Every pixel is covered by at least one patch and weights are in (0, 1].
        let norm = 1.0 / acc_w[x];
        out_u[x] = acc_u[x] * norm;
        out_v[x] = acc_v[x] * norm;
    }
}

/// The `PS` accumulators of a patch starting at column `x0`.
#[inline(always)]
fn segment<const PS: usize>(acc: &mut [f32], x0: usize) -> &mut [f32; PS] {
    (&mut acc[x0..x0 + PS])
        .try_into()
        .expect("the grid keeps patches inside the row")
}

/// Bilinear samples of `i1` at `(x0 + i + u, y + v)` for `i` in `0..PS`.
#[inline(always)]
fn sample_row<const PS: usize>(
    i1: &PaddedPlane,
    x0: usize,
    y: usize,
    uv: [f32; 2],
    out: &mut [f32; PS],
) {
    let px = x0 as f32 + uv[0];
    let py = y as f32 + uv[1];
    let fx0 = px.floor();
    let fy0 = py.floor();
    let pad = i1.pad as f32;
    let inside = fx0 >= -pad
        && fy0 >= -pad
        && fx0 + PS as f32 <= (i1.width + i1.pad - 1) as f32
        && fy0 + 1.0 <= (i1.height + i1.pad - 1) as f32;
    if inside {
        let ax = px - fx0;
        let ay = py - fy0;
        let base = i1.index(fx0 as isize, fy0 as isize);
        let top = &i1.data[base..base + PS + 1];
        let bottom = &i1.data[base + i1.stride..base + i1.stride + PS + 1];
        for i in 0..PS {
            let t = top[i] + ax * (top[i + 1] - top[i]);
            let b = bottom[i] + ax * (bottom[i + 1] - bottom[i]);
            out[i] = t + ay * (b - t);
        }
    } else {
        for (i, o) in out.iter_mut().enumerate() {
            *o = i1.sample(px + i as f32, py);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_patch_vectors_give_that_vector_everywhere() {
        let i0 = Plane::from_vec(20, 17, (0..340).map(|i| (i % 23) as f32).collect());
        let i1 = PaddedPlane::new(&i0, 16);
        let grid = PatchGrid::new(20, 17, 8, 3);
        let flow = densify(&i0, &i1, &grid, &vec![[0.75, -2.5]; grid.len()]);
        assert!(flow.u.data.iter().all(|&u| (u - 0.75).abs() < 1e-5));
        assert!(flow.v.data.iter().all(|&v| (v + 2.5).abs() < 1e-5));
    }

    #[test]
    fn the_patch_that_explains_a_pixel_dominates_it() {
        // I1 is I0 shifted right by 2: a patch claiming +2 explains every pixel exactly,
        // one claiming 0 does not, so pixels lean towards +2.
        let w = 24;
        let i0 = Plane::from_vec(
            w,
            8,
            (0..w * 8).map(|i| ((i % w) * 37 % 101) as f32).collect(),
        );
        let shifted: Vec<f32> = (0..w * 8)
            .map(|i| {
                let x = (i % w).saturating_sub(2);
                i0.data[(i / w) * w + x]
            })
            .collect();
        let i1 = PaddedPlane::new(&Plane::from_vec(w, 8, shifted), 16);
        let grid = PatchGrid::new(w, 8, 8, 4);
        assert_eq!(grid.xs, vec![0, 4, 8, 12, 16]);
        let vectors = [[2.0, 0.0], [2.0, 0.0], [0.0, 0.0], [2.0, 0.0], [2.0, 0.0]];
        let flow = densify(&i0, &i1, &grid, &vectors);
        // Columns 8..12 are covered by the patches at 4 (claiming +2, exact) and 8 (wrong):
        // a plain mean would give 1.
        for x in 8..12 {
            assert!(flow.u.data[x] > 1.8, "column {x}: {}", flow.u.data[x]);
        }
    }
}
