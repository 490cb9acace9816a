//! Readers of imported detection (or tracking) files and their assignment to the frames of
//! a scenario:
//!
//! | format | file | row / entry | frame key |
//! |---|---|---|---|
//! | [`DetectionFormat::BoxesCsv`] | AnoVox `boxes.csv` | `frame,track_id,x1,y1,x2,y2,class,score,anomalous` | AnoVox frame id |
//! | [`DetectionFormat::Mot`] | MOTChallenge `gt.txt` / `det.txt` | `frame,id,left,top,width,height[,conf[,class[,...]]]` | frame number, see [`FrameNumbering`] |
//! | [`DetectionFormat::Coco`] | COCO JSON: a results array, or a dataset object with `images` and `annotations` | `bbox` = [x, y, w, h] | `images[].file_name` when present, else `image_id` by [`FrameNumbering`] |
//! | [`DetectionFormat::Yolo`] | a folder of YOLO `.txt` files, one per frame (or one file) | `class cx cy w h [conf [track_id]]`, normalised to [0, 1] | file stem |
//!
//! A file stem names a frame when it equals the stem of a frame's RGB file, else through the
//! integer after its last `_` (or its digits), read as an AnoVox frame id. Rows whose frame
//! is not in the scenario are counted, not fatal. Malformed rows are errors naming the file
//! and line; unknown track ids (MOT's −1) become track 0, unknown classes class 0.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

mod parse;

pub use parse::{parse_coco, parse_mot, parse_yolo};

use super::error::SequenceError;
use super::scenario::Scenario;
use super::types::{BoxRecord, FrameId, Modality};

/// The format of a detection file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DetectionFormat {
    /// AnoVox / vadscope `boxes.csv` with a header.
    BoxesCsv,
    /// MOTChallenge `gt.txt` / `det.txt` (comma-separated, no header).
    Mot,
    /// COCO JSON (results array or dataset object).
    Coco,
    /// YOLO text files (normalised centre, size).
    Yolo,
}

impl DetectionFormat {
    /// Guesses the format: a folder or `.txt` file whose first data line has 5–7
    /// space-separated fields is YOLO; `.json` is COCO; a file whose first line starts with
    /// `frame,` is `boxes.csv`; other `.txt`/`.csv` files are MOT.
    pub fn guess(path: &Path) -> Result<Self, SequenceError> {
        if path.is_dir() {
            return Ok(Self::Yolo);
        }
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        if ext.as_deref() == Some("json") {
            return Ok(Self::Coco);
        }
        let text = std::fs::read_to_string(path).map_err(|e| SequenceError::io(path, e))?;
        let first = text
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'))
            .unwrap_or("");
        if first.starts_with("frame,") {
            Ok(Self::BoxesCsv)
        } else if !first.contains(',') && (5..=7).contains(&first.split_whitespace().count()) {
            Ok(Self::Yolo)
        } else if first.contains(',') {
            Ok(Self::Mot)
        } else {
            Err(SequenceError::format(
                path,
                "cannot tell the detection format (expected boxes.csv, MOT .txt, COCO .json or YOLO .txt)",
            ))
        }
    }

    /// Lowercase name, as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::BoxesCsv => "boxes-csv",
            Self::Mot => "mot",
            Self::Coco => "coco",
            Self::Yolo => "yolo",
        }
    }
}

/// How a frame *number* in a detection file (MOT frame, COCO `image_id` without images)
/// maps to a scenario frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrameNumbering {
    /// Number n is frame index n − 1 (MOTChallenge numbers image files from 1).
    #[default]
    OneBasedIndex,
    /// Number n is frame index n.
    ZeroBasedIndex,
    /// Number n is AnoVox frame id n.
    FrameId,
}

/// Which frame a detection belongs to, before it is matched to a scenario.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FrameRef {
    /// A frame number, read through a [`FrameNumbering`].
    Number(u64),
    /// An AnoVox frame id.
    Id(FrameId),
    /// A file stem (YOLO file name, COCO `file_name`).
    Stem(String),
}

