//! The background writer of a scenario's label files: a thread that appends journal
//! records (several queued records share one fsync), writes `labels.json` atomically
//! (temporary file, fsync, rename, fsync of the folder) and then empties the journal. The
//! caller only sends; [`JournalWriter::flush`] waits until everything sent is on disk.
//! A failed write keeps its records and is retried with the next message. The journal's
//! lock ([`lock_journal`]) keeps a second process from editing the same labels.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;

use crate::atomic_file::write_atomically;

use super::AnnotateError;
use super::document::encode_document;
use super::journal::{JournalRecord, encode_record};
use super::labels::LabelSet;

/// File name of the compacted labels inside vadscope's scenario folder.
pub const LABELS_FILE: &str = "labels.json";
/// File name of the edit journal inside vadscope's scenario folder.
pub const JOURNAL_FILE: &str = "labels.journal";

enum Message {
    Append(JournalRecord),
    Compact { labels: Box<LabelSet>, seq: u64 },
    Flush(Sender<Result<(), String>>),
}

/// Handle to the writer thread of one scenario's label files.
pub struct JournalWriter {
    sender: Option<Sender<Message>>,
    thread: Option<JoinHandle<()>>,
    saved_seq: Arc<AtomicU64>,
    journal: PathBuf,
}

impl JournalWriter {
    /// Starts the writer for the files in `dir`, appending to `file`, the journal as
    /// [`lock_journal`] opened it (the writer keeps its lock); `saved_seq` is the last record
    /// already on disk.
    pub fn start(dir: &Path, file: File, saved_seq: u64) -> Result<Self, AnnotateError> {
        let journal = dir.join(JOURNAL_FILE);
        let good_len = file
            .metadata()
            .map_err(|e| AnnotateError::io(&journal, e))?
            .len();
        let saved = Arc::new(AtomicU64::new(saved_seq));
        let (sender, receiver) = channel();
        let state = WriterState {
            dir: dir.to_path_buf(),
            journal: journal.clone(),
            file,
            good_len,
            pending: Vec::new(),
            pending_last_seq: saved_seq,
            saved: Arc::clone(&saved),
            error: None,
        };
        let thread = std::thread::Builder::new()
            .name("vadscope-labels-writer".into())
            .spawn(move || state.run(receiver))
            .map_err(|e| AnnotateError::io(dir, e))?;
        Ok(Self {
            sender: Some(sender),
            thread: Some(thread),
            saved_seq: saved,
            journal,
        })
    }

    /// Queues a record for the journal; returns at once.
    pub fn append(&self, record: JournalRecord) -> Result<(), AnnotateError> {
        self.send(Message::Append(record))
    }

    /// Queues writing `labels.json` with `labels` at record `seq`, after which the journal
    /// is emptied.
    pub fn compact(&self, labels: LabelSet, seq: u64) -> Result<(), AnnotateError> {
        self.send(Message::Compact {
            labels: Box::new(labels),
            seq,
        })
    }

    /// Waits until everything queued so far is on disk (fsynced).
    pub fn flush(&self) -> Result<(), AnnotateError> {
        let (reply, answer) = channel();
        self.send(Message::Flush(reply))?;
        answer
            .recv()
            .map_err(|_| self.gone())?
            .map_err(|problem| AnnotateError::Save {
                path: self.journal.clone(),
                problem,
            })
    }

    /// The last journal record known to be on disk.
    pub fn saved_seq(&self) -> u64 {
        self.saved_seq.load(Ordering::Acquire)
    }

    fn send(&self, message: Message) -> Result<(), AnnotateError> {
        self.sender
            .as_ref()
            .and_then(|s| s.send(message).ok())
            .ok_or_else(|| self.gone())
    }

    fn gone(&self) -> AnnotateError {
        AnnotateError::Save {
            path: self.journal.clone(),
            problem: "the writer thread has stopped".into(),
        }
    }
}

