//! [`Editor`]: the object the viewer (and `vadscope labels`) holds for one scenario's
//! labels. Edits apply in memory at once and are journaled by a background writer; undo
//! and redo are edits too. Opening replays the journal over `labels.json` (or over the
//! ground truth on first use); damaged files are reported, copied aside and everything
//! readable is kept.

use std::path::{Path, PathBuf};

use crate::sequence::{FrameId, Scenario};

use super::AnnotateError;
use super::document::decode_document;
use super::edit::Edit;
use super::ground_truth::ground_truth_labels;
use super::journal::{JournalRecord, Step, read_journal};
use super::labels::LabelSet;
use super::lane::LabelLane;
use super::writer::{JOURNAL_FILE, JournalWriter, LABELS_FILE, lock_journal};

/// When an edit is on disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SaveMode {
    /// `apply`, `undo` and `redo` return once the journal record is fsynced.
    #[default]
    Durable,
    /// They return as soon as the edit is applied in memory; the record is written by the
    /// background writer, and [`Editor::flush`] waits for it (for a UI thread).
    Background,
}

/// One scenario's labels with undo, redo and crash-safe saving.
pub struct Editor {
    labels: LabelSet,
    undo: Vec<Edit>,
    redo: Vec<Edit>,
    seq: u64,
    mode: SaveMode,
    writer: Option<JournalWriter>,
    dir: Option<PathBuf>,
    problems: Vec<AnnotateError>,
    set_aside: Vec<PathBuf>,
}

impl Editor {
    /// An editor that saves nothing (tests, previews).
    pub fn in_memory(labels: LabelSet) -> Self {
        Self {
            labels,
            undo: Vec::new(),
            redo: Vec::new(),
            seq: 0,
            mode: SaveMode::Durable,
            writer: None,
            dir: None,
            problems: Vec::new(),
            set_aside: Vec::new(),
        }
    }

    /// Opens the labels of `scenario` from its vadscope folder
    /// ([`Scenario::cache_dir`]), starting from its ground truth on first use.
    pub fn open(scenario: &Scenario) -> Result<Self, AnnotateError> {
        let dir = scenario.cache_dir()?;
        Self::open_in(&dir, scenario.frame_index().ids().to_vec(), || {
            ground_truth_labels(scenario)
        })
    }

    /// Opens the label files in `dir` for a scenario with these frame ids: reads
    /// `labels.json` (or, when there is none, takes `base()` and saves it), replays the
    /// journal records it does not include, and starts the writer, which holds the lock on
    /// the journal: while it lives, opening the same labels elsewhere fails with
    /// [`AnnotateError::Busy`]. Damaged files are
    /// reported ([`Editor::load_problems`]), copied aside ([`Editor::set_aside`]) and
    /// replaced by a compacted `labels.json` holding everything that could be read.
    pub fn open_in(
        dir: &Path,
        frames: Vec<FrameId>,
        base: impl FnOnce() -> (LabelSet, Vec<AnnotateError>),
    ) -> Result<Self, AnnotateError> {
        std::fs::create_dir_all(dir).map_err(|e| AnnotateError::io(dir, e))?;
        // Locked before anything is read, so a second editor reads nothing it could
        // overwrite.
        let journal_file = lock_journal(dir)?;
        let labels_path = dir.join(LABELS_FILE);
        let journal_path = dir.join(JOURNAL_FILE);
        let mut problems = Vec::new();
        let mut damaged = Vec::new();
        let (labels, saved_seq, fresh) = match std::fs::read(&labels_path) {
            Ok(bytes) => {
                let text = String::from_utf8_lossy(&bytes);
                let contents = decode_document(&labels_path, &text, frames);
                if !contents.problems.is_empty() {
                    damaged.push(labels_path.clone());
                    problems.extend(contents.problems);
                }
                (contents.labels, contents.journal_seq, false)
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                let (labels, base_problems) = base();
                problems.extend(base_problems);
                (labels, 0, true)
            }
            Err(e) => return Err(AnnotateError::io(&labels_path, e)),
        };
        let journal = read_journal(&journal_path)?;
        if !journal.problems.is_empty() {
            damaged.push(journal_path.clone());
            problems.extend(journal.problems);
        }
        let mut editor = Self::in_memory(labels);
        editor.seq = saved_seq;
        for record in journal.records.into_iter().filter(|r| r.seq > saved_seq) {
            if let Err(error) = editor.replay(&record) {
                if !damaged.contains(&journal_path) {
                    damaged.push(journal_path.clone());
                }
                problems.push(AnnotateError::File {
                    path: journal_path.clone(),
                    problem: format!("record {} does not apply, skipped: {error}", record.seq),
                });
            }
        }
        for path in &damaged {
            editor.set_aside.push(copy_aside(path)?);
        }
        editor.problems = problems;
        editor.writer = Some(JournalWriter::start(dir, journal_file, editor.seq)?);
        editor.dir = Some(dir.to_path_buf());
        if fresh || !damaged.is_empty() {
            editor.compact()?;
        }
        Ok(editor)
    }

