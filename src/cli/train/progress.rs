//! The terminal side of `vadscope train`: progress bars for cube extraction and each
//! stage, one line per finished epoch (losses, the validation rating, wall time), the
//! training statistics and the closing report.

use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use vadscope::model::TrainingStats;
use vadscope::train::{StageSummary, TrainEvent, TrainReport};

/// A progress bar drawn with `template`.
pub(super) fn bar(template: &str) -> ProgressBar {
    ProgressBar::new(0).with_style(
        ProgressStyle::with_template(template)
            .expect("static progress template")
            .progress_chars("=> "),
    )
}

fn stage_name(stage: usize) -> &'static str {
    match stage {
        1 => "memae",
        2 => "cvae",
        _ => "finetune",
    }
}

/// The progress bar of the running stage and the per-epoch lines.
#[derive(Default)]
pub(super) struct Progress {
    bar: Option<ProgressBar>,
    epochs: usize,
    steps_per_epoch: usize,
    /// When the running epoch started: its line gives its wall time.
    epoch_started: Option<Instant>,
}

impl Progress {
    /// Shows `event`: moves the bar or prints a line.
    pub(super) fn on_event(&mut self, event: &TrainEvent) {
        match *event {
            TrainEvent::StageStarted {
                stage,
                first_epoch,
                epochs,
                steps_per_epoch,
            } => {
                self.finish();
                self.epochs = epochs;
                self.steps_per_epoch = steps_per_epoch;
                let bar =
                    bar("{prefix:>12} [{bar:40}] {pos}/{len} steps ({per_sec}, eta {eta}) {msg}");
                bar.set_prefix(format!("stage {stage} {}", stage_name(stage)));
                bar.set_length((epochs * steps_per_epoch) as u64);
                bar.set_position((first_epoch * steps_per_epoch) as u64);
                if first_epoch > 0 {
                    bar.suspend(|| {
                        println!("stage {stage}: resuming at epoch {}", first_epoch + 1)
                    });
                }
                self.bar = Some(bar);
                self.epoch_started = Some(Instant::now());
            }
            TrainEvent::Step {
                epoch, step, loss, ..
            } => {
                if let Some(bar) = &self.bar {
                    bar.set_position((epoch * self.steps_per_epoch + step + 1) as u64);
                    bar.set_message(format!(
                        "epoch {}/{} loss {loss:.5}",
                        epoch + 1,
                        self.epochs
                    ));
                }
            }
            TrainEvent::EpochDone {
                stage,
                epoch,
                train_loss,
                val_loss,
                rating,
                averaged,
                lr,
                best,
            } => {
                let val = val_loss.map_or("-".to_string(), |v| format!("{v:.6}"));
                let of = match averaged {
                    0 => String::new(),
                    1 => " (average of 1 epoch)".to_string(),
                    n => format!(" (average of {n} epochs)"),
                };
                let rating = rating.map_or(String::new(), |r| {
                    format!(", validation frame AUROC {:.2} %", 100.0 * r)
                });
                let seconds = self
                    .epoch_started
                    .replace(Instant::now())
                    .map_or(0.0, |t| t.elapsed().as_secs_f64());
                let line = format!(
                    "stage {stage} {} epoch {}/{}: train loss {train_loss:.6}, validation loss \
                     {val}{rating}{of}, lr {lr:.2e}, {seconds:.1} s{}",
                    stage_name(stage),
                    epoch + 1,
                    self.epochs,
                    if best { " (best)" } else { "" }
                );
                match &self.bar {
                    Some(bar) => bar.suspend(|| println!("{line}")),
                    None => println!("{line}"),
                }
            }
            TrainEvent::StatsDone(ref stats) => {
                self.finish();
                print_stats(stats);
            }
        }
    }

    /// Clears the running bar.
    pub(super) fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

fn print_stats(stats: &TrainingStats) {
    println!(
        "training statistics over {} cubes: S_r mean {:.4} std {:.4}; S_p mean {:.4} std {:.4}",
        stats.cubes,
        stats.flow_score.mean,
        stats.flow_score.std,
        stats.frame_score.mean,
        stats.frame_score.std
    );
    for (i, band) in stats.bands.iter().enumerate() {
        println!(
            "  band {}/{}: {} cubes, S_r mean {:.4} std {:.4}; S_p mean {:.4} std {:.4}",
            i + 1,
            stats.bands.len(),
            band.cubes,
            band.flow_score.mean,
            band.flow_score.std,
            band.frame_score.mean,
            band.frame_score.std
        );
    }
}

/// The closing lines: the split, each stage's kept epoch and the checkpoint.
pub(super) fn print_report(report: &TrainReport) {
    println!(
        "{} training cubes, {} validation cubes",
        report.split.0, report.split.1
    );
    for (i, summary) in report.stages.iter().enumerate() {
        if let Some(StageSummary {
            epochs,
            best_epoch,
            best_averaged,
            best_loss,
            best_rating,
            last_train_loss,
        }) = summary
        {
            let kept = match best_averaged {
                0 | 1 => format!("epoch {}", best_epoch + 1),
                n => format!(
                    "the average of epochs {}–{}",
                    best_epoch + 2 - n,
                    best_epoch + 1
                ),
            };
            let kept_by = match best_rating {
                Some(r) => format!("validation frame AUROC {:.2} %", 100.0 * r),
                None => format!("selection loss {best_loss:.6}"),
            };
            println!(
                "stage {} {}: {epochs} epochs, kept {kept} ({kept_by}), last train loss \
                 {last_train_loss:.6}",
                i + 1,
                stage_name(i + 1),
            );
        }
    }
    println!("checkpoint: {}", report.checkpoint.display());
}
