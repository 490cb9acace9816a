//! Re-evaluating 100,000 frames: the work the viewer repeats on every weight-slider move
//! (median filter, ROC curve, AUROC, AP, FPR95, F1-max, detection latencies).
//! Target: at most 16 ms, one frame time. Run: `cargo bench --bench eval_metrics`.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use vadscope::eval::{RocCurve, detection_outcomes, median_filter};

/// Deterministic scores with anomalies in 20 % of the frames (a small LCG keeps the bench
/// free of extra dependencies).
fn synthetic_frames(n: usize) -> (Vec<f64>, Vec<bool>) {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let labels: Vec<bool> = (0..n).map(|i| (i / 500) % 5 == 4).collect();
    let scores = labels
        .iter()
        .map(|&a| next() + if a { 0.6 } else { 0.0 })
        .collect();
    (scores, labels)
}

fn bench_metrics(c: &mut Criterion) {
    let (scores, labels) = synthetic_frames(100_000);
    c.bench_function(
        "metrics_100k_frames (medfilt17 + ROC + AUROC/AP/FPR95/F1 + latency)",
        |b| {
            b.iter(|| {
                let filtered = median_filter(black_box(&scores), 17);
                let metrics = RocCurve::compute(&filtered, &labels).unwrap().metrics();
                let outcomes = detection_outcomes(&filtered, &labels, metrics.f1_threshold);
                black_box((metrics, outcomes.len()))
            })
        },
    );
}

criterion_group!(benches, bench_metrics);
criterion_main!(benches);
