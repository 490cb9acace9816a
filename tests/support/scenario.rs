//! Fixture scenarios written on the fly: [`ScenarioBuilder`], the one way the tests write a
//! scenario folder (through `ScenarioWriter`, as the generator does), and the moving square
//! most score and annotate tests run on.

use std::path::{Path, PathBuf};

use image::{Rgb, RgbImage};
use vadscope::sequence::{BoxRecord, FrameId, FrameRecord, ScenarioMeta, ScenarioWriter};

/// A scenario to write: its metadata and its frames, in the order given.
#[derive(Default)]
pub struct ScenarioBuilder {
    meta: ScenarioMeta,
    frames: Vec<FrameRecord>,
}

impl ScenarioBuilder {
    /// No frames yet, default metadata.
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets the metadata written to `scenario.json`.
    pub fn meta(mut self, meta: ScenarioMeta) -> Self {
        self.meta = meta;
        self
    }

    /// Appends `frames`.
    pub fn frames(mut self, frames: impl IntoIterator<Item = FrameRecord>) -> Self {
        self.frames.extend(frames);
        self
    }

    /// Writes the scenario into the folder `dir` and returns it.
    pub fn write(&self, dir: &Path) -> PathBuf {
        let writer = ScenarioWriter::create(dir, &self.meta).expect("create writer");
        for frame in &self.frames {
            writer.write_frame(frame).expect("write frame");
        }
        writer.finish().expect("finish")
    }
}

/// Width of the moving-square scenario's frames.
pub const SQUARE_W: u32 = 96;
/// Height of the moving-square scenario's frames.
pub const SQUARE_H: u32 = 64;
/// Side of the square.
pub const SQUARE: u32 = 16;

/// Left edge of the square in frame `k`: 8 + 4k, top edge 24.
pub fn square_x(k: u64) -> u32 {
    8 + 4 * k as u32
}

/// Frame `k` of the moving square: a square with vertical stripes 5 px wide (so that its
/// inside changes as it moves, as a textured car does) on a dark, faintly textured
/// background.
pub fn square_frame(k: u64) -> RgbImage {
    let x0 = square_x(k);
    RgbImage::from_fn(SQUARE_W, SQUARE_H, |x, y| {
        if (x0..x0 + SQUARE).contains(&x) && (24..24 + SQUARE).contains(&y) {
            if ((x - x0) / 5).is_multiple_of(2) {
                Rgb([220, 200, 180])
            } else {
                Rgb([120, 110, 100])
            }
        } else {
            let t = ((x * 7 + y * 13) % 5) as u8;
            Rgb([40 + t, 45 + t, 50 + t])
        }
    })
}

/// The ground-truth box of the square in frame `k`.
pub fn square_box(k: u64) -> BoxRecord {
    let x0 = square_x(k) as f32;
    BoxRecord {
        frame: FrameId(k),
        track_id: 5,
        x1: x0,
        y1: 24.0,
        x2: x0 + SQUARE as f32,
        y2: 24.0 + SQUARE as f32,
        class: 14,
        score: 1.0,
        anomalous: k >= 4,
    }
}

/// Frame `k` of the moving square as the writer takes it: [`square_frame`], its
/// ground-truth box [`square_box`], labelled anomalous from frame 4 on.
pub fn square_record(k: u64) -> FrameRecord {
    FrameRecord {
        boxes: vec![square_box(k)],
        anomalous: Some(k >= 4),
        ..FrameRecord::new(FrameId(k), square_frame(k))
    }
}

/// The moving square over `frames` frames ([`square_record`]), with default metadata.
pub fn square_scenario(frames: u64) -> ScenarioBuilder {
    ScenarioBuilder::new().frames((0..frames).map(square_record))
}
