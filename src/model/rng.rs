//! `NoiseRng`: the seeded random source of the model and its training (weight init, latent
//! noise, dropout masks, shuffling).
//!
//! burn's own random ops draw from one process-wide generator, so two models (or two tests)
//! running at once would steal each other's numbers. Every random number of vadscope's model
//! comes from an explicit `NoiseRng` instead, which makes training bit-reproducible from its
//! seed and lets a checkpoint store the generator state.

/// SplitMix64 generator (Steele, Lea & Flood 2014) with uniform, normal and Bernoulli draws.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NoiseRng {
    state: u64,
}

impl NoiseRng {
    /// A generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// The internal state, to store in a checkpoint.
    pub fn state(&self) -> u64 {
        self.state
    }

    /// Restores a generator from a stored state.
    pub fn from_state(state: u64) -> Self {
        Self { state }
    }

    /// A new generator whose stream is independent of this one's continuation.
    pub fn fork(&mut self) -> Self {
        Self::new(self.next_u64() ^ 0x6A09_E667_F3BC_C909)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform integer in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        // Multiply-shift keeps the bias below 2^-64 · n, negligible for data-set sizes.
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }

    /// `n` values uniform in [lo, hi).
    pub fn uniform_vec(&mut self, n: usize, lo: f64, hi: f64) -> Vec<f32> {
        (0..n)
            .map(|_| (lo + (hi - lo) * self.uniform()) as f32)
            .collect()
    }

    /// `n` values from N(mean, std²) (Box–Muller).
    pub fn normal_vec(&mut self, n: usize, mean: f64, std: f64) -> Vec<f32> {
        let mut out = Vec::with_capacity(n + 1);
        while out.len() < n {
            // 1 − u keeps the logarithm finite.
            let u1 = 1.0 - self.uniform();
            let u2 = self.uniform();
            let radius = (-2.0 * u1.ln()).sqrt();
            let angle = std::f64::consts::TAU * u2;
            out.push((mean + std * radius * angle.cos()) as f32);
            out.push((mean + std * radius * angle.sin()) as f32);
        }
        out.truncate(n);
        out
    }

    /// An inverted-dropout mask of `n` values: 0 with probability `prob`, else 1/(1−prob).
    pub fn dropout_mask(&mut self, n: usize, prob: f64) -> Vec<f32> {
        let keep = (1.0 / (1.0 - prob)) as f32;
        (0..n)
            .map(|_| if self.uniform() < prob { 0.0 } else { keep })
            .collect()
    }

    /// Shuffles `items` in place (Fisher–Yates).
    pub fn shuffle<T>(&mut self, items: &mut [T]) {
        for i in (1..items.len()).rev() {
            let j = self.below(i + 1);
            items.swap(i, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_stream_and_state_round_trips() {
        let mut a = NoiseRng::new(7);
        let mut b = NoiseRng::new(7);
        assert_eq!(a.normal_vec(5, 0.0, 1.0), b.normal_vec(5, 0.0, 1.0));
        let restored = NoiseRng::from_state(a.state());
        assert_eq!(restored.clone().next_u64(), a.next_u64());
    }

    #[test]
    fn normal_draws_have_unit_moments() {
        let v = NoiseRng::new(1).normal_vec(200_000, 0.0, 1.0);
        let mean = v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / v.len() as f64;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.02, "var {var}");
    }

    #[test]
    fn dropout_mask_keeps_the_expectation() {
        let m = NoiseRng::new(3).dropout_mask(100_000, 0.1);
        let zeros = m.iter().filter(|&&x| x == 0.0).count() as f64 / m.len() as f64;
        let mean = m.iter().map(|&x| x as f64).sum::<f64>() / m.len() as f64;
        assert!((zeros - 0.1).abs() < 0.01, "zero fraction {zeros}");
        assert!((mean - 1.0).abs() < 0.02, "mean {mean}");
    }

    #[test]
    fn shuffle_is_a_permutation() {
        let mut v: Vec<usize> = (0..100).collect();
        NoiseRng::new(9).shuffle(&mut v);
        assert_ne!(v, (0..100).collect::<Vec<_>>());
        v.sort_unstable();
        assert_eq!(v, (0..100).collect::<Vec<_>>());
    }
}
