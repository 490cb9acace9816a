//! The per-scenario flow cache: DIS flow for the frames of a [`Scenario`], stored as KITTI
//! 16-bit PNG in `<scenario cache dir>/flow/<preset>/OPTICAL_FLOW_<frame id>.png`.
//!
//! The cache dir is `<scenario>/.vadscope/` (or a per-user folder when the scenario is
//! read-only, see [`Scenario::cache_dir`]); source data is never written. Filling is
//! resumable: files that already exist with the right size are kept, and each new file is
//! written to a temporary name, flushed and renamed, so an interrupted run never leaves a
//! half-written flow behind. Frame 0 has no predecessor and gets no file (HF²-VAD treats
//! its flow as zero).
//!
//! Every pair is estimated on its own (no temporal prior), so a cached file does not depend
//! on the thread count, on which frames were cached before, or on interruptions.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::dis::DisFlow;
use super::error::FlowError;
use super::params::DisPreset;
use crate::atomic_file::remove_stale_temporaries;
use crate::sequence::flow_file::{encode_kitti_png, probe_flow, read_kitti_png};
use crate::sequence::layout::benchmark_file_name;
use crate::sequence::{FlowField, Modality, Scenario};

/// Sub-folder of the scenario cache dir that holds the flow caches, one folder per preset.
pub const FLOW_CACHE_FOLDER: &str = "flow";

/// Which frames [`fill_flow_cache`] computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CacheScope {
    /// Only frames without a stored flow in the scenario (what the model needs).
    #[default]
    MissingOnly,
    /// Every frame from 1 on, also where the scenario stores a flow (to evaluate the
    /// estimator against ground truth).
    EveryFrame,
}

/// How to fill a flow cache. The default is the `medium` preset on every core, for frames
/// without stored flow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct FlowCacheOptions {
    /// DIS preset; each preset has its own cache folder.
    pub preset: DisPreset,
    /// Worker threads; 0 means one per core.
    pub threads: usize,
    /// Which frames to compute.
    pub scope: CacheScope,
}

/// What happened to one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrameOutcome {
    /// The flow was estimated and written.
    Computed,
    /// A valid cache file was already there and was kept.
    AlreadyCached,
}

/// Progress of [`fill_flow_cache`], reported once per frame (from worker threads, in
/// completion order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CacheProgress {
    /// Frames finished so far, this one included.
    pub done: usize,
    /// Frames this run handles.
    pub total: usize,
    /// Index of the frame just finished.
    pub frame: usize,
    /// What happened to it.
    pub outcome: FrameOutcome,
}

/// Summary of a [`fill_flow_cache`] run.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct CacheReport {
    /// The cache folder of the preset.
    pub folder: PathBuf,
    /// Frames of the scenario.
    pub frames: usize,
    /// Frames whose flow was estimated and written by this run.
    pub computed: usize,
    /// Frames whose cache file already existed.
    pub already_cached: usize,
    /// Frames skipped because the scenario stores their flow (scope `MissingOnly`).
    pub stored_in_scenario: usize,
}

/// The cache folder of `preset` for `scenario` (created if needed).
pub fn flow_cache_folder(scenario: &Scenario, preset: DisPreset) -> Result<PathBuf, FlowError> {
    let folder = scenario
        .cache_dir()?
        .join(FLOW_CACHE_FOLDER)
        .join(preset.name());
    std::fs::create_dir_all(&folder).map_err(|e| FlowError::File {
        path: folder.clone(),
        problem: format!("cannot create the flow cache folder: {e}"),
    })?;
    Ok(folder)
}

/// The cache file of frame `index` in `folder` (whether or not it exists).
fn cache_file(scenario: &Scenario, folder: &Path, index: usize) -> Result<PathBuf, FlowError> {
    let id = scenario.frame_id(index).ok_or_else(|| FlowError::File {
        path: scenario.root().to_path_buf(),
        problem: format!(
            "frame index {index} is out of range (the scenario has {} frames)",
            scenario.len()
        ),
    })?;
    Ok(folder.join(benchmark_file_name(Modality::Flow, id)))
}

/// The cached flow into frame `index` (from frame `index − 1`) for `preset`, if the cache
/// holds it.
pub fn read_cached_flow(
    scenario: &Scenario,
    preset: DisPreset,
    index: usize,
) -> Result<Option<FlowField>, FlowError> {
    let folder = flow_cache_folder(scenario, preset)?;
    let path = cache_file(scenario, &folder, index)?;
    if !path.is_file() {
        return Ok(None);
    }
    Ok(Some(read_kitti_png(&path)?))
}

