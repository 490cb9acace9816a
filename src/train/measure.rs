//! The passes of a training run that measure a model rather than train it: the stage loss
//! on the held-out normal cubes, a judgement of anomaly selection (statistics over a sample
//! of the training cubes, then the judge, on the judge's threads) and the training
//! statistics stored with the final checkpoint.

use burn::module::Module;
use burn::tensor::Device;

use crate::model::losses::{stage1_loss, stage2_loss, stage3_loss};
use crate::model::{
    CheckpointMeta, Detector, Hf2Vad, Latents, ScoreScale, StatsAccumulator, TrainingStats,
};

use super::error::TrainError;
use super::selection::{AnomalySelection, EpochJudge, evenly_spaced};
use super::stages::{Context, scalar, stage1_input};

impl Context<'_> {
    /// Mean stage loss over the validation cubes in eval mode (posterior means, no dropout,
    /// BatchNorm running statistics); None without validation cubes.
    pub(super) fn validation_loss(&self, stage: usize, model: &Hf2Vad) -> Option<f64> {
        if self.val_idx.is_empty() {
            return None;
        }
        let eval = model.valid();
        let device = Device::flex();
        let w = &self.train_config.loss;
        let c = self.model_config;
        let mut sum = 0.0;
        for chunk in self.val_idx.chunks(self.train_config.eval_batch) {
            let batch = self.batch(chunk, &device);
            let loss = if stage == 1 {
                let input = stage1_input(c, batch.flows);
                stage1_loss(&eval.memae.forward(input.clone()), input, w).total
            } else {
                let target = batch.frames.clone().narrow(1, 3 * c.clip_hist, 3);
                let out = eval.forward(batch.frames, batch.flows.clone(), &Latents::Mean, None);
                if stage == 2 {
                    stage2_loss(&out, target, w).total
                } else {
                    stage3_loss(&out, batch.flows, target, w).total
                }
            };
            sum += scalar(loss) * chunk.len() as f64;
        }
        Some(sum / self.val_idx.len() as f64)
    }

    /// The rating `judge` gives the model of an epoch, scored with statistics over
    /// `selection.stats_cubes` training cubes, on the judge's threads.
    pub(super) fn rate(
        &self,
        model: &Hf2Vad,
        selection: AnomalySelection,
        judge: &mut dyn EpochJudge,
    ) -> Result<f64, TrainError> {
        let eval = model.valid();
        match self.judge_pool {
            Some(pool) => pool.install(|| self.rate_here(eval, selection, judge)),
            None => self.rate_here(eval, selection, judge),
        }
    }

    /// [`Self::rate`] on the current threads, for the model already in eval mode.
    fn rate_here(
        &self,
        model: Hf2Vad,
        selection: AnomalySelection,
        judge: &mut dyn EpochJudge,
    ) -> Result<f64, TrainError> {
        let detector = self.detector(model)?;
        let sample = evenly_spaced(self.train_idx, selection.stats_cubes.max(1));
        let stats = self.training_statistics(&detector, &sample)?;
        let detector = detector.with_training_stats(stats);
        let rating = judge
            .judge(&detector)
            .map_err(|e| TrainError::Selection(format!("{}: {e}", judge.name())))?;
        if !rating.is_finite() {
            return Err(TrainError::Selection(format!(
                "{} rated the model {rating}",
                judge.name()
            )));
        }
        Ok(rating)
    }

    /// `model` (in eval mode) as an inference detector, without training statistics.
    pub(super) fn detector(&self, model: Hf2Vad) -> Result<Detector, TrainError> {
        let meta = CheckpointMeta {
            config: self.model_config.clone(),
            stats: None,
            note: None,
        };
        Ok(Detector::new(model, meta, &Device::flex())?
            .with_max_batch(self.train_config.eval_batch))
    }

    /// S_r/S_p moments and pixel-error quantiles of `detector` over the training cubes
    /// `indices`.
    pub(super) fn training_statistics(
        &self,
        detector: &Detector,
        indices: &[usize],
    ) -> Result<TrainingStats, TrainError> {
        let bands = self.model_config.score_bands;
        let mut acc = StatsAccumulator::new(self.train_config.pixel_sample, self.train_config.seed)
            .with_bands(bands)
            .with_tails(self.model_config.score_scale == ScoreScale::TailSurprisal);
        for chunk in indices.chunks(self.train_config.eval_batch) {
            let (frames, flows) = self.data.gather(chunk);
            for (&i, cube) in chunk.iter().zip(detector.infer(&frames, &flows)?) {
                let centre = match self.data.centre_of(i) {
                    Some(centre) => centre,
                    None if bands > 1 => {
                        return Err(TrainError::Data(format!(
                            "{bands} score bands need the box centres of the cubes, which a cube file of an older vadscope lacks; delete cubes.safetensors in the output folder to extract them again"
                        )));
                    }
                    None => 0.5,
                };
                acc.push_at(
                    centre,
                    cube.s_r,
                    cube.s_p,
                    &cube.flow_error,
                    &cube.frame_error,
                );
            }
        }
        Ok(acc.finish())
    }
}
