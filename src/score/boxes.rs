//! Where the boxes of the scored objects come from ([`BoxSource`]), a per-frame reader of
//! any source ([`BoxProvider`]), and box IoU of a source against the ground truth
//! ([`match_boxes`], [`BoxMatchStats`]).
//!
//! Not to be confused with [`crate::sequence::BoxSource`], which only says where a
//! scenario's *ground-truth* boxes are read from (file or instance images).
//!
//! Matching is greedy: all (truth, predicted) pairs with IoU > 0 in order of decreasing IoU
//! (ties: lower truth index, then lower predicted index), each box used at most once. For
//! the few, mostly separated vehicles of a driving frame this equals the optimal
//! (Hungarian) assignment except in rare chains of overlaps, and it is deterministic and
//! O(n·m·log) without an assignment solver.

use std::collections::HashMap;
use std::sync::Arc;

use image::RgbImage;
use serde::{Deserialize, Serialize};

use crate::sequence::{BoxRecord, Scenario};

use super::ScoreError;
use super::motion::{MotionParams, blur_frame, motion_boxes};
use crate::sequence::detections::{DetectionFile, DetectionTable};

/// Where the boxes of the scored objects come from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BoxSource {
    /// The scenario's ground truth ([`Scenario::boxes`]: `BBOX_2D`, else instance images).
    GroundTruth,
    /// The scenario's detector boxes ([`Scenario::detections`]: `BBOX_2D_DET/boxes.csv`).
    Detections,
    /// An imported detection file (MOT, COCO, YOLO, `boxes.csv`).
    Imported(DetectionFile),
    /// Detector-free foreground boxes from frame differences (needs no weights).
    Motion(MotionParams),
    /// The original HF²-VAD's boxes: those of `base`, followed by motion boxes found outside
    /// them.
    WithMotion {
        /// The detector boxes.
        base: Box<BoxSource>,
        /// Motion-box constants.
        motion: MotionParams,
    },
}

impl BoxSource {
    /// A short stable name for cache file names (letters, digits, `-`, `+`).
    pub fn key(&self) -> Result<String, ScoreError> {
        Ok(match self {
            Self::GroundTruth => "gt".into(),
            Self::Detections => "det".into(),
            Self::Imported(file) => file.key()?,
            Self::Motion(params) => params.key(),
            Self::WithMotion { base, motion } => format!("{}+{}", base.key()?, motion.key()),
        })
    }

    /// A name for tables and the GUI.
    pub fn label(&self) -> String {
        match self {
            Self::GroundTruth => "ground truth".into(),
            Self::Detections => "detections (BBOX_2D_DET)".into(),
            Self::Imported(file) => format!(
                "{} {}",
                file.format.name(),
                file.path.file_name().map_or_else(
                    || file.path.display().to_string(),
                    |n| n.to_string_lossy().into_owned()
                )
            ),
            Self::Motion(_) => "motion boxes".into(),
            Self::WithMotion { base, .. } => format!("{} + motion boxes", base.label()),
        }
    }
}

/// Reads the boxes of any [`BoxSource`] frame by frame; files are read once, blurred frames
/// of the motion boxes are kept for the neighbouring frames.
pub struct BoxProvider<'a> {
    scenario: &'a Scenario,
    kind: ProviderKind<'a>,
}

enum ProviderKind<'a> {
    GroundTruth,
    Detections,
    Imported(DetectionTable),
    Motion {
        params: MotionParams,
        base: Option<Box<BoxProvider<'a>>>,
        blurred: HashMap<usize, Arc<RgbImage>>,
    },
}

