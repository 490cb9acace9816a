//! [`Scenario`]: one opened scenario folder, either AnoVox layout. Frames are addressed by
//! index (0-based position in the sorted frame ids); images are decoded lazily through a
//! byte-bounded LRU cache, so scrubbing a long scenario keeps memory bounded.
//!
//! Accessors return `Ok(None)` when a modality has no file for the frame and an error
//! naming the file when the file is broken or its size differs from the scenario's frames.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock, PoisonError};

use super::boxes::{boxes_from_instance, group_by_frame, read_boxes};
use super::cache::ByteLru;
use super::discovery::{LayoutKind, ScenarioFiles, scan_scenario};
use super::images::read_header;
use super::index::FrameIndex;
use super::labels::{FrameLabels, LabelInputs, derive_frame_labels};
use super::layout::{BOXES_FILE, DETECTIONS_FILE, SCENARIO_JSON_FILE};
use super::meta::{
    find_anovox_config, merge_anovox_config, read_scenario_json, read_sensor_setup_camera,
};
use super::problem::FileProblem;
use super::vadscope_dir::{resolve_cache_dir, user_cache_base};
use super::{BoxRecord, CameraIntrinsics, FrameId, Modality, ScenarioMeta, SequenceError};
use frames::{Decoded, Slot};

mod frames;

/// Options for [`Scenario::open_with`].
#[derive(Debug, Clone)]
pub struct ScenarioOptions {
    /// Byte budget of the decoded-frame cache (all image kinds together).
    pub cache_budget_bytes: usize,
    /// Base folder for vadscope's files when the scenario folder is read-only.
    pub user_cache_base: PathBuf,
}

impl Default for ScenarioOptions {
    /// 512 MiB of cache: about 430 frames of 768×512 RGB.
    fn default() -> Self {
        Self {
            cache_budget_bytes: 512 << 20,
            user_cache_base: user_cache_base(),
        }
    }
}

/// Where a scenario's boxes come from.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub enum BoxSource {
    /// `BBOX_2D/boxes.csv`.
    File(PathBuf),
    /// Derived from INSTANCE_IMG (and SEMANTIC_IMG where present).
    InstanceImages,
    /// No boxes available.
    None,
}

impl std::fmt::Display for BoxSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BoxSource::File(_) => f.write_str(BOXES_FILE),
            BoxSource::InstanceImages => f.write_str("derived from instance images"),
            BoxSource::None => f.write_str("none"),
        }
    }
}

type BoxTable = BTreeMap<FrameId, Vec<BoxRecord>>;

/// One scenario folder, opened.
#[derive(Debug)]
pub struct Scenario {
    root: PathBuf,
    name: String,
    files: ScenarioFiles,
    index: FrameIndex,
    meta: ScenarioMeta,
    resolution: (u32, u32),
    notes: Vec<FileProblem>,
    box_source: BoxSource,
    detections_file: Option<PathBuf>,
    options: ScenarioOptions,
    cache: ByteLru<(Slot, usize), Decoded>,
    labels: OnceLock<FrameLabels>,
    ground_truth_boxes: OnceLock<Result<BoxTable, SequenceError>>,
    detection_boxes: OnceLock<Result<BoxTable, SequenceError>>,
    derived_boxes: Mutex<HashMap<usize, Vec<BoxRecord>>>,
    cache_dir: OnceLock<Result<PathBuf, SequenceError>>,
}

impl Scenario {
    /// Opens a scenario folder with default options.
    pub fn open(path: &Path) -> Result<Self, SequenceError> {
        Self::open_with(path, ScenarioOptions::default())
    }

