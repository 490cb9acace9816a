//! The table formats: `frame_labels.csv` (per-frame flags, AnoVox ids) and the CSV of
//! intervals, failure tags and notes (RFC 4180 quoting, so notes may hold commas, quotes
//! and line breaks).

use std::path::Path;

use crate::atomic_file::write_atomically;
use crate::sequence::labels::{format_frame_labels, read_frame_labels};
use crate::sequence::{FrameId, Scenario};

use super::super::AnnotateError;
use super::super::edit::Edit;
use super::super::ground_truth::{intervals_from_flags, scenario_class};
use super::super::labels::{FailureTag, Interval, IntervalId, LabelSet, Origin, TagId};
use super::super::lane::LabelLane;
use super::{ExportSummary, Import};

/// The header of the intervals CSV.
pub const INTERVALS_HEADER: [&str; 9] = [
    "kind",
    "id",
    "start_index",
    "end_index",
    "start_frame",
    "end_frame",
    "label",
    "note",
    "origin",
];

/// `frame_labels.csv`: a frame is anomalous when an interval covers it.
pub fn export_frame_labels(labels: &LabelSet, path: &Path) -> Result<ExportSummary, AnnotateError> {
    let flags = LabelLane::build(labels).anomaly_flags();
    let rows: Vec<(FrameId, bool)> = labels.frame_ids().iter().copied().zip(flags).collect();
    write_atomically(path, format_frame_labels(&rows).as_bytes())?;
    Ok(ExportSummary {
        files: 1,
        records: rows.len(),
    })
}

/// Reads `frame_labels.csv`; its runs of anomalous frames replace every interval.
pub fn import_frame_labels(
    scenario: &Scenario,
    labels: &LabelSet,
    path: &Path,
) -> Result<Import, AnnotateError> {
    let rows = read_frame_labels(path)?;
    let mut flags = vec![false; labels.frame_count()];
    let mut unmatched = 0;
    for (id, anomalous) in &rows {
        match scenario.index_of(*id).filter(|&i| i < flags.len()) {
            Some(index) => flags[index] = *anomalous,
            None => unmatched += 1,
        }
    }
    let first_id = labels.fresh_interval_id().0 - 1;
    let mut edits: Vec<Edit> = labels
        .intervals()
        .map(|i| Edit::DeleteInterval(i.id))
        .collect();
    for mut interval in intervals_from_flags(&flags, &scenario_class(scenario), Origin::Imported) {
        interval.id = IntervalId(interval.id.0 + first_id);
        edits.push(Edit::AddInterval(interval));
    }
    Ok(Import {
        edit: Edit::Batch(edits),
        records: rows.len(),
        unmatched,
    })
}

fn origin_name(origin: Origin) -> &'static str {
    match origin {
        Origin::GroundTruth => "ground-truth",
        Origin::Analyst => "analyst",
        Origin::Imported => "imported",
    }
}

fn origin_of(name: &str) -> Option<Origin> {
    [Origin::GroundTruth, Origin::Analyst, Origin::Imported]
        .into_iter()
        .find(|o| origin_name(*o) == name)
}

/// One CSV field, quoted when it needs to be.
fn field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// The intervals CSV: one row per interval, tag and note, with frame indices and ids.
pub fn export_intervals(labels: &LabelSet, path: &Path) -> Result<ExportSummary, AnnotateError> {
    let id = |index: usize| {
        labels
            .frame_id(index)
            .map_or(String::new(), |f| f.0.to_string())
    };
    let mut rows: Vec<[String; 9]> = Vec::new();
    for i in labels.intervals() {
        rows.push([
            "interval".into(),
            i.id.0.to_string(),
            i.start.to_string(),
            i.end.to_string(),
            id(i.start),
            id(i.end),
            i.class.clone(),
            i.note.clone(),
            origin_name(i.origin).into(),
        ]);
    }
    for t in labels.tags() {
        rows.push([
            "tag".into(),
            t.id.0.to_string(),
            t.start.to_string(),
            t.end.to_string(),
            id(t.start),
            id(t.end),
            t.tag.clone(),
            t.note.clone(),
            String::new(),
        ]);
    }
    for (frame, text) in labels.notes() {
        rows.push([
            "note".into(),
            String::new(),
            frame.to_string(),
            frame.to_string(),
            id(frame),
            id(frame),
            String::new(),
            text.to_string(),
            String::new(),
        ]);
    }
    let mut text = INTERVALS_HEADER.join(",");
    text.push('\n');
    for row in &rows {
        let fields: Vec<String> = row.iter().map(|f| field(f)).collect();
        text.push_str(&fields.join(","));
        text.push('\n');
    }
    write_atomically(path, text.as_bytes())?;
    Ok(ExportSummary {
        files: 1,
        records: rows.len(),
    })
}

/// Splits CSV text into rows of fields with their 1-based starting line.
fn parse_csv(path: &Path, text: &str) -> Result<Vec<(usize, Vec<String>)>, AnnotateError> {
    let mut rows = Vec::new();
    let mut row = Vec::new();
    let mut current = String::new();
    let mut quoted = false;
    let mut line = 1;
    let mut row_line = 1;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                chars.next();
                current.push('"');
            }
            (true, '"') => quoted = false,
            (true, c) => {
                if c == '\n' {
                    line += 1;
                }
                current.push(c);
            }
            (false, '"') if current.is_empty() => quoted = true,
            (false, ',') => row.push(std::mem::take(&mut current)),
            (false, '\r') => {}
            (false, '\n') => {
                row.push(std::mem::take(&mut current));
                rows.push((row_line, std::mem::take(&mut row)));
                line += 1;
                row_line = line;
            }
            (false, c) => current.push(c),
        }
    }
    if quoted {
        return Err(AnnotateError::line(
            path,
            row_line,
            "a quoted field is not closed",
        ));
    }
    if !current.is_empty() || !row.is_empty() {
        row.push(current);
        rows.push((row_line, row));
    }
    rows.retain(|(_, r)| !(r.len() == 1 && r[0].is_empty()));
    Ok(rows)
}

