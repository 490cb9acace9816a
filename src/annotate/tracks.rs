//! Keyframed [`Track`]s from per-frame boxes (the ground truth's `boxes.csv`, imported MOT,
//! COCO or YOLO files), and back: every frame of a track becomes a keyframe, and a frame
//! after the end of each run of frames gets an `outside` keyframe, so that nothing is
//! interpolated across frames where the object was not boxed.

use std::collections::BTreeMap;

use crate::sequence::{BoxRecord, FrameId};

use super::labels::{Keyframe, LabelSet, Origin, Rect, Track, TrackId};

/// Builds tracks from `(frame index, box)` pairs of a scenario with `frames` frames. A box
/// whose track already has a box at that frame (files without track ids give every box
/// track 0) starts a track of its own, with an id above every id of the input.
pub fn tracks_from_boxes(
    boxes: impl IntoIterator<Item = (usize, BoxRecord)>,
    frames: usize,
    origin: Origin,
) -> Vec<Track> {
    let boxes: Vec<(usize, BoxRecord)> = boxes
        .into_iter()
        .filter(|(frame, _)| *frame < frames)
        .collect();
    let mut next_free = boxes
        .iter()
        .map(|(_, b)| b.track_id)
        .max()
        .map_or(1, |m| m + 1);
    let mut by_track: BTreeMap<u64, (u16, BTreeMap<usize, Keyframe>)> = BTreeMap::new();
    for (frame, b) in boxes {
        let keyframe = Keyframe {
            rect: Rect {
                x1: b.x1,
                y1: b.y1,
                x2: b.x2,
                y2: b.y2,
            },
            outside: false,
            anomalous: b.anomalous,
        };
        let taken = by_track
            .get(&b.track_id)
            .is_some_and(|(_, keys)| keys.contains_key(&frame));
        let id = if taken {
            next_free += 1;
            next_free - 1
        } else {
            b.track_id
        };
        by_track
            .entry(id)
            .or_insert_with(|| (b.class, BTreeMap::new()))
            .1
            .insert(frame, keyframe);
    }
    by_track
        .into_iter()
        .map(|(id, (class, mut keyframes))| {
            let ends: Vec<(usize, Keyframe)> = keyframes
                .iter()
                .filter(|(frame, _)| {
                    **frame + 1 < frames && !keyframes.contains_key(&(**frame + 1))
                })
                .map(|(frame, k)| {
                    (
                        frame + 1,
                        Keyframe {
                            outside: true,
                            ..*k
                        },
                    )
                })
                .collect();
            keyframes.extend(ends);
            Track {
                id: TrackId(id),
                class,
                keyframes,
                origin,
            }
        })
        .collect()
}

/// Every visible box of every frame, interpolated, as `boxes.csv` records (score 1) with
/// the frame's AnoVox id, sorted by frame and track: what the box exports write.
pub fn boxes_by_frame(labels: &LabelSet) -> Vec<(usize, BoxRecord)> {
    let mut out = Vec::new();
    for (index, &id) in labels.frame_ids().iter().enumerate() {
        for b in labels.boxes_at(index) {
            out.push((index, box_record(id, &b)));
        }
    }
    out
}

fn box_record(frame: FrameId, b: &super::labels::FrameBox) -> BoxRecord {
    BoxRecord {
        frame,
        track_id: b.track.0,
        x1: b.rect.x1,
        y1: b.rect.y1,
        x2: b.rect.x2,
        y2: b.rect.y2,
        class: b.class,
        score: 1.0,
        anomalous: b.anomalous,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(track_id: u64, x: f32) -> BoxRecord {
        BoxRecord {
            frame: FrameId(0),
            track_id,
            x1: x,
            y1: 0.0,
            x2: x + 4.0,
            y2: 4.0,
            class: 14,
            score: 1.0,
            anomalous: false,
        }
    }

    #[test]
    fn runs_end_with_outside_and_duplicates_split() {
        let boxes = vec![
            (0, record(7, 0.0)),
            (1, record(7, 2.0)),
            (4, record(7, 8.0)),
            (4, record(7, 30.0)),
        ];
        let tracks = tracks_from_boxes(boxes, 6, Origin::GroundTruth);
        assert_eq!(tracks.len(), 2);
        let t = &tracks[0];
        assert_eq!(t.id, TrackId(7));
        assert_eq!(
            t.keyframes.keys().copied().collect::<Vec<_>>(),
            vec![0, 1, 2, 4, 5]
        );
        assert!(t.box_at(3).is_none(), "no interpolation across the gap");
        assert!(t.box_at(5).is_none());
        assert_eq!(tracks[1].id, TrackId(8));
        assert_eq!(tracks[1].box_at(4).map(|b| b.rect.x1), Some(30.0));
    }
}