/// One detection as read from a file (pixels, x2/y2 exclusive).
#[derive(Debug, Clone, PartialEq)]
pub struct RawDetection {
    /// The frame it belongs to.
    pub frame: FrameRef,
    /// The box; its `frame` field is set when it is assigned to a scenario frame.
    pub bbox: BoxRecord,
}

/// An imported detection file and how to read it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectionFile {
    /// The file (a folder for YOLO).
    pub path: PathBuf,
    /// Its format.
    pub format: DetectionFormat,
    /// How frame numbers map to frames (MOT, COCO results without images).
    pub numbering: FrameNumbering,
    /// Detections scoring below this are dropped.
    pub min_score: Option<f32>,
}

impl DetectionFile {
    /// A file of a guessed format with default numbering and no score limit.
    pub fn guess(path: &Path) -> Result<Self, SequenceError> {
        Ok(Self {
            path: path.to_path_buf(),
            format: DetectionFormat::guess(path)?,
            numbering: FrameNumbering::default(),
            min_score: None,
        })
    }

    /// Reads every detection (`width`×`height` scales YOLO's normalised boxes).
    pub fn read(&self, width: u32, height: u32) -> Result<Vec<RawDetection>, SequenceError> {
        let path = &self.path;
        let read = |p: &Path| std::fs::read_to_string(p).map_err(|e| SequenceError::io(p, e));
        let mut all = match self.format {
            DetectionFormat::BoxesCsv => crate::sequence::boxes::read_boxes(path)?
                .into_iter()
                .map(|b| RawDetection {
                    frame: FrameRef::Id(b.frame),
                    bbox: b,
                })
                .collect(),
            DetectionFormat::Mot => parse_mot(path, &read(path)?)?,
            DetectionFormat::Coco => parse_coco(path, &read(path)?)?,
            DetectionFormat::Yolo => {
                let files = if path.is_dir() {
                    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
                        .map_err(|e| SequenceError::io(path, e))?
                        .filter_map(Result::ok)
                        .map(|e| e.path())
                        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
                        .collect();
                    files.sort();
                    files
                } else {
                    vec![path.clone()]
                };
                let mut all = Vec::new();
                for file in files {
                    let stem = file
                        .file_stem()
                        .map(|s| s.to_string_lossy().into_owned())
                        .unwrap_or_default();
                    all.extend(parse_yolo(
                        &file,
                        &read(&file)?,
                        FrameRef::Stem(stem),
                        width,
                        height,
                    )?);
                }
                all
            }
        };
        if let Some(min) = self.min_score {
            all.retain(|d| d.bbox.score >= min);
        }
        Ok(all)
    }

    /// A short stable name for cache file names: format and a hash of the file contents and
    /// reading options, so a changed file gets a new cache.
    pub fn key(&self) -> Result<String, SequenceError> {
        let mut hash = crate::fnv::Fnv64::new();
        let mut add_file = |p: &Path| -> Result<(), SequenceError> {
            hash.write(&std::fs::read(p).map_err(|e| SequenceError::io(p, e))?);
            Ok(())
        };
        if self.path.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(&self.path)
                .map_err(|e| SequenceError::io(&self.path, e))?
                .filter_map(Result::ok)
                .map(|e| e.path())
                .collect();
            files.sort();
            for f in files.iter().filter(|f| f.is_file()) {
                add_file(f)?;
            }
        } else {
            add_file(&self.path)?;
        }
        hash.write(format!("{:?}{:?}", self.numbering, self.min_score).as_bytes());
        Ok(format!(
            "{}-{:08x}",
            self.format.name(),
            hash.finish() as u32
        ))
    }
}

/// Detections assigned to the frames of one scenario.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DetectionTable {
    /// Boxes per frame index (frames without detections are absent).
    pub by_frame: BTreeMap<usize, Vec<BoxRecord>>,
    /// Detections whose frame is not in the scenario.
    pub unmatched: usize,
}

