//! Import of weights laid out as the reference PyTorch state dicts: the per-network
//! safetensors files of the parity fixtures and the official `.pth` checkpoints
//! (`torch.save({"model_state_dict": HFVAD.state_dict()})`, keys `memAE.*` / `vunet.*`).
//!
//! Both go through burn-store (`SafetensorsStore`, `PytorchStore`) with a key remapping from
//! the reference's module paths (`in_conv.conv.conv.0.weight`, `f_phi.blocks.s2_1…`) to
//! ours (`in_conv.conv1.weight`, `f_phi.blocks.2…`). BatchNorm `num_batches_tracked` is
//! ignored; `weight_g`/`weight_v` keep their names (our [`NormConv2d`](super::layers::NormConv2d)
//! holds the same pair). A reference checkpoint does not store its config: the sizes are
//! read off the tensor shapes, λ is set to 1/slots (the reference's pairing) and dropout to
//! 0.1 (neither changes inference).

use std::collections::BTreeMap;
use std::path::Path;

use burn::store::{KeyRemapper, ModuleSnapshot, ModuleStore, PytorchStore, SafetensorsStore};
use burn::tensor::Device;

use super::config::{InputConventions, ModelConfig, SkipOp};
use super::error::ModelError;
use super::hf2vad::Hf2Vad;
use super::memae::MlMemAeSc;
use super::rng::NoiseRng;
use super::vunet::Vunet;

/// Reference names of the four layers of a `double_conv` Sequential and ours.
const DOUBLE_CONV_LAYERS: [(usize, &str); 4] = [(0, "conv1"), (1, "bn1"), (3, "conv2"), (4, "bn2")];

/// (regex, replacement) pairs that rename ML-MemAE-SC keys found under the prefix `from`
/// (e.g. `""` or `"memAE."`) to our module paths under `to`.
pub fn memae_key_map(from: &str, to: &str) -> Vec<(String, String)> {
    let p = regex_escape(from);
    let mut map = Vec::new();
    for (index, name) in DOUBLE_CONV_LAYERS {
        map.push((
            format!(r"^{p}in_conv\.conv\.conv\.{index}\."),
            format!("{to}in_conv.{name}."),
        ));
        map.push((
            format!(r"^{p}(down_\d)\.mpconv\.1\.conv\.{index}\."),
            format!("{to}${{1}}.double.{name}."),
        ));
        map.push((
            format!(r"^{p}(up_\d)\.conv\.conv\.{index}\."),
            format!("{to}${{1}}.double.{name}."),
        ));
    }
    map.push((
        format!(r"^{p}(down_\d)\.mpconv\.0\."),
        format!("{to}${{1}}.conv."),
    ));
    map.push((format!(r"^{p}(up_\d)\.up\."), format!("{to}${{1}}.up.")));
    map.push((format!(r"^{p}out_conv\.conv\."), format!("{to}out_conv.")));
    map.push((
        format!(r"^{p}(mem\d)\.memMatrix$"),
        format!("{to}${{1}}.slots"),
    ));
    map
}

