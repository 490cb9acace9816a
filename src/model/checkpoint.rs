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
//! reader can still open it. The file is written to a scratch name and renamed into place,
//! in a canonical layout (header keys sorted, tensors stored in name order), so saving the
//! same model twice gives the same bytes: score caches key models by a hash of the file.

use std::collections::HashMap;
use std::fs::File;
use std::io::Read;
use std::path::Path;

use burn::module::Module;
use burn::store::{ModuleSnapshot, SafetensorsStore};
use burn::tensor::Device;

use crate::atomic_file::write_atomically;

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
    let mut store = SafetensorsStore::from_bytes(None)
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
        .map_err(|e| ModelError::save(path, e))?;
    let bytes = store.get_bytes().map_err(|e| ModelError::save(path, e))?;
    let bytes = canonical_bytes(&bytes).map_err(|reason| {
        ModelError::save(
            path,
            format!("unexpected safetensors from burn-store: {reason}"),
        )
    })?;
    // Atomic, so a crash leaves either the old checkpoint or the new one.
    write_atomically(path, &bytes).map_err(|e| ModelError::save(e.path, e.source))
}

/// A safetensors file re-laid out canonically: the header's keys (and those of
/// `__metadata__`) sorted, tensor data stored in name order, the header padded with spaces
/// to a multiple of 8 bytes. burn-store keeps both in hash maps, whose order changes from
/// run to run.
fn canonical_bytes(bytes: &[u8]) -> Result<Vec<u8>, String> {
    let mut reader = bytes;
    let (header, header_len) = read_header(&mut reader)?;
    let header = header
        .as_object()
        .ok_or_else(|| "header is not a JSON object".to_string())?;
    let data = &bytes[8 + header_len..];

    let mut names: Vec<&String> = header.keys().collect();
    names.sort();
    let mut out_header = serde_json::Map::new();
    let mut out_data = Vec::with_capacity(data.len());
    for name in names {
        let mut entry = header[name]
            .as_object()
            .cloned()
            .ok_or_else(|| format!("header entry '{name}' is not an object"))?;
        entry.sort_keys();
        if name != "__metadata__" {
            let (begin, end) = entry
                .get("data_offsets")
                .and_then(|o| o.as_array())
                .and_then(|o| Some((o.first()?.as_u64()?, o.get(1)?.as_u64()?)))
                .ok_or_else(|| format!("tensor '{name}' has no data offsets"))?;
            let slice = usize::try_from(begin)
                .ok()
                .zip(usize::try_from(end).ok())
                .and_then(|(begin, end)| data.get(begin..end))
                .ok_or_else(|| format!("tensor '{name}' runs past the end of the data"))?;
            let new_begin = out_data.len();
            out_data.extend_from_slice(slice);
            entry.insert(
                "data_offsets".into(),
                serde_json::json!([new_begin, out_data.len()]),
            );
        }
        out_header.insert(name.clone(), serde_json::Value::Object(entry));
    }
    let mut header_bytes = serde_json::to_vec(&out_header).map_err(|e| e.to_string())?;
    header_bytes.resize(header_bytes.len().next_multiple_of(8), b' ');
    let mut out = Vec::with_capacity(8 + header_bytes.len() + out_data.len());
    out.extend_from_slice(&(header_bytes.len() as u64).to_le_bytes());
    out.extend_from_slice(&header_bytes);
    out.extend_from_slice(&out_data);
    Ok(out)
}

/// The JSON header at the start of a safetensors stream and its length in bytes, leaving
/// `reader` at the first byte of tensor data.
fn read_header(reader: &mut impl Read) -> Result<(serde_json::Value, usize), String> {
    let mut len = [0u8; 8];
    reader
        .read_exact(&mut len)
        .map_err(|e| format!("not a safetensors file: {e}"))?;
    let len = u64::from_le_bytes(len);
    if len > MAX_HEADER {
        return Err(format!("safetensors header of {len} bytes is implausible"));
    }
    let mut header = vec![0u8; len as usize];
    reader
        .read_exact(&mut header)
        .map_err(|e| format!("truncated safetensors header: {e}"))?;
    let header = serde_json::from_slice(&header)
        .map_err(|e| format!("safetensors header is not JSON: {e}"))?;
    Ok((header, len as usize))
}

/// The `__metadata__` map of a safetensors file's header.
fn read_header_metadata(path: &Path) -> Result<HashMap<String, String>, ModelError> {
    let mut file = File::open(path).map_err(|e| ModelError::load(path, e))?;
    let (header, _) = read_header(&mut file).map_err(|reason| ModelError::load(path, reason))?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{BoxFilter, Detector, FlowUnits};

    #[test]
    fn options_beyond_the_paper_survive_a_checkpoint_and_drive_inference() {
        let mut config = ModelConfig::parity();
        config.conventions.flow_units = FlowUnits::Patch;
        config.box_filter = BoxFilter::DRIVING;
        config.joint_flows = true;
        let device = Device::flex();
        let model = Hf2Vad::new(&config, &device, &mut NoiseRng::new(4)).expect("model");
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("joint.safetensors");
        let meta = CheckpointMeta {
            config: config.clone(),
            stats: None,
            note: None,
        };
        save_checkpoint(&path, &model, &meta).expect("save");
        assert_eq!(read_checkpoint_meta(&path).expect("meta").config, config);

        let detector = Detector::from_checkpoint(&path).expect("load");
        assert_eq!(detector.config(), &config);
        let p = config.patch_size;
        let frames = vec![0.5; 2 * config.cube_frame_channels() * p * p];
        let flows = NoiseRng::new(5).normal_vec(2 * config.cube_flow_channels() * p * p, 0.0, 1.0);
        let out = detector.infer(&frames, &flows).expect("infer");
        assert_eq!(out.len(), 2);
        assert_eq!(
            out[0].recon_flows.len(),
            config.cube_flow_channels() * p * p
        );
        assert!(out.iter().all(|c| c.s_r.is_finite() && c.s_r > 0.0));

        // Frame-width flow units keep their reference width.
        config.conventions.flow_units = FlowUnits::FrameWidth { width: 768 };
        let meta = CheckpointMeta {
            config: config.clone(),
            ..meta
        };
        save_checkpoint(&path, &model, &meta).expect("save");
        assert_eq!(read_checkpoint_meta(&path).expect("meta").config, config);
    }
}