    /// Opens a scenario folder: scans its files, builds the frame index from the RGB
    /// frames, reads metadata (`scenario.json`, AnoVox's configuration, `sensor_setup.json`)
    /// and the size of the first readable RGB frame. Broken metadata is noted, not fatal;
    /// a folder without readable RGB frames is an error.
    pub fn open_with(path: &Path, options: ScenarioOptions) -> Result<Self, SequenceError> {
        if !path.is_dir() {
            return Err(SequenceError::NotAScenario {
                path: path.to_path_buf(),
                problem: "not a folder".into(),
            });
        }
        let files = scan_scenario(path)?;
        let rgb = files.of(Modality::Rgb).filter(|f| !f.is_empty()).ok_or_else(|| {
            SequenceError::NotAScenario {
                path: path.to_path_buf(),
                problem: "no RGB frames (expected RGB_IMG/RGB_IMG_<frame>.png or RGB-CAM*/<folder>_<frame>.png)"
                    .into(),
            }
        })?;
        let index = FrameIndex::new(rgb.keys().copied());
        let resolution = first_readable_size(path, rgb)?;
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        let mut notes = files.notes.clone();
        let meta = load_meta(path, &name, &files, &mut notes);
        let box_source = find_box_source(path, &files);
        let detections_file = Some(path.join(DETECTIONS_FILE)).filter(|p| p.is_file());
        Ok(Self {
            root: path.to_path_buf(),
            name,
            files,
            index,
            meta,
            resolution,
            notes,
            box_source,
            detections_file,
            cache: ByteLru::new(options.cache_budget_bytes),
            options,
            labels: OnceLock::new(),
            ground_truth_boxes: OnceLock::new(),
            detection_boxes: OnceLock::new(),
            derived_boxes: Mutex::new(HashMap::new()),
            cache_dir: OnceLock::new(),
        })
    }

    /// Number of frames (RGB frames).
    pub fn len(&self) -> usize {
        self.index.len()
    }

    /// Whether the scenario has no frames (never true for an opened scenario).
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// The AnoVox frame id of frame `index`.
    pub fn frame_id(&self, index: usize) -> Option<FrameId> {
        self.index.frame_id(index)
    }

    /// The index of AnoVox frame `id`.
    pub fn index_of(&self, id: FrameId) -> Option<usize> {
        self.index.index_of(id)
    }

    /// The frame index (sorted ids, gaps, runs).
    pub fn frame_index(&self) -> &FrameIndex {
        &self.index
    }

    /// The scenario folder's name, e.g. `Scenario_ef183332-...`.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The scenario folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Metadata: `scenario.json`, completed from AnoVox's configuration and sensor setup.
    pub fn meta(&self) -> &ScenarioMeta {
        &self.meta
    }

    /// The camera: from the metadata, else AnoVox's (FOV 90°, centred, 1.8 m) at the frame size.
    pub fn camera(&self) -> CameraIntrinsics {
        self.meta
            .camera
            .unwrap_or_else(|| CameraIntrinsics::anovox(self.resolution.0, self.resolution.1))
    }

    /// Width and height of the frames (of the first readable RGB frame).
    pub fn resolution(&self) -> (u32, u32) {
        self.resolution
    }

    /// Which AnoVox convention the scenario's folders follow.
    pub fn layout(&self) -> LayoutKind {
        self.files.layout()
    }

    /// Every per-frame file, by modality.
    pub fn files(&self) -> &ScenarioFiles {
        &self.files
    }

    /// Problems noticed while opening (skipped files, broken metadata); not fatal.
    pub fn notes(&self) -> &[FileProblem] {
        &self.notes
    }

    /// Whether any frame has a file of `modality`.
    pub fn has(&self, modality: Modality) -> bool {
        self.files.of(modality).is_some_and(|f| !f.is_empty())
    }

    /// The file of `modality` for frame `index`, if there is one.
    pub fn file(&self, modality: Modality, index: usize) -> Option<&Path> {
        self.files.file(modality, self.index.frame_id(index)?)
    }

    /// Per-frame anomaly flags and their source, derived once (see
    /// [`super::labels::derive_frame_labels`] for the order of preference).
    pub fn frame_labels(&self) -> &FrameLabels {
        self.labels.get_or_init(|| {
            derive_frame_labels(&LabelInputs {
                root: &self.root,
                files: &self.files,
                index: &self.index,
                meta: &self.meta,
            })
        })
    }

    /// Where [`Scenario::boxes`] come from (decided when the scenario is opened).
    pub fn box_source(&self) -> &BoxSource {
        &self.box_source
    }

    /// Ground-truth boxes of frame `index`: from `BBOX_2D/boxes.csv`, else derived from the
    /// instance image (track id = instance id; see [`boxes_from_instance`]).
    pub fn boxes(&self, index: usize) -> Result<Vec<BoxRecord>, SequenceError> {
        let id = self.frame_id_checked(index)?;
        match self.box_source() {
            BoxSource::File(path) => {
                let table = self.ground_truth_boxes.get_or_init(|| load_box_table(path));
                Ok(boxes_of(table.as_ref().map_err(Clone::clone)?, id))
            }
            BoxSource::InstanceImages => self.derived_boxes(index, id),
            BoxSource::None => Ok(Vec::new()),
        }
    }

