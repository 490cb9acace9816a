//! Scoring scenarios with one checkpoint, reusing the caches that are current: the loop
//! `vadscope score`, `vadscope eval`, `render`/`export` and the viewer's scoring job share.
//! The checkpoint is hashed once for the cache keys and the model is loaded only when a
//! scenario has no current cache; what to do with an unusable cache (score again, or report
//! it) and how to show progress are the caller's.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use crate::model::Detector;
use crate::sequence::Scenario;

use super::ScoreError;
use super::cache::{CacheLookup, ModelKey, ScoreCache};
use super::run::{ScoreProgress, ScoreRequest, score_scenario};

/// Finds or makes the score caches of scenarios for one checkpoint.
pub struct Scorer {
    checkpoint: PathBuf,
    key: ModelKey,
    detector: Option<Detector>,
}

impl Scorer {
    /// A scorer for `checkpoint`, hashed here for the cache keys (the model itself is
    /// loaded on first use).
    pub fn new(checkpoint: PathBuf) -> Result<Self, ScoreError> {
        let key = ModelKey::of_checkpoint(&checkpoint)?;
        Ok(Self {
            checkpoint,
            key,
            detector: None,
        })
    }

    /// The checkpoint this scorer scores with.
    pub fn checkpoint(&self) -> &Path {
        &self.checkpoint
    }

    /// The checkpoint's cache key.
    pub fn model_key(&self) -> ModelKey {
        self.key
    }

    /// The cache of `scenario` for `request`: current, missing or unusable
    /// ([`ScoreCache::find`]).
    pub fn find(
        &self,
        scenario: &Scenario,
        request: &ScoreRequest,
    ) -> Result<CacheLookup, ScoreError> {
        ScoreCache::find(scenario, &request.key(scenario, self.key)?)
    }

    /// The model, loaded now unless it is loaded already (for callers that would rather
    /// fail before they show progress).
    pub fn load_model(&mut self) -> Result<&Detector, ScoreError> {
        Ok(match &mut self.detector {
            Some(detector) => detector,
            slot => slot.insert(Detector::from_checkpoint(&self.checkpoint)?),
        })
    }

    /// Scores `scenario` for `request` now, loading the model unless it is loaded already;
    /// `progress` is called after each batch and `cancel` is checked between batches. The
    /// scenario's decoded frames are let go afterwards, scored or not: a caller going through
    /// many scenarios would otherwise keep each one's ([`Scenario::release_decoded`]).
    pub fn score(
        &mut self,
        scenario: &Scenario,
        request: &ScoreRequest,
        progress: &mut dyn FnMut(ScoreProgress),
        cancel: &AtomicBool,
    ) -> Result<ScoreCache, ScoreError> {
        let key = self.key;
        let detector = self.load_model()?;
        let scored = score_scenario(scenario, detector, key, request, progress, cancel);
        scenario.release_decoded();
        scored
    }
}
