//! The three seams a scoring run is written against: [`FrameBoxes`] (the boxes of a frame;
//! [`BoxProvider`] implements it), [`CubeSource`] (the cubes of a frame's boxes;
//! [`ScenarioCubes`] cuts them from a scenario with `model::stc`) and [`CubeScorer`] (the
//! model; [`Detector`] implements it). Each can be replaced in tests and by other callers
//! (model selection feeds cubes cut once).

use std::cell::RefCell;

use crate::flow::{FlowProvider, FlowSource};
use crate::model::stc::{Cube, CubeGeometry, cubes_at};
use crate::model::{BoxFilter, CubeResult, Detector, ModelError, TrainingStats};
use crate::sequence::{BoxRecord, Scenario};

use super::super::ScoreError;
use super::super::boxes::BoxProvider;

/// The boxes of each frame.
pub trait FrameBoxes {
    /// The boxes of frame `index`.
    fn boxes(&mut self, index: usize) -> Result<Vec<BoxRecord>, ScoreError>;
}

impl FrameBoxes for BoxProvider<'_> {
    fn boxes(&mut self, index: usize) -> Result<Vec<BoxRecord>, ScoreError> {
        BoxProvider::boxes(self, index)
    }
}

impl<F: FnMut(usize) -> Result<Vec<BoxRecord>, ScoreError>> FrameBoxes for F {
    fn boxes(&mut self, index: usize) -> Result<Vec<BoxRecord>, ScoreError> {
        self(index)
    }
}

/// The cubes of a frame's boxes.
pub trait CubeSource {
    /// Cubes of frame `index`, one per box of `boxes` whose crop is not empty, in box order.
    fn cubes(&mut self, index: usize, boxes: &[BoxRecord]) -> Result<Vec<Cube>, ScoreError>;
}

impl<F: FnMut(usize, &[BoxRecord]) -> Result<Vec<Cube>, ScoreError>> CubeSource for F {
    fn cubes(&mut self, index: usize, boxes: &[BoxRecord]) -> Result<Vec<Cube>, ScoreError> {
        self(index, boxes)
    }
}

/// The model as the run sees it.
pub trait CubeScorer {
    /// Patch side P.
    fn patch_size(&self) -> usize;
    /// Past frames per cube t.
    fn clip_hist(&self) -> usize;
    /// Training statistics (needed for frame scores).
    fn training_stats(&self) -> Option<TrainingStats>;
    /// Which boxes the model scores (those it was trained on); the rest are left out.
    fn box_filter(&self) -> BoxFilter {
        BoxFilter::KEEP_ALL
    }
    /// Scores B cubes: `frames` [B, 3(t+1), P, P] in [0, 1], `flows` [B, 2t, P, P].
    fn score(&self, frames: &[f32], flows: &[f32]) -> Result<Vec<CubeResult>, ModelError>;
}

impl CubeScorer for Detector {
    fn patch_size(&self) -> usize {
        self.config().patch_size
    }
    fn clip_hist(&self) -> usize {
        self.config().clip_hist
    }
    fn training_stats(&self) -> Option<TrainingStats> {
        Detector::training_stats(self).cloned()
    }
    fn box_filter(&self) -> BoxFilter {
        self.config().box_filter
    }
    fn score(&self, frames: &[f32], flows: &[f32]) -> Result<Vec<CubeResult>, ModelError> {
        self.infer(frames, flows)
    }
}

/// The cubes of a scenario's frames, cut by [`cubes_at`] from its frames and the flows of a
/// [`FlowProvider`].
pub struct ScenarioCubes<'a> {
    scenario: &'a Scenario,
    flows: FlowProvider<'a>,
    geometry: CubeGeometry,
}

impl<'a> ScenarioCubes<'a> {
    /// Cubes of `geometry` from `scenario`, flows from `flow`.
    pub fn new(scenario: &'a Scenario, flow: FlowSource, geometry: CubeGeometry) -> Self {
        Self {
            scenario,
            flows: FlowProvider::new(scenario, flow),
            geometry,
        }
    }
}

impl CubeSource for ScenarioCubes<'_> {
    fn cubes(&mut self, index: usize, boxes: &[BoxRecord]) -> Result<Vec<Cube>, ScoreError> {
        let scenario = self.scenario;
        let flows = &mut self.flows;
        // The cube builder speaks ModelError; our own errors (which name the file) are kept
        // aside and reported as they are.
        let own_error: RefCell<Option<ScoreError>> = RefCell::new(None);
        let keep = |e: ScoreError| {
            let message = e.to_string();
            own_error.borrow_mut().get_or_insert(e);
            ModelError::Cube(message)
        };
        let result = cubes_at(
            index,
            boxes,
            self.geometry,
            &mut |k| scenario.rgb(k).map_err(|e| keep(e.into())),
            &mut |k| flows.flow(k).map_err(|e| keep(e.into())),
        );
        result.map_err(|source| {
            own_error.take().unwrap_or_else(|| ScoreError::Model {
                scenario: scenario.root().to_path_buf(),
                frame: index,
                source,
            })
        })
    }
}
