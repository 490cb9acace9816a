//! Weight averaging of the late epochs (`TrainConfig::averaging`): the steps of training are
//! those of a run without it, from the first averaged epoch on selection rates the running
//! mean (which differs from the epoch's own weights once it holds two), it can be kept, and
//! an interrupted run resumes to the same average.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use vadscope::model::ModelConfig;
use vadscope::train::{
    AnomalySelection, TrainConfig, TrainEvent, TrainReport, WeightAveraging, train_judged,
};

use super::fixtures::{ScoreSumJudge, judged_training, synthetic_cubes};
use crate::support::model::tiny_config;

/// Stage 1 for 4 epochs, every epoch judged, averaging from the third when `averaged`.
fn config(averaged: bool) -> TrainConfig {
    let selection = AnomalySelection {
        every: 1,
        stats_cubes: 12,
        threads: None,
    };
    TrainConfig {
        averaging: averaged.then_some(WeightAveraging {
            from_epoch: 2,
            batch_norm_cubes: 12,
        }),
        ..judged_training(4, selection)
    }
}

/// A run in `dir`, with the judge's ratings and every finished epoch's
/// (train loss, epochs averaged).
fn run(
    dir: &Path,
    config: &TrainConfig,
    stop_after_epoch: Option<usize>,
) -> (TrainReport, Vec<f64>, Vec<(f64, usize)>) {
    let mut judge = ScoreSumJudge {
        cubes: synthetic_cubes(),
        ratings: Vec::new(),
        threads: Vec::new(),
    };
    let mut epochs = Vec::new();
    let report = train_judged(
        None,
        &tiny_config(ModelConfig::paper()),
        config,
        &synthetic_cubes(),
        dir,
        Some(&mut judge),
        &mut |e| {
            if let TrainEvent::EpochDone {
                epoch,
                train_loss,
                averaged,
                ..
            } = e
            {
                epochs.push((*train_loss, *averaged));
                assert!(stop_after_epoch != Some(*epoch), "simulated crash");
            }
        },
    )
    .expect("training");
    (report, judge.ratings, epochs)
}

#[test]
fn averaging_rates_the_running_mean_without_changing_the_steps() {
    let (plain_dir, averaged_dir) = (
        tempfile::tempdir().expect("dir"),
        tempfile::tempdir().expect("dir"),
    );
    let (_, plain_ratings, plain_epochs) = run(plain_dir.path(), &config(false), None);
    let (report, ratings, epochs) = run(averaged_dir.path(), &config(true), None);

    // Training takes the same steps: the epochs' losses are identical.
    let losses = |e: &[(f64, usize)]| e.iter().map(|x| x.0).collect::<Vec<_>>();
    assert_eq!(losses(&epochs), losses(&plain_epochs));
    assert_eq!(
        epochs.iter().map(|x| x.1).collect::<Vec<_>>(),
        vec![0, 0, 1, 2]
    );
    // Before the averaging the candidates are the epochs' own weights; an average of one
    // epoch is its weights with recomputed BatchNorm statistics, and of two a new model.
    assert_eq!(ratings[..2], plain_ratings[..2]);
    assert_ne!(ratings[3], plain_ratings[3]);
    let summary = report.stages[0].clone().expect("stage 1 ran");
    let best = (0..4)
        .max_by(|&a, &b| ratings[a].total_cmp(&ratings[b]))
        .expect("ratings");
    assert_eq!(summary.best_epoch, best);
    assert_eq!(summary.best_averaged, epochs[best].1);
    assert_eq!(summary.best_rating, Some(ratings[best]));
}

#[test]
fn an_interrupted_averaging_run_resumes_to_the_same_model() {
    let whole = tempfile::tempdir().expect("dir");
    let (whole_report, whole_ratings, _) = run(whole.path(), &config(true), None);

    let resumed = tempfile::tempdir().expect("dir");
    // Stop right after the first averaged epoch was checkpointed.
    let crash = catch_unwind(AssertUnwindSafe(|| {
        run(resumed.path(), &config(true), Some(2))
    }));
    assert!(crash.is_err());
    let (report, ratings, epochs) = run(resumed.path(), &config(true), None);
    assert_eq!(epochs.iter().map(|x| x.1).collect::<Vec<_>>(), vec![2]);
    assert_eq!(ratings[..], whole_ratings[3..]);
    assert_eq!(report.stats, whole_report.stats, "resumed run differs");
}
