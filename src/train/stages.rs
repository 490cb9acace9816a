//! The three training stages of HF²-VAD (spec §5) over a [`CubeSet`], with per-epoch
//! checkpoints, resume, model selection (on held-out normal cubes, or by an
//! [`EpochJudge`], see [`super::selection`]), optional weight averaging of the late epochs
//! ([`super::averaging`]) and the final training statistics.
//!
//! Output folder layout:
//!
//! | file | content |
//! |---|---|
//! | `state.json` | progress: stage, next epoch, best selection value, RNG state, summaries |
//! | `last_model.bpk`, `last_optim.bpk` | model and Adam state after the last finished epoch |
//! | `stage{1,2,3}_best.bpk` | the model at the kept epoch of each stage |
//! | `average_model.bpk` | the running weight average of the current stage, with averaging |
//! | `model.safetensors` | the final vadscope checkpoint (config, training statistics) |
//!
//! The model files are named and written in [`super::model_files`].

use std::path::Path;

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor};

use crate::atomic_file::{remove_stale_temporaries, write_atomically_with};
use crate::model::inference::to_model_conventions;
use crate::model::layers::tensor;
use crate::model::losses::{stage1_loss, stage2_loss, stage3_loss};
use crate::model::{CheckpointMeta, Hf2Vad, Latents, ModelConfig, NoiseRng, save_checkpoint};

use super::averaging::RunningAverage;
use super::config::TrainConfig;
use super::cubes::CubeSet;
use super::error::TrainError;
use super::model_files::{
    AVERAGE_MODEL, FINAL, LAST_MODEL, LAST_OPTIM, best_file, initial_model, load_model, save_model,
};
use super::progress::{StageSummary, TrainEvent, TrainReport};
use super::run_state::{EpochFiles, TrainState, recover_state, write_state};
use super::selection::EpochJudge;

/// Trains a model of `model_config` on the normal cubes `data` through the three stages,
/// writing checkpoints to `out_dir` and resuming from them when the folder holds an
/// unfinished run of the same configuration. The weights start from the seeded random
/// initialisation.
pub fn train(
    model_config: &ModelConfig,
    train_config: &TrainConfig,
    data: &CubeSet,
    out_dir: &Path,
    on_event: &mut dyn FnMut(&TrainEvent),
) -> Result<TrainReport, TrainError> {
    train_judged(
        None,
        model_config,
        train_config,
        data,
        out_dir,
        None,
        on_event,
    )
}

/// As [`train`], but the weights start from the vadscope checkpoint `initial` (whose config
/// must be `model_config`), e.g. the result of a stage-1-only run before training stage 2.
/// A resumed run continues from its own checkpoints instead.
pub fn train_from_checkpoint(
    initial: &Path,
    model_config: &ModelConfig,
    train_config: &TrainConfig,
    data: &CubeSet,
    out_dir: &Path,
    on_event: &mut dyn FnMut(&TrainEvent),
) -> Result<TrainReport, TrainError> {
    train_judged(
        Some(initial),
        model_config,
        train_config,
        data,
        out_dir,
        None,
        on_event,
    )
}

