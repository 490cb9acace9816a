//! Weight averaging over the late epochs of a stage (stochastic weight averaging, Izmailov
//! et al., 2018): from a chosen epoch on, each finished epoch's weights are folded into a
//! running mean, and the mean — not the epoch's own weights — is what selection rates and
//! may keep. Training itself goes on from the epoch's own weights, so a run with averaging
//! follows exactly the same steps as one without.
//!
//! Why: the detection of a reconstruction model moves by several points from one epoch to
//! the next while its loss barely does (the selection rows of `assets/model/MODEL.md`); the
//! mean of the weights along the late trajectory sits in a flatter part of the loss surface
//! than any single point of it and does not depend on where one epoch happened to stop.
//!
//! The BatchNorm running statistics of averaged weights are not the average of the epochs'
//! statistics, so after each fold the averaged model's statistics are recomputed from a
//! fixed, evenly spaced sample of the training cubes (forward passes in training mode, no
//! update of any weight).

use std::collections::HashMap;

use burn::module::{Module, ModuleMapper, ModuleVisitor, Param, ParamId};
use burn::tensor::{Tensor, TensorData};
use serde::{Deserialize, Serialize};

use crate::model::Hf2Vad;

use super::error::TrainError;
use super::selection::evenly_spaced;
use super::stages::{Context, stage1_input};

/// Stochastic weight averaging of each trained stage's late epochs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct WeightAveraging {
    /// First epoch (0-based) whose weights enter the average; earlier epochs are candidates
    /// for selection with their own weights, as without averaging.
    pub from_epoch: usize,
    /// Training cubes (evenly spaced) whose batches recompute the averaged model's BatchNorm
    /// running statistics.
    pub batch_norm_cubes: usize,
}

impl WeightAveraging {
    /// Averaging from 0-based epoch `from_epoch` on, BatchNorm statistics from 2,048 cubes
    /// (64 batches of 32: the momentum-0.1 running mean forgets its start to 0.1 %).
    pub fn from_epoch(from_epoch: usize) -> Self {
        Self {
            from_epoch,
            batch_norm_cubes: 2048,
        }
    }

    /// Whether the weights of 0-based `epoch` enter the average.
    pub fn includes(&self, epoch: usize) -> bool {
        epoch >= self.from_epoch
    }
}

/// The running mean of the weights of `count` epochs, in inference form (no autodiff).
pub(super) struct RunningAverage {
    model: Hf2Vad,
    count: usize,
}

impl RunningAverage {
    /// An average of one epoch: `model`'s weights.
    pub(super) fn start(model: &Hf2Vad) -> Self {
        Self {
            model: model.valid(),
            count: 1,
        }
    }

    /// An average of `count` epochs read back from a run's files.
    pub(super) fn resumed(model: Hf2Vad, count: usize) -> Self {
        Self {
            model: model.valid(),
            count,
        }
    }

    /// The same average with the weights and running statistics of `prepared` (this
    /// average after [`Context::prepare_average`]).
    pub(super) fn with_weights(self, prepared: &Hf2Vad) -> Self {
        Self {
            model: prepared.valid(),
            count: self.count,
        }
    }

    /// Epochs averaged.
    pub(super) fn count(&self) -> usize {
        self.count
    }

    /// The averaged weights.
    pub(super) fn model(&self) -> &Hf2Vad {
        &self.model
    }

    /// The average with `model`'s weights folded in: every float tensor (parameters and
    /// running statistics) becomes `mean + (new − mean) / (count + 1)`.
    pub(super) fn fold_in(self, model: &Hf2Vad) -> Result<Self, TrainError> {
        let mut collector = FloatCollector::default();
        model.valid().visit(&mut collector);
        let count = self.count + 1;
        let mut folder = Folder {
            new: collector.values,
            weight: 1.0 / count as f32,
            unmatched: 0,
        };
        let averaged = self.model.map(&mut folder);
        if folder.unmatched > 0 || !folder.new.is_empty() {
            return Err(TrainError::Config(format!(
                "weight averaging: {} tensors of the average and {} of the epoch's model have no \
                 counterpart",
                folder.unmatched,
                folder.new.len()
            )));
        }
        Ok(Self {
            model: averaged,
            count,
        })
    }
}

