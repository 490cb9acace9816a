//! Failure cases and their tags: jumping between cases, tagging the cursor's case, and the
//! failure table as CSV.

use std::path::Path;

use crate::app::error::AppError;
use crate::app::failures::{FailureCase, FailureRow, TAGS_FILE, failures_csv, write_atomically};

use super::AppState;
use super::log::LogLevel;

impl AppState {
    /// The frames "tag range" tags: mark to cursor, else the selected failure run when it
    /// is in this scenario, else the cursor's frame.
    pub(super) fn tag_range(&self) -> (usize, usize) {
        let frame = self.frame();
        if let Some(mark) = self.labeling.mark {
            return (mark.min(frame), mark.max(frame));
        }
        self.failure_cursor
            .and_then(|c| self.failures.get(c))
            .filter(|c| c.scenario == self.current)
            .map_or((frame, frame), |c| (c.start, c.end))
    }

    pub(super) fn jump_to_failure(&mut self, index: usize) {
        let Some(case) = self.failures.get(index).cloned() else {
            return;
        };
        self.failure_cursor = Some(index);
        if case.scenario != self.current {
            self.select_scenario(case.scenario);
        }
        self.playback.seek(case.focus);
    }

    /// Failure cases of every scored scenario, ranked within each kind.
    pub fn failures(&self) -> &[FailureCase] {
        &self.failures
    }

    /// The failure case last jumped to.
    pub fn failure_cursor(&self) -> Option<usize> {
        self.failure_cursor
    }

    /// The tag of failure case `index`.
    pub fn failure_tag(&self, index: usize) -> Option<&str> {
        let case = self.failures.get(index)?;
        self.tags.get(case.scenario)?.get(&case.tag_key())
    }

    /// Tags failure case `index` (an empty text removes the tag) and saves the scenario's
    /// tags; a failed save is logged and the tag kept in memory.
    pub fn set_failure_tag(&mut self, index: usize, tag: &str) {
        let Some(case) = self.failures.get(index) else {
            return;
        };
        let (scenario, key) = (case.scenario, case.tag_key());
        let Some(tags) = self.tags.get_mut(scenario) else {
            return;
        };
        tags.set(key, tag);
        let path = self
            .dataset
            .as_ref()
            .and_then(|d| d.scenarios.get(scenario))
            .and_then(|e| e.scenario.as_ref())
            .map(|s| s.cache_dir().map(|d| d.join(TAGS_FILE)));
        let saved = match path {
            Some(Ok(path)) => tags.save(&path),
            Some(Err(e)) => Err(e.into()),
            None => Ok(()),
        };
        if let Err(e) = saved {
            self.log(LogLevel::Error, format!("failure tags not saved: {e}"));
        }
    }

    /// The failure cases as CSV (see [`crate::app::failures::FAILURE_CSV_HEADER`]).
    pub fn failures_csv(&self) -> String {
        let Some(dataset) = &self.dataset else {
            return failures_csv(std::iter::empty());
        };
        failures_csv(self.failures.iter().enumerate().map(|(i, case)| {
            let entry = &dataset.scenarios[case.scenario];
            let id = |frame: usize| entry.scenario.as_ref().and_then(|s| s.frame_id(frame));
            FailureRow {
                case,
                scenario: &entry.name,
                ids: [id(case.start), id(case.focus), id(case.end)],
                tag: self.failure_tag(i),
            }
        }))
    }

    /// Writes [`Self::failures_csv`] to `path`.
    pub fn export_failures(&self, path: &Path) -> Result<(), AppError> {
        write_atomically(path, self.failures_csv().as_bytes())
    }
}