/// As [`train`] (from `initial` when given, as [`train_from_checkpoint`]), with the
/// `judge` that rates the judged epochs when `train_config.anomaly_selection` is set (it
/// must be given then, and only then).
pub fn train_judged(
    initial: Option<&Path>,
    model_config: &ModelConfig,
    train_config: &TrainConfig,
    data: &CubeSet,
    out_dir: &Path,
    mut judge: Option<&mut dyn EpochJudge>,
    on_event: &mut dyn FnMut(&TrainEvent),
) -> Result<TrainReport, TrainError> {
    model_config.validate()?;
    check_inputs(model_config, train_config, data)?;
    match (&train_config.anomaly_selection, &judge) {
        (Some(_), None) => {
            return Err(TrainError::Config(
                "anomaly selection needs a judge (validation scenarios with anomalies)".into(),
            ));
        }
        (None, Some(_)) => {
            return Err(TrainError::Config(
                "a judge was given but the training config selects on the validation loss".into(),
            ));
        }
        _ => {}
    }
    std::fs::create_dir_all(out_dir).map_err(|e| TrainError::io(out_dir, e))?;
    // Checkpoints half-written by a run that was killed.
    remove_stale_temporaries(out_dir);
    let (train_idx, val_idx) = data.split(train_config.val_fraction, train_config.seed);
    let device = Device::flex().autodiff();

    let mut state = match recover_state(out_dir)? {
        Some(state) => {
            if state.model_config != *model_config
                || state.train_config != *train_config
                || state.cubes != data.len()
            {
                return Err(TrainError::Config(format!(
                    "{} holds a run with another model config, training config or data set; \
                     use an empty folder",
                    out_dir.display()
                )));
            }
            state
        }
        None => TrainState {
            model_config: model_config.clone(),
            train_config: train_config.clone(),
            cubes: data.len(),
            stage: 1,
            next_epoch: 0,
            best_loss: None,
            best_epoch: 0,
            best_averaged: 0,
            averaged: 0,
            rng_state: NoiseRng::new(train_config.seed ^ 0x5EED).state(),
            summaries: [None, None, None],
            pending: Vec::new(),
        },
    };

    let mut init_rng = NoiseRng::new(train_config.seed);
    let mut model = Hf2Vad::new(model_config, &device, &mut init_rng)?;
    let resuming = out_dir.join(LAST_MODEL).is_file() && state.next_epoch > 0;
    if resuming {
        load_model(&mut model, &out_dir.join(LAST_MODEL))?;
    } else if let Some(previous) = (1..state.stage)
        .rev()
        .map(|s| out_dir.join(best_file(s)))
        .find(|p| p.is_file())
    {
        load_model(&mut model, &previous)?;
    } else if let Some(initial) = initial {
        model = initial_model(initial, model_config, &device)?;
    }

    let judge_pool = match train_config.anomaly_selection.and_then(|s| s.threads) {
        Some(threads) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| {
                    TrainError::Config(format!("cannot start {threads} judge threads: {e}"))
                })?,
        ),
        None => None,
    };
    let ctx = Context {
        model_config,
        train_config,
        data,
        train_idx: &train_idx,
        val_idx: &val_idx,
        out_dir,
        device: &device,
        judge_pool: judge_pool.as_ref(),
    };
    while state.stage <= 3 {
        let stage = state.stage;
        let settings = train_config.stage(stage);
        let mut optim = AdamConfig::new()
            .with_epsilon(train_config.adam_epsilon as f32)
            .init();
        if state.next_epoch > 0 {
            optim = optim
                .load(out_dir.join(LAST_OPTIM))
                .map_err(|e| TrainError::file(out_dir.join(LAST_OPTIM), e))?;
        }
        model = prepare_for_stage(model, stage);
        if settings.epochs > 0 {
            model = ctx.run_stage(
                stage,
                model,
                &mut optim,
                &mut state,
                judge.as_mut().map(|j| &mut **j as &mut dyn EpochJudge),
                on_event,
            )?;
        }
        // The next stage starts from this stage's best model (or carries on unchanged if the
        // stage was skipped).
        if settings.epochs > 0 {
            load_model(&mut model, &out_dir.join(best_file(stage)))?;
        }
        state.stage += 1;
        state.next_epoch = 0;
        state.best_loss = None;
        state.best_epoch = 0;
        state.best_averaged = 0;
        state.averaged = 0;
        write_state(out_dir, &state)?;
    }

    let model = model.valid();
    let stats = ctx.training_statistics(&ctx.detector(model.clone())?, &train_idx)?;
    on_event(&TrainEvent::StatsDone(Box::new(stats.clone())));
    let checkpoint = out_dir.join(FINAL);
    let note = format!(
        "trained by vadscope: seed {}, {} training / {} validation cubes",
        train_config.seed,
        train_idx.len(),
        val_idx.len()
    );
    let meta = CheckpointMeta {
        config: model_config.clone(),
        stats: Some(stats.clone()),
        note: Some(note),
    };
    save_checkpoint(&checkpoint, &model, &meta)?;
    Ok(TrainReport {
        checkpoint,
        stats,
        stages: state.summaries,
        split: (train_idx.len(), val_idx.len()),
    })
}

fn check_inputs(
    model: &ModelConfig,
    train: &TrainConfig,
    data: &CubeSet,
) -> Result<(), TrainError> {
    if data.patch() != model.patch_size || data.clip_hist() != model.clip_hist {
        return Err(TrainError::Data(format!(
            "cubes are {}×{} with {} past frames; the model wants {}×{} with {}",
            data.patch(),
            data.patch(),
            data.clip_hist(),
            model.patch_size,
            model.patch_size,
            model.clip_hist
        )));
    }
    if data.len() < 2 {
        return Err(TrainError::Data(format!(
            "{} cubes; at least 2 are needed",
            data.len()
        )));
    }
    for n in 1..=3 {
        let s = train.stage(n);
        if s.batch_size == 0 || !(s.lr.is_finite() && s.lr > 0.0) {
            return Err(TrainError::Config(format!(
                "stage {n}: batch size must be positive and the learning rate positive and finite"
            )));
        }
    }
    if !(0.0..1.0).contains(&train.val_fraction) || train.eval_batch == 0 {
        return Err(TrainError::Config(
            "val_fraction must be in [0, 1) and eval_batch positive".into(),
        ));
    }
    Ok(())
}

