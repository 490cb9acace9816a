//! Labeling speed with 10,000 labels in a 20,000-frame scenario (5,000 intervals, 2,000
//! failure tags, 1,000 notes, 20 tracks of 100 keyframes): one edit (moving an interval
//! edge) with its journal record handed to the background writer, plus everything the
//! viewer redraws from (the per-frame lane, the intervals and boxes of the current
//! frame). Target: at most 16 ms for edit + redraw data. Also the same edit waiting for
//! its fsync, and the lane alone.

use criterion::{Criterion, criterion_group, criterion_main};
use vadscope::annotate::{
    Edge, Edit, Editor, FailureTag, Interval, IntervalId, Keyframe, LabelLane, LabelSet, Origin,
    Rect, SaveMode, TagId, Track, TrackId,
};
use vadscope::sequence::FrameId;

const FRAMES: usize = 20_000;

fn many_labels() -> Edit {
    let mut edits = Vec::new();
    for k in 0..5_000usize {
        let start = (k * 37) % FRAMES;
        edits.push(Edit::AddInterval(Interval {
            id: IntervalId(k as u64 + 1),
            start,
            end: (start + k % 50).min(FRAMES - 1),
            class: "anomaly".into(),
            note: String::new(),
            origin: Origin::Analyst,
        }));
    }
    for k in 0..2_000usize {
        let start = (k * 101) % FRAMES;
        edits.push(Edit::AddTag(FailureTag {
            id: TagId(k as u64 + 1),
            start,
            end: (start + 30).min(FRAMES - 1),
            tag: "glare".into(),
            note: String::new(),
        }));
    }
    for k in 0..1_000usize {
        edits.push(Edit::SetNote {
            frame: k * 19,
            text: Some(format!("note {k}")),
        });
    }
    for t in 0..20u64 {
        let keyframes = (0..100usize)
            .map(|k| {
                let x = (k % 40) as f32 * 10.0;
                (
                    k * 200 + t as usize,
                    Keyframe {
                        rect: Rect {
                            x1: x,
                            y1: 50.0,
                            x2: x + 40.0,
                            y2: 90.0,
                        },
                        outside: k % 10 == 9,
                        anomalous: false,
                    },
                )
            })
            .collect();
        edits.push(Edit::AddTrack(Track {
            id: TrackId(t + 1),
            class: 14,
            keyframes,
            origin: Origin::Analyst,
        }));
    }
    Edit::Batch(edits)
}

fn editor(dir: &std::path::Path, mode: SaveMode) -> Editor {
    let frames: Vec<FrameId> = (0..FRAMES as u64).map(FrameId).collect();
    let mut editor = Editor::open_in(dir, frames.clone(), || (LabelSet::new(frames), Vec::new()))
        .expect("open labels");
    editor.apply(many_labels()).expect("labels");
    assert_eq!(editor.labels().label_count(), 10_000);
    editor.compact().expect("compact");
    editor.set_save_mode(mode);
    editor
}

/// Moves the end of interval `k` by one frame back and forth.
fn move_edge(editor: &Editor, k: u64) -> Edit {
    let interval = editor
        .labels()
        .interval(IntervalId(k % 5_000 + 1))
        .expect("interval");
    let end = if interval.end > interval.start {
        interval.end - 1
    } else {
        interval.end + 1
    };
    Edit::UpdateInterval(interval.with_edge(Edge::End, end.min(FRAMES - 1)))
}

fn redraw_data(editor: &Editor, frame: usize) -> usize {
    let lane = LabelLane::build(editor.labels());
    let labels = editor.labels();
    lane.len() + labels.intervals_at(frame).len() + labels.boxes_at(frame).len()
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut background = editor(&dir.path().join("background"), SaveMode::Background);
    let mut k = 0u64;
    c.bench_function(
        "annotate: edit + redraw data, 10k labels, background journal",
        |b| {
            b.iter(|| {
                k += 1;
                let edit = move_edge(&background, k);
                background.apply(edit).expect("edit");
                redraw_data(&background, (k as usize * 13) % FRAMES)
            })
        },
    );
    background.flush().expect("flush");

    let mut durable = editor(&dir.path().join("durable"), SaveMode::Durable);
    c.bench_function(
        "annotate: edit + redraw data, 10k labels, fsync before return",
        |b| {
            b.iter(|| {
                k += 1;
                let edit = move_edge(&durable, k);
                durable.apply(edit).expect("edit");
                redraw_data(&durable, (k as usize * 13) % FRAMES)
            })
        },
    );

    c.bench_function("annotate: lane rebuild, 10k labels", |b| {
        b.iter(|| LabelLane::build(durable.labels()).len())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
