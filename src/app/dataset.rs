//! The open data set: its scenarios (opened lazily through `sequence`, a scenario that
//! fails to open is kept as an entry with its error), their labels and conditions, and
//! where each one's scores stand.

use std::path::{Path, PathBuf};

use crate::score::{ScoreCache, ScoreProgress, ScoreTable};
use crate::sequence::{Domain, Scenario, Weather, discover_scenarios};

use super::error::AppError;

/// The scores of a scenario as the viewer holds them.
#[derive(Debug)]
pub enum Scores {
    /// An opened score cache: tables in memory, per-object maps read from disk on demand.
    Cache(ScoreCache),
    /// A table alone (no maps, so no heatmaps or patches): synthetic or imported scores.
    Table(ScoreTable),
}

impl Scores {
    /// The scalar tables.
    pub fn table(&self) -> &ScoreTable {
        match self {
            Self::Cache(cache) => cache.table(),
            Self::Table(table) => table,
        }
    }

    /// The cache, when the scores have maps on disk.
    pub fn cache(&self) -> Option<&ScoreCache> {
        match self {
            Self::Cache(cache) => Some(cache),
            Self::Table(_) => None,
        }
    }
}

/// Where a scenario's scores stand.
#[derive(Debug, Default)]
pub enum ScoreStatus {
    /// Not looked up or scored yet.
    #[default]
    Pending,
    /// Being scored by the background job.
    Scoring(ScoreProgress),
    /// Scored.
    Ready(Scores),
    /// Scoring failed or was cancelled; the message says why.
    Failed(String),
}

impl ScoreStatus {
    /// The scores, when ready.
    pub fn scores(&self) -> Option<&Scores> {
        match self {
            Self::Ready(scores) => Some(scores),
            _ => None,
        }
    }

    /// A short word for the scenario browser.
    pub fn label(&self) -> String {
        match self {
            Self::Pending => "not scored".into(),
            Self::Scoring(p) => format!("scoring {}/{}", p.frames_done, p.frames_total),
            Self::Ready(_) => "scored".into(),
            Self::Failed(_) => "failed".into(),
        }
    }
}

/// One scenario of the data set.
#[derive(Debug)]
pub struct ScenarioEntry {
    /// The scenario folder.
    pub root: PathBuf,
    /// Folder name.
    pub name: String,
    /// The opened scenario; `None` when it could not be opened or has no frames on disk.
    pub scenario: Option<Scenario>,
    /// Why the scenario could not be opened.
    pub error: Option<String>,
    /// Number of frames.
    pub frames: usize,
    /// Road environment.
    pub domain: Domain,
    /// Weather.
    pub weather: Weather,
    /// Per-frame anomaly flags (ground truth), one per frame.
    pub labels: Vec<bool>,
    /// Where its scores stand.
    pub status: ScoreStatus,
}

impl ScenarioEntry {
    /// Opens the scenario at `root`; a scenario that cannot be opened gives an entry with
    /// its error and no frames.
    pub fn open(root: &Path) -> Self {
        let name = root.file_name().map_or_else(
            || root.display().to_string(),
            |n| n.to_string_lossy().into(),
        );
        match Scenario::open(root) {
            Ok(scenario) if scenario.is_empty() => Self::failed(
                root,
                name,
                format!("{}: no readable RGB frame", root.display()),
            ),
            Ok(scenario) => {
                let meta = scenario.meta();
                Self {
                    root: root.to_path_buf(),
                    name,
                    frames: scenario.len(),
                    domain: meta.domain,
                    weather: meta.weather,
                    labels: scenario.frame_labels().flags.clone(),
                    scenario: Some(scenario),
                    error: None,
                    status: ScoreStatus::Pending,
                }
            }
            Err(e) => Self::failed(root, name, e.to_string()),
        }
    }

    fn failed(root: &Path, name: String, error: String) -> Self {
        Self {
            root: root.to_path_buf(),
            name,
            scenario: None,
            error: Some(error),
            frames: 0,
            domain: Domain::Unknown,
            weather: Weather::Unknown,
            labels: Vec::new(),
            status: ScoreStatus::Pending,
        }
    }

    /// An entry of scores alone, without frames on disk (synthetic or imported score
    /// tables): `labels` has one flag per frame of `table`.
    pub fn from_table(name: &str, labels: Vec<bool>, table: ScoreTable) -> Self {
        Self {
            root: PathBuf::from(name),
            name: name.to_string(),
            scenario: None,
            error: None,
            frames: table.frames.len(),
            domain: Domain::Unknown,
            weather: Weather::Unknown,
            labels,
            status: ScoreStatus::Ready(Scores::Table(table)),
        }
    }

    /// The scores, when ready.
    pub fn scores(&self) -> Option<&Scores> {
        self.status.scores()
    }
}

/// A data set: one scenario folder, or a root holding `Scenario_*` folders.
#[derive(Debug)]
pub struct Dataset {
    /// The path that was opened.
    pub root: PathBuf,
    /// The scenarios, sorted by folder name.
    pub scenarios: Vec<ScenarioEntry>,
}

impl Dataset {
    /// Opens `path` (a scenario or a data-set root). Errors when `path` holds no scenario;
    /// scenarios that fail to open are kept with their error.
    pub fn open(path: &Path) -> Result<Self, AppError> {
        let roots = discover_scenarios(path)?;
        Ok(Self {
            root: path.to_path_buf(),
            scenarios: roots.iter().map(|r| ScenarioEntry::open(r)).collect(),
        })
    }

    /// A data set of entries built elsewhere (for example [`ScenarioEntry::from_table`]).
    pub fn from_entries(root: impl Into<PathBuf>, scenarios: Vec<ScenarioEntry>) -> Self {
        Self {
            root: root.into(),
            scenarios,
        }
    }

    /// Number of scenarios.
    pub fn len(&self) -> usize {
        self.scenarios.len()
    }

    /// Whether the data set has no scenario.
    pub fn is_empty(&self) -> bool {
        self.scenarios.is_empty()
    }
}