    /// Detector boxes of frame `index` from `BBOX_2D_DET/boxes.csv` (empty without the file).
    pub fn detections(&self, index: usize) -> Result<Vec<BoxRecord>, SequenceError> {
        let id = self.frame_id_checked(index)?;
        let Some(path) = &self.detections_file else {
            return Ok(Vec::new());
        };
        let table = self.detection_boxes.get_or_init(|| load_box_table(path));
        Ok(boxes_of(table.as_ref().map_err(Clone::clone)?, id))
    }

    fn derived_boxes(&self, index: usize, id: FrameId) -> Result<Vec<BoxRecord>, SequenceError> {
        let memo = || {
            self.derived_boxes
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
        };
        if let Some(boxes) = memo().get(&index) {
            return Ok(boxes.clone());
        }
        let Some(instance) = self.instance(index)? else {
            return Ok(Vec::new());
        };
        let semantic = self.semantic(index)?;
        let boxes = boxes_from_instance(id, &instance, semantic.as_ref().map(|s| &s.ids));
        memo().insert(index, boxes.clone());
        Ok(boxes)
    }

    /// vadscope's folder for this scenario: `<scenario>/.vadscope/`, or a per-user cache
    /// folder keyed by the scenario path when the scenario folder is read-only. Created
    /// on first use.
    pub fn cache_dir(&self) -> Result<PathBuf, SequenceError> {
        self.cache_dir
            .get_or_init(|| resolve_cache_dir(&self.root, &self.options.user_cache_base))
            .clone()
    }
}

fn find_box_source(root: &Path, files: &ScenarioFiles) -> BoxSource {
    let file = root.join(BOXES_FILE);
    if file.is_file() {
        BoxSource::File(file)
    } else if files.of(Modality::Instance).is_some_and(|f| !f.is_empty()) {
        BoxSource::InstanceImages
    } else {
        BoxSource::None
    }
}

fn load_box_table(path: &Path) -> Result<BoxTable, SequenceError> {
    read_boxes(path).map(group_by_frame)
}

fn boxes_of(table: &BoxTable, id: FrameId) -> Vec<BoxRecord> {
    table.get(&id).cloned().unwrap_or_default()
}

/// The size of the first RGB frame whose header can be read.
fn first_readable_size(
    root: &Path,
    rgb: &BTreeMap<FrameId, PathBuf>,
) -> Result<(u32, u32), SequenceError> {
    let mut last_error = None;
    for path in rgb.values() {
        match read_header(path) {
            Ok(header) => return Ok((header.width, header.height)),
            Err(error) => last_error = Some(error),
        }
    }
    Err(SequenceError::NotAScenario {
        path: root.to_path_buf(),
        problem: format!(
            "none of the {} RGB frames can be read (last error: {})",
            rgb.len(),
            last_error.map_or_else(String::new, |e| e.to_string())
        ),
    })
}

/// `scenario.json`, then AnoVox's configuration entry, then `sensor_setup.json`; problems
/// go to `notes`.
fn load_meta(
    root: &Path,
    name: &str,
    files: &ScenarioFiles,
    notes: &mut Vec<FileProblem>,
) -> ScenarioMeta {
    let json = root.join(SCENARIO_JSON_FILE);
    let mut meta = if json.is_file() {
        read_scenario_json(&json).unwrap_or_else(|error| {
            notes.push(FileProblem::from_error(&error));
            ScenarioMeta::default()
        })
    } else {
        ScenarioMeta::default()
    };
    if let (Some(uuid), Some(dataset_root)) = (name.strip_prefix("Scenario_"), root.parent()) {
        match find_anovox_config(dataset_root, uuid) {
            Ok(Some(entry)) => merge_anovox_config(&mut meta, &entry),
            Ok(None) => {}
            Err(error) => notes.push(FileProblem::from_error(&error)),
        }
    }
    if meta.camera.is_none() {
        let rgb_folder = files
            .folders
            .get(&Modality::Rgb)
            .and_then(|f| f.file_name())
            .map(|n| n.to_string_lossy().into_owned());
        match read_sensor_setup_camera(root, rgb_folder.as_deref()) {
            Ok(camera) => meta.camera = camera,
            Err(error) => notes.push(FileProblem::from_error(&error)),
        }
    }
    meta
}