/// Stage 2 trains the CVAE alone: ML-MemAE-SC frozen, BatchNorm on running statistics.
/// Stages 1 and 3 train with everything unfrozen.
fn prepare_for_stage(mut model: Hf2Vad, stage: usize) -> Hf2Vad {
    model.memae = if stage == 2 {
        model.memae.freeze()
    } else {
        model.memae.unfreeze()
    };
    model
}

/// Scalar value of a loss tensor.
pub(super) fn scalar(t: Tensor<1>) -> f64 {
    t.into_scalar::<f32>() as f64
}

/// What every stage of a run shares: configs, data and its split, output folder, devices.
/// Its passes that measure a model (validation loss, judgements, statistics) are in
/// [`super::measure`].
pub(super) struct Context<'a> {
    pub(super) model_config: &'a ModelConfig,
    pub(super) train_config: &'a TrainConfig,
    pub(super) data: &'a CubeSet,
    pub(super) train_idx: &'a [usize],
    pub(super) val_idx: &'a [usize],
    pub(super) out_dir: &'a Path,
    pub(super) device: &'a Device,
    /// The threads of a judgement, when they differ from the training steps'.
    pub(super) judge_pool: Option<&'a rayon::ThreadPool>,
}

/// What ML-MemAE-SC learns from in stage 1: the cube's last flow, as the reference, or all
/// its flows when they are reconstructed jointly.
pub(super) fn stage1_input(config: &ModelConfig, flows: Tensor<4>) -> Tensor<4> {
    if config.joint_flows {
        flows
    } else {
        flows.narrow(1, 2 * (config.num_flows - 1), 2)
    }
}

/// A batch as model-ready tensors.
pub(super) struct Batch {
    pub(super) frames: Tensor<4>,
    pub(super) flows: Tensor<4>,
    pub(super) len: usize,
}

