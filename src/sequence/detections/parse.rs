//! The parsers of the detection formats (MOT text, YOLO text, COCO JSON) into
//! [`RawDetection`]s, with errors that name the file, the line and the field.

use std::collections::HashMap;
use std::path::Path;

use serde::Deserialize;

use super::super::error::SequenceError;
use super::super::types::{BoxRecord, FrameId};
use super::{FrameRef, RawDetection};

fn record(track_id: u64, class: u16, xywh: [f64; 4], score: f64) -> BoxRecord {
    let [x, y, w, h] = xywh;
    BoxRecord {
        frame: FrameId(0),
        track_id,
        x1: x as f32,
        y1: y as f32,
        x2: (x + w) as f32,
        y2: (y + h) as f32,
        class,
        score: score as f32,
        anomalous: false,
    }
}

/// Parses a number of a text row; `what` names the column in the error.
fn number(path: &Path, line: usize, field: &str, what: &str) -> Result<f64, SequenceError> {
    field
        .trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            SequenceError::line(
                path,
                line,
                format!("{what} {field:?} is not a finite number"),
            )
        })
}

/// A non-negative integer written as an integer or as an integral float (`12` or `12.0`).
fn whole(path: &Path, line: usize, field: &str, what: &str) -> Result<u64, SequenceError> {
    let v = number(path, line, field, what)?;
    if v < 0.0 || v.fract() != 0.0 || v > u32::MAX as f64 {
        return Err(SequenceError::line(
            path,
            line,
            format!("{what} {field:?} is not a non-negative whole number"),
        ));
    }
    Ok(v as u64)
}

/// Track id or class: −1 (unknown) and other negatives become 0.
fn optional_id(path: &Path, line: usize, field: &str, what: &str) -> Result<u64, SequenceError> {
    let v = number(path, line, field, what)?;
    if v.fract() != 0.0 {
        return Err(SequenceError::line(
            path,
            line,
            format!("{what} {field:?} is not a whole number"),
        ));
    }
    Ok(if v < 0.0 { 0 } else { v as u64 })
}

fn check_size(path: &Path, line: usize, w: f64, h: f64) -> Result<(), SequenceError> {
    if w < 0.0 || h < 0.0 {
        return Err(SequenceError::line(
            path,
            line,
            format!("box size {w}×{h} is negative"),
        ));
    }
    Ok(())
}

/// Parses MOTChallenge text: `frame,id,left,top,width,height[,conf[,class[,...]]]` per line;
/// blank lines and `#` comments are skipped.
pub fn parse_mot(path: &Path, text: &str) -> Result<Vec<RawDetection>, SequenceError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let row = raw.trim();
        if row.is_empty() || row.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = row.split(',').collect();
        if fields.len() < 6 {
            return Err(SequenceError::line(
                path,
                line,
                format!(
                    "{} fields; MOT rows need at least 6 (frame,id,left,top,width,height)",
                    fields.len()
                ),
            ));
        }
        let frame = whole(path, line, fields[0], "frame")?;
        let track = optional_id(path, line, fields[1], "id")?;
        let left = number(path, line, fields[2], "left")?;
        let top = number(path, line, fields[3], "top")?;
        let width = number(path, line, fields[4], "width")?;
        let height = number(path, line, fields[5], "height")?;
        check_size(path, line, width, height)?;
        let score = match fields.get(6) {
            Some(f) => number(path, line, f, "conf")?,
            None => 1.0,
        };
        let class = match fields.get(7) {
            Some(f) => optional_id(path, line, f, "class")?.min(u64::from(u16::MAX)) as u16,
            None => 0,
        };
        out.push(RawDetection {
            frame: FrameRef::Number(frame),
            bbox: record(track, class, [left, top, width, height], score),
        });
    }
    Ok(out)
}

