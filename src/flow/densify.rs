//! Densification: from one vector per patch to one vector per pixel.
//!
//! Every pixel takes the weighted mean of the vectors of all patches covering it, weighted
//! by `1 / max(1, |I1(x + u) − I0(x)|)`, so a patch whose vector does not explain this pixel
//! counts less. Rows are independent and run in parallel.

use rayon::prelude::*;

use super::grid::PatchGrid;
use super::plane::{PaddedPlane, Plane};

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
    let (w, h) = (i0.width, i0.height);
    let ps = grid.patch_size;
    let cols = grid.cols();
    let mut flow = DenseFlow::zeros(w, h);
    flow.u
        .data
        .par_chunks_mut(w)
        .zip(flow.v.data.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (out_u, out_v))| {
            let mut acc_w = vec![0.0f32; w];
            let mut acc_u = vec![0.0f32; w];
            let mut acc_v = vec![0.0f32; w];
            let i0_row = i0.row(y);
            for row in grid.rows_covering(y) {
                for (col, &x0) in grid.xs.iter().enumerate() {
                    let [u, v] = patch_flow[row * cols + col];
                    accumulate_patch_row(
                        i1,
                        &i0_row[x0..x0 + ps],
                        x0,
                        y,
                        [u, v],
                        (
                            &mut acc_w[x0..x0 + ps],
                            &mut acc_u[x0..x0 + ps],
                            &mut acc_v[x0..x0 + ps],
                        ),
                    );
                }
            }
            for x in 0..w {
                // Every pixel is covered by at least one patch and weights are in (0, 1].
                let norm = 1.0 / acc_w[x];
                out_u[x] = acc_u[x] * norm;
                out_v[x] = acc_v[x] * norm;
            }
        });
    flow
}

/// Adds one patch's contribution to the accumulators of one image row segment.
#[inline]
fn accumulate_patch_row(
    i1: &PaddedPlane,
    i0_seg: &[f32],
    x0: usize,
    y: usize,
    uv: [f32; 2],
    acc: (&mut [f32], &mut [f32], &mut [f32]),
) {
    let (acc_w, acc_u, acc_v) = acc;
    let n = i0_seg.len();
    let px = x0 as f32 + uv[0];
    let py = y as f32 + uv[1];
    let fx0 = px.floor();
    let fy0 = py.floor();
    let pad = i1.pad as f32;
    let inside = fx0 >= -pad
        && fy0 >= -pad
        && fx0 + n as f32 <= (i1.width + i1.pad - 1) as f32
        && fy0 + 1.0 <= (i1.height + i1.pad - 1) as f32;
    let mut add = |i: usize, p: f32| {
        let weight = 1.0 / (p - i0_seg[i]).abs().max(1.0);
        acc_w[i] += weight;
        acc_u[i] += weight * uv[0];
        acc_v[i] += weight * uv[1];
    };
    if inside {
        let ax = px - fx0;
        let ay = py - fy0;
        let base = i1.index(fx0 as isize, fy0 as isize);
        let top = &i1.data[base..base + n + 1];
        let bottom = &i1.data[base + i1.stride..base + i1.stride + n + 1];
        for i in 0..n {
            let t = top[i] + ax * (top[i + 1] - top[i]);
            let b = bottom[i] + ax * (bottom[i + 1] - bottom[i]);
            add(i, t + ay * (b - t));
        }
    } else {
        for i in 0..n {
            add(i, i1.sample(px + i as f32, py));
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
