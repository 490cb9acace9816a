//! `labels.json`: the compacted labels, one item per line so that a damaged file still
//! yields every intact line:
//!
//! ```text
//! {"header":{"format":"vadscope-labels","version":1,"journal_seq":12,"frames":200},
//! "items":[
//! {"interval":{...}},
//! {"track":{...}},
//! {"tag":{...}},
//! {"note":{"frame":3,"text":"..."}}
//! ]}
//! ```
//!
//! `journal_seq` is the last journal record the file includes. Items are checked as they
//! are loaded, through the same [`Edit`]s the editor applies.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::AnnotateError;
use super::edit::Edit;
use super::labels::{FailureTag, Interval, LabelSet, Track};

/// The `format` value of the header.
pub const FORMAT_NAME: &str = "vadscope-labels";
/// The version this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// The first line of `labels.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Always [`FORMAT_NAME`].
    pub format: String,
    /// [`FORMAT_VERSION`].
    pub version: u32,
    /// The last journal record included.
    pub journal_seq: u64,
    /// Frames of the scenario the labels belong to.
    pub frames: usize,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Item {
    Interval(Interval),
    Track(Track),
    Tag(FailureTag),
    Note { frame: usize, text: String },
}

impl Item {
    fn into_edit(self) -> Edit {
        match self {
            Item::Interval(i) => Edit::AddInterval(i),
            Item::Track(t) => Edit::AddTrack(t),
            Item::Tag(t) => Edit::AddTag(t),
            Item::Note { frame, text } => Edit::SetNote {
                frame,
                text: Some(text),
            },
        }
    }
}

#[derive(Deserialize)]
struct Whole {
    header: Header,
    items: Vec<Item>,
}

/// The text of `labels.json` for `labels` at journal record `journal_seq`.
pub fn encode_document(labels: &LabelSet, journal_seq: u64) -> String {
    let header = Header {
        format: FORMAT_NAME.into(),
        version: FORMAT_VERSION,
        journal_seq,
        frames: labels.frame_count(),
    };
    let items: Vec<String> = labels
        .intervals()
        .map(|i| json(&Item::Interval(i.clone())))
        .chain(labels.tracks().map(|t| json(&Item::Track(t.clone()))))
        .chain(labels.tags().map(|t| json(&Item::Tag(t.clone()))))
        .chain(labels.notes().map(|(frame, text)| {
            json(&Item::Note {
                frame,
                text: text.to_string(),
            })
        }))
        .collect();
    format!(
        "{{\"header\":{},\n\"items\":[\n{}\n]}}\n",
        json(&header),
        items.join(",\n")
    )
}

/// One line of JSON.
fn json<T: Serialize>(value: &T) -> String {
    serde_json::to_string(value).expect("labels serialise to JSON")
}

/// What could be read from a `labels.json`.
#[derive(Debug)]
pub struct DocumentContents {
    /// The labels read (every intact, valid item).
    pub labels: LabelSet,
    /// The header's journal sequence number (0 when the header is unreadable).
    pub journal_seq: u64,
    /// Whether the header could be read.
    pub header_read: bool,
    /// One error per damaged or invalid line.
    pub problems: Vec<AnnotateError>,
}

/// Parses `labels.json` text for a scenario with these frame ids. A file that is not valid
/// JSON as a whole is read line by line; every problem names the file and line.
pub fn decode_document(
    path: &Path,
    text: &str,
    frames: Vec<crate::sequence::FrameId>,
) -> DocumentContents {
    let mut contents = DocumentContents {
        labels: LabelSet::new(frames),
        journal_seq: 0,
        header_read: false,
        problems: Vec::new(),
    };
    let items: Vec<(usize, Item)> = match serde_json::from_str::<Whole>(text) {
        Ok(whole) => {
            accept_header(path, 1, whole.header, &mut contents);
            let mut line = 2;
            whole
                .items
                .into_iter()
                .map(|item| {
                    line += 1;
                    (line, item)
                })
                .collect()
        }
        Err(error) => {
            contents.problems.push(AnnotateError::line(
                path,
                error.line(),
                format!("not valid labels JSON ({error}); reading the intact lines"),
            ));
            line_by_line(path, text, &mut contents)
        }
    };
    for (line, item) in items {
        if let Err(error) = item.into_edit().apply(&mut contents.labels) {
            contents
                .problems
                .push(AnnotateError::line(path, line, error.to_string()));
        }
    }
    contents
}

fn accept_header(path: &Path, line: usize, header: Header, contents: &mut DocumentContents) {
    if header.format != FORMAT_NAME || header.version != FORMAT_VERSION {
        contents.problems.push(AnnotateError::line(
            path,
            line,
            format!(
                "format {:?} version {} is not {FORMAT_NAME:?} version {FORMAT_VERSION}",
                header.format, header.version
            ),
        ));
    }
    if header.frames != contents.labels.frame_count() {
        contents.problems.push(AnnotateError::line(
            path,
            line,
            format!(
                "labels are for {} frames but the scenario has {}",
                header.frames,
                contents.labels.frame_count()
            ),
        ));
    }
    contents.journal_seq = header.journal_seq;
    contents.header_read = true;
}

fn line_by_line(path: &Path, text: &str, contents: &mut DocumentContents) -> Vec<(usize, Item)> {
    let mut items = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let row = raw.trim().trim_end_matches(',');
        if row.is_empty() || row == "\"items\":[" || row == "]}" {
            continue;
        }
        if let Some(header) = row.strip_prefix("{\"header\":") {
            match serde_json::from_str::<Header>(header) {
                Ok(header) => accept_header(path, line, header, contents),
                Err(e) => contents.problems.push(AnnotateError::line(
                    path,
                    line,
                    format!("unreadable header: {e}"),
                )),
            }
            continue;
        }
        match serde_json::from_str::<Item>(row) {
            Ok(item) => items.push((line, item)),
            Err(e) => contents.problems.push(AnnotateError::line(
                path,
                line,
                format!("unreadable label, skipped: {e}"),
            )),
        }
    }
    items
}
