//! Validation scenarios with anomalies as the judge of a model in training: the frame AUROC
//! that `vadscope eval` would report for the model on them (ground-truth boxes, the
//! reference protocol), computed in memory.
//!
//! The cubes are cut once, when the set is loaded, with the box filter and geometry of the
//! model being trained; each judgement then only runs the model over them, fuses the
//! scores with the default weights and evaluates, so judging costs about one inference pass
//! over the validation objects. `vadscope train --select-on` keeps the epoch it rates
//! highest ([`crate::train::selection`]).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use crate::flow::FlowSource;
use crate::model::stc::{Cube, CubeGeometry};
use crate::model::{BoxFilter, Detector, ModelConfig};
use crate::sequence::{BoxRecord, Scenario};
use crate::train::EpochJudge;

use super::ScoreError;
use super::boxes::{BoxProvider, BoxSource};
use super::cache::{CacheKey, ModelKey, REFERENCE_BATCH};
use super::evaluate::{Grouping, ScenarioScores, evaluate_table};
use super::fusion::{FrameMetricOptions, FusionWeights};
use super::run::{CubeSource, ScenarioCubes, ScoringPlan, score_table};

/// One validation scenario with its boxes and cubes cut.
struct ValidationScenario {
    scenario: Scenario,
    plan: ScoringPlan,
    /// Ground-truth boxes per frame, as scoring reads them (before the box filter).
    boxes: Vec<Vec<BoxRecord>>,
    /// Cubes per frame of the boxes the filter keeps.
    cubes: Vec<Vec<Cube>>,
}

/// Scenarios with anomalies whose pooled frame AUROC rates models of one configuration.
pub struct ValidationSet {
    scenarios: Vec<ValidationScenario>,
    geometry: CubeGeometry,
    box_filter: BoxFilter,
}

impl ValidationSet {
    /// Opens the scenario folders `folders` and cuts the cubes of their ground-truth boxes
    /// that `config`'s box filter keeps, flows from `flow`; `progress(done, total)` after
    /// each scenario. The scenarios together must hold both normal and anomalous frames
    /// after the first `clip_hist`.
    pub fn load(
        folders: &[PathBuf],
        config: &ModelConfig,
        flow: FlowSource,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Self, ScoreError> {
        let geometry = CubeGeometry::of(config);
        let mut scenarios = Vec::with_capacity(folders.len());
        let (mut normal, mut anomalous) = (0usize, 0usize);
        for (done, folder) in folders.iter().enumerate() {
            let scenario = Scenario::open(folder)?;
            let flags = &scenario.frame_labels().flags;
            for &flag in flags.iter().skip(config.clip_hist) {
                if flag {
                    anomalous += 1;
                } else {
                    normal += 1;
                }
            }
            let loaded = cut(scenario, config, geometry, flow)?;
            scenarios.push(loaded);
            progress(done + 1, folders.len());
        }
        if normal == 0 || anomalous == 0 {
            return Err(ScoreError::Invalid(format!(
                "the validation scenarios ({}) hold {normal} normal and {anomalous} anomalous \
                 frames; judging a model needs both (e.g. `vadscope generate --preset test`)",
                folders
                    .iter()
                    .map(|f| f.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        Ok(Self {
            scenarios,
            geometry,
            box_filter: config.box_filter,
        })
    }

    /// Cubes the model runs over per judgement.
    pub fn cubes(&self) -> usize {
        self.scenarios
            .iter()
            .map(|s| s.cubes.iter().map(Vec::len).sum::<usize>())
            .sum()
    }

    /// Scenarios in the set.
    pub fn len(&self) -> usize {
        self.scenarios.len()
    }

    /// Whether the set holds no scenario (never, once loaded).
    pub fn is_empty(&self) -> bool {
        self.scenarios.is_empty()
    }

    /// The pooled frame AUROC of `detector` (which must have training statistics and the
    /// geometry and box filter the set was cut for): the first `clip_hist` frames dropped,
    /// median filter 17 per scenario, default fusion weights.
    pub fn frame_auroc(&self, detector: &Detector) -> Result<f64, ScoreError> {
        let config = detector.config();
        if CubeGeometry::of(config) != self.geometry || config.box_filter != self.box_filter {
            return Err(ScoreError::Invalid(
                "the model's cube geometry or box filter differs from the one the validation \
                 cubes were cut for"
                    .into(),
            ));
        }
        let cancel = AtomicBool::new(false);
        let mut items = Vec::with_capacity(self.scenarios.len());
        for s in &self.scenarios {
            let mut boxes = |index: usize| Ok(s.boxes[index].clone());
            let mut cubes = |index: usize, _: &[BoxRecord]| Ok(s.cubes[index].clone());
            let table = score_table(&s.plan, &mut boxes, &mut cubes, detector, &cancel)?;
            items.push(ScenarioScores::from_table(
                &s.scenario,
                BoxSource::GroundTruth.label(),
                table,
                None,
            )?);
        }
        let rows = evaluate_table(
            &items,
            None,
            &FusionWeights::default(),
            &FrameMetricOptions::default(),
            Grouping::NONE,
        )?;
        rows.first()
            .and_then(|row| row.metrics.as_ref())
            .map(|m| m.auroc)
            .ok_or_else(|| ScoreError::Invalid("the validation frames hold a single class".into()))
    }
}

impl EpochJudge for ValidationSet {
    fn name(&self) -> &str {
        "validation frame AUROC"
    }

    fn judge(&mut self, detector: &Detector) -> Result<f64, String> {
        self.frame_auroc(detector).map_err(|e| e.to_string())
    }
}

/// The boxes and cubes of every frame of `scenario` as a scoring run with `config` cuts
/// them.
fn cut(
    scenario: Scenario,
    config: &ModelConfig,
    geometry: CubeGeometry,
    flow: FlowSource,
) -> Result<ValidationScenario, ScoreError> {
    let source = BoxSource::GroundTruth;
    let key = CacheKey {
        scenario: scenario.name().to_string(),
        // Never written: the key only names the in-memory table.
        model: ModelKey(0),
        boxes: source.key()?,
        flow: flow.key(),
    };
    let plan = ScoringPlan::of_scenario(&scenario, key, REFERENCE_BATCH, 1);
    let mut provider = BoxProvider::new(&scenario, &source)?;
    let mut boxes = Vec::with_capacity(scenario.len());
    for index in 0..scenario.len() {
        boxes.push(provider.boxes(index)?);
    }
    let mut cubes = Vec::with_capacity(scenario.len());
    {
        let mut source = ScenarioCubes::new(&scenario, flow, geometry);
        for (index, frame_boxes) in boxes.iter().enumerate() {
            let kept = config
                .box_filter
                .apply(frame_boxes.clone(), plan.frame_size);
            cubes.push(if kept.is_empty() {
                Vec::new()
            } else {
                source.cubes(index, &kept)?
            });
        }
    }
    Ok(ValidationScenario {
        scenario,
        plan,
        boxes,
        cubes,
    })
}
