//! [`ScenarioWriter`]: writes a scenario in the benchmark layout (0-based frame ids when we
//! generate data), with vadscope's extensions (`OPTICAL_FLOW`, `BBOX_2D/boxes.csv`,
//! `frame_labels.csv`, `scenario.json`).
//!
//! Frames are independent files, so `write_frame` takes `&self` and may run on several
//! threads at once; within one frame the modalities are encoded in parallel as well. Boxes
//! and flags are collected behind a mutex and written by `finish`.
//!
//! A scenario appears whole or not at all: its files go to a hidden staging folder beside
//! the scenario folder (`.<name>.partial`, which discovery skips), and `finish` renames it
//! into place. A writer dropped before `finish` removes its staging folder; one left by a
//! killed process is removed by the next writer of the same scenario.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use image::ExtendedColorType;
use rayon::prelude::*;

use super::boxes::write_boxes;
use super::depth::encode_depth_image;
use super::flow_file::encode_kitti_png;
use super::images::encode_png;
use super::keyvalue::format_key_values;
use super::labels::write_frame_labels;
use super::layout::{BOXES_FILE, FRAME_LABELS_FILE, SCENARIO_JSON_FILE, benchmark_file};
use super::meta::write_scenario_json;
use super::{BoxRecord, FrameId, FrameRecord, Modality, ScenarioMeta, SequenceError};

/// Writes one scenario folder in the benchmark layout.
#[derive(Debug)]
pub struct ScenarioWriter {
    dir: PathBuf,
    staging: PathBuf,
    meta: ScenarioMeta,
    collected: Mutex<Collected>,
    /// Set by `finish` once the staging folder has become the scenario folder.
    finished: bool,
}

/// What `finish` needs from the frames written so far.
#[derive(Debug, Default)]
struct Collected {
    written: HashSet<FrameId>,
    boxes: Vec<BoxRecord>,
    labels: Vec<(FrameId, bool)>,
}

