//! [`ValidationReport`]: what a scenario folder holds and what is wrong with it — frame
//! count, resolution, which modalities exist for which frames, id gaps, size mismatches and
//! unreadable files. Problems are listed, not fatal. Only headers are decoded (PNG headers,
//! `.flo`/`.npy` headers and file lengths), so validating a long scenario is fast.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;

use super::boxes::read_boxes;
use super::discovery::LayoutKind;
use super::flow_file::probe_flow;
use super::images::{ColorLayout, read_header};
use super::index::{FrameRun, IdGap};
use super::keyvalue::read_key_values;
use super::labels::{join_runs, read_frame_labels};
use super::layout::{BOXES_FILE, DETECTIONS_FILE, FRAME_LABELS_FILE};
use super::problem::FileProblem;
use super::scenario::Scenario;
use super::{FrameId, Modality, SequenceError};

/// How completely one modality covers the scenario's frames.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModalityCoverage {
    /// The modality.
    pub modality: Modality,
    /// The folder its files were read from.
    pub folder: Option<PathBuf>,
    /// Files that belong to a frame of the scenario.
    pub frames_with_file: usize,
    /// Frames (by index) without a file. For flow, frame 0 is not counted: flow into the
    /// first frame does not exist.
    pub missing: Vec<FrameRun>,
    /// Frame ids with a file of this modality but no RGB frame.
    pub without_rgb: Vec<FrameId>,
}

/// A file whose size differs from the scenario's frames.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct SizeMismatch {
    /// The file.
    pub path: PathBuf,
    /// Its modality.
    pub modality: Modality,
    /// Its width and height.
    pub size: (u32, u32),
    /// The scenario's frame size.
    pub expected: (u32, u32),
}

/// Everything validation found about one scenario.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValidationReport {
    /// The scenario folder.
    pub scenario: PathBuf,
    /// Its name.
    pub name: String,
    /// Benchmark or generator layout.
    pub layout: LayoutKind,
    /// Number of frames (RGB frames).
    pub frames: usize,
    /// First and last frame id.
    pub frame_ids: (FrameId, FrameId),
    /// Usual distance between consecutive ids.
    pub frame_step: u64,
    /// Frame size (of the first readable RGB frame).
    pub resolution: (u32, u32),
    /// Coverage of every modality that has at least one file.
    pub modalities: Vec<ModalityCoverage>,
    /// Holes in the id sequence.
    pub id_gaps: Vec<IdGap>,
    /// Files whose size differs from the frames.
    pub size_mismatches: Vec<SizeMismatch>,
    /// Files that cannot be read or have the wrong format.
    pub unreadable: Vec<FileProblem>,
    /// Other findings: skipped files, broken metadata, labels or boxes of unknown frames.
    pub notes: Vec<FileProblem>,
}

impl ValidationReport {
    /// True when nothing is missing, mismatched or unreadable and there are no gaps.
    pub fn is_clean(&self) -> bool {
        self.id_gaps.is_empty()
            && self.size_mismatches.is_empty()
            && self.unreadable.is_empty()
            && self
                .modalities
                .iter()
                .all(|m| m.missing.is_empty() && m.without_rgb.is_empty())
    }

    /// Number of listed problems (gaps, mismatches, unreadable files, coverage holes, notes).
    pub fn problem_count(&self) -> usize {
        self.id_gaps.len()
            + self.size_mismatches.len()
            + self.unreadable.len()
            + self.notes.len()
            + self
                .modalities
                .iter()
                .map(|m| m.missing.len() + m.without_rgb.len())
                .sum::<usize>()
    }

    /// A human-readable report.
    pub fn render_text(&self) -> String {
        let mut text = String::new();
        let (first, last) = self.frame_ids;
        let _ = writeln!(
            text,
            "{} ({:?} layout): {} frames, ids {first}-{last} (step {}), {}x{}",
            self.name,
            self.layout,
            self.frames,
            self.frame_step,
            self.resolution.0,
            self.resolution.1
        );
        for coverage in &self.modalities {
            let _ = write!(
                text,
                "  {:<13} {:>6} / {}",
                coverage.modality.folder(),
                coverage.frames_with_file,
                self.frames
            );
            if !coverage.missing.is_empty() {
                let _ = write!(text, "  missing {}", join_runs(&coverage.missing));
            }
            if !coverage.without_rgb.is_empty() {
                let ids: Vec<String> = coverage
                    .without_rgb
                    .iter()
                    .map(ToString::to_string)
                    .collect();
                let _ = write!(text, "  without RGB frame: ids {}", ids.join(", "));
            }
            text.push('\n');
        }
        for gap in &self.id_gaps {
            let _ = writeln!(
                text,
                "  gap after #{} : ids {} -> {} ({} frames missing)",
                gap.index, gap.after, gap.before, gap.missing
            );
        }
        for mismatch in &self.size_mismatches {
            let _ = writeln!(
                text,
                "  size mismatch: {} is {}x{}, frames are {}x{}",
                mismatch.path.display(),
                mismatch.size.0,
                mismatch.size.1,
                mismatch.expected.0,
                mismatch.expected.1
            );
        }
        for problem in &self.unreadable {
            let _ = writeln!(text, "  unreadable: {problem}");
        }
        for note in &self.notes {
            let _ = writeln!(text, "  note: {note}");
        }
        if self.is_clean() && self.notes.is_empty() {
            text.push_str("  no problems found\n");
        }
        text
    }
}

impl std::fmt::Display for ValidationReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render_text())
    }
}

/// What checking one file found.
enum FileCheck {
    Fine,
    Size(SizeMismatch),
    Unreadable(FileProblem),
}

