//! What the viewer remembers between runs: panel sizes and which panels are open, the
//! analyst's settings and the recently opened data sets, as a small JSON file in the
//! user's configuration folder (`<config dir>/vadscope/viewer.json`).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::error::AppError;
use super::failures::write_atomically;
use super::settings::ViewSettings;

/// Recent data sets kept.
pub const RECENT_CAPACITY: usize = 8;

/// Open flags and sizes of the panels, the settings and the recent data sets.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Layout {
    /// Width of the left panel (scenarios, failure cases), points.
    pub left_width: f32,
    /// Width of the right panel (weights, metrics, inspector), points.
    pub right_width: f32,
    /// Height of the timeline, points.
    pub timeline_height: f32,
    /// Whether the left panel is open.
    pub left_open: bool,
    /// Whether the right panel is open.
    pub right_open: bool,
    /// Whether the timeline is open.
    pub timeline_open: bool,
    /// Whether the log panel is open.
    pub log_open: bool,
    /// The analyst's settings.
    pub settings: ViewSettings,
    /// Recently opened data sets, newest first.
    pub recent: Vec<PathBuf>,
}

impl Default for Layout {
    fn default() -> Self {
        Self {
            left_width: 300.0,
            right_width: 330.0,
            timeline_height: 190.0,
            left_open: true,
            right_open: true,
            timeline_open: true,
            log_open: true,
            settings: ViewSettings::default(),
            recent: Vec::new(),
        }
    }
}

impl Layout {
    /// Where the layout is kept for this user: `<config dir>/vadscope/viewer.json`.
    pub fn default_path() -> Option<PathBuf> {
        dirs::config_dir().map(|d| d.join("vadscope").join("viewer.json"))
    }

    /// Reads the layout at `path`; no file gives the default layout.
    pub fn load(path: &Path) -> Result<Self, AppError> {
        match std::fs::read_to_string(path) {
            Ok(text) => serde_json::from_str(&text).map_err(|e| AppError::File {
                path: path.to_path_buf(),
                problem: format!("not a viewer layout: {e}"),
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Self::default()),
            Err(e) => Err(AppError::io(path, e)),
        }
    }

    /// Writes the layout to `path` atomically.
    pub fn save(&self, path: &Path) -> Result<(), AppError> {
        let text = serde_json::to_string_pretty(self).map_err(|e| AppError::File {
            path: path.to_path_buf(),
            problem: e.to_string(),
        })?;
        write_atomically(path, text.as_bytes())
    }

    /// Puts `path` first among the recent data sets.
    pub fn remember(&mut self, path: &Path) {
        let path = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        self.recent.retain(|p| p != &path);
        self.recent.insert(0, path);
        self.recent.truncate(RECENT_CAPACITY);
    }
}