impl<'a> BoxProvider<'a> {
    /// A provider of `source` for `scenario` (imported files are read and assigned here).
    pub fn new(scenario: &'a Scenario, source: &BoxSource) -> Result<Self, ScoreError> {
        let kind = match source {
            BoxSource::GroundTruth => ProviderKind::GroundTruth,
            BoxSource::Detections => ProviderKind::Detections,
            BoxSource::Imported(file) => {
                let (w, h) = scenario.resolution();
                ProviderKind::Imported(DetectionTable::assign(
                    scenario,
                    file.read(w, h)?,
                    file.numbering,
                ))
            }
            BoxSource::Motion(params) => {
                params.validate()?;
                ProviderKind::Motion {
                    params: *params,
                    base: None,
                    blurred: HashMap::new(),
                }
            }
            BoxSource::WithMotion { base, motion } => {
                motion.validate()?;
                ProviderKind::Motion {
                    params: *motion,
                    base: Some(Box::new(BoxProvider::new(scenario, base)?)),
                    blurred: HashMap::new(),
                }
            }
        };
        Ok(Self { scenario, kind })
    }

    /// Detections of an imported file that belong to no frame of the scenario (0 for other
    /// sources).
    pub fn unmatched_detections(&self) -> usize {
        match &self.kind {
            ProviderKind::Imported(table) => table.unmatched,
            ProviderKind::Motion {
                base: Some(base), ..
            } => base.unmatched_detections(),
            _ => 0,
        }
    }

    /// The boxes of frame `index`.
    pub fn boxes(&mut self, index: usize) -> Result<Vec<BoxRecord>, ScoreError> {
        let scenario = self.scenario;
        match &mut self.kind {
            ProviderKind::GroundTruth => Ok(scenario.boxes(index)?),
            ProviderKind::Detections => Ok(scenario.detections(index)?),
            ProviderKind::Imported(table) => Ok(table.boxes(index)),
            ProviderKind::Motion {
                params,
                base,
                blurred,
            } => {
                let mut boxes = match base {
                    Some(base) => base.boxes(index)?,
                    None => Vec::new(),
                };
                let id = scenario.frame_id(index).ok_or_else(|| {
                    ScoreError::Invalid(format!(
                        "{}: frame index {index} is out of range ({} frames)",
                        scenario.root().display(),
                        scenario.len()
                    ))
                })?;
                let last = scenario.len() - 1;
                // Neighbours outside the scenario are reflected (frame −1 is frame 1), so
                // border frames still sum two differences and the threshold keeps its meaning.
                let before = if index > 0 { index - 1 } else { last.min(1) };
                let after = if index < last {
                    index + 1
                } else {
                    last.saturating_sub(1)
                };
                let wanted = [before, index, after];
                blurred.retain(|k, _| wanted.contains(k));
                let mut frames = Vec::with_capacity(3);
                for k in wanted {
                    let frame = match blurred.get(&k) {
                        Some(f) => f.clone(),
                        None => {
                            let f = Arc::new(blur_frame(
                                scenario.rgb(k)?.as_ref(),
                                params.gauss_kernel,
                            ));
                            blurred.insert(k, f.clone());
                            f
                        }
                    };
                    frames.push(frame);
                }
                let found = motion_boxes(id, &frames[0], &frames[1], &frames[2], params, &boxes)?;
                boxes.extend(found);
                Ok(boxes)
            }
        }
    }
}

/// Intersection over union of two boxes (x2/y2 exclusive); 0 when either is empty.
pub fn box_iou(a: &BoxRecord, b: &BoxRecord) -> f32 {
    let iw = (a.x2.min(b.x2) - a.x1.max(b.x1)).max(0.0);
    let ih = (a.y2.min(b.y2) - a.y1.max(b.y1)).max(0.0);
    let inter = iw * ih;
    let union =
        a.width().max(0.0) * a.height().max(0.0) + b.width().max(0.0) * b.height().max(0.0) - inter;
    if union > 0.0 && inter.is_finite() {
        inter / union
    } else {
        0.0
    }
}

/// One matched pair of a truth and a predicted box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxMatch {
    /// Index into the truth boxes.
    pub truth: usize,
    /// Index into the predicted boxes.
    pub predicted: usize,
    /// Their IoU (> 0).
    pub iou: f32,
}

