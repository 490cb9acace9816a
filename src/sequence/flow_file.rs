//! Dense optical flow fields and their file formats: KITTI 16-bit PNG, Middlebury `.flo`
//! and HF²-VAD `.npy` arrays.
//!
//! A flow stored at frame *i* is the motion from frame *i−1* to frame *i*, in pixels of the
//! frame it was computed on (u right, v down).

/// A dense 2D displacement field with an optional per-pixel validity flag.
#[derive(Debug, Clone, PartialEq)]
pub struct FlowField {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Interleaved (u, v) per pixel, row-major: `uv[2 * (y * width + x)]` is u.
    pub uv: Vec<f32>,
    /// Per-pixel validity (false where the motion is unknown, e.g. occluded), row-major.
    /// `None` means every pixel is valid.
    pub valid: Option<Vec<bool>>,
}

impl FlowField {
    /// A zero flow of the given size, every pixel valid.
    pub fn zeros(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            uv: vec![0.0; 2 * width as usize * height as usize],
            valid: None,
        }
    }

    /// The (u, v) displacement at pixel (x, y).
    pub fn at(&self, x: u32, y: u32) -> [f32; 2] {
        let i = 2 * (y as usize * self.width as usize + x as usize);
        [self.uv[i], self.uv[i + 1]]
    }

    /// Whether pixel (x, y) carries a known displacement.
    pub fn is_valid(&self, x: u32, y: u32) -> bool {
        self.valid
            .as_ref()
            .is_none_or(|v| v[y as usize * self.width as usize + x as usize])
    }
}
