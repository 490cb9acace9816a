//! The library side of `vadscope train`: gather the cubes of normal scenarios and run the
//! three stages on them.
//!
//! Cubes use the ground-truth boxes of each frame (`Scenario::boxes`) that the model's box
//! filter keeps, and the flows of a [`FlowSource`]: the ones the scenarios store, or DIS
//! estimates (the flow that data without stored flow is scored on, read from and written to
//! each scenario's flow cache); frames labelled anomalous and boxes
//! flagged anomalous are left out, so only normal behaviour is learnt. No cube comes from a
//! frame before `clip_hist`: those cubes would repeat frame 0 and hold the zero flow stored
//! there, a degenerate input scoring never weighs (its metrics skip those frames). Each
//! scenario is its own group for the validation split.

use std::path::{Path, PathBuf};

use crate::flow::{FlowProvider, FlowSource};
use crate::model::stc::{CubeGeometry, cubes_at};
use crate::model::{BoxFilter, ModelConfig, ModelError};
use crate::sequence::{Scenario, discover_scenarios};

use super::config::TrainConfig;
use super::cubes::CubeSet;
use super::error::TrainError;
use super::progress::{TrainEvent, TrainReport};
use super::selection::EpochJudge;
use super::stages::train_judged;

/// How cubes are taken from scenarios.
#[derive(Debug, Clone, PartialEq)]
pub struct CubeExtraction {
    /// Patch side P, history t and flow units of the cubes.
    pub geometry: CubeGeometry,
    /// Which boxes give cubes (the model's [`ModelConfig::box_filter`]).
    pub box_filter: BoxFilter,
    /// Use every n-th frame as a cube target, counted from frame `clip_hist` (1: all
    /// frames).
    pub frame_stride: usize,
    /// Leave out frames labelled anomalous and boxes flagged anomalous.
    pub normal_only: bool,
    /// Where the cubes' flows come from.
    pub flow: FlowSource,
}

impl CubeExtraction {
    /// Every frame of every scenario, normal objects only, sized for `config`.
    pub fn for_model(config: &ModelConfig) -> Self {
        Self {
            geometry: CubeGeometry::of(config),
            box_filter: config.box_filter,
            frame_stride: 1,
            normal_only: true,
            flow: FlowSource::Stored,
        }
    }
}

/// The scenario folders under each of `paths` (a scenario or a folder of scenarios).
pub fn scenario_folders(paths: &[PathBuf]) -> Result<Vec<PathBuf>, TrainError> {
    let mut folders = Vec::new();
    for path in paths {
        let found = discover_scenarios(path)
            .map_err(|e| TrainError::file(path, format!("no scenarios: {e}")))?;
        folders.extend(found);
    }
    folders.sort();
    folders.dedup();
    Ok(folders)
}

/// The cubes of the scenarios `folders`; `progress(done, total)` after each scenario.
pub fn cubes_from_scenarios(
    folders: &[PathBuf],
    extraction: &CubeExtraction,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<CubeSet, TrainError> {
    let geometry = extraction.geometry;
    let mut set = CubeSet::new(geometry.patch, geometry.clip_hist);
    for (group, folder) in folders.iter().enumerate() {
        let scenario = Scenario::open(folder)
            .map_err(|e| TrainError::file(folder, format!("cannot open scenario: {e}")))?;
        add_scenario(&mut set, &scenario, group as u32, extraction)?;
        progress(group + 1, folders.len());
    }
    Ok(set)
}

fn add_scenario(
    set: &mut CubeSet,
    scenario: &Scenario,
    group: u32,
    extraction: &CubeExtraction,
) -> Result<(), TrainError> {
    let labels = scenario.frame_labels();
    let first = extraction.geometry.clip_hist;
    let mut flows = FlowProvider::new(scenario, extraction.flow);
    // The cube builder speaks ModelError; every message names the scenario.
    let root = scenario.root().display().to_string();
    let cube_error = |e: &dyn std::fmt::Display| ModelError::Cube(e.to_string());
    let named = |e: ModelError| match e {
        ModelError::Cube(m) if !m.starts_with(&root) => ModelError::Cube(format!("{root}: {m}")),
        other => other,
    };
    for index in (first..scenario.len()).step_by(extraction.frame_stride.max(1)) {
        if extraction.normal_only && labels.is_anomalous(index) {
            continue;
        }
        let boxes: Vec<_> = scenario
            .boxes(index)
            .map_err(|e| TrainError::file(scenario.root(), e))?
            .into_iter()
            .filter(|b| !(extraction.normal_only && b.anomalous))
            .collect();
        let boxes = extraction.box_filter.apply(boxes, scenario.resolution());
        let cubes = cubes_at(
            index,
            &boxes,
            extraction.geometry,
            &mut |k| scenario.rgb(k).map_err(|e| cube_error(&e)),
            &mut |k| flows.flow(k).map_err(|e| cube_error(&e)),
        )
        .map_err(named)?;
        let width = scenario.resolution().0.max(1) as f32;
        for cube in cubes {
            let centre = 0.5 * (cube.bbox.x1 + cube.bbox.x2) / width;
            set.push(&cube.frames, &cube.flows, group, centre)?;
        }
    }
    Ok(())
}

/// What `vadscope train` asks for.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainRequest {
    /// Scenario folders, or folders of scenarios, of normal driving.
    pub data: Vec<PathBuf>,
    /// Where checkpoints, the resume state and the final `model.safetensors` go.
    pub out_dir: PathBuf,
    /// The model to train.
    pub model: ModelConfig,
    /// The training settings.
    pub train: TrainConfig,
    /// How cubes are taken from the scenarios (patch and history must match `model`).
    pub extraction: CubeExtraction,
    /// Reuse (or write) the extracted cubes here, e.g. `<out_dir>/cubes.safetensors`.
    pub cube_file: Option<PathBuf>,
    /// Start from this vadscope checkpoint instead of random weights (its config must be
    /// `model`).
    pub initial: Option<PathBuf>,
}

/// Extracts (or loads) the cubes of `request.data` and trains on them; see
/// [`train`](super::stages::train) for the stages, checkpoints and resume, and
/// [`train_judged`] for `judge` (required exactly when `request.train` selects by one).
pub fn train_from_scenarios(
    request: &TrainRequest,
    judge: Option<&mut dyn EpochJudge>,
    on_event: &mut dyn FnMut(&TrainEvent),
    on_extract: &mut dyn FnMut(usize, usize),
) -> Result<TrainReport, TrainError> {
    let cubes = match &request.cube_file {
        Some(path) if path.is_file() => CubeSet::load(path)?,
        cube_file => {
            let folders = scenario_folders(&request.data)?;
            if folders.is_empty() {
                return Err(TrainError::Data("no scenario folders given".into()));
            }
            let set = cubes_from_scenarios(&folders, &request.extraction, on_extract)?;
            if let Some(path) = cube_file {
                save_beside(path, &set)?;
            }
            set
        }
    };
    train_judged(
        request.initial.as_deref(),
        &request.model,
        &request.train,
        &cubes,
        &request.out_dir,
        judge,
        on_event,
    )
}

fn save_beside(path: &Path, set: &CubeSet) -> Result<(), TrainError> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| TrainError::io(parent, e))?;
    }
    set.save(path)
}