impl Context<'_> {
    /// The cubes `indices` as model-ready tensors on `device`.
    pub(super) fn batch(&self, indices: &[usize], device: &Device) -> Batch {
        let c = self.model_config;
        let p = c.patch_size;
        let (frames, flows) = self.data.gather(indices);
        let (frames, flows) = to_model_conventions(c, &frames, &flows);
        let n = indices.len();
        Batch {
            frames: tensor(frames, [n, c.cube_frame_channels(), p, p], device),
            flows: tensor(flows, [n, c.cube_flow_channels(), p, p], device),
            len: n,
        }
    }

    fn run_stage(
        &self,
        stage: usize,
        mut model: Hf2Vad,
        optim: &mut ModuleOptimizer,
        state: &mut TrainState,
        mut judge: Option<&mut dyn EpochJudge>,
        on_event: &mut dyn FnMut(&TrainEvent),
    ) -> Result<Hf2Vad, TrainError> {
        let settings = self.train_config.stage(stage);
        let full_steps = self.train_idx.len().div_ceil(settings.batch_size);
        let steps = settings
            .max_steps_per_epoch
            .map_or(full_steps, |m| m.min(full_steps));
        on_event(&TrainEvent::StageStarted {
            stage,
            first_epoch: state.next_epoch,
            epochs: settings.epochs,
            steps_per_epoch: steps,
        });
        let mut rng = NoiseRng::from_state(state.rng_state);
        let averaging = self.train_config.averaging;
        let mut average = match averaging {
            Some(_) if state.averaged > 0 => {
                let mut saved = model.valid().train();
                load_model(&mut saved, &self.out_dir.join(AVERAGE_MODEL))?;
                Some(RunningAverage::resumed(saved, state.averaged))
            }
            _ => None,
        };
        for epoch in state.next_epoch..settings.epochs {
            // The files this epoch replaces, committed with the state at its end.
            let mut epoch_files = EpochFiles::new(self.out_dir);
            let lr = settings.schedule.rate(settings.lr, epoch);
            let mut order = self.train_idx.to_vec();
            rng.shuffle(&mut order);
            let mut loss_sum = 0.0;
            let mut seen = 0;
            for (step, chunk) in order.chunks(settings.batch_size).take(steps).enumerate() {
                let batch = self.batch(chunk, self.device);
                let (next, loss) = self.train_step(stage, model, optim, lr, batch, &mut rng);
                model = next;
                if !loss.is_finite() {
                    return Err(TrainError::Data(format!(
                        "stage {stage} epoch {epoch} step {step}: loss became {loss}"
                    )));
                }
                loss_sum += loss * chunk.len() as f64;
                seen += chunk.len();
                on_event(&TrainEvent::Step {
                    stage,
                    epoch,
                    step,
                    loss,
                });
            }
            let train_loss = loss_sum / seen.max(1) as f64;
            // From the averaging's first epoch on, the candidate of each epoch is the
            // running mean of the weights; training goes on from the epoch's own.
            let (averaged_model, averaged) = match averaging.filter(|a| a.includes(epoch)) {
                Some(averaging) => {
                    let folded = match average.take() {
                        None => RunningAverage::start(&model),
                        Some(mean) => mean.fold_in(&model)?,
                    };
                    let prepared = self.prepare_average(&folded, averaging, stage);
                    save_model(&prepared, &epoch_files.stage(AVERAGE_MODEL))?;
                    let count = folded.count();
                    average = Some(folded.with_weights(&prepared));
                    (Some(prepared), count)
                }
                None => (None, 0),
            };
            let candidate_model = averaged_model.as_ref().unwrap_or(&model);
            let val_loss = self.validation_loss(stage, candidate_model);
            let rating = match (self.train_config.anomaly_selection, judge.as_deref_mut()) {
                (Some(selection), Some(judge)) if selection.judges(epoch, settings.epochs) => {
                    Some(self.rate(candidate_model, selection, judge)?)
                }
                _ => None,
            };
            // Lower is better; with anomaly selection only judged epochs are candidates.
            let candidate = match self.train_config.anomaly_selection {
                None => Some(val_loss.unwrap_or(train_loss)),
                Some(_) => rating.map(|r| -r),
            };
            let best = candidate.is_some_and(|c| state.best_loss.is_none_or(|b| c < b));
            if let Some(value) = candidate.filter(|_| best) {
                state.best_loss = Some(value);
                state.best_epoch = epoch;
                state.best_averaged = averaged;
                save_model(candidate_model, &epoch_files.stage(&best_file(stage)))?;
            }
            save_model(&model, &epoch_files.stage(LAST_MODEL))?;
            write_atomically_with(&epoch_files.stage(LAST_OPTIM), |scratch| {
                optim
                    .save(scratch)
                    .map_err(|e| TrainError::file(scratch, e))
            })?;
            state.next_epoch = epoch + 1;
            state.averaged = averaged;
            state.rng_state = rng.state();
            let best_loss = state.best_loss.unwrap_or(train_loss);
            state.summaries[stage - 1] = Some(StageSummary {
                epochs: epoch + 1,
                best_epoch: state.best_epoch,
                best_averaged: state.best_averaged,
                best_loss,
                // Before the first judged epoch nothing is kept yet, so nothing is rated.
                best_rating: self
                    .train_config
                    .anomaly_selection
                    .and(state.best_loss)
                    .map(|value| -value),
                last_train_loss: train_loss,
            });
            epoch_files.commit(state)?;
            on_event(&TrainEvent::EpochDone {
                stage,
                epoch,
                train_loss,
                val_loss,
                rating,
                averaged,
                lr,
                best,
            });
        }
        Ok(model)
    }

    /// One optimiser step of `stage`; returns the updated model and the batch loss.
    fn train_step(
        &self,
        stage: usize,
        mut model: Hf2Vad,
        optim: &mut ModuleOptimizer,
        lr: f64,
        batch: Batch,
        rng: &mut NoiseRng,
    ) -> (Hf2Vad, f64) {
        let w = &self.train_config.loss;
        let c = self.model_config;
        match stage {
            1 => {
                let input = stage1_input(c, batch.flows);
                let out = model.memae.forward(input.clone());
                let loss = stage1_loss(&out, input, w).total;
                let grads = GradientsParams::from_grads(loss.backward(), &model.memae);
                model.memae = optim.step(lr, model.memae, grads);
                (model, scalar(loss))
            }
            _ => {
                let latents = Latents::sampled(c, batch.len, self.device, rng);
                let target = batch.frames.clone().narrow(1, 3 * c.clip_hist, 3);
                let out = model.forward(batch.frames, batch.flows.clone(), &latents, Some(rng));
                if stage == 2 {
                    let loss = stage2_loss(&out, target, w).total;
                    let grads = GradientsParams::from_grads(loss.backward(), &model.vunet);
                    model.vunet = optim.step(lr, model.vunet, grads);
                    (model, scalar(loss))
                } else {
                    let loss = stage3_loss(&out, batch.flows, target, w).total;
                    let grads = GradientsParams::from_grads(loss.backward(), &model);
                    let model = optim.step(lr, model, grads);
                    (model, scalar(loss))
                }
            }
        }
    }
}