impl Context<'_> {
    /// `average` ready to be rated and kept: back on the training device, with the
    /// BatchNorm running statistics of ML-MemAE-SC recomputed over
    /// `averaging.batch_norm_cubes` training cubes when `stage` trains it (stages 1 and 3;
    /// in stage 2 it is frozen and its statistics are the ones every epoch had).
    pub(super) fn prepare_average(
        &self,
        average: &RunningAverage,
        averaging: WeightAveraging,
        stage: usize,
    ) -> Hf2Vad {
        let model = average.model().clone().train();
        if stage == 2 {
            return model;
        }
        let batch_size = self.train_config.stage(stage).batch_size;
        let sample = evenly_spaced(self.train_idx, averaging.batch_norm_cubes.max(1));
        for chunk in sample.chunks(batch_size) {
            let batch = self.batch(chunk, self.device);
            // Only the running statistics' update matters; the output and its graph go.
            drop(
                model
                    .memae
                    .forward(stage1_input(self.model_config, batch.flows)),
            );
        }
        model
    }
}

/// Collects every float tensor of a module by parameter id.
#[derive(Default)]
struct FloatCollector {
    values: HashMap<ParamId, TensorData>,
}

impl ModuleVisitor for FloatCollector {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        self.values.insert(param.id, param.val().into_data());
    }
}

/// Moves each float tensor of the average towards the collected one of the same id.
struct Folder {
    new: HashMap<ParamId, TensorData>,
    weight: f32,
    unmatched: usize,
}

impl ModuleMapper for Folder {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let Some(new) = self.new.remove(&param.id) else {
            self.unmatched += 1;
            return param;
        };
        let weight = self.weight;
        param.map(|mean| {
            let device = mean.device();
            let shape = mean.shape();
            let old = mean.into_data();
            let folded: Vec<f32> = old
                .iter::<f32>()
                .zip(new.iter::<f32>())
                .map(|(m, x)| m + (x - m) * weight)
                .collect();
            Tensor::from_data(TensorData::new(folded, shape), &device)
        })
    }
}

#[cfg(test)]
mod tests {
    use burn::tensor::Device;

    use super::*;
    use crate::model::{ModelConfig, NoiseRng};

    /// The weights of `model` as one list, in visiting order.
    fn weights(model: &Hf2Vad) -> Vec<f32> {
        struct All(Vec<f32>);
        impl ModuleVisitor for All {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                self.0.extend(param.val().into_data().iter::<f32>());
            }
        }
        let mut all = All(Vec::new());
        model.visit(&mut all);
        all.0
    }

    #[test]
    fn folding_in_gives_the_mean_of_the_weights() {
        let config = ModelConfig {
            patch_size: 16,
            feature_root: 4,
            num_slots: 8,
            nf_start: 8,
            nf_max: 16,
            ..ModelConfig::paper()
        };
        let device = Device::flex();
        let model = |seed| Hf2Vad::new(&config, &device, &mut NoiseRng::new(seed)).expect("model");
        // Other weights under the same parameter ids, as the epochs of one run have.
        struct Scaled(f32);
        impl ModuleMapper for Scaled {
            fn map_float<const D: usize>(&mut self, p: Param<Tensor<D>>) -> Param<Tensor<D>> {
                let k = self.0;
                p.map(|t| t.mul_scalar(k).add_scalar(k))
            }
        }
        let a = model(1);
        let b = a.valid().map(&mut Scaled(2.0));
        let c = a.valid().map(&mut Scaled(-0.5));
        let average = RunningAverage::start(&a)
            .fold_in(&b)
            .and_then(|avg| avg.fold_in(&c))
            .expect("fold");
        assert_eq!(average.count(), 3);
        let (wa, wb, wc) = (weights(&a), weights(&b), weights(&c));
        let mean = weights(average.model());
        assert_eq!(mean.len(), wa.len());
        for i in 0..wa.len() {
            let expected = (wa[i] + wb[i] + wc[i]) / 3.0;
            assert!(
                (mean[i] - expected).abs() <= 1e-6 * expected.abs().max(1.0),
                "weight {i}: {} against {expected}",
                mean[i]
            );
        }
        // A model of other parameters is refused, not averaged by position.
        let stranger = model(2);
        assert!(average.fold_in(&stranger).is_err());
    }
}
