//! 2D boxes: the MOT-like `BBOX_2D/boxes.csv` (`frame,track_id,x1,y1,x2,y2,class,score,anomalous`,
//! pixels, x2/y2 exclusive) for ground truth and `BBOX_2D_DET/boxes.csv` for detections, and
//! boxes derived from instance images when no file exists.

use std::collections::BTreeMap;
use std::path::Path;

use super::csv_table::CsvTable;
use super::images::InstanceImage;
use super::palette;
use super::{BoxRecord, FrameId, SequenceError};

/// The header of `boxes.csv`.
pub const BOXES_HEADER: &str = "frame,track_id,x1,y1,x2,y2,class,score,anomalous";

/// Columns every `boxes.csv` must have; `score` (default 1) and `anomalous` (default 0)
/// may be missing.
const REQUIRED: [&str; 7] = ["frame", "track_id", "x1", "y1", "x2", "y2", "class"];

/// Sorts boxes by frame, then track id (the order `boxes.csv` is written in).
pub fn sort_boxes(boxes: &mut [BoxRecord]) {
    boxes.sort_by_key(|b| (b.frame, b.track_id));
}

/// Formats boxes as `boxes.csv` text, sorted by frame and track.
pub fn format_boxes(boxes: &[BoxRecord]) -> String {
    let mut sorted = boxes.to_vec();
    sort_boxes(&mut sorted);
    let mut text = String::with_capacity(48 * (sorted.len() + 1));
    text.push_str(BOXES_HEADER);
    text.push('\n');
    for b in &sorted {
        text.push_str(&format!(
            "{},{},{},{},{},{},{},{},{}\n",
            b.frame.0,
            b.track_id,
            b.x1,
            b.y1,
            b.x2,
            b.y2,
            b.class,
            b.score,
            u8::from(b.anomalous)
        ));
    }
    text
}

/// Writes `boxes.csv`.
pub fn write_boxes(path: &Path, boxes: &[BoxRecord]) -> Result<(), SequenceError> {
    std::fs::write(path, format_boxes(boxes)).map_err(|e| SequenceError::io(path, e))
}

/// Parses `boxes.csv` text; a bad row is an error naming the file, line and column.
pub fn parse_boxes(path: &Path, text: &str) -> Result<Vec<BoxRecord>, SequenceError> {
    table_to_boxes(&CsvTable::parse(path, text, &REQUIRED)?)
}

/// Reads `boxes.csv`.
pub fn read_boxes(path: &Path) -> Result<Vec<BoxRecord>, SequenceError> {
    table_to_boxes(&CsvTable::read(path, &REQUIRED)?)
}

fn table_to_boxes(table: &CsvTable) -> Result<Vec<BoxRecord>, SequenceError> {
    let col = |name: &str| table.column(name).unwrap_or(usize::MAX);
    let [frame, track, x1, y1, x2, y2, class] = REQUIRED.map(col);
    let score = table.column("score");
    let anomalous = table.column("anomalous");
    let mut boxes = Vec::new();
    for row in table.rows() {
        let record = BoxRecord {
            frame: FrameId(row.parse(frame, "frame")?),
            track_id: row.parse(track, "track_id")?,
            x1: row.parse(x1, "x1")?,
            y1: row.parse(y1, "y1")?,
            x2: row.parse(x2, "x2")?,
            y2: row.parse(y2, "y2")?,
            class: row.parse(class, "class")?,
            score: score.map_or(Ok(1.0), |c| row.parse(c, "score"))?,
            anomalous: anomalous.map_or(Ok(false), |c| row.flag(c, "anomalous"))?,
        };
        let coordinates = [record.x1, record.y1, record.x2, record.y2];
        if coordinates.iter().any(|c| !c.is_finite()) {
            return Err(row.error("box coordinates must be finite".into()));
        }
        if record.x2 < record.x1 || record.y2 < record.y1 {
            return Err(row.error(format!(
                "box has x2 < x1 or y2 < y1: ({}, {}, {}, {})",
                record.x1, record.y1, record.x2, record.y2
            )));
        }
        boxes.push(record);
    }
    Ok(boxes)
}

/// Groups boxes by frame id, keeping file order within a frame.
pub fn group_by_frame(boxes: Vec<BoxRecord>) -> BTreeMap<FrameId, Vec<BoxRecord>> {
    let mut grouped: BTreeMap<FrameId, Vec<BoxRecord>> = BTreeMap::new();
    for record in boxes {
        grouped.entry(record.frame).or_default().push(record);
    }
    grouped
}

/// Pixel extent of one instance while it is being scanned.
struct Extent {
    x1: u32,
    y1: u32,
    x2: u32,
    y2: u32,
    pixels: u32,
    class_votes: BTreeMap<u8, u32>,
    anomaly_pixels: u32,
}

/// Smallest instance (in pixels) that becomes a box: single stray pixels are noise.
pub const MIN_BOX_PIXELS: u32 = 4;

