//! Every scored object of a scenario as one row ([`object_rows`], written as CSV by
//! [`write_object_csv`]; `vadscope eval --objects FILE`): its box, S_r, S_p and fused
//! score, whether it sets its frame's score and whether it is the ground-truth anomalous
//! object. A frame AUROC says *whether* a model flags anomaly frames; these rows say *which*
//! object it flags, the first thing to read when a model misses.

use std::fmt::Write as _;
use std::path::Path;

use crate::atomic_file::write_atomically;
use crate::sequence::{BoxRecord, Scenario};

use super::ScoreError;
use super::boxes::box_iou;
use super::cache::{ObjectScore, ScoreTable};
use super::fusion::{FrameFusion, FusionWeights};

/// One scored object.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectRow {
    /// Scenario folder name.
    pub scenario: String,
    /// Box source label (`ground truth`, `motion`, ...).
    pub box_source: String,
    /// Frame index.
    pub frame: usize,
    /// AnoVox frame id.
    pub frame_id: u64,
    /// Whether the frame is labelled anomalous.
    pub anomalous_frame: bool,
    /// The scored object (box, class, track, S_r, S_p).
    pub object: ObjectScore,
    /// Fused object score `w_r (S_r − μ_r)/σ_r + w_p (S_p − μ_p)/σ_p`.
    pub score: f64,
    /// Whether this object has the highest score of its frame (the frame's score).
    pub top: bool,
    /// Whether it is a ground-truth anomalous object of the frame.
    pub anomalous_object: bool,
}

/// Whether the scored `object` is one of the anomalous boxes among `truth`: the same track
/// (when the source has tracks) or IoU ≥ 0.5 with one.
pub fn is_anomalous_object(object: &ObjectScore, scored: &BoxRecord, truth: &[BoxRecord]) -> bool {
    truth.iter().filter(|b| b.anomalous).any(|b| {
        (object.track_id != 0 && b.track_id == object.track_id) || box_iou(b, scored) >= 0.5
    })
}

/// The rows of every object of `table` (scores of `scenario` from box source
/// `box_source`), fused with `weights`, in frame order.
pub fn object_rows(
    scenario: &Scenario,
    box_source: &str,
    table: &ScoreTable,
    weights: &FusionWeights,
) -> Result<Vec<ObjectRow>, ScoreError> {
    let fusion = FrameFusion::of_table(table, weights);
    let labels = scenario.frame_labels();
    let mut rows = Vec::with_capacity(table.objects.len());
    for (i, entry) in table.frames.iter().enumerate() {
        let objects = table.frame_objects(i);
        if objects.is_empty() {
            continue;
        }
        let truth = scenario.boxes(i)?;
        let top = fusion.top_object(objects);
        for (k, object) in objects.iter().enumerate() {
            let scored = object.box_record(entry.id);
            rows.push(ObjectRow {
                scenario: scenario.name().to_string(),
                box_source: box_source.to_string(),
                frame: i,
                frame_id: entry.id.0,
                anomalous_frame: labels.is_anomalous(i),
                object: *object,
                score: fusion.object_score(object),
                top: top == Some(k),
                anomalous_object: is_anomalous_object(object, &scored, &truth),
            });
        }
    }
    Ok(rows)
}

/// The CSV header of [`write_object_csv`].
pub const OBJECT_CSV_HEADER: &str = "scenario,box_source,frame,frame_id,anomalous_frame,track_id,class,x1,y1,x2,y2,s_r,s_p,score,top,anomalous_object";

/// Writes `rows` as CSV to `path` (atomically: a failed write leaves any earlier file).
pub fn write_object_csv(path: &Path, rows: &[ObjectRow]) -> Result<(), ScoreError> {
    let mut text = String::with_capacity(64 * (rows.len() + 1));
    text.push_str(OBJECT_CSV_HEADER);
    text.push('\n');
    for r in rows {
        let o = &r.object;
        let [x1, y1, x2, y2] = o.bbox;
        // Writing into a String cannot fail.
        let _ = writeln!(
            text,
            "{},{},{},{},{},{},{},{x1},{y1},{x2},{y2},{},{},{:.6},{},{}",
            r.scenario,
            r.box_source.replace(',', ";"),
            r.frame,
            r.frame_id,
            u8::from(r.anomalous_frame),
            o.track_id,
            o.class,
            o.s_r,
            o.s_p,
            r.score,
            u8::from(r.top),
            u8::from(r.anomalous_object),
        );
    }
    Ok(write_atomically(path, text.as_bytes())?)
}