/// Parses the lines of one YOLO file (`class cx cy w h [conf [track_id]]`, normalised; the
/// track id as tracking exports write it, 0 when absent) for frame `frame`, scaling to an
/// image of `width`×`height` pixels.
pub fn parse_yolo(
    path: &Path,
    text: &str,
    frame: FrameRef,
    width: u32,
    height: u32,
) -> Result<Vec<RawDetection>, SequenceError> {
    let (iw, ih) = (f64::from(width), f64::from(height));
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let row = raw.trim();
        if row.is_empty() || row.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = row.split_whitespace().collect();
        if !(5..=7).contains(&fields.len()) {
            return Err(SequenceError::line(
                path,
                line,
                format!(
                    "{} fields; YOLO rows are `class cx cy w h [conf [track_id]]`",
                    fields.len()
                ),
            ));
        }
        let class = whole(path, line, fields[0], "class")?.min(u64::from(u16::MAX)) as u16;
        let mut v = [0f64; 4];
        for (k, name) in ["cx", "cy", "w", "h"].iter().enumerate() {
            v[k] = number(path, line, fields[k + 1], name)?;
            if !(-0.5..=1.5).contains(&v[k]) {
                return Err(SequenceError::line(
                    path,
                    line,
                    format!(
                        "{name} {} is not normalised to [0, 1] (YOLO coordinates are fractions of the image)",
                        fields[k + 1]
                    ),
                ));
            }
        }
        check_size(path, line, v[2], v[3])?;
        let score = match fields.get(5) {
            Some(f) => number(path, line, f, "conf")?,
            None => 1.0,
        };
        let track = match fields.get(6) {
            Some(f) => optional_id(path, line, f, "track_id")?,
            None => 0,
        };
        let (w, h) = (v[2] * iw, v[3] * ih);
        out.push(RawDetection {
            frame: frame.clone(),
            bbox: record(
                track,
                class,
                [v[0] * iw - w / 2.0, v[1] * ih - h / 2.0, w, h],
                score,
            ),
        });
    }
    Ok(out)
}

#[derive(Deserialize)]
struct CocoDataset {
    #[serde(default)]
    images: Vec<CocoImage>,
    annotations: Vec<CocoAnnotation>,
}

#[derive(Deserialize)]
struct CocoImage {
    id: u64,
    file_name: String,
}

#[derive(Deserialize)]
struct CocoAnnotation {
    image_id: u64,
    bbox: [f64; 4],
    #[serde(default)]
    category_id: Option<i64>,
    #[serde(default)]
    score: Option<f64>,
    #[serde(default)]
    track_id: Option<i64>,
}

/// Parses COCO JSON: a results array (`[{image_id, category_id, bbox, score}]`) or a dataset
/// object (`{images: [{id, file_name}], annotations: [...]}`). Syntax and type errors name
/// the line and column; bad boxes name the annotation.
pub fn parse_coco(path: &Path, text: &str) -> Result<Vec<RawDetection>, SequenceError> {
    let json_error = |e: serde_json::Error| {
        SequenceError::line(path, e.line(), format!("invalid COCO JSON: {e}"))
    };
    let (annotations, names) = if text.trim_start().starts_with('[') {
        let list: Vec<CocoAnnotation> = serde_json::from_str(text).map_err(json_error)?;
        (list, None)
    } else {
        let doc: CocoDataset = serde_json::from_str(text).map_err(json_error)?;
        let names: HashMap<u64, String> = doc
            .images
            .into_iter()
            .map(|im| {
                let stem = Path::new(&im.file_name).file_stem().map_or_else(
                    || im.file_name.clone(),
                    |s| s.to_string_lossy().into_owned(),
                );
                (im.id, stem)
            })
            .collect();
        (doc.annotations, (!names.is_empty()).then_some(names))
    };
    annotations
        .into_iter()
        .enumerate()
        .map(|(k, a)| {
            let problem = |what: String| {
                SequenceError::format(
                    path,
                    format!("annotation {k} (image_id {}): {what}", a.image_id),
                )
            };
            if a.bbox.iter().any(|v| !v.is_finite()) {
                return Err(problem("bbox has a non-finite value".into()));
            }
            if a.bbox[2] < 0.0 || a.bbox[3] < 0.0 {
                return Err(problem(format!(
                    "bbox size {}×{} is negative",
                    a.bbox[2], a.bbox[3]
                )));
            }
            let frame = match &names {
                Some(names) => FrameRef::Stem(
                    names
                        .get(&a.image_id)
                        .cloned()
                        .ok_or_else(|| problem("image_id is not in `images`".into()))?,
                ),
                None => FrameRef::Number(a.image_id),
            };
            let class = a.category_id.unwrap_or(0).clamp(0, i64::from(u16::MAX)) as u16;
            let track = a.track_id.unwrap_or(0).max(0) as u64;
            Ok(RawDetection {
                frame,
                bbox: record(track, class, a.bbox, a.score.unwrap_or(1.0)),
            })
        })
        .collect()
}
