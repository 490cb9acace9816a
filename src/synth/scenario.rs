//! A scenario from spec to files: builds the world (road, scenery, traffic simulation,
//! lighting) from the seed, renders frames (in parallel chunks, each chunk carrying the
//! previous frame's geometry for the flow), and writes them through
//! `sequence::writer::ScenarioWriter`.

use std::ops::Range;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::SynthError;
use super::frame::{geometry, render_record};
use super::gbuffer::GBuffer;
use super::lighting::Lighting;
use super::rng::Rng;
use super::road::Road;
use super::scenery::Scenery;
use super::spec::{ScenarioKind, ScenarioSpec};
use super::traffic::{AnomalyWindow, FRAME_DT, Traffic, simulate};
use super::world::{BACKDROP_SAMPLES, World, backdrop_height};
use crate::sequence::discovery::scan_scenario;
use crate::sequence::layout::SCENARIO_JSON_FILE;
use crate::sequence::meta::read_scenario_json;
use crate::sequence::writer::ScenarioWriter;
use crate::sequence::{
    CameraIntrinsics, Domain, FrameId, FrameRecord, FrameWindow, Modality, ScenarioMeta,
};

/// Generator name and version recorded in `scenario.json`.
pub const GENERATOR_NAME: &str = concat!("vadscope-synth ", env!("CARGO_PKG_VERSION"));

/// A built scenario: simulated and ready to render any frame.
pub struct Scenario {
    world: World,
}

impl Scenario {
    /// The world, for the renderer's unit tests.
    #[cfg(test)]
    pub(super) fn world(&self) -> &World {
        &self.world
    }

    /// Builds the world and simulates the traffic of `spec`.
    pub fn build(spec: &ScenarioSpec) -> Result<Self, SynthError> {
        spec.validate()?;
        let root = Rng::new(spec.seed);
        let mut rng = root.fork(1);
        let frames = spec.frames as f32;
        let seconds = frames * FRAME_DT + 5.0;
        let highway = matches!(spec.domain, Domain::Highway);
        let (reach, draw) = if highway {
            (33.0 * seconds, 750.0)
        } else {
            (15.0 * seconds, 450.0)
        };
        let s_end = 2.2 * reach + 900.0;
        let mut road = if highway {
            Road::highway(&mut rng, -400.0, s_end)
        } else {
            Road::city(&mut rng, -400.0, s_end)
        };
        let traffic = simulate(spec, &mut road, &root.fork(2))?;
        let ego_end = traffic
            .states
            .last()
            .map_or(0.0, |st| st[super::traffic::EGO].s);
        let scenery = Scenery::generate(&mut root.fork(3), &road, -200.0, ego_end + draw + 50.0);
        let lighting = Lighting::new(spec.weather, &mut root.fork(4));
        let mut salts = root.fork(5);
        Ok(Self {
            world: World {
                spec: spec.clone(),
                intrinsics: CameraIntrinsics::anovox(spec.width, spec.height),
                road,
                scenery,
                traffic,
                lighting,
                ground_salt: salts.next_u64() as u32,
                cloud_salt: salts.next_u64() as u32,
                backdrop: {
                    let salt = salts.next_u64() as u32;
                    (0..BACKDROP_SAMPLES)
                        .map(|i| {
                            let az = -std::f32::consts::PI
                                + std::f32::consts::TAU * i as f32 / BACKDROP_SAMPLES as f32;
                            backdrop_height(spec.domain, az, salt)
                        })
                        .collect()
                },
                labels_lead_as_agent: spec.kind == ScenarioKind::Braking,
            },
        })
    }

    /// The spec.
    pub fn spec(&self) -> &ScenarioSpec {
        &self.world.spec
    }

    /// Number of frames.
    pub fn frame_count(&self) -> usize {
        self.world.traffic.states.len()
    }

    /// The simulated traffic (vehicles and their per-frame states).
    pub fn traffic(&self) -> &Traffic {
        &self.world.traffic
    }