impl ScenarioWriter {
    /// Starts a new scenario that `finish` will put at `dir`, which must not exist yet or
    /// be an empty folder; the files are written to [`staging_folder`]`(dir)` until then.
    pub fn create(dir: &Path, meta: &ScenarioMeta) -> Result<Self, SequenceError> {
        if dir.exists() && !dir.is_dir() {
            return Err(SequenceError::format(
                dir,
                "a file stands where the scenario folder should go",
            ));
        }
        if std::fs::read_dir(dir).is_ok_and(|mut entries| entries.next().is_some()) {
            return Err(SequenceError::format(
                dir,
                "the scenario folder already exists and is not empty",
            ));
        }
        let staging = staging_folder(dir).ok_or_else(|| {
            SequenceError::format(dir, "a scenario folder needs a name and a parent folder")
        })?;
        if staging.exists() {
            // Left by a writer that was killed before it could finish or clean up.
            std::fs::remove_dir_all(&staging).map_err(|e| SequenceError::io(&staging, e))?;
        }
        std::fs::create_dir_all(&staging).map_err(|e| SequenceError::io(&staging, e))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            staging,
            meta: meta.clone(),
            collected: Mutex::new(Collected::default()),
            finished: false,
        })
    }

    /// The scenario folder that `finish` creates.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Writes every modality present in `frame` (`RGB_IMG/RGB_IMG_<id>.png`, SEMANTIC_IMG (L PNG),
    /// INSTANCE_IMG (RGB PNG), DEPTH_IMG (CARLA 24-bit RGB PNG), OPTICAL_FLOW (KITTI 16-bit PNG),
    /// ACTION/ANOMALY `key ; value` CSV) and records its boxes and anomaly flag.
    ///
    /// Takes `&self` and is safe to call from several threads at once. Every image must
    /// have the RGB frame's size, and a frame id may be written once only. The boxes are
    /// recorded under `frame.id` whatever their own `frame` field says.
    pub fn write_frame(&self, frame: &FrameRecord) -> Result<(), SequenceError> {
        self.claim_frame(frame.id)?;
        let files = encode_frame(&self.staging, frame)?;
        files.par_iter().try_for_each(|(path, bytes)| {
            if let Some(folder) = path.parent() {
                std::fs::create_dir_all(folder).map_err(|e| SequenceError::io(folder, e))?;
            }
            std::fs::write(path, bytes).map_err(|e| SequenceError::io(path, e))
        })?;
        let mut collected = self.lock();
        collected
            .boxes
            .extend(frame.boxes.iter().map(|b| BoxRecord {
                frame: frame.id,
                ..*b
            }));
        if let Some(anomalous) = frame.anomalous {
            collected.labels.push((frame.id, anomalous));
        }
        Ok(())
    }

    /// Writes BBOX_2D/boxes.csv (sorted by frame, track; only when some frame carried
    /// boxes), frame_labels.csv (`frame,anomaly`; only when some frame carried a flag),
    /// scenario.json, then moves the scenario into place; returns the scenario folder.
    pub fn finish(mut self) -> Result<PathBuf, SequenceError> {
        let collected = std::mem::take(
            self.collected
                .get_mut()
                .unwrap_or_else(std::sync::PoisonError::into_inner),
        );
        if !collected.boxes.is_empty() {
            let path = self.staging.join(BOXES_FILE);
            if let Some(folder) = path.parent() {
                std::fs::create_dir_all(folder).map_err(|e| SequenceError::io(folder, e))?;
            }
            write_boxes(&path, &collected.boxes)?;
        }
        if !collected.labels.is_empty() {
            write_frame_labels(&self.staging.join(FRAME_LABELS_FILE), &collected.labels)?;
        }
        write_scenario_json(&self.staging.join(SCENARIO_JSON_FILE), &self.meta)?;
        // An empty folder at the destination (allowed by `create`) would make the rename
        // fail on some systems; a non-empty one, made while this writer ran, is kept.
        if self.dir.is_dir() {
            std::fs::remove_dir(&self.dir).map_err(|e| SequenceError::io(&self.dir, e))?;
        }
        std::fs::rename(&self.staging, &self.dir).map_err(|e| SequenceError::io(&self.dir, e))?;
        self.finished = true;
        Ok(self.dir.clone())
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Collected> {
        // A panic in another writer thread cannot leave `Collected` half-updated (each
        // update is a single push/extend), so a poisoned lock is still usable.
        self.collected
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn claim_frame(&self, id: FrameId) -> Result<(), SequenceError> {
        if self.lock().written.insert(id) {
            Ok(())
        } else {
            Err(SequenceError::format(
                benchmark_file(&self.dir, Modality::Rgb, id),
                format!("frame {id} is written twice"),
            ))
        }
    }
}

impl Drop for ScenarioWriter {
    /// A scenario that was not finished is incomplete: its staging folder goes.
    fn drop(&mut self) {
        if !self.finished {
            // Nothing to report to: the error that stopped the writer is what matters, and
            // a folder left behind is removed by the next writer of the scenario.
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// The hidden folder beside `dir` where [`ScenarioWriter`] writes `dir`'s files until it
/// finishes (`<parent>/.<name>.partial`); `None` when `dir` has no name.
pub fn staging_folder(dir: &Path) -> Option<PathBuf> {
    let name = dir.file_name()?;
    let mut staged = std::ffi::OsString::from(".");
    staged.push(name);
    staged.push(".partial");
    Some(dir.with_file_name(staged))
}

/// One encoding task of a frame.
enum Encode<'a> {
    Rgb8(&'a image::RgbImage),
    L8(&'a image::GrayImage),
    Depth(&'a [f32]),
    Flow(&'a super::FlowField),
    KeyValues(&'a super::KeyValues),
}

/// Encodes every modality of `frame` into (path, bytes), in parallel.
fn encode_frame(dir: &Path, frame: &FrameRecord) -> Result<Vec<(PathBuf, Vec<u8>)>, SequenceError> {
    let mut tasks = vec![(Modality::Rgb, Encode::Rgb8(&frame.rgb))];
    if let Some(semantic) = &frame.semantic {
        tasks.push((Modality::Semantic, Encode::L8(semantic)));
    }
    if let Some(instance) = &frame.instance {
        tasks.push((Modality::Instance, Encode::Rgb8(instance)));
    }
    if let Some(depth) = &frame.depth_m {
        tasks.push((Modality::Depth, Encode::Depth(depth)));
    }
    if let Some(flow) = &frame.flow {
        tasks.push((Modality::Flow, Encode::Flow(flow)));
    }
    if let Some(action) = &frame.action {
        tasks.push((Modality::Action, Encode::KeyValues(action)));
    }
    if let Some(anomaly) = &frame.anomaly {
        tasks.push((Modality::Anomaly, Encode::KeyValues(anomaly)));
    }
    let size = frame.rgb.dimensions();
    tasks
        .into_par_iter()
        .map(|(modality, task)| {
            let path = benchmark_file(dir, modality, frame.id);
            let bytes = encode_task(&path, size, task)?;
            Ok((path, bytes))
        })
        .collect()
}

fn encode_task(
    path: &Path,
    (width, height): (u32, u32),
    task: Encode<'_>,
) -> Result<Vec<u8>, SequenceError> {
    let check_size = |w: u32, h: u32| {
        if (w, h) == (width, height) {
            Ok(())
        } else {
            Err(SequenceError::format(
                path,
                format!("image is {w}x{h} but the RGB frame is {width}x{height}"),
            ))
        }
    };
    match task {
        Encode::Rgb8(image) => {
            check_size(image.width(), image.height())?;
            encode_png(path, image.as_raw(), width, height, ExtendedColorType::Rgb8)
        }
        Encode::L8(image) => {
            check_size(image.width(), image.height())?;
            encode_png(path, image.as_raw(), width, height, ExtendedColorType::L8)
        }
        Encode::Depth(metres) => {
            let image = encode_depth_image(width, height, metres).ok_or_else(|| {
                SequenceError::format(
                    path,
                    format!(
                        "depth buffer holds {} values, the {width}x{height} frame needs {}",
                        metres.len(),
                        width as usize * height as usize
                    ),
                )
            })?;
            encode_png(path, image.as_raw(), width, height, ExtendedColorType::Rgb8)
        }
        Encode::Flow(flow) => {
            check_size(flow.width, flow.height)?;
            encode_kitti_png(path, flow)
        }
        Encode::KeyValues(values) => format_key_values(path, values).map(String::into_bytes),
    }
}