/// Reads the intervals CSV; its rows replace every interval, tag and note. Frames are
/// found by AnoVox id (`start_frame`, `end_frame`), or by index when the id is empty.
pub fn import_intervals(
    scenario: &Scenario,
    labels: &LabelSet,
    path: &Path,
) -> Result<Import, AnnotateError> {
    let text = std::fs::read_to_string(path).map_err(|e| AnnotateError::io(path, e))?;
    let rows = parse_csv(path, &text)?;
    let Some(((_, header), body)) = rows.split_first() else {
        return Err(AnnotateError::file(path, "empty file"));
    };
    let column = |name: &str| {
        header
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| AnnotateError::line(path, 1, format!("header lacks column '{name}'")))
    };
    let [
        kind,
        id,
        start_index,
        end_index,
        start_frame,
        end_frame,
        label,
        note,
    ] = [
        "kind",
        "id",
        "start_index",
        "end_index",
        "start_frame",
        "end_frame",
        "label",
        "note",
    ]
    .map(column);
    let (kind, id, start_index, end_index) = (kind?, id?, start_index?, end_index?);
    let (start_frame, end_frame, label, note) = (start_frame?, end_frame?, label?, note?);
    let origin = header.iter().position(|h| h.trim() == "origin");
    let mut edits: Vec<Edit> = labels
        .intervals()
        .map(|i| Edit::DeleteInterval(i.id))
        .chain(labels.tags().map(|t| Edit::DeleteTag(t.id)))
        .chain(
            labels
                .notes()
                .map(|(frame, _)| Edit::SetNote { frame, text: None }),
        )
        .collect();
    let mut unmatched = 0;
    let mut next_interval = labels.fresh_interval_id().0;
    let mut next_tag = labels.fresh_tag_id().0;
    for (line, row) in body {
        let line = *line;
        let get = |c: usize| row.get(c).map_or("", |s| s.as_str());
        let frame =
            |id_column: usize, index_column: usize| -> Result<Option<usize>, AnnotateError> {
                let id = get(id_column).trim();
                if id.is_empty() {
                    let index = get(index_column).trim();
                    return index.parse().map(Some).map_err(|_| {
                        AnnotateError::line(
                            path,
                            line,
                            format!("frame index {index:?} is not a number"),
                        )
                    });
                }
                let id: u64 = id.parse().map_err(|_| {
                    AnnotateError::line(path, line, format!("frame id {id:?} is not a number"))
                })?;
                Ok(scenario.index_of(FrameId(id)))
            };
        let (Some(start), Some(end)) = (
            frame(start_frame, start_index)?,
            frame(end_frame, end_index)?,
        ) else {
            unmatched += 1;
            continue;
        };
        let number = |c: usize| -> Result<Option<u64>, AnnotateError> {
            let v = get(c).trim();
            if v.is_empty() {
                return Ok(None);
            }
            v.parse()
                .map(Some)
                .map_err(|_| AnnotateError::line(path, line, format!("id {v:?} is not a number")))
        };
        match get(kind).trim() {
            "interval" => {
                let origin = match origin.map(get).map(str::trim).filter(|o| !o.is_empty()) {
                    None => Origin::Imported,
                    Some(name) => origin_of(name).ok_or_else(|| {
                        AnnotateError::line(path, line, format!("unknown origin {name:?}"))
                    })?,
                };
                let id = number(id)?.unwrap_or_else(|| {
                    next_interval += 1;
                    next_interval - 1
                });
                edits.push(Edit::AddInterval(Interval {
                    id: IntervalId(id),
                    start,
                    end,
                    class: get(label).to_string(),
                    note: get(note).to_string(),
                    origin,
                }));
            }
            "tag" => {
                let id = number(id)?.unwrap_or_else(|| {
                    next_tag += 1;
                    next_tag - 1
                });
                edits.push(Edit::AddTag(FailureTag {
                    id: TagId(id),
                    start,
                    end,
                    tag: get(label).to_string(),
                    note: get(note).to_string(),
                }));
            }
            "note" => edits.push(Edit::SetNote {
                frame: start,
                text: Some(get(note).to_string()),
            }),
            other => {
                return Err(AnnotateError::line(
                    path,
                    line,
                    format!("kind {other:?} is not interval, tag or note"),
                ));
            }
        }
    }
    Ok(Import {
        edit: Edit::Batch(edits),
        records: body.len(),
        unmatched,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_fields_with_commas_quotes_and_newlines_survive() {
        let note = "left lane, \"glare\"\nsecond line";
        let text = format!("a,b\n1,{}\n", field(note));
        let rows = parse_csv(Path::new("t.csv"), &text).expect("valid");
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1], (2, vec!["1".to_string(), note.to_string()]));
        let error = parse_csv(Path::new("t.csv"), "a\n\"open\n").expect_err("unclosed");
        assert!(error.to_string().contains("t.csv:2"), "{error}");
    }
}
