//! Finding scenarios and their files on disk, in both AnoVox conventions.
//!
//! - A dataset root holds `Scenario_*` folders (`Scenario_Configuration_Files` and stray
//!   files are skipped); a scenario folder can also be opened directly.
//! - Benchmark layout: one folder per modality, named like [`Modality::folder`], holding
//!   `<FOLDER>_<frame>.<ext>`.
//! - Generator layout: sensor folders named `<TYPE><location><rotation>_<hash>`, e.g.
//!   `RGB-CAM(0, 0, 1.8)(0, 0, 0)_8112341084538454858`, holding `<folder>_<frame>.png`. The
//!   type prefix gives the modality (RGB-CAM, DEPTH_CAM, SEMANTIC-CAM, INSTANCE-CAM;
//!   LIDAR and SEMANTIC-LIDAR are not read). With several cameras, the forward camera at
//!   (0, 0, 1.8)(0, 0, 0) is taken, else the first by name; the others are noted.
//! - The frame id is the integer after the last `_` of the file stem.
//! - Flow: `OPTICAL_FLOW/OPTICAL_FLOW_<frame>.{png,flo,npy}` first; otherwise HF²-VAD's
//!   `<image file name>.npy` next to the RGB image (`RGB_IMG/RGB_IMG_<frame>.png.npy`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::layout::CONFIG_FOLDER;
use super::problem::FileProblem;
use super::{FrameId, Modality, SequenceError};

/// Which AnoVox convention a scenario's folders follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum LayoutKind {
    /// `RGB_IMG/RGB_IMG_<frame>.png`, ... (what vadscope writes).
    Benchmark,
    /// Sensor folders such as `RGB-CAM(0, 0, 1.8)(0, 0, 0)_<hash>/`.
    Generator,
}

/// Every per-frame file of one scenario, by modality and frame id.
#[derive(Debug, Clone, Default)]
pub struct ScenarioFiles {
    /// Frame id → file, per modality (modalities without files are absent).
    pub frames: BTreeMap<Modality, BTreeMap<FrameId, PathBuf>>,
    /// The folder each modality was read from.
    pub folders: BTreeMap<Modality, PathBuf>,
    /// Things skipped while scanning (names without a frame id, duplicates, extra cameras).
    pub notes: Vec<FileProblem>,
}

impl ScenarioFiles {
    /// The files of one modality (empty when the modality is absent).
    pub fn of(&self, modality: Modality) -> Option<&BTreeMap<FrameId, PathBuf>> {
        self.frames.get(&modality)
    }

    /// The file of `modality` for frame `id`, if there is one.
    pub fn file(&self, modality: Modality, id: FrameId) -> Option<&Path> {
        self.frames.get(&modality)?.get(&id).map(PathBuf::as_path)
    }

    /// The convention of the RGB folder.
    pub fn layout(&self) -> LayoutKind {
        match self.folders.get(&Modality::Rgb).and_then(|f| f.file_name()) {
            Some(name) if name == Modality::Rgb.folder() => LayoutKind::Benchmark,
            Some(_) => LayoutKind::Generator,
            None => LayoutKind::Benchmark,
        }
    }
}

/// Generator-layout sensor type prefixes. `SEMANTIC-LIDAR` is listed before `LIDAR`'s
/// lookalikes only for clarity: matching is by exact prefix, and lidar data is not read.
const GENERATOR_PREFIXES: [(&str, Option<Modality>); 6] = [
    ("RGB-CAM", Some(Modality::Rgb)),
    ("DEPTH_CAM", Some(Modality::Depth)),
    ("SEMANTIC-CAM", Some(Modality::Semantic)),
    ("INSTANCE-CAM", Some(Modality::Instance)),
    ("SEMANTIC-LIDAR", None),
    ("LIDAR", None),
];

/// The mounting of AnoVox's MONO forward camera, preferred when several cameras exist.
const FORWARD_CAMERA: &str = "(0, 0, 1.8)(0, 0, 0)";

/// A modality folder found in a scenario.
#[derive(Debug, Clone, PartialEq, Eq)]
struct ModalityFolder {
    modality: Modality,
    path: PathBuf,
    /// `None` for benchmark folders; the text after the type prefix for sensor folders.
    sensor_mount: Option<String>,
}

