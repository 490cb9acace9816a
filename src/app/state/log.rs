//! The log panel's messages: what the state reports (progress, results, failures), kept up
//! to a fixed number of entries.

use super::AppState;

/// How serious a log entry is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogLevel {
    /// Progress and results.
    Info,
    /// Something could not be used, the rest goes on.
    Warning,
    /// Something failed.
    Error,
}

/// One message of the log panel.
#[derive(Debug, Clone, PartialEq)]
pub struct LogEntry {
    /// How serious.
    pub level: LogLevel,
    /// What happened, naming the file involved.
    pub message: String,
}

/// Log entries kept (older ones are dropped).
const LOG_CAPACITY: usize = 500;

impl AppState {
    /// The log, oldest first.
    pub fn log_entries(&self) -> &[LogEntry] {
        &self.log
    }

    /// Adds a log entry.
    pub fn log(&mut self, level: LogLevel, message: impl Into<String>) {
        self.push_log(LogEntry {
            level,
            message: message.into(),
        });
    }

    pub(super) fn push_log(&mut self, entry: LogEntry) {
        if self.log.len() >= LOG_CAPACITY {
            self.log.remove(0);
        }
        self.log.push(entry);
    }
}
