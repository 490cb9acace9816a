//! Training hyper-parameters: per-stage epochs, batch sizes, learning rates and schedules,
//! Adam settings, loss weights, seed and validation split. Defaults are the reference's
//! (spec §5); every number can be changed.

use serde::{Deserialize, Serialize};

use super::averaging::WeightAveraging;
use super::selection::AnomalySelection;

use crate::model::losses::LossWeights;

/// Learning-rate schedule over epochs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum LrSchedule {
    /// PyTorch `StepLR`: multiply by `gamma` every `every` epochs.
    Step {
        /// Epochs between decays.
        every: usize,
        /// Decay factor.
        gamma: f64,
    },
    /// PyTorch `MultiStepLR`: multiply by `gamma` at each milestone epoch.
    MultiStep {
        /// Epochs at which the rate decays.
        milestones: Vec<usize>,
        /// Decay factor.
        gamma: f64,
    },
}

impl LrSchedule {
    /// The learning rate during 0-based `epoch`, from base rate `lr`.
    pub fn rate(&self, lr: f64, epoch: usize) -> f64 {
        let decays = match self {
            LrSchedule::Step { every, .. } => epoch.checked_div(*every).unwrap_or(0),
            LrSchedule::MultiStep { milestones, .. } => {
                milestones.iter().filter(|&&m| epoch >= m).count()
            }
        };
        let gamma = match self {
            LrSchedule::Step { gamma, .. } | LrSchedule::MultiStep { gamma, .. } => *gamma,
        };
        lr * gamma.powi(decays as i32)
    }
}

/// Settings of one training stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageConfig {
    /// Number of epochs (0 skips the stage).
    pub epochs: usize,
    /// Cubes (stage 1: flows) per optimiser step.
    pub batch_size: usize,
    /// Base learning rate.
    pub lr: f64,
    /// Learning-rate schedule.
    pub schedule: LrSchedule,
    /// Stop an epoch after this many steps (None: a full pass). For smoke runs and tests.
    pub max_steps_per_epoch: Option<usize>,
}

/// Everything the three stages need besides the model config and the data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    /// Stage 1: ML-MemAE-SC alone on the last flow of each cube.
    pub stage1: StageConfig,
    /// Stage 2: the CVAE with ML-MemAE-SC frozen (BatchNorm on running statistics).
    pub stage2: StageConfig,
    /// Stage 3: everything fine-tuned together.
    pub stage3: StageConfig,
    /// Adam ε (reference 1e-7).
    pub adam_epsilon: f64,
    /// Loss weights.
    pub loss: LossWeights,
    /// Seed of initialisation, shuffling, dropout, latent noise and the split.
    pub seed: u64,
    /// Fraction of the normal cubes held out for model selection (by scenario group when
    /// the data has several groups).
    pub val_fraction: f64,
    /// Batch size of validation and statistics passes.
    pub eval_batch: usize,
    /// At most this many values per error kind enter the pixel quantiles.
    pub pixel_sample: usize,
    /// Keep each stage's epoch by an anomaly judge (validation scenarios with anomalies)
    /// instead of the normal validation loss; `None` (the default, and the reference's
    /// rule): the lowest normal validation loss.
    #[serde(default)]
    pub anomaly_selection: Option<AnomalySelection>,
    /// Average the weights of each trained stage's late epochs; selection then rates the
    /// running average. `None` (the default, and the reference): no averaging.
    #[serde(default)]
    pub averaging: Option<WeightAveraging>,
}

impl Default for TrainConfig {
    fn default() -> Self {
        let step = LrSchedule::Step {
            every: 50,
            gamma: 0.8,
        };
        Self {
            stage1: StageConfig {
                epochs: 80,
                batch_size: 256,
                lr: 1e-4,
                schedule: LrSchedule::MultiStep {
                    milestones: vec![50],
                    gamma: 0.8,
                },
                max_steps_per_epoch: None,
            },
            stage2: StageConfig {
                epochs: 80,
                batch_size: 128,
                lr: 1e-4,
                schedule: step.clone(),
                max_steps_per_epoch: None,
            },
            stage3: StageConfig {
                epochs: 80,
                batch_size: 128,
                lr: 8e-5,
                schedule: step,
                max_steps_per_epoch: None,
            },
            adam_epsilon: 1e-7,
            loss: LossWeights::default(),
            seed: 0,
            val_fraction: 0.1,
            eval_batch: 64,
            pixel_sample: 4_000_000,
            anomaly_selection: None,
            averaging: None,
        }
    }
}

impl TrainConfig {
    /// The settings of stage `n` (1, 2 or 3).
    pub fn stage(&self, n: usize) -> &StageConfig {
        match n {
            1 => &self.stage1,
            2 => &self.stage2,
            _ => &self.stage3,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedules_match_pytorch_step_and_multistep() {
        let step = LrSchedule::Step {
            every: 50,
            gamma: 0.8,
        };
        assert_eq!(step.rate(1.0, 49), 1.0);
        assert!((step.rate(1.0, 50) - 0.8).abs() < 1e-12);
        assert!((step.rate(1.0, 100) - 0.64).abs() < 1e-12);
        let multi = LrSchedule::MultiStep {
            milestones: vec![50],
            gamma: 0.8,
        };
        assert!((multi.rate(1.0, 120) - 0.8).abs() < 1e-12);
        assert_eq!(
            LrSchedule::Step {
                every: 0,
                gamma: 0.5
            }
            .rate(2.0, 9),
            2.0
        );
    }
}