/// Whether `name` is a scenario folder name in a dataset root.
pub fn is_scenario_name(name: &str) -> bool {
    name.starts_with("Scenario_") && name != CONFIG_FOLDER
}

/// Whether `dir` looks like a scenario itself: it has an RGB folder of either layout.
pub fn looks_like_scenario(dir: &Path) -> bool {
    list_subfolders(dir).is_ok_and(|folders| {
        folders
            .iter()
            .filter_map(|(name, path)| classify_folder(name, path))
            .any(|f| f.modality == Modality::Rgb)
    })
}

/// The scenarios under `path`: `[path]` when it is a scenario folder itself, else its
/// `Scenario_*` subfolders sorted by name. An error when there are none.
pub fn discover_scenarios(path: &Path) -> Result<Vec<PathBuf>, SequenceError> {
    if !path.is_dir() {
        return Err(SequenceError::NotAScenario {
            path: path.to_path_buf(),
            problem: "not a folder".into(),
        });
    }
    if looks_like_scenario(path) {
        return Ok(vec![path.to_path_buf()]);
    }
    let scenarios: Vec<PathBuf> = list_subfolders(path)?
        .into_iter()
        .filter(|(name, _)| is_scenario_name(name))
        .map(|(_, path)| path)
        .collect();
    if scenarios.is_empty() {
        return Err(SequenceError::NotAScenario {
            path: path.to_path_buf(),
            problem: "no Scenario_* folders and no RGB_IMG/ or RGB-CAM*/ folder".into(),
        });
    }
    Ok(scenarios)
}

/// Subfolders of `dir` as (name, path), sorted by name; hidden folders are skipped.
fn list_subfolders(dir: &Path) -> Result<Vec<(String, PathBuf)>, SequenceError> {
    let mut folders = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| SequenceError::io(dir, e))? {
        let entry = entry.map_err(|e| SequenceError::io(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if !name.starts_with('.') && is_dir_entry(&entry) {
            folders.push((name, entry.path()));
        }
    }
    folders.sort();
    Ok(folders)
}

/// Whether a directory entry is a file, following symbolic links. The entry's own type
/// needs no extra system call, which matters for folders of 30,000 frames.
fn is_file_entry(entry: &std::fs::DirEntry) -> bool {
    match entry.file_type() {
        Ok(kind) if kind.is_symlink() => entry.path().is_file(),
        Ok(kind) => kind.is_file(),
        Err(_) => false,
    }
}

/// Whether a directory entry is a folder, following symbolic links.
fn is_dir_entry(entry: &std::fs::DirEntry) -> bool {
    match entry.file_type() {
        Ok(kind) if kind.is_symlink() => entry.path().is_dir(),
        Ok(kind) => kind.is_dir(),
        Err(_) => false,
    }
}

fn classify_folder(name: &str, path: &Path) -> Option<ModalityFolder> {
    if let Some(modality) = Modality::ALL.into_iter().find(|m| m.folder() == name) {
        return Some(ModalityFolder {
            modality,
            path: path.to_path_buf(),
            sensor_mount: None,
        });
    }
    let (prefix, modality) = GENERATOR_PREFIXES
        .iter()
        .find(|(prefix, _)| sensor_mount_of(name, prefix).is_some())?;
    Some(ModalityFolder {
        modality: (*modality)?,
        path: path.to_path_buf(),
        sensor_mount: sensor_mount_of(name, prefix).map(str::to_string),
    })
}

/// The text after a sensor type prefix, when `name` is `<prefix>(...`: the `(` guard keeps
/// `LIDAR` from matching `LIDAR_X` folders and makes prefixes exact.
fn sensor_mount_of<'a>(name: &'a str, prefix: &str) -> Option<&'a str> {
    name.strip_prefix(prefix)
        .filter(|rest| rest.starts_with('('))
}

/// Scans a scenario folder: picks one folder per modality and lists its frame files.
pub fn scan_scenario(dir: &Path) -> Result<ScenarioFiles, SequenceError> {
    let candidates: Vec<ModalityFolder> = list_subfolders(dir)?
        .iter()
        .filter_map(|(name, path)| classify_folder(name, path))
        .collect();
    let mut files = ScenarioFiles::default();
    let chosen = choose_folders(&candidates, &mut files.notes);
    for folder in chosen {
        let listing = list_frame_files(&folder, &mut files.notes)?;
        for (modality, frames) in listing {
            if !frames.is_empty() {
                files.frames.entry(modality).or_default().extend(frames);
            }
        }
        files.folders.insert(folder.modality, folder.path.clone());
    }
    record_adjacent_flow_folder(&mut files);
    Ok(files)
}

