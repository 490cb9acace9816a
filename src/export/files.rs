//! The files of an export: PNG images, streamed animated GIFs, `scores.csv`, and the
//! frame range clipped to the scenario.

use std::fs::File;
use std::io::BufWriter;
use std::ops::Range;
use std::path::{Path, PathBuf};

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbaImage};

use crate::render::{Provenance, scores_csv};
use crate::score::ScoreSeries;
use crate::score::ScoreTable;
use crate::sequence::Scenario;

use super::ExportError;

/// Time each frame of an exported GIF is shown (10 frames/s).
pub const GIF_FRAME_MS: u32 = 100;

/// Writes `image` as PNG at `path`.
pub fn write_png(image: &RgbaImage, path: &Path) -> Result<(), ExportError> {
    image.save(path).map_err(|source| ExportError::Image {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes the `scores.csv` of `series` (fused from `table`) with its provenance header.
pub fn write_scores_csv(
    path: &Path,
    table: &ScoreTable,
    series: &ScoreSeries,
    provenance: &Provenance,
) -> Result<(), ExportError> {
    std::fs::write(path, scores_csv(table, series, provenance))
        .map_err(|e| ExportError::io(path, e))
}

/// The frames of `range` clipped to the scenario (all of them for `None`); an error when
/// nothing is left.
pub fn frames_in(
    scenario: &Scenario,
    range: Option<&Range<usize>>,
) -> Result<Range<usize>, ExportError> {
    let n = scenario.len();
    let frames = match range {
        Some(r) => r.start.min(n)..r.end.min(n),
        None => 0..n,
    };
    if frames.is_empty() {
        let asked = range.cloned().unwrap_or(0..0);
        return Err(ExportError::NoFrames {
            scenario: scenario.root().to_path_buf(),
            start: asked.start,
            end: asked.end,
            frames: n,
        });
    }
    Ok(frames)
}

/// An endlessly looping animated GIF at 10 frames/s, written frame by frame (nothing is
/// held in memory but the encoder's state).
pub struct GifWriter {
    path: PathBuf,
    encoder: GifEncoder<BufWriter<File>>,
}

impl GifWriter {
    /// Creates the file at `path`.
    pub fn create(path: &Path) -> Result<Self, ExportError> {
        let file = File::create(path).map_err(|e| ExportError::io(path, e))?;
        let mut encoder = GifEncoder::new_with_speed(BufWriter::new(file), 10);
        encoder
            .set_repeat(Repeat::Infinite)
            .map_err(|source| ExportError::Image {
                path: path.to_path_buf(),
                source,
            })?;
        Ok(Self {
            path: path.to_path_buf(),
            encoder,
        })
    }

    /// Appends one frame.
    pub fn push(&mut self, image: &RgbaImage) -> Result<(), ExportError> {
        let frame = Frame::from_parts(
            image.clone(),
            0,
            0,
            Delay::from_numer_denom_ms(GIF_FRAME_MS, 1),
        );
        self.encoder
            .encode_frame(frame)
            .map_err(|source| ExportError::Image {
                path: self.path.clone(),
                source,
            })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }
}