    /// Lane width of the road (m).
    pub fn lane_width(&self) -> f32 {
        self.world.road.lane_width
    }

    /// The anomaly window in frames (sudden-braking scenarios).
    pub fn anomaly_window(&self) -> Option<AnomalyWindow> {
        self.world.traffic.anomaly
    }

    /// Camera intrinsics.
    pub fn intrinsics(&self) -> CameraIntrinsics {
        self.world.intrinsics
    }

    /// `scenario.json` metadata.
    pub fn meta(&self) -> ScenarioMeta {
        let spec = &self.world.spec;
        ScenarioMeta {
            domain: spec.domain,
            weather: spec.weather,
            time_of_day: Some(self.world.lighting.time_of_day().to_string()),
            anomaly_type: Some(spec.kind.anomaly_type()),
            anomaly_window: self.world.traffic.anomaly.map(|w| FrameWindow {
                start: FrameId(w.start as u64),
                end: FrameId(w.end as u64),
            }),
            town: Some(spec.town.clone()),
            seed: Some(spec.seed),
            generator: Some(GENERATOR_NAME.to_string()),
            fps: 1.0 / FRAME_DT,
            camera: Some(self.world.intrinsics),
        }
    }

    /// Renders one frame with all modalities (the flow needs the previous frame's geometry,
    /// which is ray-cast as well).
    pub fn render_frame(&self, frame: usize) -> Result<FrameRecord, SynthError> {
        if frame >= self.frame_count() {
            return Err(SynthError::InvalidSpec {
                problem: format!(
                    "frame {frame} is outside the scenario's {} frames",
                    self.frame_count()
                ),
            });
        }
        let prev = (frame > 0).then(|| geometry(&self.world, frame - 1));
        Ok(render_record(&self.world, frame, prev.as_ref()).0)
    }

    /// Renders consecutive frames in order on the calling thread's pool (rows in parallel).
    pub fn render_range(&self, frames: Range<usize>) -> Vec<FrameRecord> {
        let end = frames.end.min(self.frame_count());
        let start = frames.start.min(end);
        let mut prev: Option<GBuffer> = (start > 0).then(|| geometry(&self.world, start - 1));
        let mut out = Vec::with_capacity(end - start);
        for k in start..end {
            let (record, gbuf) = render_record(&self.world, k, prev.as_ref());
            prev = Some(gbuf);
            out.push(record);
        }
        out
    }

    /// Renders every frame, several chunks of consecutive frames in parallel, and hands
    /// each finished frame to `sink` (from any thread, in no particular order). Stops at the
    /// first error of `sink`.
    pub fn render_all<E: Send>(
        &self,
        sink: impl Fn(FrameRecord) -> Result<(), E> + Sync,
    ) -> Result<(), E> {
        let n = self.frame_count();
        // One chunk per thread keeps the extra geometry pass at each chunk start rare; rows
        // are parallel inside a frame as well. Equal lengths (at least `MIN_CHUNK`), because
        // a thread whose chunk ends early can only help with the others' parallel rows,
        // not with their per-frame serial steps.
        let chunks = rayon::current_num_threads().min(n / MIN_CHUNK).max(1);
        let size = n.div_ceil(chunks).max(1);
        let ranges: Vec<Range<usize>> =
            (0..n).step_by(size).map(|a| a..(a + size).min(n)).collect();
        ranges.into_par_iter().try_for_each(|r| {
            let mut prev: Option<GBuffer> =
                (r.start > 0).then(|| geometry(&self.world, r.start - 1));
            for k in r {
                let (record, gbuf) = render_record(&self.world, k, prev.as_ref());
                prev = Some(gbuf);
                sink(record)?;
            }
            Ok(())
        })
    }
}

/// Fewest frames [`Scenario::render_all`] gives one chunk (each chunk starts with an extra
/// geometry pass for its first frame's flow).
const MIN_CHUNK: usize = 8;