/// One folder per modality: a benchmark folder wins over sensor folders; among sensor
/// folders the forward camera wins, then the one sharing the RGB camera's mount.
fn choose_folders(
    candidates: &[ModalityFolder],
    notes: &mut Vec<FileProblem>,
) -> Vec<ModalityFolder> {
    let rgb_mount = pick(candidates, Modality::Rgb, None).and_then(|f| f.sensor_mount.clone());
    let mut chosen = Vec::new();
    for modality in Modality::ALL {
        let Some(winner) = pick(candidates, modality, rgb_mount.as_deref()) else {
            continue;
        };
        for other in candidates
            .iter()
            .filter(|c| c.modality == modality && *c != winner)
        {
            notes.push(FileProblem::new(
                &other.path,
                format!(
                    "ignored: {} is read from {}",
                    modality.folder(),
                    winner.path.display()
                ),
            ));
        }
        chosen.push(winner.clone());
    }
    chosen
}

fn pick<'a>(
    candidates: &'a [ModalityFolder],
    modality: Modality,
    rgb_mount: Option<&str>,
) -> Option<&'a ModalityFolder> {
    let of_modality = || candidates.iter().filter(move |c| c.modality == modality);
    of_modality()
        .find(|c| c.sensor_mount.is_none())
        .or_else(|| {
            of_modality().find(|c| rgb_mount.is_some() && c.sensor_mount.as_deref() == rgb_mount)
        })
        .or_else(|| {
            of_modality().find(|c| {
                c.sensor_mount
                    .as_deref()
                    .is_some_and(|m| m.starts_with(FORWARD_CAMERA))
            })
        })
        .or_else(|| of_modality().next())
}

/// File extensions a modality's files may have, in order of preference for duplicates.
fn accepted_extensions(modality: Modality) -> &'static [&'static str] {
    match modality {
        Modality::Action | Modality::Anomaly => &["csv"],
        Modality::Flow => &["png", "flo", "npy"],
        _ => &["png", "jpg", "jpeg"],
    }
}

