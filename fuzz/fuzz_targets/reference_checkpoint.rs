//! Checkpoints of the reference PyTorch code (`.pth`: a zip of pickles, or a legacy pickle):
//! the shapes read and the config inferred from them, then the weights.
#![no_main]
use burn::tensor::Device;
use libfuzzer_sys::fuzz_target;
use vadscope::model::weights::{import_reference_checkpoint, import_reference_memae};
use vadscope::model::{FlowUnits, InputConventions};
use vadscope_fuzz::scratch_file;

fuzz_target!(|bytes: &[u8]| {
    let path = scratch_file("reference.pth", bytes);
    let conventions = InputConventions::reference(FlowUnits::NativePixels);
    let _ = import_reference_checkpoint(&path, conventions, &Device::flex());
    let _ = import_reference_memae(&path, conventions, &Device::flex());
});