    fn replay(&mut self, record: &JournalRecord) -> Result<(), AnnotateError> {
        let inverse = record.edit.apply(&mut self.labels)?;
        match record.step {
            Step::Do => {
                self.undo.push(inverse);
                self.redo.clear();
            }
            Step::Undo => {
                self.undo.pop();
                self.redo.push(inverse);
            }
            Step::Redo => {
                self.redo.pop();
                self.undo.push(inverse);
            }
        }
        self.seq = record.seq;
        Ok(())
    }

    /// The labels as they are now.
    pub fn labels(&self) -> &LabelSet {
        &self.labels
    }

    /// The per-frame lane of the labels as they are now.
    pub fn lane(&self) -> LabelLane {
        LabelLane::build(&self.labels)
    }

    /// Problems found while opening (damaged files, records that did not apply, ground
    /// truth that could not be read), each naming its file and line or offset.
    pub fn load_problems(&self) -> &[AnnotateError] {
        &self.problems
    }

    /// Copies of damaged label files made while opening (`<file>.corrupt-<time>`).
    pub fn set_aside(&self) -> &[PathBuf] {
        &self.set_aside
    }

    /// The folder the label files are in (`None` for an in-memory editor).
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    /// Chooses when edits are on disk (default [`SaveMode::Durable`]).
    pub fn set_save_mode(&mut self, mode: SaveMode) {
        self.mode = mode;
    }

    /// Sequence number of the last edit applied (journal record).
    pub fn seq(&self) -> u64 {
        self.seq
    }

    /// Sequence number of the last edit known to be on disk (all of them in memory).
    pub fn saved_seq(&self) -> u64 {
        self.writer
            .as_ref()
            .map_or(self.seq, JournalWriter::saved_seq)
    }

    /// Applies `edit` (see [`Edit::apply`]) and journals it. An invalid edit changes
    /// nothing; a failed save leaves the edit applied and queued for the next write, and
    /// says so.
    pub fn apply(&mut self, edit: Edit) -> Result<(), AnnotateError> {
        let inverse = edit.apply(&mut self.labels)?;
        self.undo.push(inverse);
        self.redo.clear();
        self.record(Step::Do, edit)
    }

    /// Undoes the last edit; `false` when there is nothing to undo.
    pub fn undo(&mut self) -> Result<bool, AnnotateError> {
        let Some(edit) = self.undo.pop() else {
            return Ok(false);
        };
        let inverse = match edit.apply(&mut self.labels) {
            Ok(inverse) => inverse,
            Err(error) => {
                self.undo.push(edit);
                return Err(error);
            }
        };
        self.redo.push(inverse);
        self.record(Step::Undo, edit)?;
        Ok(true)
    }

    /// Redoes the last undone edit; `false` when there is nothing to redo.
    pub fn redo(&mut self) -> Result<bool, AnnotateError> {
        let Some(edit) = self.redo.pop() else {
            return Ok(false);
        };
        let inverse = match edit.apply(&mut self.labels) {
            Ok(inverse) => inverse,
            Err(error) => {
                self.redo.push(edit);
                return Err(error);
            }
        };
        self.undo.push(inverse);
        self.record(Step::Redo, edit)?;
        Ok(true)
    }

    /// Whether there is an edit to undo.
    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    /// Whether there is an undone edit to redo.
    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    fn record(&mut self, step: Step, edit: Edit) -> Result<(), AnnotateError> {
        self.seq += 1;
        let Some(writer) = &self.writer else {
            return Ok(());
        };
        writer.append(JournalRecord {
            seq: self.seq,
            step,
            edit,
        })?;
        match self.mode {
            SaveMode::Durable => writer.flush(),
            SaveMode::Background => Ok(()),
        }
    }

    /// Waits until every edit applied so far is on disk.
    pub fn flush(&self) -> Result<(), AnnotateError> {
        self.writer.as_ref().map_or(Ok(()), JournalWriter::flush)
    }

    /// Writes `labels.json` with the labels as they are now and empties the journal, then
    /// waits for it. Undo and redo stay available in memory.
    pub fn compact(&mut self) -> Result<(), AnnotateError> {
        let Some(writer) = &self.writer else {
            return Ok(());
        };
        writer.compact(self.labels.clone(), self.seq)?;
        writer.flush()
    }
}

/// Copies a damaged file to `<file>.corrupt-<unix ms>` (fsynced) and returns the copy's
/// path; the original is replaced only afterwards, by a compacted `labels.json`.
fn copy_aside(path: &Path) -> Result<PathBuf, AnnotateError> {
    let millis = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis());
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let mut target = path.with_file_name(format!("{name}.corrupt-{millis}"));
    let mut k = 1;
    while target.exists() {
        target = path.with_file_name(format!("{name}.corrupt-{millis}-{k}"));
        k += 1;
    }
    std::fs::copy(path, &target).map_err(|e| AnnotateError::io(&target, e))?;
    std::fs::File::open(&target)
        .and_then(|f| f.sync_all())
        .map_err(|e| AnnotateError::io(&target, e))?;
    Ok(target)
}
