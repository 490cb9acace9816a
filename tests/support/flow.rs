//! Synthetic frame pairs with exact motion for the flow tests: textures are continuous
//! functions (sums of plane waves), so the second frame is the first under an exactly known
//! warp, with no resampling error.

use image::GrayImage;
use vadscope::flow::FlowField;

/// A small deterministic generator (SplitMix64), so tests need no dependency.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Roughly normal (sum of uniforms), mean 0, standard deviation 1.
    pub fn normal(&mut self) -> f64 {
        (0..12).map(|_| self.unit()).sum::<f64>() - 6.0
    }
}

/// A band-limited texture: a sum of plane waves with random directions and phases whose
/// amplitude falls with frequency.
pub struct Texture {
    waves: Vec<(f64, f64, f64, f64)>,
    mean: f64,
}

impl Texture {
    pub fn new(seed: u64, mean: f64) -> Self {
        let mut rng = Rng::new(seed);
        let waves = (0..24)
            .map(|i| {
                let freq = 0.04 + 0.56 * (i as f64 / 23.0);
                let angle = rng.unit() * std::f64::consts::TAU;
                let amp = 26.0 / (1.0 + 4.0 * freq);
                (
                    freq * angle.cos(),
                    freq * angle.sin(),
                    rng.unit() * std::f64::consts::TAU,
                    amp,
                )
            })
            .collect();
        Self { waves, mean }
    }

    pub fn at(&self, x: f64, y: f64) -> f64 {
        self.mean
            + self
                .waves
                .iter()
                .map(|&(kx, ky, phase, amp)| amp * (kx * x + ky * y + phase).sin())
                .sum::<f64>()
    }
}

/// Renders a frame from a continuous intensity function, with Gaussian noise of `sigma`
/// grey levels, rounded to 8 bits.
pub fn render(
    width: u32,
    height: u32,
    noise: (u64, f64),
    intensity: impl Fn(f64, f64) -> f64,
) -> GrayImage {
    let mut rng = Rng::new(noise.0);
    GrayImage::from_fn(width, height, |x, y| {
        let v = intensity(x as f64, y as f64) + noise.1 * rng.normal();
        image::Luma([v.round().clamp(0.0, 255.0) as u8])
    })
}

/// A flow field from a per-pixel function.
pub fn flow_from_fn(width: u32, height: u32, f: impl Fn(f64, f64) -> [f64; 2]) -> FlowField {
    let mut flow = FlowField::zeros(width, height);
    for y in 0..height {
        for x in 0..width {
            let [u, v] = f(x as f64, y as f64);
            let i = 2 * (y * width + x) as usize;
            flow.uv[i] = u as f32;
            flow.uv[i + 1] = v as f32;
        }
    }
    flow
}

/// Mean EPE over pixels at least `margin` pixels from the border (where content can leave
/// or enter the frame, no method can know the motion).
pub fn interior_epe(estimate: &FlowField, truth: &FlowField, margin: u32) -> f64 {
    let (w, h) = (truth.width, truth.height);
    region_epe(estimate, truth, (margin, w - margin), (margin, h - margin))
}

/// Mean EPE over columns `xs.0..xs.1` and rows `ys.0..ys.1`.
pub fn region_epe(estimate: &FlowField, truth: &FlowField, xs: (u32, u32), ys: (u32, u32)) -> f64 {
    let mut sum = 0.0;
    let mut n = 0usize;
    for y in ys.0..ys.1 {
        for x in xs.0..xs.1 {
            let [a, b] = estimate.at(x, y);
            let [c, d] = truth.at(x, y);
            sum += f64::from(((a - c).powi(2) + (b - d).powi(2)).sqrt());
            n += 1;
        }
    }
    sum / n as f64
}