/// The flow into frame `index` for `preset`: read from the cache when it holds the frame,
/// else estimated with `dis` (which must be built from `preset`) and written to the cache,
/// so scoring and `vadscope flow` share one set of files and get identical flows.
pub fn cached_or_estimated_flow(
    scenario: &Scenario,
    preset: DisPreset,
    dis: &DisFlow,
    index: usize,
) -> Result<FlowField, FlowError> {
    let folder = flow_cache_folder(scenario, preset)?;
    let path = cache_file(scenario, &folder, index)?;
    if is_usable_cache_file(&path, scenario.resolution()) {
        return Ok(read_kitti_png(&path)?);
    }
    let flow = estimate_pair(scenario, dis, index)?;
    write_atomically(&path, &flow)?;
    // Read back what was stored, so a flow is the same (KITTI's 1/64 px steps) whether it
    // was just computed or found in the cache.
    Ok(read_kitti_png(&path)?)
}

fn estimate_pair(scenario: &Scenario, dis: &DisFlow, index: usize) -> Result<FlowField, FlowError> {
    if index == 0 {
        return Err(FlowError::File {
            path: scenario.root().to_path_buf(),
            problem: "frame 0 has no previous frame to estimate flow from".into(),
        });
    }
    let prev = scenario.rgb(index - 1)?;
    let next = scenario.rgb(index)?;
    dis.estimate(prev.as_ref(), next.as_ref(), None)
        .map_err(|source| FlowError::Frame {
            scenario: scenario.root().to_path_buf(),
            index,
            source: Box::new(source),
        })
}

/// Whether `path` is a cache file of the scenario's frame size (header check only).
fn is_usable_cache_file(path: &Path, size: (u32, u32)) -> bool {
    path.is_file() && probe_flow(path).is_ok_and(|dims| dims == size)
}

/// Computes and stores the DIS flow of every frame of `scenario` that `options.scope`
/// selects and the cache does not hold yet. `progress` is called once per selected frame.
///
/// On error, the files written so far stay (a later run resumes from them) and the first
/// error is returned.
pub fn fill_flow_cache(
    scenario: &Scenario,
    options: &FlowCacheOptions,
    progress: impl Fn(CacheProgress) + Sync,
) -> Result<CacheReport, FlowError> {
    let folder = flow_cache_folder(scenario, options.preset)?;
    remove_stale_temporaries(&folder);
    let frames = scenario.len();
    let stored = |i: usize| scenario.file(Modality::Flow, i).is_some();
    let selected: Vec<usize> = (1..frames)
        .filter(|&i| options.scope == CacheScope::EveryFrame || !stored(i))
        .collect();
    let stored_in_scenario = frames.saturating_sub(1) - selected.len();
    let dis = DisFlow::from_preset(options.preset);
    let size = scenario.resolution();
    let done = AtomicUsize::new(0);
    let computed = AtomicUsize::new(0);
    let total = selected.len();
    let work = || {
        selected.par_iter().try_for_each(|&index| {
            let path = cache_file(scenario, &folder, index)?;
            let outcome = if is_usable_cache_file(&path, size) {
                FrameOutcome::AlreadyCached
            } else {
                let flow = estimate_pair(scenario, &dis, index)?;
                write_atomically(&path, &flow)?;
                computed.fetch_add(1, Ordering::Relaxed);
                FrameOutcome::Computed
            };
            let done = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(CacheProgress {
                done,
                total,
                frame: index,
                outcome,
            });
            Ok::<(), FlowError>(())
        })
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads)
        .build()
        .map_err(|e| FlowError::InvalidParams {
            problem: format!("cannot start {} worker threads: {e}", options.threads),
        })?
        .install(work)?;
    let computed = computed.into_inner();
    Ok(CacheReport {
        folder,
        frames,
        computed,
        already_cached: total - computed,
        stored_in_scenario,
    })
}

/// Stores `flow` at `path` as a KITTI PNG, atomically ([`crate::atomic_file`]): `path`
/// is either absent or complete.
fn write_atomically(path: &Path, flow: &FlowField) -> Result<(), FlowError> {
    let bytes = encode_kitti_png(path, flow)?;
    crate::atomic_file::write_atomically(path, &bytes).map_err(|e| FlowError::File {
        path: e.path,
        problem: e.source.to_string(),
    })
}
