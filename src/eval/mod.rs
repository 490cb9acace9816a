//! Evaluation metrics over plain arrays: ROC curves, AUROC (micro and macro), average
//! precision, FPR at 95 % TPR, F1-max, detection latency, the median filter and the robust
//! and z-score statistics that HF²-VAD's scores are built from.
//!
//! This module depends on nothing else in vadscope: scores are `f64` slices, labels are
//! `bool` slices. Definitions follow scikit-learn and SciPy exactly so that numbers can be
//! compared with the papers' evaluation code (see `shared/parity/metrics.json`).

mod curve;
mod events;
mod filter;
mod stats;

pub use curve::{MetricsError, RocCurve, RocPoint, ScoreMetrics, macro_auroc};
pub use events::{AnomalyEvent, DetectionOutcome, anomaly_events, detection_outcomes, runs_above};
pub use filter::median_filter;
pub use stats::{MeanStd, RobustStats, quantile_linear};
