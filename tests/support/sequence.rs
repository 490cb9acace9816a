//! Helpers of the sequence tests: small frames and the files of hand-made scenarios (the
//! scenarios themselves are written with [`super::scenario::ScenarioBuilder`]).

use std::path::Path;

use image::{GrayImage, Luma, Rgb, RgbImage};
use vadscope::sequence::{FrameId, FrameRecord};

/// Frame width used by the tests.
pub const W: u32 = 16;
/// Frame height used by the tests.
pub const H: u32 = 12;

/// An RGB frame whose pixels encode the frame number, so frames can be told apart.
pub fn rgb_frame(k: u64) -> RgbImage {
    RgbImage::from_fn(W, H, |x, y| Rgb([x as u8, y as u8, k as u8]))
}

/// A frame record with only an RGB image ([`rgb_frame`]).
pub fn rgb_only(id: u64) -> FrameRecord {
    FrameRecord::new(FrameId(id), rgb_frame(id))
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
