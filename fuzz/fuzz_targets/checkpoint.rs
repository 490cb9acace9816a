//! vadscope checkpoints (`.safetensors` with the model config and statistics in the
//! header): the header alone, then the whole model as the viewer loads it.
#![no_main]
use burn::tensor::Device;
use libfuzzer_sys::fuzz_target;
use vadscope::model::checkpoint::{load_checkpoint, read_checkpoint_meta};
use vadscope_fuzz::scratch_file;

fuzz_target!(|bytes: &[u8]| {
    let path = scratch_file("model.safetensors", bytes);
    if read_checkpoint_meta(&path).is_ok() {
        let _ = load_checkpoint(&path, &Device::flex());
    }
});
