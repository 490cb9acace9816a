//! vadscope's own model checkpoints: **one safetensors file** holding the weights (our module
//! paths) and, in the safetensors header's `__metadata__` map, everything needed to use them:
//!
//! | key | value |
//! |---|---|
//! | `vadscope.format` | `hf2vad-checkpoint/1` |
//! | `vadscope.config` | the [`ModelConfig`] as JSON, input conventions included |
//! | `vadscope.training_stats` | the [`TrainingStats`] as JSON (absent before they exist) |
//! | `vadscope.note` | free text (e.g. which stage and epoch produced the file) |
//!
//! A single file cannot drift apart from its config or statistics, and any safetensors
//! reader can still open it. The file is written to a scratch name and renamed into place.

use std::collections::HashMap;
use std::fs::File;
use std::io::Read;
use std::path::Path;

use burn::module::Module;
use burn::store::{ModuleSnapshot, SafetensorsStore};
use burn::tensor::Device;

use super::config::ModelConfig;
use super::error::ModelError;
use super::hf2vad::Hf2Vad;
use super::rng::NoiseRng;
use super::stats::TrainingStats;

/// Value of the `vadscope.format` metadata entry.
pub const CHECKPOINT_FORMAT: &str = "hf2vad-checkpoint/1";
const KEY_FORMAT: &str = "vadscope.format";
const KEY_CONFIG: &str = "vadscope.config";
const KEY_STATS: &str = "vadscope.training_stats";
const KEY_NOTE: &str = "vadscope.note";
/// Largest safetensors header we accept (the format's own limit is 100 MB).
const MAX_HEADER: u64 = 100_000_000;

/// The metadata of a checkpoint, readable without loading the weights.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckpointMeta {
    /// The model config (with input conventions).
    pub config: ModelConfig,
    /// Training statistics, if computed.
    pub stats: Option<TrainingStats>,
    /// Free-text note.
    pub note: Option<String>,
}

/// A loaded checkpoint.
#[derive(Debug, Clone)]
pub struct Checkpoint {
    /// The model, on the device it was loaded to.
    pub model: Hf2Vad,
    /// Config, statistics and note.
    pub meta: CheckpointMeta,
}

/// Writes `model` with its metadata to `path` (replacing an existing file).
pub fn save_checkpoint(
    path: &Path,
    model: &Hf2Vad,
    meta: &CheckpointMeta,
) -> Result<(), ModelError> {
    let config = serde_json::to_string(&meta.config).map_err(|e| ModelError::save(path, e))?;
    let mut store = SafetensorsStore::from_file(path)
        .overwrite(true)
        .metadata(KEY_FORMAT, CHECKPOINT_FORMAT)
        .metadata(KEY_CONFIG, config);
    if let Some(stats) = &meta.stats {
        let stats = serde_json::to_string(stats).map_err(|e| ModelError::save(path, e))?;
        store = store.metadata(KEY_STATS, stats);
    }
    if let Some(note) = &meta.note {
        store = store.metadata(KEY_NOTE, note.clone());
    }
    model
        .valid()
        .save_into(&mut store)
        .map_err(|e| ModelError::save(path, e))
}

/// The `__metadata__` map of a safetensors file's header.
fn read_header_metadata(path: &Path) -> Result<HashMap<String, String>, ModelError> {
    let mut file = File::open(path).map_err(|e| ModelError::load(path, e))?;
    let mut len = [0u8; 8];
    file.read_exact(&mut len)
        .map_err(|e| ModelError::load(path, format!("not a safetensors file: {e}")))?;
    let len = u64::from_le_bytes(len);
    if len > MAX_HEADER {
        return Err(ModelError::load(
            path,
            format!("safetensors header of {len} bytes is implausible"),
        ));
    }
    let mut header = vec![0u8; len as usize];
    file.read_exact(&mut header)
        .map_err(|e| ModelError::load(path, format!("truncated safetensors header: {e}")))?;
    let header: serde_json::Value = serde_json::from_slice(&header)
        .map_err(|e| ModelError::load(path, format!("safetensors header is not JSON: {e}")))?;
    let metadata = header
        .get("__metadata__")
        .and_then(|m| m.as_object())
        .map(|m| {
            m.iter()
                .filter_map(|(k, v)| v.as_str().map(|v| (k.clone(), v.to_string())))
                .collect()
        })
        .unwrap_or_default();
    Ok(metadata)
}

/// Reads a checkpoint's config, statistics and note without touching the weights.
pub fn read_checkpoint_meta(path: &Path) -> Result<CheckpointMeta, ModelError> {
    let metadata = read_header_metadata(path)?;
    match metadata.get(KEY_FORMAT).map(String::as_str) {
        Some(CHECKPOINT_FORMAT) => {}
        Some(other) => {
            return Err(ModelError::load(
                path,
                format!("unsupported checkpoint format '{other}' (expected {CHECKPOINT_FORMAT})"),
            ));
        }
        None => {
            return Err(ModelError::load(
                path,
                "not a vadscope checkpoint (no vadscope.format metadata); reference weights \
                 are imported with model::weights",
            ));
        }
    }
    let config_json = metadata
        .get(KEY_CONFIG)
        .ok_or_else(|| ModelError::load(path, "checkpoint has no vadscope.config"))?;
    let config: ModelConfig = serde_json::from_str(config_json)
        .map_err(|e| ModelError::load(path, format!("bad vadscope.config: {e}")))?;
    config.validate().map_err(|e| ModelError::load(path, e))?;
    let stats = metadata
        .get(KEY_STATS)
        .map(|s| serde_json::from_str(s))
        .transpose()
        .map_err(|e| ModelError::load(path, format!("bad vadscope.training_stats: {e}")))?;
    Ok(CheckpointMeta {
        config,
        stats,
        note: metadata.get(KEY_NOTE).cloned(),
    })
}

/// Loads a checkpoint onto `device` (a plain device gives an inference-ready model).
pub fn load_checkpoint(path: &Path, device: &Device) -> Result<Checkpoint, ModelError> {
    let meta = read_checkpoint_meta(path)?;
    let mut model = Hf2Vad::new(&meta.config, device, &mut NoiseRng::new(0))?;
    let mut store = SafetensorsStore::from_file(path);
    model
        .load_from(&mut store)
        .map_err(|e| ModelError::load(path, e))?;
    Ok(Checkpoint { model, meta })
}
