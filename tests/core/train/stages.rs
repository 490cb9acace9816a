//! The three training stages on a tiny model and synthetic cubes: losses fall, the final
//! checkpoint reproduces the model's outputs, and an interrupted run resumes to exactly the
//! result of an uninterrupted one; the lowered convolutions train the same loss curve as
//! burn's own, stage by stage; anomaly selection keeps the epoch its judge rates highest.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use vadscope::model::gemm_conv::training::with_burn_layers;
use vadscope::model::{Detector, ModelConfig, read_checkpoint_meta};
use vadscope::train::{
    AnomalySelection, EpochJudge, StageConfig, TrainConfig, TrainEvent, TrainReport, train,
    train_from_checkpoint, train_judged,
};

use super::fixtures::{ScoreSumJudge, judged_training, synthetic_cubes, tiny_training};
use crate::support::model::tiny_config;

fn run(dir: &Path, epochs: usize, events: &mut Vec<TrainEvent>) -> TrainReport {
    train(
        &tiny_config(ModelConfig::paper()),
        &tiny_training(epochs),
        &synthetic_cubes(),
        dir,
        &mut |e| events.push(e.clone()),
    )
    .expect("training")
}

#[test]
fn three_stages_reduce_their_losses_and_the_checkpoint_reproduces_the_model() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut events = Vec::new();
    let report = run(dir.path(), 3, &mut events);
    assert_eq!(report.split, (18, 6), "one of four scenarios held out");

    for stage in 1..=3 {
        let losses: Vec<f64> = events
            .iter()
            .filter_map(|e| match e {
                TrainEvent::EpochDone {
                    stage: s,
                    train_loss,
                    ..
                } if *s == stage => Some(*train_loss),
                _ => None,
            })
            .collect();
        assert_eq!(losses.len(), 3, "stage {stage} epochs");
        assert!(
            losses[2] < losses[0],
            "stage {stage} training loss did not fall: {losses:?}"
        );
    }

    // The checkpoint carries config and statistics, and reloading it reproduces the
    // statistics exactly (same outputs on the same training cubes).
    let meta = read_checkpoint_meta(&report.checkpoint).expect("meta");
    assert_eq!(meta.config, tiny_config(ModelConfig::paper()));
    assert_eq!(meta.stats.as_ref(), Some(&report.stats));
    // Same batch size as the statistics pass, so the arithmetic is the same.
    let detector = Detector::from_checkpoint(&report.checkpoint)
        .expect("load")
        .with_max_batch(8);
    let data = synthetic_cubes();
    let (train_idx, _) = data.split(0.25, 7);
    let (frames, flows) = data.gather(&train_idx);
    let cubes = detector.infer(&frames, &flows).expect("infer");
    let n = cubes.len() as f64;
    let mean_r = cubes.iter().map(|c| c.s_r as f64).sum::<f64>() / n;
    let mean_p = cubes.iter().map(|c| c.s_p as f64).sum::<f64>() / n;
    assert_eq!(report.stats.cubes, 18);
    assert!((mean_r - report.stats.flow_score.mean).abs() <= 1e-9 * mean_r.abs().max(1.0));
    assert!((mean_p - report.stats.frame_score.mean).abs() <= 1e-9 * mean_p.abs().max(1.0));
}