impl Scenario {
    /// Validates the scenario: coverage per modality, id gaps, sizes and readability of
    /// every file (headers only), plus `boxes.csv`, `frame_labels.csv` and the notes from
    /// opening. An error only when no RGB frame is readable.
    pub fn validate(&self) -> Result<ValidationReport, SequenceError> {
        let expected = self.resolution();
        let files: Vec<(Modality, &Path)> = self
            .files()
            .frames
            .iter()
            .flat_map(|(modality, frames)| frames.values().map(move |p| (*modality, p.as_path())))
            .collect();
        let checks: Vec<(Modality, FileCheck)> = files
            .par_iter()
            .map(|(modality, path)| (*modality, check_file(*modality, path, expected)))
            .collect();
        let mut report = ValidationReport {
            scenario: self.root().to_path_buf(),
            name: self.name().to_string(),
            layout: self.layout(),
            frames: self.len(),
            frame_ids: (
                self.frame_id(0).unwrap_or(FrameId(0)),
                self.frame_id(self.len().saturating_sub(1))
                    .unwrap_or(FrameId(0)),
            ),
            frame_step: self.frame_index().step(),
            resolution: expected,
            modalities: self.coverage(),
            id_gaps: self.frame_index().gaps(),
            size_mismatches: Vec::new(),
            unreadable: Vec::new(),
            notes: self.notes().to_vec(),
        };
        let mut unreadable_rgb = 0;
        for (modality, check) in checks {
            match check {
                FileCheck::Fine => {}
                FileCheck::Size(mismatch) => report.size_mismatches.push(mismatch),
                FileCheck::Unreadable(problem) => {
                    unreadable_rgb += usize::from(modality == Modality::Rgb);
                    report.unreadable.push(problem);
                }
            }
        }
        if unreadable_rgb == self.len() {
            return Err(SequenceError::NotAScenario {
                path: self.root().to_path_buf(),
                problem: format!("none of the {} RGB frames can be read", self.len()),
            });
        }
        self.check_side_files(&mut report);
        Ok(report)
    }

    fn coverage(&self) -> Vec<ModalityCoverage> {
        let index = self.frame_index();
        self.files()
            .frames
            .iter()
            .map(|(modality, frames)| {
                let counted = |i: usize| !(*modality == Modality::Flow && i == 0);
                let missing = index.runs(|i| {
                    counted(i)
                        && index
                            .frame_id(i)
                            .is_some_and(|id| !frames.contains_key(&id))
                });
                ModalityCoverage {
                    modality: *modality,
                    folder: self.files().folders.get(modality).cloned(),
                    frames_with_file: frames
                        .keys()
                        .filter(|id| index.index_of(**id).is_some())
                        .count(),
                    missing,
                    without_rgb: frames
                        .keys()
                        .filter(|id| index.index_of(**id).is_none())
                        .copied()
                        .collect(),
                }
            })
            .collect()
    }

    /// Parses `boxes.csv` (ground truth and detections) and `frame_labels.csv` when present.
    fn check_side_files(&self, report: &mut ValidationReport) {
        for relative in [BOXES_FILE, DETECTIONS_FILE] {
            let path = self.root().join(relative);
            if !path.is_file() {
                continue;
            }
            match read_boxes(&path) {
                Ok(boxes) => {
                    let unknown: BTreeMap<FrameId, ()> = boxes
                        .iter()
                        .filter(|b| self.index_of(b.frame).is_none())
                        .map(|b| (b.frame, ()))
                        .collect();
                    if !unknown.is_empty() {
                        let ids: Vec<String> = unknown.keys().map(ToString::to_string).collect();
                        report.notes.push(FileProblem::new(
                            &path,
                            format!("boxes for frames that do not exist: {}", ids.join(", ")),
                        ));
                    }
                }
                Err(error) => report.unreadable.push(FileProblem::from_error(&error)),
            }
        }
        let labels = self.root().join(FRAME_LABELS_FILE);
        if labels.is_file()
            && let Err(error) = read_frame_labels(&labels)
        {
            report.unreadable.push(FileProblem::from_error(&error));
        }
    }
}

/// Checks one file's readability, format and size without decoding its pixels.
fn check_file(modality: Modality, path: &Path, expected: (u32, u32)) -> FileCheck {
    let size = match modality {
        Modality::Action | Modality::Anomaly => {
            return match read_key_values(path) {
                Ok(_) => FileCheck::Fine,
                Err(error) => FileCheck::Unreadable(FileProblem::from_error(&error)),
            };
        }
        Modality::Flow => probe_flow(path),
        _ => read_header(path).and_then(|header| {
            check_layout(modality, path, header.color)?;
            Ok((header.width, header.height))
        }),
    };
    match size {
        Ok(size) if size == expected => FileCheck::Fine,
        Ok(size) => FileCheck::Size(SizeMismatch {
            path: path.to_path_buf(),
            modality,
            size,
            expected,
        }),
        Err(error) => FileCheck::Unreadable(FileProblem::from_error(&error)),
    }
}

/// Whether an image's pixel layout suits its modality.
fn check_layout(modality: Modality, path: &Path, color: ColorLayout) -> Result<(), SequenceError> {
    let fits = match modality {
        Modality::Semantic => matches!(
            color,
            ColorLayout::L8 | ColorLayout::Rgb8 | ColorLayout::Rgba8
        ),
        Modality::Instance | Modality::Depth => {
            matches!(color, ColorLayout::Rgb8 | ColorLayout::Rgba8)
        }
        _ => true,
    };
    if fits {
        Ok(())
    } else {
        Err(SequenceError::format(
            path,
            format!(
                "{} image has unsupported pixel layout {color:?}",
                modality.folder()
            ),
        ))
    }
}