impl DetectionTable {
    /// Assigns `detections` to the frames of `scenario` (see the module docs for keys).
    pub fn assign(
        scenario: &Scenario,
        detections: Vec<RawDetection>,
        numbering: FrameNumbering,
    ) -> Self {
        let stems: HashMap<String, usize> = (0..scenario.len())
            .filter_map(|i| {
                let stem = scenario.file(Modality::Rgb, i)?.file_stem()?;
                Some((stem.to_string_lossy().into_owned(), i))
            })
            .collect();
        let by_id = |id: u64| scenario.index_of(FrameId(id));
        let mut table = Self::default();
        for mut d in detections {
            let index = match &d.frame {
                FrameRef::Number(n) => match numbering {
                    FrameNumbering::OneBasedIndex => n.checked_sub(1).map(|i| i as usize),
                    FrameNumbering::ZeroBasedIndex => Some(*n as usize),
                    FrameNumbering::FrameId => by_id(*n),
                },
                FrameRef::Id(id) => scenario.index_of(*id),
                FrameRef::Stem(stem) => stems
                    .get(stem)
                    .copied()
                    .or_else(|| trailing_number(stem).and_then(by_id)),
            }
            .filter(|&i| i < scenario.len());
            match index.and_then(|i| Some((i, scenario.frame_id(i)?))) {
                Some((i, id)) => {
                    d.bbox.frame = id;
                    table.by_frame.entry(i).or_default().push(d.bbox);
                }
                None => table.unmatched += 1,
            }
        }
        table
    }

    /// The boxes of frame `index` (empty when it has none).
    pub fn boxes(&self, index: usize) -> Vec<BoxRecord> {
        self.by_frame.get(&index).cloned().unwrap_or_default()
    }
}

/// The integer after the last `_` of a stem, else its trailing digits (`RGB_IMG_0042` → 42,
/// `frame0042` → 42).
fn trailing_number(stem: &str) -> Option<u64> {
    let tail = stem.rsplit('_').next().unwrap_or(stem);
    tail.parse().ok().or_else(|| {
        let digits = stem.len() - stem.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        stem[stem.len() - digits..].parse().ok()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trailing_numbers_follow_anovox_names() {
        assert_eq!(trailing_number("RGB_IMG_0042"), Some(42));
        assert_eq!(trailing_number("frame0042"), Some(42));
        assert_eq!(trailing_number("000007"), Some(7));
        assert_eq!(trailing_number("image"), None);
    }

    #[test]
    fn mot_rows_become_boxes_with_defaults() {
        let text = "# comment\n1,3,10,20,30,40,0.9,2,1\n\n2,-1,5.5,6,7,8\n";
        let d = parse_mot(Path::new("det.txt"), text).expect("valid");
        assert_eq!(d.len(), 2);
        assert_eq!(d[0].frame, FrameRef::Number(1));
        let b = d[0].bbox;
        assert_eq!(
            (b.track_id, b.x1, b.y1, b.x2, b.y2, b.class),
            (3, 10.0, 20.0, 40.0, 60.0, 2)
        );
        assert!((b.score - 0.9).abs() < 1e-6);
        assert_eq!((d[1].bbox.track_id, d[1].bbox.score), (0, 1.0));
    }

    #[test]
    fn yolo_rows_scale_to_the_image() {
        let d = parse_yolo(
            Path::new("f.txt"),
            "2 0.5 0.5 0.25 0.5 0.7\n",
            FrameRef::Id(FrameId(1)),
            200,
            100,
        )
        .expect("valid");
        let b = d[0].bbox;
        assert_eq!(
            (b.x1, b.y1, b.x2, b.y2, b.class),
            (75.0, 25.0, 125.0, 75.0, 2)
        );
        let tracked = parse_yolo(
            Path::new("f.txt"),
            "2 0.5 0.5 0.25 0.5 0.7 12\n",
            FrameRef::Id(FrameId(1)),
            200,
            100,
        )
        .expect("valid");
        assert_eq!(tracked[0].bbox.track_id, 12);
        assert_eq!(b.track_id, 0);
    }
}
