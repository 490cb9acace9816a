//! The sparse patch grid of one pyramid level.

/// Origins (top-left corners) of the search patches of one level.
///
/// Patches are `patch_size` wide and start every `stride` pixels; the last row and column
/// are moved inwards to end exactly at the image border, so every pixel is covered by at
/// least one patch.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct PatchGrid {
    pub patch_size: usize,
    pub xs: Vec<usize>,
    pub ys: Vec<usize>,
}

/// Patch origins along one axis of length `len >= patch_size`.
fn origins(len: usize, patch_size: usize, stride: usize) -> Vec<usize> {
    let span = len - patch_size;
    let count = span.div_ceil(stride) + 1;
    (0..count).map(|i| (i * stride).min(span)).collect()
}

impl PatchGrid {
    /// The grid for a `width × height` level; both must be at least `patch_size`.
    pub fn new(width: usize, height: usize, patch_size: usize, stride: usize) -> Self {
        Self {
            patch_size,
            xs: origins(width, patch_size, stride),
            ys: origins(height, patch_size, stride),
        }
    }

    /// Number of patches per row.
    pub fn cols(&self) -> usize {
        self.xs.len()
    }

    /// Number of patch rows.
    pub fn rows(&self) -> usize {
        self.ys.len()
    }

    /// Total number of patches.
    pub fn len(&self) -> usize {
        self.xs.len() * self.ys.len()
    }

    /// Centre of patch (row, col) in pixel-centre coordinates of the level.
    pub fn centre(&self, row: usize, col: usize) -> (f32, f32) {
        let half = (self.patch_size as f32 - 1.0) * 0.5;
        (self.xs[col] as f32 + half, self.ys[row] as f32 + half)
    }

    /// Range of patch rows whose patches cover image row `y`.
    pub fn rows_covering(&self, y: usize) -> std::ops::Range<usize> {
        let first = self.ys.partition_point(|&oy| oy + self.patch_size <= y);
        let end = self.ys.partition_point(|&oy| oy <= y);
        first..end
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_covers_every_pixel_and_stays_inside() {
        for (len, ps, stride) in [(8, 8, 4), (9, 8, 4), (20, 8, 3), (37, 8, 4), (100, 8, 3)] {
            let o = origins(len, ps, stride);
            assert_eq!(o[0], 0);
            assert_eq!(*o.last().unwrap() + ps, len);
            for pair in o.windows(2) {
                assert!(pair[1] > pair[0] && pair[1] - pair[0] <= stride);
            }
        }
    }

    #[test]
    fn rows_covering_lists_exactly_the_covering_patch_rows() {
        let grid = PatchGrid::new(30, 30, 8, 3);
        for y in 0..30 {
            let expected: Vec<usize> = (0..grid.rows())
                .filter(|&r| grid.ys[r] <= y && y < grid.ys[r] + 8)
                .collect();
            let got: Vec<usize> = grid.rows_covering(y).collect();
            assert_eq!(got, expected, "row {y}");
        }
    }
}
