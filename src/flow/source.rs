//! Where the optical flow of the cubes comes from ([`FlowSource`]) and a per-frame reader of
//! it ([`FlowProvider`]): scoring and training cut their cubes from it.
//!
//! Stored flows are the scenario's `OPTICAL_FLOW` files ([`Scenario::flow`]). Estimated
//! flows come from the scenario's DIS flow cache (`.vadscope/flow/<preset>/`, filled by
//! `vadscope flow`), and frames the cache lacks are estimated with [`DisFlow`] from frame
//! i−1 to frame i and written to it, so a second scoring run, the viewer and `vadscope
//! flow` all read the same files. In memory only the frames a cube still needs are kept.

use std::collections::HashMap;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::sequence::Scenario;

use super::cache::cached_or_estimated_flow;
use super::{DisFlow, DisPreset, FlowError, FlowField};

/// Where the flows of the cubes come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FlowSource {
    /// The scenario's stored flows; a missing flow (other than at frame 0) is an error.
    Stored,
    /// Estimated with DIS at this preset, ignoring stored flows.
    Estimated(DisPreset),
    /// Stored where present, else estimated with DIS at this preset.
    StoredElseEstimated(DisPreset),
}

impl Default for FlowSource {
    /// Stored flows where the scenario has them, else DIS at the `medium` preset (the
    /// sample scenarios ship without flow).
    fn default() -> Self {
        Self::StoredElseEstimated(DisPreset::Medium)
    }
}

impl FlowSource {
    /// A short stable name for cache file names.
    pub fn key(&self) -> String {
        match self {
            Self::Stored => "stored".into(),
            Self::Estimated(p) => format!("dis-{}", p.name()),
            Self::StoredElseEstimated(p) => format!("stored-dis-{}", p.name()),
        }
    }
}

/// Estimated flows kept at most (the cubes of one frame need `clip_hist` of them).
const KEPT_ESTIMATES: usize = 8;

/// Reads the flow stored at (leading into) each frame from a [`FlowSource`].
pub struct FlowProvider<'a> {
    scenario: &'a Scenario,
    source: FlowSource,
    estimator: Option<DisFlow>,
    estimates: HashMap<usize, Arc<FlowField>>,
}

impl<'a> FlowProvider<'a> {
    /// A provider of `source` for `scenario`.
    pub fn new(scenario: &'a Scenario, source: FlowSource) -> Self {
        let estimator = match source {
            FlowSource::Stored => None,
            FlowSource::Estimated(p) | FlowSource::StoredElseEstimated(p) => {
                Some(DisFlow::from_preset(p))
            }
        };
        Self {
            scenario,
            source,
            estimator,
            estimates: HashMap::new(),
        }
    }

    /// The flow from frame `index − 1` to frame `index`; `None` at frame 0 when nothing is
    /// stored there (there is no previous frame), and for stored flows that are missing.
    pub fn flow(&mut self, index: usize) -> Result<Option<Arc<FlowField>>, FlowError> {
        if self.source != FlowSource::Stored
            && let Some(f) = self.estimates.get(&index)
        {
            return Ok(Some(f.clone()));
        }
        let stored = match self.source {
            FlowSource::Estimated(_) => None,
            _ => self.scenario.flow(index)?,
        };
        if stored.is_some() || index == 0 {
            return Ok(stored);
        }
        let (
            Some(estimator),
            FlowSource::Estimated(preset) | FlowSource::StoredElseEstimated(preset),
        ) = (&self.estimator, self.source)
        else {
            return Ok(None);
        };
        let flow = cached_or_estimated_flow(self.scenario, preset, estimator, index).map_err(
            |source| FlowError::Frame {
                scenario: self.scenario.root().to_path_buf(),
                index,
                source: Box::new(source),
            },
        )?;
        let flow = Arc::new(flow);
        self.estimates.insert(index, flow.clone());
        if self.estimates.len() > KEPT_ESTIMATES {
            let keep_from = index.saturating_sub(KEPT_ESTIMATES - 1);
            self.estimates.retain(|&k, _| k >= keep_from && k <= index);
        }
        Ok(Some(flow))
    }
}
