//! The median filter HF²-VAD applies to per-video frame scores.

/// `scipy.signal.medfilt(values, kernel)`: the median of each window of `kernel` values
/// centred on the sample, with **zeros** padded beyond both ends (as SciPy does, which pulls
/// the first and last `kernel / 2` scores towards 0). An even `kernel` is rejected by SciPy;
/// here it is widened to the next odd size so a slider can never produce an invalid filter.
/// Kernels of 0 or 1 return the input unchanged.
pub fn median_filter(values: &[f64], kernel: usize) -> Vec<f64> {
    if kernel <= 1 || values.is_empty() {
        return values.to_vec();
    }
    let half = kernel / 2;
    let width = 2 * half + 1;
    let mut window = vec![0.0f64; width];
    (0..values.len())
        .map(|i| {
            for (k, slot) in window.iter_mut().enumerate() {
                *slot = (i + k)
                    .checked_sub(half)
                    .and_then(|j| values.get(j))
                    .copied()
                    .unwrap_or(0.0);
            }
            let (_, median, _) = window.select_nth_unstable_by(half, |a, b| a.total_cmp(b));
            *median
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_padding_pulls_the_ends_down() {
        let x = [4.0, 3.0, 5.0, 6.0, 7.0];
        assert_eq!(median_filter(&x, 3), vec![3.0, 4.0, 5.0, 6.0, 6.0]);
        assert_eq!(median_filter(&[5.0; 5], 11), vec![0.0; 5]);
    }

    #[test]
    fn removes_single_spikes_and_widens_even_kernels() {
        let x = [1.0, 1.0, 9.0, 1.0, 1.0];
        assert_eq!(median_filter(&x, 3), vec![1.0, 1.0, 1.0, 1.0, 1.0]);
        assert_eq!(median_filter(&x, 2), median_filter(&x, 3));
        assert_eq!(median_filter(&x, 1), x.to_vec());
    }
}