/// Generates `spec` into `out_dir/Scenario_<name>/` (benchmark layout with every modality,
/// boxes, frame labels and `scenario.json`) and returns the folder. `on_frame` is called with
/// each frame index once that frame is written (from worker threads, in completion order).
pub fn generate_scenario(
    spec: &ScenarioSpec,
    out_dir: &Path,
    on_frame: impl Fn(usize) + Sync,
) -> Result<PathBuf, SynthError> {
    generate_scenario_without(spec, out_dir, &[], on_frame)
}

/// Checks that `out_dir/Scenario_<name>/` holds what [`generate_scenario_without`] writes
/// for `spec` and `omit`: the same `scenario.json`, frames `0..frames` and the same
/// modality folders. This is what lets `vadscope generate --resume` keep the scenarios an
/// interrupted run finished (the writer only ever leaves whole scenarios) instead of
/// rendering them again. The files' content is not compared: the same spec writes the same
/// bytes.
pub fn check_generated(
    spec: &ScenarioSpec,
    out_dir: &Path,
    omit: &[Modality],
) -> Result<PathBuf, SynthError> {
    let dir = spec.folder_in(out_dir);
    let not_the_same = |problem: String| SynthError::NotTheSame {
        path: dir.clone(),
        problem,
    };
    let scenario = Scenario::build(spec)?;
    let found = read_scenario_json(&dir.join(SCENARIO_JSON_FILE))
        .map_err(|e| not_the_same(e.to_string()))?;
    if found != scenario.meta() {
        return Err(not_the_same(
            "its scenario.json differs (another seed, image size or generator version)".into(),
        ));
    }
    let files = scan_scenario(&dir).map_err(|e| not_the_same(e.to_string()))?;
    let frames = spec.frames as u64;
    let rgb_ids: Vec<u64> = files
        .of(Modality::Rgb)
        .map(|by_id| by_id.keys().map(|id| id.0).collect())
        .unwrap_or_default();
    if !rgb_ids.iter().copied().eq(0..frames) {
        return Err(not_the_same(format!(
            "it holds {} RGB frames, this scenario has frames 0-{}",
            rgb_ids.len(),
            frames - 1
        )));
    }
    for modality in Modality::ALL {
        let written = !omit.contains(&modality)
            && (modality != Modality::Anomaly || scenario.world.labels_lead_as_agent);
        let present = files.of(modality).is_some_and(|by_id| !by_id.is_empty());
        if written != present {
            return Err(not_the_same(format!(
                "{} is {}",
                modality.folder(),
                if present {
                    "there but left out of this run"
                } else {
                    "missing"
                }
            )));
        }
    }
    Ok(dir)
}

/// As [`generate_scenario`], but leaves the `omit`ted modalities out of the written files
/// (for small bundles, e.g. no depth and no flow). RGB frames are always written; the
/// rendered content of what is kept does not change.
pub fn generate_scenario_without(
    spec: &ScenarioSpec,
    out_dir: &Path,
    omit: &[Modality],
    on_frame: impl Fn(usize) + Sync,
) -> Result<PathBuf, SynthError> {
    let scenario = Scenario::build(spec)?;
    let dir = spec.folder_in(out_dir);
    let write_err = |source| SynthError::Write {
        path: dir.clone(),
        source,
    };
    let writer = ScenarioWriter::create(&dir, &scenario.meta()).map_err(write_err)?;
    scenario.render_all(|mut record| {
        let k = record.id.0 as usize;
        for modality in omit {
            match modality {
                Modality::Rgb => {}
                Modality::Semantic => record.semantic = None,
                Modality::Instance => record.instance = None,
                Modality::Depth => record.depth_m = None,
                Modality::Flow => record.flow = None,
                Modality::Action => record.action = None,
                Modality::Anomaly => record.anomaly = None,
            }
        }
        writer.write_frame(&record).map_err(write_err)?;
        on_frame(k);
        Ok(())
    })?;
    writer.finish().map_err(write_err)
}