/// (regex, replacement) pairs that rename VUNet keys found under `from` (e.g. `""` or
/// `"vunet."`) to our module paths under `to`, for a network of `n` stages.
pub fn vunet_key_map(n: usize, from: &str, to: &str) -> Vec<(String, String)> {
    let p = regex_escape(from);
    let mut map = Vec::new();
    for stage in 1..=n {
        for block in 1..=2 {
            map.push((
                format!(r"^{p}(f_phi|e_theta)\.blocks\.s{stage}_{block}\."),
                format!("{to}${{1}}.blocks.{}.", 2 * (stage - 1) + block - 1),
            ));
        }
        if stage > 1 {
            map.push((
                format!(r"^{p}(f_phi|e_theta)\.downs\.s{stage}\."),
                format!("{to}${{1}}.downs.{}.", stage - 2),
            ));
        }
    }
    map.push((
        format!(r"^{p}(f_phi|e_theta)\.in_op\."),
        format!("{to}${{1}}.in_op."),
    ));
    map.push((format!(r"^{p}zc\."), format!("{to}zc.")));

    for (scale, stage) in [n, n - 1].into_iter().enumerate() {
        for (offset, block) in [(0, 2), (1, 1)] {
            map.push((
                format!(r"^{p}bottleneck\.blocks\.s{stage}_{block}\."),
                format!("{to}bottleneck.blocks.{}.", 2 * scale + offset),
            ));
        }
        map.push((
            format!(r"^{p}bottleneck\.channel_norm\.s{stage}\."),
            format!("{to}bottleneck.channel_norm.{scale}."),
        ));
    }
    map.push((
        format!(r"^{p}bottleneck\.auto_blocks\.0\."),
        format!("{to}bottleneck.auto_first."),
    ));
    for i in 1..=3 {
        map.push((
            format!(r"^{p}bottleneck\.auto_blocks\.{i}\."),
            format!("{to}bottleneck.auto_rest.{}.", i - 1),
        ));
    }
    map.push((
        format!(r"^{p}bottleneck\.(conv1x1|up|param_converter)\."),
        format!("{to}bottleneck.${{1}}."),
    ));

    for (i, stage) in (1..=n.saturating_sub(2)).rev().enumerate() {
        map.push((
            format!(r"^{p}decoder\.ups\.s{}\.", stage + 1),
            format!("{to}decoder.ups.{i}."),
        ));
        for (offset, block) in [(0, 2), (1, 1)] {
            map.push((
                format!(r"^{p}decoder\.blocks\.s{stage}_{block}\."),
                format!("{to}decoder.blocks.{}.", 2 * i + offset),
            ));
        }
    }
    map.push((
        format!(r"^{p}decoder\.final_layer\."),
        format!("{to}decoder.final_layer."),
    ));
    map
}

/// Escapes the regex metacharacters of a key prefix (only `.` occurs in practice).
fn regex_escape(prefix: &str) -> String {
    let mut out = String::with_capacity(prefix.len() * 2);
    for c in prefix.chars() {
        if "\\.+*?()|[]{}^$".contains(c) {
            out.push('\\');
        }
        out.push(c);
    }
    out
}

fn remapper(path: &Path, pairs: Vec<(String, String)>) -> Result<KeyRemapper, ModelError> {
    KeyRemapper::from_patterns(pairs).map_err(|e| ModelError::load(path, format!("key map: {e}")))
}

/// Loads ML-MemAE-SC weights from a safetensors file with the reference's unprefixed keys
/// (`ML_MemAE_SC.state_dict()`, e.g. the parity fixture `memae.safetensors`).
pub fn load_memae_safetensors(net: &mut MlMemAeSc, path: &Path) -> Result<(), ModelError> {
    let mut store = SafetensorsStore::from_file(path).remap(remapper(path, memae_key_map("", ""))?);
    net.load_from(&mut store)
        .map_err(|e| ModelError::load(path, e))?;
    Ok(())
}

/// Loads CVAE weights from a safetensors file with the reference's unprefixed keys
/// (`VUnet.state_dict()`, e.g. the parity fixture `vunet.safetensors`).
pub fn load_vunet_safetensors(net: &mut Vunet, path: &Path) -> Result<(), ModelError> {
    let pairs = vunet_key_map(net.n_stages, "", "");
    let mut store = SafetensorsStore::from_file(path).remap(remapper(path, pairs)?);
    net.load_from(&mut store)
        .map_err(|e| ModelError::load(path, e))?;
    Ok(())
}

/// A PyTorch checkpoint opened at its `model_state_dict`.
fn open_checkpoint(
    path: &Path,
) -> Result<(PytorchStore, BTreeMap<String, Vec<usize>>), ModelError> {
    if !path.is_file() {
        return Err(ModelError::load(path, "no such file"));
    }
    let mut store = PytorchStore::from_file(path)
        .with_top_level_key("model_state_dict")
        .map_indices_contiguous(false);
    let shapes = store
        .get_all_tensors()
        .map_err(|e| ModelError::load(path, e))?
        .iter()
        .map(|(k, t)| (k.clone(), t.shape.as_slice().to_vec()))
        .collect();
    Ok((store, shapes))
}

