//! The files of an export: PNG images, streamed animated GIFs, `scores.csv`, and the
//! frame range clipped to the scenario.
//!
//! Every file is written atomically ([`crate::atomic_file`]): a process killed mid-export
//! leaves whole files and hidden temporaries, never a truncated image under its final name.

use std::cell::RefCell;
use std::io::{self, Cursor, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, ImageFormat, RgbaImage};

use crate::atomic_file::{AtomicFile, write_atomically};
use crate::render::{Provenance, scores_csv};
use crate::score::ScoreSeries;
use crate::score::ScoreTable;
use crate::sequence::Scenario;

use super::ExportError;

/// Time each frame of an exported GIF is shown (10 frames/s).
pub const GIF_FRAME_MS: u32 = 100;

/// Writes `image` as PNG at `path`, atomically.
pub fn write_png(image: &RgbaImage, path: &Path) -> Result<(), ExportError> {
    let mut bytes = Vec::new();
    image
        .write_to(&mut Cursor::new(&mut bytes), ImageFormat::Png)
        .map_err(|source| ExportError::Image {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(write_atomically(path, &bytes)?)
}

/// Writes the `scores.csv` of `series` (fused from `table`) with its provenance header.
pub fn write_scores_csv(
    path: &Path,
    table: &ScoreTable,
    series: &ScoreSeries,
    provenance: &Provenance,
) -> Result<(), ExportError> {
    Ok(write_atomically(
        path,
        scores_csv(table, series, provenance).as_bytes(),
    )?)
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
/// held in memory but the encoder's state) to a temporary file that replaces `path` only
/// on [`GifWriter::finish`]; dropped unfinished, it leaves any earlier file at `path` alone.
pub struct GifWriter {
    path: PathBuf,
    file: Rc<RefCell<AtomicFile>>,
    encoder: GifEncoder<SharedFile>,
}

/// The GIF's file, shared between the encoder, which writes the GIF trailer when it is
/// dropped, and the writer, which commits the file after that.
struct SharedFile(Rc<RefCell<AtomicFile>>);

impl Write for SharedFile {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        self.0.borrow_mut().write(bytes)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.0.borrow_mut().flush()
    }
}

impl GifWriter {
    /// Starts the file that will live at `path`.
    pub fn create(path: &Path) -> Result<Self, ExportError> {
        let file = AtomicFile::create(path)?;
        let file = Rc::new(RefCell::new(file));
        let mut encoder = GifEncoder::new_with_speed(SharedFile(Rc::clone(&file)), 10);
        encoder
            .set_repeat(Repeat::Infinite)
            .map_err(|source| ExportError::Image {
                path: path.to_path_buf(),
                source,
            })?;
        Ok(Self {
            path: path.to_path_buf(),
            file,
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

    /// Ends the GIF after the frames pushed so far and puts it in place at [`Self::path`].
    pub fn finish(self) -> Result<(), ExportError> {
        let Self {
            path,
            file,
            encoder,
        } = self;
        // The encoder writes the GIF trailer when it is dropped, and with it goes the
        // other handle on the file.
        drop(encoder);
        let file = Rc::try_unwrap(file)
            .map_err(|_| ExportError::io(&path, io::Error::other("the GIF file is still shared")))?
            .into_inner();
        Ok(file.commit()?)
    }
}