/// Derives vehicle boxes from an instance image: one box per instance id, spanning every
/// pixel of that id that belongs to a vehicle, i.e. whose instance tag (red channel) is a
/// vehicle class (14–19), or whose semantic class is (14–19, agents 114–119, anomaly 100)
/// when a semantic image of the same size is given. Semantic anomaly ids make the box
/// anomalous. Per-id extents rather than connected components, because an id is one actor
/// even when an occluder splits it. Track id = instance id, class = the most frequent
/// vehicle class of the instance (the tag where it is a vehicle), score 1.
pub fn boxes_from_instance(
    frame: FrameId,
    instance: &InstanceImage,
    semantic: Option<&image::GrayImage>,
) -> Vec<BoxRecord> {
    let semantic = semantic.filter(|s| s.dimensions() == (instance.width, instance.height));
    let mut extents: BTreeMap<u16, Extent> = BTreeMap::new();
    for (i, (&tag, &id)) in instance.tags.iter().zip(&instance.ids).enumerate() {
        let semantic_class = semantic.map(|s| s.as_raw()[i]);
        if semantic_class == Some(palette::EGO_VEHICLE) {
            continue;
        }
        let class = if palette::is_vehicle_id(tag) {
            tag
        } else {
            match semantic_class {
                Some(c) if palette::is_vehicle_id(c) => c,
                _ => continue,
            }
        };
        let x = (i % instance.width as usize) as u32;
        let y = (i / instance.width as usize) as u32;
        let extent = extents.entry(id).or_insert(Extent {
            x1: x,
            y1: y,
            x2: x,
            y2: y,
            pixels: 0,
            class_votes: BTreeMap::new(),
            anomaly_pixels: 0,
        });
        extent.x1 = extent.x1.min(x);
        extent.y1 = extent.y1.min(y);
        extent.x2 = extent.x2.max(x);
        extent.y2 = extent.y2.max(y);
        extent.pixels += 1;
        *extent.class_votes.entry(class).or_default() += 1;
        extent.anomaly_pixels += u32::from(palette::is_anomaly_id(semantic_class.unwrap_or(tag)));
    }
    extents
        .into_iter()
        .filter(|(_, e)| e.pixels >= MIN_BOX_PIXELS)
        .map(|(id, e)| BoxRecord {
            frame,
            track_id: u64::from(id),
            x1: e.x1 as f32,
            y1: e.y1 as f32,
            x2: (e.x2 + 1) as f32,
            y2: (e.y2 + 1) as f32,
            class: majority_class(&e.class_votes),
            score: 1.0,
            anomalous: e.anomaly_pixels > 0,
        })
        .collect()
}

fn majority_class(votes: &BTreeMap<u8, u32>) -> u16 {
    votes
        .iter()
        .max_by_key(|(class, count)| (**count, std::cmp::Reverse(**class)))
        .map_or(0, |(class, _)| u16::from(*class))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_round_trip_sorts_by_frame_then_track() {
        let make = |frame, track_id, anomalous| BoxRecord {
            frame: FrameId(frame),
            track_id,
            x1: 1.5,
            y1: 2.0,
            x2: 10.25,
            y2: 20.0,
            class: 14,
            score: 0.875,
            anomalous,
        };
        let boxes = vec![make(2, 7, false), make(1, 9, true), make(1, 3, false)];
        let text = format_boxes(&boxes);
        assert!(text.starts_with(BOXES_HEADER));
        let back = parse_boxes(Path::new("boxes.csv"), &text).expect("valid");
        assert_eq!(back, vec![boxes[2], boxes[1], boxes[0]]);
    }

    #[test]
    fn optional_columns_default_and_bad_rows_are_named() {
        let text = "frame,track_id,x1,y1,x2,y2,class\n4,1,0,0,5,5,15\n";
        let boxes = parse_boxes(Path::new("b.csv"), text).expect("valid");
        assert_eq!(boxes[0].score, 1.0);
        assert!(!boxes[0].anomalous);
        for (bad, needle) in [
            ("frame,track_id,x1,y1,x2,y2,class\n4,1,0,0,5\n", "b.csv:2"),
            (
                "frame,track_id,x1,y1,x2,y2,class\n4,1,0,zero,5,5,15\n",
                "column 'y1'",
            ),
            (
                "frame,track_id,x1,y1,x2,y2,class\n4,1,9,0,5,5,15\n",
                "x2 < x1",
            ),
            ("frame,x1\n", "header lacks column 'track_id'"),
            ("", "empty file"),
        ] {
            let error = parse_boxes(Path::new("b.csv"), bad).expect_err(bad);
            let message = error.to_string();
            assert!(
                message.contains("b.csv") && message.contains(needle),
                "{message}"
            );
        }
    }

    #[test]
    fn instance_extents_become_boxes() {
        let mut rgb = image::RgbImage::new(8, 6);
        for y in 1..4 {
            for x in 2..6 {
                rgb.put_pixel(x, y, image::Rgb([14, 0x05, 0x01]));
            }
        }
        rgb.put_pixel(7, 5, image::Rgb([14, 9, 0]));
        rgb.put_pixel(0, 0, image::Rgb([1, 3, 0]));
        let instance = InstanceImage::from_rgb(&rgb);
        let boxes = boxes_from_instance(FrameId(3), &instance, None);
        assert_eq!(boxes.len(), 1, "the single pixel of id 9 is noise");
        let b = boxes[0];
        assert_eq!(b.track_id, 0x105);
        assert_eq!((b.x1, b.y1, b.x2, b.y2), (2.0, 1.0, 6.0, 4.0));
        assert_eq!(b.class, 14);
        assert!(!b.anomalous);

        let mut semantic = image::GrayImage::new(8, 6);
        for y in 1..4 {
            for x in 2..6 {
                semantic.put_pixel(x, y, image::Luma([palette::ANOMALY]));
            }
        }
        let boxes = boxes_from_instance(FrameId(3), &instance, Some(&semantic));
        assert_eq!(boxes.len(), 1);
        assert!(boxes[0].anomalous);
        assert_eq!(boxes[0].class, 14, "the instance tag names the class");
    }
}
