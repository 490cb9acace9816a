//! The persistent progress of a training run: `state.json`, and the model files each epoch
//! commits together with it.
//!
//! An epoch ends by replacing several files (the last model and Adam's state, the stage's
//! best model, the running average) and the state that says which epoch they belong to.
//! Each file is atomic on its own ([`crate::atomic_file`]); the set is made atomic by
//! staging. The epoch's files are written as `<name>.next`; the state naming them as pending
//! is written (the commit point); the staged files are renamed into place; the state is
//! written again without them. A run killed before the commit leaves staged files, which
//! resume deletes; one killed after it leaves renames, which resume finishes. Either way a
//! resumed run sees the files of exactly one epoch, so it ends with the model an
//! uninterrupted run gives.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::atomic_file::write_atomically;
use crate::model::ModelConfig;

use super::config::TrainConfig;
use super::error::TrainError;
use super::progress::StageSummary;

/// The state file's name inside the output folder.
const STATE: &str = "state.json";

/// Suffix of a file staged for the epoch being committed.
const STAGED_SUFFIX: &str = ".next";

/// Persistent progress of a run (`state.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct TrainState {
    pub(super) model_config: ModelConfig,
    pub(super) train_config: TrainConfig,
    pub(super) cubes: usize,
    pub(super) stage: usize,
    pub(super) next_epoch: usize,
    pub(super) best_loss: Option<f64>,
    pub(super) best_epoch: usize,
    /// Epochs averaged into the kept model (0: its own epoch's weights).
    #[serde(default)]
    pub(super) best_averaged: usize,
    /// Epochs in the running weight average (`AVERAGE_MODEL`) of the current stage.
    #[serde(default)]
    pub(super) averaged: usize,
    pub(super) rng_state: u64,
    pub(super) summaries: [Option<StageSummary>; 3],
    /// Files of the committed epoch still waiting under their staged names.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) pending: Vec<String>,
}

/// Where the file `name` of the epoch being committed is written before the commit.
fn staged(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}{STAGED_SUFFIX}"))
}

/// Reads the state of the run in `dir`, if there is one, after bringing the folder to the
/// last committed epoch: renames a kill interrupted are finished, and files staged for an
/// epoch that was never committed are deleted.
pub(super) fn recover_state(dir: &Path) -> Result<Option<TrainState>, TrainError> {
    let path = dir.join(STATE);
    let mut state = if path.is_file() {
        let text = std::fs::read_to_string(&path).map_err(|e| TrainError::io(&path, e))?;
        let state: TrainState = serde_json::from_str(&text)
            .map_err(|e| TrainError::file(&path, format!("unreadable training state: {e}")))?;
        Some(state)
    } else {
        None
    };
    if let Some(state) = state.as_mut().filter(|s| !s.pending.is_empty()) {
        promote(dir, &state.pending)?;
        state.pending.clear();
        write_state(dir, state)?;
    }
    remove_uncommitted(dir)?;
    Ok(state)
}

/// Writes `state` to `dir`, atomically.
pub(super) fn write_state(dir: &Path, state: &TrainState) -> Result<(), TrainError> {
    let path = dir.join(STATE);
    let text = serde_json::to_string_pretty(state).map_err(|e| TrainError::io(&path, e))?;
    Ok(write_atomically(&path, text.as_bytes())?)
}

/// The files one epoch replaces in the run folder: each is written at the path
/// [`EpochFiles::stage`] gives for it, and [`EpochFiles::commit`] puts them all in place
/// together with the state.
pub(super) struct EpochFiles<'a> {
    dir: &'a Path,
    names: Vec<String>,
}

impl<'a> EpochFiles<'a> {
    /// No file staged yet, in the run folder `dir`.
    pub(super) fn new(dir: &'a Path) -> Self {
        Self {
            dir,
            names: Vec::new(),
        }
    }

    /// The path to write the epoch's file `name` at until the commit.
    pub(super) fn stage(&mut self, name: &str) -> PathBuf {
        self.names.push(name.to_string());
        staged(self.dir, name)
    }

    /// Commits `state` together with the staged files, and puts those files in place.
    pub(super) fn commit(self, state: &mut TrainState) -> Result<(), TrainError> {
        state.pending = self.names;
        write_state(self.dir, state)?;
        promote(self.dir, &state.pending)?;
        state.pending.clear();
        write_state(self.dir, state)
    }
}

/// Renames the staged files `names` into place; one already renamed is skipped.
fn promote(dir: &Path, names: &[String]) -> Result<(), TrainError> {
    for name in names {
        let from = staged(dir, name);
        if from.is_file() {
            let to = dir.join(name);
            std::fs::rename(&from, &to).map_err(|e| TrainError::io(&to, e))?;
        }
    }
    Ok(())
}

/// Deletes the staged files in `dir`: after [`promote`], only those of an epoch that was
/// never committed are left.
fn remove_uncommitted(dir: &Path) -> Result<(), TrainError> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_file()
            && path
                .file_name()
                .is_some_and(|n| n.to_string_lossy().ends_with(STAGED_SUFFIX))
        {
            std::fs::remove_file(&path).map_err(|e| TrainError::io(&path, e))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ModelConfig;

    fn state() -> TrainState {
        TrainState {
            model_config: ModelConfig::compact(),
            train_config: TrainConfig::default(),
            cubes: 10,
            stage: 1,
            next_epoch: 1,
            best_loss: None,
            best_epoch: 0,
            best_averaged: 0,
            averaged: 0,
            rng_state: 7,
            summaries: [None, None, None],
            pending: Vec::new(),
        }
    }

    #[test]
    fn a_kill_before_the_commit_keeps_the_old_epoch_and_one_after_it_the_new() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        let mut committed = state();
        write_state(dir, &committed).unwrap();
        std::fs::write(dir.join("last_model.bpk"), b"epoch 1").unwrap();

        // Killed after staging, before the commit: the staged file goes.
        std::fs::write(staged(dir, "last_model.bpk"), b"epoch 2").unwrap();
        assert_eq!(recover_state(dir).unwrap(), Some(committed.clone()));
        assert_eq!(
            std::fs::read(dir.join("last_model.bpk")).unwrap(),
            b"epoch 1"
        );
        assert!(!staged(dir, "last_model.bpk").exists());

        // Killed after the commit, before the rename: resume finishes it.
        std::fs::write(staged(dir, "last_model.bpk"), b"epoch 2").unwrap();
        committed.next_epoch = 2;
        committed.pending = vec!["last_model.bpk".into()];
        write_state(dir, &committed).unwrap();
        let recovered = recover_state(dir).unwrap().unwrap();
        assert!(recovered.pending.is_empty());
        assert_eq!(recovered.next_epoch, 2);
        assert_eq!(
            std::fs::read(dir.join("last_model.bpk")).unwrap(),
            b"epoch 2"
        );
        assert_eq!(recover_state(dir).unwrap(), Some(recovered));

        // A whole commit.
        let mut next = state();
        next.next_epoch = 3;
        let mut files = EpochFiles::new(dir);
        std::fs::write(files.stage("last_model.bpk"), b"epoch 3").unwrap();
        files.commit(&mut next).unwrap();
        assert!(next.pending.is_empty());
        assert_eq!(
            std::fs::read(dir.join("last_model.bpk")).unwrap(),
            b"epoch 3"
        );
        assert_eq!(recover_state(dir).unwrap(), Some(next));
    }
}