impl Drop for JournalWriter {
    /// Writes what is still queued, then stops the thread.
    fn drop(&mut self) {
        self.sender.take();
        if let Some(thread) = self.thread.take() {
            // A panicked writer has nothing more to write; its records are in the journal
            // up to the last successful flush.
            let _ = thread.join();
        }
    }
}

/// Opens the journal in `dir` for appending and takes the exclusive lock that marks the
/// scenario's labels as being edited, so that two processes never edit them at once (the
/// second would overwrite the first one's `labels.json` and lose its edits). The lock lasts
/// as long as the file stays open and the operating system drops it when the process ends,
/// however it ends, so a killed editor never leaves the labels locked. The journal is
/// emptied in place, never replaced, so the lock stays with it.
pub fn lock_journal(dir: &Path) -> Result<File, AnnotateError> {
    let path = dir.join(JOURNAL_FILE);
    let file = OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .map_err(|e| AnnotateError::io(&path, e))?;
    match file.try_lock() {
        Err(std::fs::TryLockError::WouldBlock) => Err(AnnotateError::Busy { path }),
        // A filesystem without locks (some network shares) still lets the labels be
        // edited, unguarded, rather than not at all.
        Ok(()) | Err(std::fs::TryLockError::Error(_)) => Ok(file),
    }
}

struct WriterState {
    dir: PathBuf,
    journal: PathBuf,
    file: File,
    /// Journal length after the last successful write.
    good_len: u64,
    pending: Vec<u8>,
    pending_last_seq: u64,
    saved: Arc<AtomicU64>,
    error: Option<String>,
}

impl WriterState {
    fn run(mut self, receiver: Receiver<Message>) {
        while let Ok(first) = receiver.recv() {
            let mut flushes = Vec::new();
            let mut next = Some(first);
            while let Some(message) = next {
                match message {
                    Message::Append(record) => {
                        self.pending
                            .extend_from_slice(encode_record(&record).as_bytes());
                        self.pending_last_seq = record.seq;
                    }
                    Message::Compact { labels, seq } => {
                        self.write_pending();
                        if self.error.is_none() {
                            let outcome = self.compact(&labels, seq);
                            self.note(outcome);
                        }
                    }
                    Message::Flush(reply) => flushes.push(reply),
                }
                next = receiver.try_recv().ok();
            }
            self.write_pending();
            if !flushes.is_empty() {
                let outcome = self.error.clone().map_or(Ok(()), Err);
                if self.pending.is_empty() {
                    // Reported once; nothing is left to retry.
                    self.error = None;
                }
                for reply in flushes {
                    // A caller that stopped waiting does not need the answer.
                    let _ = reply.send(outcome.clone());
                }
            }
        }
        self.write_pending();
    }

    fn note(&mut self, result: Result<(), String>) {
        if let Err(problem) = result {
            self.error = Some(problem);
        }
    }

    /// Appends and fsyncs the pending records; on failure they stay pending.
    fn write_pending(&mut self) {
        if self.pending.is_empty() {
            return;
        }
        let result = self
            .file
            .write_all(&self.pending)
            .and_then(|()| self.file.sync_data())
            .map_err(|e| format!("{}: {e}", self.journal.display()));
        match result {
            Ok(()) => {
                self.good_len += self.pending.len() as u64;
                self.pending.clear();
                self.error = None;
                self.saved.store(self.pending_last_seq, Ordering::Release);
            }
            Err(problem) => {
                // Cut off any partial line, so the retry starts on a clean line; if even
                // that fails, reading the journal reports the partial line as damaged.
                self.error = Some(problem);
                let _ = self.file.set_len(self.good_len);
            }
        }
    }

    fn compact(&mut self, labels: &LabelSet, seq: u64) -> Result<(), String> {
        let path = self.dir.join(LABELS_FILE);
        write_atomically(&path, encode_document(labels, seq).as_bytes())
            .map_err(|e| e.to_string())?;
        self.file
            .set_len(0)
            .and_then(|()| self.file.sync_all())
            .map_err(|e| format!("{}: {e}", self.journal.display()))?;
        self.good_len = 0;
        self.error = None;
        Ok(())
    }
}
