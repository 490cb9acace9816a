//! Helpers of the tests that train or run a model: the tiny network they use.

use vadscope::model::ModelConfig;

/// `base` shrunk to the tests' tiny network, named `test-tiny`: 16×16 cubes, 4 base
/// features, 8 memory slots, a CVAE of 8 to 16 features.
pub fn tiny_config(base: ModelConfig) -> ModelConfig {
    ModelConfig {
        preset: "test-tiny".into(),
        patch_size: 16,
        feature_root: 4,
        num_slots: 8,
        shrink_thres: 1.0 / 8.0,
        nf_start: 8,
        nf_max: 16,
        ..base
    }
}