/// Greedy one-to-one matching by decreasing IoU (see the module docs).
pub fn match_boxes(truth: &[BoxRecord], predicted: &[BoxRecord]) -> Vec<BoxMatch> {
    let mut pairs: Vec<BoxMatch> = truth
        .iter()
        .enumerate()
        .flat_map(|(t, a)| {
            predicted.iter().enumerate().filter_map(move |(p, b)| {
                let iou = box_iou(a, b);
                (iou > 0.0).then_some(BoxMatch {
                    truth: t,
                    predicted: p,
                    iou,
                })
            })
        })
        .collect();
    pairs.sort_by(|a, b| {
        b.iou
            .total_cmp(&a.iou)
            .then(a.truth.cmp(&b.truth))
            .then(a.predicted.cmp(&b.predicted))
    });
    let mut truth_used = vec![false; truth.len()];
    let mut predicted_used = vec![false; predicted.len()];
    pairs
        .into_iter()
        .filter(|m| {
            let free = !truth_used[m.truth] && !predicted_used[m.predicted];
            if free {
                truth_used[m.truth] = true;
                predicted_used[m.predicted] = true;
            }
            free
        })
        .collect()
}

/// Box agreement of a source with the ground truth, accumulated over frames.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BoxMatchStats {
    /// A match counts as found when its IoU reaches this.
    pub iou_threshold: f32,
    /// Frames added.
    pub frames: u64,
    /// Ground-truth boxes.
    pub truth_boxes: u64,
    /// Predicted boxes.
    pub predicted_boxes: u64,
    /// Matches with IoU ≥ `iou_threshold`.
    pub found: u64,
    /// Sum over truth boxes of the IoU of their match (0 when unmatched).
    pub iou_sum: f64,
}

impl BoxMatchStats {
    /// Empty statistics counting matches at `iou_threshold` (0.5 is the usual value).
    pub fn new(iou_threshold: f32) -> Self {
        Self {
            iou_threshold,
            frames: 0,
            truth_boxes: 0,
            predicted_boxes: 0,
            found: 0,
            iou_sum: 0.0,
        }
    }

    /// Adds one frame.
    pub fn add_frame(&mut self, truth: &[BoxRecord], predicted: &[BoxRecord]) {
        let matches = match_boxes(truth, predicted);
        self.frames += 1;
        self.truth_boxes += truth.len() as u64;
        self.predicted_boxes += predicted.len() as u64;
        self.found += matches
            .iter()
            .filter(|m| m.iou >= self.iou_threshold)
            .count() as u64;
        self.iou_sum += matches.iter().map(|m| f64::from(m.iou)).sum::<f64>();
    }

    /// Adds the counts of `other` (same threshold assumed).
    pub fn merge(&mut self, other: &BoxMatchStats) {
        self.frames += other.frames;
        self.truth_boxes += other.truth_boxes;
        self.predicted_boxes += other.predicted_boxes;
        self.found += other.found;
        self.iou_sum += other.iou_sum;
    }

    /// Mean IoU of the ground-truth boxes with their match (0 for unmatched ones); `None`
    /// without ground-truth boxes.
    pub fn mean_iou(&self) -> Option<f64> {
        (self.truth_boxes > 0).then(|| self.iou_sum / self.truth_boxes as f64)
    }

    /// Fraction of ground-truth boxes found at the threshold.
    pub fn recall(&self) -> Option<f64> {
        (self.truth_boxes > 0).then(|| self.found as f64 / self.truth_boxes as f64)
    }

    /// Fraction of predicted boxes that found a ground-truth box at the threshold.
    pub fn precision(&self) -> Option<f64> {
        (self.predicted_boxes > 0).then(|| self.found as f64 / self.predicted_boxes as f64)
    }
}

/// Box agreement of `source` with the ground truth of `scenario` over all its frames.
pub fn match_scenario(
    scenario: &Scenario,
    source: &BoxSource,
    iou_threshold: f32,
) -> Result<BoxMatchStats, ScoreError> {
    let mut provider = BoxProvider::new(scenario, source)?;
    let mut stats = BoxMatchStats::new(iou_threshold);
    for i in 0..scenario.len() {
        stats.add_frame(&scenario.boxes(i)?, &provider.boxes(i)?);
    }
    Ok(stats)
}