/// Lists `<name>_<frame>.<ext>` files of a folder. RGB folders may also hold HF²-VAD flows
/// (`<image name>.npy`), which are returned under [`Modality::Flow`].
fn list_frame_files(
    folder: &ModalityFolder,
    notes: &mut Vec<FileProblem>,
) -> Result<BTreeMap<Modality, BTreeMap<FrameId, PathBuf>>, SequenceError> {
    let dir = &folder.path;
    let mut found: BTreeMap<Modality, BTreeMap<FrameId, PathBuf>> = BTreeMap::new();
    let mut names: Vec<(String, PathBuf)> = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| SequenceError::io(dir, e))? {
        let entry = entry.map_err(|e| SequenceError::io(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if !name.starts_with('.') && is_file_entry(&entry) {
            names.push((name, entry.path()));
        }
    }
    names.sort();
    for (name, path) in names {
        let Some((modality, stem, extension)) = split_frame_file(folder.modality, &name) else {
            notes.push(FileProblem::new(
                &path,
                format!("ignored: not a {} file", folder.modality.folder()),
            ));
            continue;
        };
        let Some(id) = frame_id_of_stem(stem) else {
            notes.push(FileProblem::new(
                &path,
                "ignored: no frame number after the last '_'",
            ));
            continue;
        };
        let preference = |p: &Path| {
            let ext = p
                .extension()
                .and_then(|e| e.to_str())
                .unwrap_or_default()
                .to_ascii_lowercase();
            accepted_extensions(modality)
                .iter()
                .position(|e| *e == ext)
                .unwrap_or(usize::MAX)
        };
        let frames = found.entry(modality).or_default();
        match frames.get(&id) {
            Some(existing) => {
                let (keep, drop) = if preference(&path) < preference(existing) {
                    (path.clone(), existing.clone())
                } else {
                    (existing.clone(), path.clone())
                };
                notes.push(FileProblem::new(
                    &drop,
                    format!(
                        "ignored: frame {id} ({extension}) also in {}",
                        keep.display()
                    ),
                ));
                frames.insert(id, keep);
            }
            None => {
                frames.insert(id, path);
            }
        }
    }
    Ok(found)
}

/// (modality, stem, extension) of a file in a `folder_modality` folder, or `None` when its
/// extension does not belong there.
fn split_frame_file(folder_modality: Modality, name: &str) -> Option<(Modality, &str, &str)> {
    let (stem, extension) = name.rsplit_once('.')?;
    let lower = extension.to_ascii_lowercase();
    if folder_modality == Modality::Rgb && lower == "npy" {
        let (image_stem, image_extension) = stem.rsplit_once('.')?;
        let is_image = accepted_extensions(Modality::Rgb)
            .contains(&image_extension.to_ascii_lowercase().as_str());
        return is_image.then_some((Modality::Flow, image_stem, extension));
    }
    accepted_extensions(folder_modality)
        .contains(&lower.as_str())
        .then_some((folder_modality, stem, extension))
}

/// The integer after the last `_` of a file stem.
pub fn frame_id_of_stem(stem: &str) -> Option<FrameId> {
    let (_, number) = stem.rsplit_once('_')?;
    if number.is_empty() || !number.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    number.parse().ok().map(FrameId)
}

/// Flows found only as `.npy` next to the RGB images come from the RGB folder. (The RGB
/// folder is listed before `OPTICAL_FLOW/`, so `OPTICAL_FLOW/` files already won any frame
/// both have.)
fn record_adjacent_flow_folder(files: &mut ScenarioFiles) {
    if files.frames.contains_key(&Modality::Flow)
        && !files.folders.contains_key(&Modality::Flow)
        && let Some(rgb) = files.folders.get(&Modality::Rgb).cloned()
    {
        files.folders.insert(Modality::Flow, rgb);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_id_is_the_number_after_the_last_underscore() {
        assert_eq!(frame_id_of_stem("RGB_IMG_5720"), Some(FrameId(5720)));
        assert_eq!(
            frame_id_of_stem("RGB-CAM(0, 0, 1.8)(0, 0, 0)_8112341084538454858_16"),
            Some(FrameId(16))
        );
        assert_eq!(frame_id_of_stem("RGB_IMG_"), None);
        assert_eq!(frame_id_of_stem("RGB_IMG_12a"), None);
        assert_eq!(frame_id_of_stem("frame12"), None);
        assert_eq!(frame_id_of_stem("x_-3"), None);
    }

    #[test]
    fn sensor_prefixes_distinguish_lidar_from_semantic_lidar() {
        let path = Path::new("/x");
        let classify = |name: &str| classify_folder(name, path).map(|f| f.modality);
        assert_eq!(
            classify("RGB-CAM(0, 0, 1.8)(0, 0, 0)_81"),
            Some(Modality::Rgb)
        );
        assert_eq!(
            classify("DEPTH_CAM(0, 0, 1.8)(0, 0, 0)_81"),
            Some(Modality::Depth)
        );
        assert_eq!(
            classify("SEMANTIC-CAM(0, 0, 1.8)(0, 0, 0)_81"),
            Some(Modality::Semantic)
        );
        assert_eq!(
            classify("INSTANCE-CAM(0, 0, 1.8)(0, 0, 0)_81"),
            Some(Modality::Instance)
        );
        assert_eq!(classify("SEMANTIC-LIDAR(0, 0, 1.8)(0, 0, 0)_7"), None);
        assert_eq!(classify("LIDAR(0, 0, 1.8)(0, 0, 0)_7"), None);
        assert_eq!(classify("SEMANTIC_IMG"), Some(Modality::Semantic));
        assert_eq!(classify("ROUTE_MAP"), None);
        assert_eq!(classify("RGB-CAMERA"), None);
    }

    #[test]
    fn npy_next_to_images_is_flow() {
        assert_eq!(
            split_frame_file(Modality::Rgb, "RGB_IMG_7.png.npy"),
            Some((Modality::Flow, "RGB_IMG_7", "npy"))
        );
        assert_eq!(split_frame_file(Modality::Rgb, "notes.npy"), None);
        assert_eq!(
            split_frame_file(Modality::Action, "ACTION_3.csv"),
            Some((Modality::Action, "ACTION_3", "csv"))
        );
        assert_eq!(split_frame_file(Modality::Action, "ACTION_3.png"), None);
    }
}