/// The config of the reference model whose state dict (keys under `memae`/`vunet`) has
/// `shapes`; `None` for the vunet prefix reads only the ML-MemAE-SC part.
fn infer_config(
    path: &Path,
    shapes: &BTreeMap<String, Vec<usize>>,
    memae: &str,
    vunet: Option<&str>,
    conventions: InputConventions,
) -> Result<ModelConfig, ModelError> {
    let dim = |key: String, axis: usize| -> Result<usize, ModelError> {
        shapes
            .get(&key)
            .and_then(|s| s.get(axis).copied())
            .ok_or_else(|| ModelError::load(path, format!("missing tensor '{key}'")))
    };
    let mut config = ModelConfig::paper();
    config.preset = "reference-import".into();
    config.conventions = conventions;
    config.feature_root = dim(format!("{memae}in_conv.conv.conv.0.weight"), 0)?;
    let in_ch = dim(format!("{memae}in_conv.conv.conv.0.weight"), 1)?;
    if in_ch != 2 {
        return Err(ModelError::load(
            path,
            format!("ML-MemAE-SC takes {in_ch} input channels; vadscope supports one flow (2)"),
        ));
    }
    for level in 1..=3 {
        config.mem_usage[level] = shapes.contains_key(&format!("{memae}mem{level}.memMatrix"));
    }
    let slots = (1..=3)
        .find(|&l| config.mem_usage[l])
        .map(|l| dim(format!("{memae}mem{l}.memMatrix"), 0))
        .transpose()?;
    config.num_slots = slots.unwrap_or(1);
    config.shrink_thres = 1.0 / config.num_slots as f64;
    for level in 1..=3 {
        let fused = dim(format!("{memae}up_{level}.conv.conv.0.weight"), 1)?;
        let up_in = config.feature_root << level;
        config.skip_ops[level - 1] = if fused == up_in {
            SkipOp::Concat
        } else {
            SkipOp::None
        };
    }
    if let Some(v) = vunet {
        config.nf_start = dim(format!("{v}f_phi.in_op.conv.weight_v"), 0)?;
        config.nf_max = dim(format!("{v}zc.conv1x1.conv.weight_v"), 0)?;
        let motion = dim(format!("{v}e_theta.in_op.conv.weight_v"), 1)?;
        config.num_flows = motion / 2;
        config.clip_hist = config.num_flows;
        let stages = shapes
            .keys()
            .filter(|k| k.starts_with(&format!("{v}f_phi.downs.")) && k.ends_with(".conv.bias"))
            .count()
            + 1;
        config.patch_size = 1 << (stages + 1);
    }
    config
        .validate()
        .map_err(|e| ModelError::load(path, format!("inferred an unusable config: {e}")))?;
    Ok(config)
}

/// Imports a full HF²-VAD checkpoint of the reference code (`{"model_state_dict": ...}` with
/// `memAE.*` and `vunet.*` keys). The reference trains on BGR frames; pass the conventions
/// the weights were trained with (typically [`InputConventions::reference`]).
pub fn import_reference_checkpoint(
    path: &Path,
    conventions: InputConventions,
    device: &Device,
) -> Result<(Hf2Vad, ModelConfig), ModelError> {
    let (mut store, shapes) = open_checkpoint(path)?;
    if !shapes.keys().any(|k| k.starts_with("vunet.")) {
        return Err(ModelError::load(
            path,
            "no 'vunet.*' keys: a stage-1 (ML-MemAE-SC only) checkpoint; use \
             import_reference_memae",
        ));
    }
    let config = infer_config(path, &shapes, "memAE.", Some("vunet."), conventions)?;
    let mut model = Hf2Vad::new(&config, device, &mut NoiseRng::new(0))?;
    let mut pairs = memae_key_map("memAE.", "memae.");
    pairs.extend(vunet_key_map(config.n_stages(), "vunet.", "vunet."));
    store = store.remap(remapper(path, pairs)?);
    model
        .load_from(&mut store)
        .map_err(|e| ModelError::load(path, e))?;
    Ok((model, config))
}

/// Imports the ML-MemAE-SC of a reference checkpoint: a stage-1 file (unprefixed keys) or
/// the `memAE.*` part of a full one. The returned config has the paper's CVAE sizes.
pub fn import_reference_memae(
    path: &Path,
    conventions: InputConventions,
    device: &Device,
) -> Result<(MlMemAeSc, ModelConfig), ModelError> {
    let (store, shapes) = open_checkpoint(path)?;
    let prefix = if shapes.keys().any(|k| k.starts_with("memAE.")) {
        "memAE."
    } else {
        ""
    };
    let config = infer_config(path, &shapes, prefix, None, conventions)?;
    let mut net = MlMemAeSc::new(&config, device, &mut NoiseRng::new(0));
    let mut store = store.remap(remapper(path, memae_key_map(prefix, ""))?);
    net.load_from(&mut store)
        .map_err(|e| ModelError::load(path, e))?;
    Ok((net, config))
}
