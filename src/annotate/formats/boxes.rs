//! The box formats: `boxes.csv`, MOT `gt.txt`, COCO JSON and YOLO with track ids. Exports
//! write every visible box of every frame; imports go through `sequence::detections`.

use std::fmt::Write as _;
use std::path::Path;

use crate::atomic_file::write_atomically;
use crate::sequence::boxes::format_boxes;
use crate::sequence::detections::{DetectionFile, DetectionFormat, DetectionTable, FrameNumbering};
use crate::sequence::{BoxRecord, Modality, Scenario};

use super::super::AnnotateError;
use super::super::edit::Edit;
use super::super::labels::{LabelSet, Origin};
use super::super::tracks::{boxes_by_frame, tracks_from_boxes};
use super::{ExportSummary, Import, LabelFormat};

/// `BBOX_2D/boxes.csv` layout.
pub fn export_boxes_csv(labels: &LabelSet, path: &Path) -> Result<ExportSummary, AnnotateError> {
    let boxes: Vec<BoxRecord> = boxes_by_frame(labels).into_iter().map(|(_, b)| b).collect();
    write_atomically(path, format_boxes(&boxes).as_bytes())?;
    Ok(ExportSummary {
        files: 1,
        records: boxes.len(),
    })
}

/// MOT `gt.txt`: `frame,id,left,top,width,height,1,class,1` with frame = index + 1.
pub fn export_mot(labels: &LabelSet, path: &Path) -> Result<ExportSummary, AnnotateError> {
    let boxes = boxes_by_frame(labels);
    let mut text = String::new();
    for (index, b) in &boxes {
        // Writing to a String cannot fail.
        let _ = writeln!(
            text,
            "{},{},{},{},{},{},1,{},1",
            index + 1,
            b.track_id,
            b.x1,
            b.y1,
            b.width(),
            b.height(),
            b.class
        );
    }
    write_atomically(path, text.as_bytes())?;
    Ok(ExportSummary {
        files: 1,
        records: boxes.len(),
    })
}

fn rgb_name(scenario: &Scenario, index: usize) -> Result<String, AnnotateError> {
    scenario
        .file(Modality::Rgb, index)
        .and_then(Path::file_name)
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| {
            AnnotateError::file(
                scenario.root(),
                format!("frame {index} has no RGB file to name it by"),
            )
        })
}

/// COCO dataset JSON: one image per frame (`file_name` = its RGB file, `frame_id` = its
/// AnoVox id), one annotation per visible box with `track_id` and `attributes.anomalous`.
pub fn export_coco(
    scenario: &Scenario,
    labels: &LabelSet,
    path: &Path,
) -> Result<ExportSummary, AnnotateError> {
    let (width, height) = scenario.resolution();
    let mut images = Vec::with_capacity(labels.frame_count());
    for (index, id) in labels.frame_ids().iter().enumerate() {
        images.push(serde_json::json!({
            "id": index + 1,
            "file_name": rgb_name(scenario, index)?,
            "width": width,
            "height": height,
            "frame_id": id.0,
        }));
    }
    let boxes = boxes_by_frame(labels);
    let mut classes: Vec<u16> = boxes.iter().map(|(_, b)| b.class).collect();
    classes.sort_unstable();
    classes.dedup();
    let annotations: Vec<serde_json::Value> = boxes
        .iter()
        .enumerate()
        .map(|(k, (index, b))| {
            serde_json::json!({
                "id": k + 1,
                "image_id": index + 1,
                "category_id": b.class,
                "bbox": [b.x1, b.y1, b.width(), b.height()],
                "area": b.width() * b.height(),
                "iscrowd": 0,
                "track_id": b.track_id,
                "attributes": { "anomalous": b.anomalous },
            })
        })
        .collect();
    let categories: Vec<serde_json::Value> = classes
        .iter()
        .map(|c| serde_json::json!({ "id": c, "name": format!("class-{c}") }))
        .collect();
    let document = serde_json::json!({
        "info": { "description": format!("vadscope labels of {}", scenario.name()) },
        "images": images,
        "annotations": annotations,
        "categories": categories,
    });
    write_atomically(path, document.to_string().as_bytes())?;
    Ok(ExportSummary {
        files: 1,
        records: boxes.len(),
    })
}

/// YOLO with track ids: a folder with one `<RGB stem>.txt` per frame (empty when the
/// frame has no box), rows `class cx cy w h 1 track_id` normalised to the image size.
pub fn export_yolo(
    scenario: &Scenario,
    labels: &LabelSet,
    dir: &Path,
) -> Result<ExportSummary, AnnotateError> {
    std::fs::create_dir_all(dir).map_err(|e| AnnotateError::io(dir, e))?;
    let (width, height) = scenario.resolution();
    let (w, h) = (f64::from(width), f64::from(height));
    let mut records = 0;
    for index in 0..labels.frame_count() {
        let name = rgb_name(scenario, index)?;
        let stem = Path::new(&name)
            .file_stem()
            .map_or_else(|| name.clone(), |s| s.to_string_lossy().into_owned());
        let mut text = String::new();
        for b in labels.boxes_at(index) {
            let r = b.rect;
            let (x1, y1, x2, y2) = (
                f64::from(r.x1),
                f64::from(r.y1),
                f64::from(r.x2),
                f64::from(r.y2),
            );
            // Writing to a String cannot fail.
            let _ = writeln!(
                text,
                "{} {} {} {} {} 1 {}",
                b.class,
                (x1 + x2) / 2.0 / w,
                (y1 + y2) / 2.0 / h,
                (x2 - x1) / w,
                (y2 - y1) / h,
                b.track.0
            );
            records += 1;
        }
        write_atomically(&dir.join(format!("{stem}.txt")), text.as_bytes())?;
    }
    Ok(ExportSummary {
        files: labels.frame_count(),
        records,
    })
}

/// Reads a box file and returns the edit that replaces every track with its tracks.
pub fn import_boxes(
    scenario: &Scenario,
    labels: &LabelSet,
    format: LabelFormat,
    path: &Path,
) -> Result<Import, AnnotateError> {
    let format = match format {
        LabelFormat::BoxesCsv => DetectionFormat::BoxesCsv,
        LabelFormat::Mot => DetectionFormat::Mot,
        LabelFormat::Coco => DetectionFormat::Coco,
        _ => DetectionFormat::Yolo,
    };
    let file = DetectionFile {
        path: path.to_path_buf(),
        format,
        numbering: FrameNumbering::OneBasedIndex,
        min_score: None,
    };
    let (width, height) = scenario.resolution();
    let raw = file.read(width, height)?;
    let records = raw.len();
    let table = DetectionTable::assign(scenario, raw, file.numbering);
    let boxes = table
        .by_frame
        .into_iter()
        .flat_map(|(index, boxes)| boxes.into_iter().map(move |b| (index, b)));
    let mut edits: Vec<Edit> = labels.tracks().map(|t| Edit::DeleteTrack(t.id)).collect();
    edits.extend(
        tracks_from_boxes(boxes, labels.frame_count(), Origin::Imported)
            .into_iter()
            .map(Edit::AddTrack),
    );
    Ok(Import {
        edit: Edit::Batch(edits),
        records,
        unmatched: table.unmatched,
    })
}
