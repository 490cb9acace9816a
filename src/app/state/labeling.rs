//! The labeling mode as the state drives it: one `annotate::Editor` per scenario opened on
//! first use, and each labeling [`Action`](crate::app::action::Action) turned into one edit.

use crate::app::action::Action;
use crate::app::dataset::Dataset;
use crate::app::labeling::{Labeling, ScenarioLabels};
use crate::app::settings::Reference;

use super::AppState;
use super::log::LogLevel;

impl AppState {
    /// Opens the labels of scenario `index` unless open, logging what opening found wrong
    /// (damaged files are named and copied aside); returns whether they are open.
    pub(super) fn open_labels(&mut self, index: usize) -> bool {
        if self.labeling.is_open(index) {
            return true;
        }
        let Some(entry) = self.dataset.as_ref().and_then(|d| d.scenarios.get(index)) else {
            return false;
        };
        let Some(scenario) = &entry.scenario else {
            let message = format!("{}: no scenario on disk, nothing to label", entry.name);
            self.log(LogLevel::Warning, message);
            return false;
        };
        let name = entry.name.clone();
        match ScenarioLabels::open(scenario) {
            Ok((labels, report)) => {
                for problem in report.problems {
                    self.log(LogLevel::Error, format!("labels of {name}: {problem}"));
                }
                for copy in report.set_aside {
                    self.log(
                        LogLevel::Warning,
                        format!("the damaged label file was kept as {}", copy.display()),
                    );
                }
                let dir = labels
                    .editor()
                    .dir()
                    .map_or_else(String::new, |d| d.display().to_string());
                self.log(LogLevel::Info, format!("labels of {name} open ({dir})"));
                self.labeling.insert(index, labels);
                true
            }
            Err(e) => {
                self.log(LogLevel::Error, format!("labels of {name} not opened: {e}"));
                false
            }
        }
    }

    /// Opens every scenario's labels (for the analyst-labels reference).
    pub(super) fn open_all_labels(&mut self) {
        let len = self.dataset.as_ref().map_or(0, Dataset::len);
        for index in 0..len {
            let on_disk = self
                .dataset
                .as_ref()
                .is_some_and(|d| d.scenarios[index].scenario.is_some());
            if on_disk {
                self.open_labels(index);
            }
        }
    }

    /// Carries out a labeling action on the current scenario; what fails is logged.
    pub(super) fn label(&mut self, action: Action) {
        if !self.labeling.active {
            self.log(
                LogLevel::Warning,
                "labeling is off: press L (or View > Labeling mode) first",
            );
            return;
        }
        if !self.open_labels(self.current) {
            return;
        }
        let frame = self.frame();
        let range = self.tag_range();
        let (result, changed) = self.labeling.perform(self.current, action, frame, range);
        match result {
            Ok(Some(message)) => self.log(LogLevel::Info, message),
            Ok(None) => {}
            Err(e) => self.log(LogLevel::Warning, format!("labeling: {e}")),
        }
        if changed && self.settings.reference == Reference::AnalystLabels {
            self.refuse();
        }
    }

    /// The labeling mode: whether it is on, the mark, the selected box, the tag text.
    pub fn labeling(&self) -> &Labeling {
        &self.labeling
    }

    /// Whether the labeling mode is on.
    pub fn is_labeling(&self) -> bool {
        self.labeling.active
    }

    /// The tag text "tag range" uses, to edit.
    pub fn tag_text_mut(&mut self) -> &mut String {
        &mut self.labeling.tag_text
    }

    /// The current scenario's labels, when open.
    pub fn current_labels(&self) -> Option<&ScenarioLabels> {
        self.labeling.get(self.current)
    }
}
