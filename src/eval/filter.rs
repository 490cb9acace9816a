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
    // Sample `j` of the zero-padded signal.
    let padded = |j: isize| {
        usize::try_from(j)
            .ok()
            .and_then(|j| values.get(j))
            .copied()
            .unwrap_or(0.0)
    };
    // The window kept sorted as it slides: one removal and one insertion per sample instead
    // of a selection over the whole window, which is what keeps a slider move over 100,000
    // frames inside one frame time.
    let mut window: Vec<f64> = (-(half as isize)..=half as isize).map(padded).collect();
    window.sort_unstable_by(f64::total_cmp);
    let mut filtered = Vec::with_capacity(values.len());
    for i in 0..values.len() as isize {
        filtered.push(window[half]);
        let outgoing = padded(i - half as isize);
        let incoming = padded(i + half as isize + 1);
        if outgoing.to_bits() == incoming.to_bits() {
            continue;
        }
        // The outgoing sample's slot becomes a hole that walks towards the incoming
        // sample's place, shifting the neighbours it passes by one.
        let mut at = window.partition_point(|v| v.total_cmp(&outgoing).is_lt());
        while at + 1 < window.len() && window[at + 1].total_cmp(&incoming).is_lt() {
            window[at] = window[at + 1];
            at += 1;
        }
        while at > 0 && window[at - 1].total_cmp(&incoming).is_gt() {
            window[at] = window[at - 1];
            at -= 1;
        }
        window[at] = incoming;
    }
    filtered
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

    #[test]
    fn sliding_window_equals_a_fresh_sort_of_every_window() {
        let x: Vec<f64> = (0..200u64)
            .map(|i| ((i * 7919) % 101) as f64 - 50.0 + if i % 13 == 0 { 0.5 } else { 0.0 })
            .collect();
        for kernel in [3, 5, 17, 31, 401] {
            let half = kernel / 2;
            let expected: Vec<f64> = (0..x.len())
                .map(|i| {
                    let mut w: Vec<f64> = (0..kernel)
                        .map(|k| {
                            (i + k)
                                .checked_sub(half)
                                .and_then(|j| x.get(j))
                                .copied()
                                .unwrap_or(0.0)
                        })
                        .collect();
                    w.sort_by(f64::total_cmp);
                    w[half]
                })
                .collect();
            assert_eq!(median_filter(&x, kernel), expected, "kernel {kernel}");
        }
    }
}
