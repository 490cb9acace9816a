//! The model files of a training run's output folder: the per-epoch burnpack checkpoints
//! that resume reads back, the final checkpoint's name, and the checked initial model of
//! `--init`.
//!
//! Burnpack keeps parameter ids, which the optimizer state is keyed by; that is why resume
//! files are burnpack while the deliverable is a safetensors checkpoint.

use std::path::Path;

use burn::module::Module;
use burn::store::{BurnpackStore, ModuleSnapshot};
use burn::tensor::Device;

use crate::atomic_file::write_atomically_with;
use crate::model::{Hf2Vad, ModelConfig, load_checkpoint};

use super::error::TrainError;

/// The model after the last finished epoch.
pub(super) const LAST_MODEL: &str = "last_model.bpk";
/// Adam's state after the last finished epoch.
pub(super) const LAST_OPTIM: &str = "last_optim.bpk";
/// The running weight average of the current stage ([`super::averaging`]).
pub(super) const AVERAGE_MODEL: &str = "average_model.bpk";
/// The final vadscope checkpoint.
pub(super) const FINAL: &str = "model.safetensors";

/// The model at the best validation epoch of `stage`.
pub(super) fn best_file(stage: usize) -> String {
    format!("stage{stage}_best.bpk")
}

/// The model of the vadscope checkpoint `path`, which must have been made with `config`
/// (up to the score bands and scale, which only shape the statistics computed after
/// training, and native-pixel flows named frame-width units, which the caller vouches leave
/// the cubes as they were).
pub(super) fn initial_model(
    path: &Path,
    config: &ModelConfig,
    device: &Device,
) -> Result<Hf2Vad, TrainError> {
    let checkpoint = load_checkpoint(path, device)?;
    let mut same_network = ModelConfig {
        score_bands: config.score_bands,
        score_scale: config.score_scale,
        ..checkpoint.meta.config.clone()
    };
    if same_network
        .conventions
        .flow_units
        .relabels_as(config.conventions.flow_units)
    {
        same_network.conventions.flow_units = config.conventions.flow_units;
    }
    if same_network != *config {
        return Err(TrainError::file(
            path,
            format!(
                "the checkpoint's model config (preset '{}') differs from the one being \
                 trained (preset '{}')",
                checkpoint.meta.config.preset, config.preset
            ),
        ));
    }
    Ok(checkpoint.model)
}

/// Loads the burnpack file `path` into `model`.
pub(super) fn load_model(model: &mut Hf2Vad, path: &Path) -> Result<(), TrainError> {
    let mut store = BurnpackStore::from_file(path);
    model
        .load_from(&mut store)
        .map_err(|e| TrainError::file(path, e))?;
    Ok(())
}

/// Writes `model` to the burnpack file `path`, atomically.
pub(super) fn save_model(model: &Hf2Vad, path: &Path) -> Result<(), TrainError> {
    write_atomically_with(path, |scratch| {
        // valid() folds pending BatchNorm running-stat updates in and keeps parameter ids.
        let mut store = BurnpackStore::from_file(scratch).overwrite(true);
        model
            .valid()
            .save_into(&mut store)
            .map_err(|e| TrainError::file(scratch, e))
    })
}