#[test]
fn jointly_reconstructed_flows_train_in_every_stage() {
    let config = ModelConfig {
        joint_flows: true,
        ..tiny_config(ModelConfig::paper())
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let mut events = Vec::new();
    let report = train(
        &config,
        &tiny_training(3),
        &synthetic_cubes(),
        dir.path(),
        &mut |e| events.push(e.clone()),
    )
    .expect("training");
    let stage1: Vec<f64> = events
        .iter()
        .filter_map(|e| match e {
            TrainEvent::EpochDone {
                stage: 1,
                train_loss,
                ..
            } => Some(*train_loss),
            _ => None,
        })
        .collect();
    assert_eq!(stage1.len(), 3);
    assert!(
        stage1[2] < stage1[0],
        "stage 1 loss did not fall: {stage1:?}"
    );
    let meta = read_checkpoint_meta(&report.checkpoint).expect("meta");
    assert!(meta.config.joint_flows);
    assert!(report.stats.flow_score.mean.is_finite() && report.stats.flow_score.mean > 0.0);
}

#[test]
fn interrupted_training_resumes_to_the_same_model() {
    let whole = tempfile::tempdir().expect("temp dir");
    let whole_report = run(whole.path(), 2, &mut Vec::new());

    let resumed = tempfile::tempdir().expect("temp dir");
    // Interrupt right after stage 2's first epoch was checkpointed.
    let interrupted = catch_unwind(AssertUnwindSafe(|| {
        train(
            &tiny_config(ModelConfig::paper()),
            &tiny_training(2),
            &synthetic_cubes(),
            resumed.path(),
            &mut |e| {
                if matches!(
                    e,
                    TrainEvent::EpochDone {
                        stage: 2,
                        epoch: 0,
                        ..
                    }
                ) {
                    panic!("simulated crash");
                }
            },
        )
    }));
    assert!(interrupted.is_err());
    let mut events = Vec::new();
    let resumed_report = run(resumed.path(), 2, &mut events);
    assert!(events.contains(&TrainEvent::StageStarted {
        stage: 2,
        first_epoch: 1,
        epochs: 2,
        steps_per_epoch: 3
    }));
    assert_eq!(
        resumed_report.stats, whole_report.stats,
        "resumed run differs"
    );
    // Summaries went through JSON (last-bit rounding of f64), so compare them loosely.
    for (a, b) in resumed_report.stages.iter().zip(&whole_report.stages) {
        let (a, b) = (
            a.as_ref().expect("stage ran"),
            b.as_ref().expect("stage ran"),
        );
        assert_eq!((a.epochs, a.best_epoch), (b.epochs, b.best_epoch));
        assert!((a.best_loss - b.best_loss).abs() <= 1e-12 * b.best_loss.abs());
        assert!((a.last_train_loss - b.last_train_loss).abs() <= 1e-12 * b.last_train_loss.abs());
    }

    // A different configuration in the same folder is refused.
    let err = train(
        &tiny_config(ModelConfig::paper()),
        &tiny_training(3),
        &synthetic_cubes(),
        resumed.path(),
        &mut |_| {},
    )
    .expect_err("mismatched run");
    assert!(err.to_string().contains("another model config"), "{err}");
}

/// Each stage's epoch losses, train and validation, in event order.
fn epoch_losses(events: &[TrainEvent]) -> Vec<(usize, f64, f64)> {
    events
        .iter()
        .filter_map(|e| match e {
            TrainEvent::EpochDone {
                stage,
                train_loss,
                val_loss,
                ..
            } => Some((*stage, *train_loss, val_loss.expect("validation loss"))),
            _ => None,
        })
        .collect()
}

#[test]
fn lowered_and_fused_layers_train_the_same_loss_curve_as_burns() {
    // The reference's learning rates: Adam moves every weight by about the learning rate
    // whatever its gradient's size, so the rounding differences of two correct gradients
    // reach the loss in proportion to it. The convolution biases in front of a BatchNorm
    // have a gradient that is zero but for rounding, which Adam with ε = 1e-8 turns into
    // steps of the learning rate (the running means lag them, so the validation loss
    // moves): at ε = 1e-8 the two paths' stage-1 validation losses differ by up to 8.8e-5,
    // at ε = 1e-6 by 1.5e-5, while their training losses agree to 1e-7. So the comparison
    // uses ε = 1e-6, and each stage starts both paths from the same weights (burn's path's
    // result of the stage before) rather than carrying that noise across stages.
    let base = tiny_training(2);
    let only = |stage: usize| {
        let pick = |s: usize, config: StageConfig, lr: f64| StageConfig {
            epochs: if s == stage { config.epochs } else { 0 },
            lr,
            ..config
        };
        TrainConfig {
            stage1: pick(1, base.stage1.clone(), 1e-4),
            stage2: pick(2, base.stage2.clone(), 1e-4),
            stage3: pick(3, base.stage3.clone(), 8e-5),
            adam_epsilon: 1e-6,
            ..base.clone()
        }
    };
    let model = tiny_config(ModelConfig::paper());
    let run = |config: &TrainConfig, init: Option<&Path>, dir: &Path| {
        let mut events = Vec::new();
        let on_event = &mut |e: &TrainEvent| events.push(e.clone());
        match init {
            Some(init) => {
                train_from_checkpoint(init, &model, config, &synthetic_cubes(), dir, on_event)
            }
            None => train(&model, config, &synthetic_cubes(), dir, on_event),
        }
        .expect("training");
        epoch_losses(&events)
    };
    // The folder of burn's path's run of the stage before, whose model the next stage starts
    // from.
    let mut previous: Option<tempfile::TempDir> = None;
    for stage in 1..=3 {
        let config = only(stage);
        let init = previous
            .as_ref()
            .map(|dir| dir.path().join("model.safetensors"));
        let (ours_dir, burn_dir) = (
            tempfile::tempdir().expect("dir"),
            tempfile::tempdir().expect("dir"),
        );
        let ours = run(&config, init.as_deref(), ours_dir.path());
        let burn = with_burn_layers(|| run(&config, init.as_deref(), burn_dir.path()));
        // Two epochs of three steps.
        assert_eq!(ours.iter().map(|l| l.0).collect::<Vec<_>>(), [stage; 2]);
        for ((_, train, val), (_, burn_train, burn_val)) in ours.iter().zip(&burn) {
            for (ours, reference) in [(train, burn_train), (val, burn_val)] {
                let error = (ours - reference).abs() / reference.abs().max(1e-12);
                assert!(
                    error <= 1e-4,
                    "stage {stage}: loss {ours} through the lowered path, {reference} through burn's"
                );
            }
        }
        previous = Some(burn_dir);
    }
}

/// A judge that hands out scripted ratings and records what it was shown.
struct ScriptedJudge {
    ratings: Vec<f64>,
    /// Training cubes behind the statistics of each judged model.
    stats_cubes: Vec<u64>,
}

impl EpochJudge for ScriptedJudge {
    fn name(&self) -> &str {
        "scripted judge"
    }

    fn judge(&mut self, detector: &Detector) -> Result<f64, String> {
        let stats = detector.training_stats().ok_or("no statistics")?;
        self.stats_cubes.push(stats.cubes);
        self.ratings
            .get(self.stats_cubes.len() - 1)
            .copied()
            .ok_or_else(|| "judged more often than scripted".to_string())
    }
}

#[test]
fn anomaly_selection_keeps_the_judged_epoch_rated_highest() {
    let dir = tempfile::tempdir().expect("temp dir");
    let config = judged_training(
        5,
        AnomalySelection {
            every: 2,
            stats_cubes: 5,
            threads: None,
        },
    );
    // Epochs 2, 4 and 5 (the last) are judged; the second judgement is the best.
    let mut judge = ScriptedJudge {
        ratings: vec![0.6, 0.8, 0.7],
        stats_cubes: Vec::new(),
    };
    let mut events = Vec::new();
    let report = train_judged(
        None,
        &tiny_config(ModelConfig::paper()),
        &config,
        &synthetic_cubes(),
        dir.path(),
        Some(&mut judge),
        &mut |e| events.push(e.clone()),
    )
    .expect("training");
    assert_eq!(
        judge.stats_cubes,
        vec![5, 5, 5],
        "statistics over the sample"
    );
    let epochs: Vec<(usize, Option<f64>, bool)> = events
        .iter()
        .filter_map(|e| match e {
            TrainEvent::EpochDone {
                epoch,
                rating,
                best,
                ..
            } => Some((*epoch, *rating, *best)),
            _ => None,
        })
        .collect();
    assert_eq!(
        epochs,
        vec![
            (0, None, false),
            (1, Some(0.6), true),
            (2, None, false),
            (3, Some(0.8), true),
            (4, Some(0.7), false),
        ]
    );
    let summary = report.stages[0].clone().expect("stage 1 ran");
    assert_eq!(summary.best_epoch, 3);
    assert_eq!(summary.best_rating, Some(0.8));
    // The final statistics are over all training cubes, not the sample.
    assert_eq!(report.stats.cubes, 18);
}

#[test]
fn anomaly_selection_without_a_judge_and_a_failing_judge_are_reported() {
    let dir = tempfile::tempdir().expect("temp dir");
    let model = tiny_config(ModelConfig::paper());
    let config = judged_training(1, AnomalySelection::EVERY_EPOCH);
    let err = train_judged(
        None,
        &model,
        &config,
        &synthetic_cubes(),
        dir.path(),
        None,
        &mut |_| {},
    )
    .expect_err("no judge");
    assert!(err.to_string().contains("needs a judge"), "{err}");

    let mut judge = ScriptedJudge {
        ratings: Vec::new(),
        stats_cubes: Vec::new(),
    };
    let err = train_judged(
        None,
        &model,
        &config,
        &synthetic_cubes(),
        dir.path(),
        Some(&mut judge),
        &mut |_| {},
    )
    .expect_err("judge fails");
    let message = err.to_string();
    assert!(
        message.contains("scripted judge") && message.contains("judged more often"),
        "{message}"
    );
}

#[test]
fn judging_on_more_threads_gives_the_same_ratings() {
    let judged = |threads: Option<usize>| {
        let dir = tempfile::tempdir().expect("temp dir");
        let config = judged_training(
            2,
            AnomalySelection {
                every: 1,
                stats_cubes: 12,
                threads,
            },
        );
        let mut judge = ScoreSumJudge {
            cubes: synthetic_cubes(),
            ratings: Vec::new(),
            threads: Vec::new(),
        };
        let one_thread = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool");
        one_thread.install(|| {
            train_judged(
                None,
                &tiny_config(ModelConfig::paper()),
                &config,
                &synthetic_cubes(),
                dir.path(),
                Some(&mut judge),
                &mut |_| {},
            )
            .expect("training")
        });
        (judge.ratings, judge.threads)
    };
    let (same_threads, on_one) = judged(None);
    let (more_threads, on_two) = judged(Some(2));
    assert_eq!((on_one, on_two), (vec![1, 1], vec![2, 2]));
    assert_eq!(same_threads, more_threads);
}
