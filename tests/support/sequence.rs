//! Helpers of the sequence tests: small scenarios written on the fly.

use std::path::{Path, PathBuf};

use image::{GrayImage, Luma, Rgb, RgbImage};
use vadscope::sequence::{FrameId, FrameRecord, ScenarioMeta, ScenarioWriter};

/// Frame width used by the tests.
pub const W: u32 = 16;
/// Frame height used by the tests.
pub const H: u32 = 12;

/// An RGB frame whose pixels encode the frame number, so frames can be told apart.
pub fn rgb_frame(k: u64) -> RgbImage {
    RgbImage::from_fn(W, H, |x, y| Rgb([x as u8, y as u8, k as u8]))
}

/// A frame record with only an RGB image.
pub fn rgb_only(id: u64) -> FrameRecord {
    FrameRecord {
        id: FrameId(id),
        rgb: rgb_frame(id),
        semantic: None,
        instance: None,
        depth_m: None,
        flow: None,
        action: None,
        anomaly: None,
        boxes: Vec::new(),
        anomalous: None,
    }
}

/// A semantic image of road (1) with a `class` block at x 4..8, y 3..7.
pub fn semantic_with_block(class: u8) -> GrayImage {
    GrayImage::from_fn(W, H, |x, y| {
        Luma([if (4..8).contains(&x) && (3..7).contains(&y) {
            class
        } else {
            1
        }])
    })
}

/// Writes `frames` through `ScenarioWriter` into `dir` and returns the folder.
pub fn write_scenario(dir: &Path, meta: &ScenarioMeta, frames: &[FrameRecord]) -> PathBuf {
    let writer = ScenarioWriter::create(dir, meta).expect("create writer");
    for frame in frames {
        writer.write_frame(frame).expect("write frame");
    }
    writer.finish().expect("finish")
}

/// Writes an 8-bit RGB PNG, creating the folder.
pub fn save_rgb(path: &Path, image: &RgbImage) {
    std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
    image.save(path).expect("save png");
}

/// Writes an 8-bit grey PNG, creating the folder.
pub fn save_gray(path: &Path, image: &GrayImage) {
    std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
    image.save(path).expect("save png");
}

/// Writes a text file, creating the folder.
pub fn save_text(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
    std::fs::write(path, text).expect("write text");
}

/// Asserts that an error message names the file (by file name) and contains `needle`.
pub fn assert_names(message: &str, file_name: &str, needle: &str) {
    assert!(
        message.contains(file_name),
        "error does not name {file_name}: {message}"
    );
    assert!(
        message.contains(needle),
        "error does not say {needle:?}: {message}"
    );
}
