//! The edit journal (`labels.journal`): one line per applied step,
//! `<seq> <checksum> <json>\n`, where the checksum is FNV-1a (32 bit, hex) of
//! `<seq> <json>`. A line that does not parse or whose checksum is wrong is reported with
//! its line number and byte offset; a last line without its newline is a write that a
//! crash cut short.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::AnnotateError;
use super::edit::Edit;

/// How a journaled edit came about; replay uses it to rebuild the undo and redo stacks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Step {
    /// A new edit (clears the redo stack).
    Do,
    /// The inverse of the last edit, applied by undo.
    Undo,
    /// An undone edit applied again by redo.
    Redo,
}

/// One journal line: the edit that was applied to the labels, as applied.
#[derive(Debug, Clone, PartialEq)]
pub struct JournalRecord {
    /// Sequence number, increasing by one per record over the life of the labels.
    pub seq: u64,
    /// How the edit came about.
    pub step: Step,
    /// The edit applied.
    pub edit: Edit,
}

#[derive(Serialize, Deserialize)]
struct Body {
    step: Step,
    edit: Edit,
}

fn checksum(seq: u64, json: &str) -> u32 {
    crate::fnv::fnv1a32(format!("{seq} {json}").as_bytes())
}

/// The journal line of `record`, newline included.
pub fn encode_record(record: &JournalRecord) -> String {
    let body = Body {
        step: record.step,
        edit: record.edit.clone(),
    };
    let json = serde_json::to_string(&body).expect("edits serialise to JSON");
    format!(
        "{} {:08x} {json}\n",
        record.seq,
        checksum(record.seq, &json)
    )
}

/// What could be read from a journal.
#[derive(Debug, Default)]
pub struct JournalContents {
    /// The records that read back intact, in file order.
    pub records: Vec<JournalRecord>,
    /// One error per damaged line (line number and byte offset in the message).
    pub problems: Vec<AnnotateError>,
}

/// Reads the journal at `path` (a missing journal is empty). Damaged lines are skipped and
/// reported; everything intact is kept.
pub fn read_journal(path: &Path) -> Result<JournalContents, AnnotateError> {
    let bytes = match std::fs::read(path) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(JournalContents::default()),
        Err(e) => return Err(AnnotateError::io(path, e)),
    };
    let mut contents = JournalContents::default();
    let mut offset = 0usize;
    for (i, raw) in bytes.split_inclusive(|&b| b == b'\n').enumerate() {
        let line = i + 1;
        let at = offset;
        offset += raw.len();
        if !raw.ends_with(b"\n") {
            contents.problems.push(AnnotateError::line(
                path,
                line,
                format!(
                    "record cut short at byte offset {at} ({} bytes without a newline: a write a crash interrupted)",
                    raw.len()
                ),
            ));
            continue;
        }
        match decode_line(&raw[..raw.len() - 1]) {
            Ok(record) => contents.records.push(record),
            Err(problem) => contents.problems.push(AnnotateError::line(
                path,
                line,
                format!("damaged record at byte offset {at}: {problem}"),
            )),
        }
    }
    Ok(contents)
}

fn decode_line(raw: &[u8]) -> Result<JournalRecord, String> {
    let text = std::str::from_utf8(raw).map_err(|_| "not UTF-8".to_string())?;
    let mut parts = text.splitn(3, ' ');
    let (Some(seq), Some(sum), Some(json)) = (parts.next(), parts.next(), parts.next()) else {
        return Err("expected `<seq> <checksum> <json>`".into());
    };
    let seq: u64 = seq
        .parse()
        .map_err(|_| format!("sequence number {seq:?} is not a number"))?;
    let sum = u32::from_str_radix(sum, 16).map_err(|_| format!("checksum {sum:?} is not hex"))?;
    if sum != checksum(seq, json) {
        return Err("checksum does not match the content".into());
    }
    let body: Body = serde_json::from_str(json).map_err(|e| format!("invalid JSON: {e}"))?;
    Ok(JournalRecord {
        seq,
        step: body.step,
        edit: body.edit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_and_damage_is_located() {
        let record = JournalRecord {
            seq: 7,
            step: Step::Undo,
            edit: Edit::SetNote {
                frame: 3,
                text: Some("glare, see \"left\"".into()),
            },
        };
        let line = encode_record(&record);
        assert!(line.ends_with('\n') && line.starts_with("7 "));
        assert_eq!(decode_line(line.trim_end().as_bytes()), Ok(record));
        let flipped = line.replacen("glare", "glade", 1);
        assert!(
            decode_line(flipped.trim_end().as_bytes())
                .unwrap_err()
                .contains("checksum")
        );
    }
}
