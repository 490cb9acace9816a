//! The per-scenario flow cache and its evaluation, on small generated scenarios: files land
//! in the cache folder only, runs resume, results do not depend on the thread count, and
//! the estimate is close to the generator's exact flow.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use vadscope::flow::cache::{
    CacheScope, FlowCacheOptions, FrameOutcome, fill_flow_cache, flow_cache_folder,
    read_cached_flow,
};
use vadscope::flow::evaluate::{evaluate_cached_flow, evaluate_flow};
use vadscope::flow::{DisPreset, FlowField, PixelBox, box_endpoint_error, endpoint_error};
use vadscope::sequence::palette::is_vehicle_id;
use vadscope::sequence::{Domain, Modality, Scenario, Weather};
use vadscope::synth::{ScenarioKind, ScenarioSpec, generate_scenario_without};

const FRAMES: u32 = 6;

/// A small generated scenario in `dir`, with or without its exact flow.
fn generate(dir: &Path, with_flow: bool) -> PathBuf {
    let mut spec = ScenarioSpec::new(ScenarioKind::Normal, Domain::City, Weather::Sun, 5);
    spec.frames = FRAMES;
    spec.width = 128;
    spec.height = 96;
    let omit: &[Modality] = if with_flow {
        &[Modality::Depth]
    } else {
        &[Modality::Depth, Modality::Flow]
    };
    generate_scenario_without(&spec, dir, omit, |_| {}).expect("generate")
}

/// Every file under `dir` with its bytes, relative paths sorted.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).expect("read_dir").flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let bytes = std::fs::read(&path).expect("read");
                out.push((path.strip_prefix(dir).expect("prefix").to_path_buf(), bytes));
            }
        }
    }
    out.sort();
    out
}

fn options(preset: DisPreset, threads: usize) -> FlowCacheOptions {
    FlowCacheOptions {
        preset,
        threads,
        scope: CacheScope::MissingOnly,
    }
}

#[test]
fn cache_fills_missing_frames_without_touching_source_data_and_resumes() {
    let tmp = tempfile::tempdir().expect("tmp");
    let root = generate(tmp.path(), false);
    let source_before: Vec<_> = snapshot(&root)
        .into_iter()
        .filter(|(p, _)| !p.starts_with(".vadscope"))
        .collect();
    let scenario = Scenario::open(&root).expect("open");
    assert!(!scenario.has(Modality::Flow));

    let seen = Mutex::new(Vec::new());
    let report = fill_flow_cache(&scenario, &options(DisPreset::Fast, 2), |p| {
        seen.lock().unwrap().push(p);
    })
    .expect("fill");
    let folder = flow_cache_folder(&scenario, DisPreset::Fast).expect("folder");
    assert_eq!(folder, root.join(".vadscope/flow/fast"));
    assert_eq!(report.folder, folder);
    assert_eq!(
        (report.frames, report.computed, report.already_cached),
        (6, 5, 0)
    );
    assert_eq!(report.stored_in_scenario, 0);
    let seen = seen.into_inner().unwrap();
    assert_eq!(seen.len(), 5);
    assert!(
        seen.iter()
            .all(|p| p.total == 5 && p.outcome == FrameOutcome::Computed)
    );
    let mut done: Vec<usize> = seen.iter().map(|p| p.done).collect();
    done.sort_unstable();
    assert_eq!(done, vec![1, 2, 3, 4, 5]);

    // One file per frame from 1 on, no temporary left, source data unchanged.
    let files: Vec<String> = std::fs::read_dir(&folder)
        .expect("read_dir")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(files.len(), 5, "{files:?}");
    assert!(
        files
            .iter()
            .all(|f| f.starts_with("OPTICAL_FLOW_") && f.ends_with(".png"))
    );
    assert!(
        read_cached_flow(&scenario, DisPreset::Fast, 0)
            .expect("read")
            .is_none()
    );
    let flow = read_cached_flow(&scenario, DisPreset::Fast, 3)
        .expect("read")
        .expect("cached");
    assert_eq!((flow.width, flow.height), (128, 96));
    let source_after: Vec<_> = snapshot(&root)
        .into_iter()
        .filter(|(p, _)| !p.starts_with(".vadscope"))
        .collect();
    assert!(source_before == source_after, "source data changed");

    // A second run keeps everything; after losing one file and gaining a leftover
    // temporary of a dead process, only that frame is recomputed and the leftover goes.
    let again = fill_flow_cache(&scenario, &options(DisPreset::Fast, 1), |_| {}).expect("again");
    assert_eq!((again.computed, again.already_cached), (0, 5));
    let lost = folder.join(&files[0]);
    let kept = std::fs::read(&lost).expect("read");
    std::fs::remove_file(&lost).expect("remove");
    let leftover = folder.join(format!(".{}.4000000000.tmp", files[0]));
    std::fs::write(&leftover, b"half a png").expect("write");
    let resumed = fill_flow_cache(&scenario, &options(DisPreset::Fast, 1), |_| {}).expect("resume");
    assert_eq!((resumed.computed, resumed.already_cached), (1, 4));
    assert_eq!(
        std::fs::read(&lost).expect("read"),
        kept,
        "recomputed file differs"
    );
    assert!(!leftover.exists());

    // A truncated cache file is not trusted.
    std::fs::write(&lost, b"\x89PNG").expect("truncate");
    let repaired =
        fill_flow_cache(&scenario, &options(DisPreset::Fast, 1), |_| {}).expect("repair");
    assert_eq!(repaired.computed, 1);
    assert_eq!(std::fs::read(&lost).expect("read"), kept);
}

#[test]
fn cached_files_do_not_depend_on_the_thread_count() {
    let tmp = tempfile::tempdir().expect("tmp");
    let root = generate(tmp.path(), false);
    let scenario = Scenario::open(&root).expect("open");
    fill_flow_cache(&scenario, &options(DisPreset::Ultrafast, 1), |_| {}).expect("fill");
    let folder = flow_cache_folder(&scenario, DisPreset::Ultrafast).expect("folder");
    let one = snapshot(&folder);
    std::fs::remove_dir_all(&folder).expect("clear");
    fill_flow_cache(&scenario, &options(DisPreset::Ultrafast, 3), |_| {}).expect("fill");
    assert!(one == snapshot(&folder));
}

#[test]
fn stored_flow_is_left_alone_unless_every_frame_is_asked_for() {
    let tmp = tempfile::tempdir().expect("tmp");
    let root = generate(tmp.path(), true);
    let scenario = Scenario::open(&root).expect("open");
    let report =
        fill_flow_cache(&scenario, &options(DisPreset::Ultrafast, 2), |_| {}).expect("fill");
    assert_eq!((report.computed, report.stored_in_scenario), (0, 5));
    let every = FlowCacheOptions {
        scope: CacheScope::EveryFrame,
        ..options(DisPreset::Ultrafast, 2)
    };
    let report = fill_flow_cache(&scenario, &every, |_| {}).expect("fill");
    assert_eq!(report.computed, 5);
}

#[test]
fn evaluation_against_the_generators_exact_flow() {
    let tmp = tempfile::tempdir().expect("tmp");
    let root = generate(tmp.path(), true);
    let scenario = Scenario::open(&root).expect("open");
    let (report, eval) =
        evaluate_flow(&scenario, &options(DisPreset::Medium, 2), |_| {}).expect("evaluate");
    assert_eq!(report.computed, 5);
    assert_eq!(eval.frames.len(), 5);
    assert_eq!(eval.preset, DisPreset::Medium);
    let valid = eval.mean_epe_valid.expect("valid pixels");
    eprintln!("{}", eval.summary());
    // Zero flow as the baseline: the motion of a forward-driving ego camera at 10 fps is
    // large near the bottom of the frame, where the road has little texture.
    let mut zero_valid = Vec::new();
    let mut zero_boxes = Vec::new();
    for frame in &eval.frames {
        let truth = scenario.flow(frame.index).expect("read").expect("stored");
        let zero = FlowField::zeros(truth.width, truth.height);
        zero_valid.push(
            endpoint_error(&zero, &truth)
                .expect("epe")
                .mean_valid
                .expect("valid"),
        );
        for b in scenario.boxes(frame.index).expect("boxes") {
            if !u8::try_from(b.class).is_ok_and(is_vehicle_id) {
                continue;
            }
            if let Ok(Some(e)) = box_endpoint_error(&zero, &truth, PixelBox::from(&b), 32) {
                zero_boxes.push(e);
            }
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    eprintln!(
        "zero flow: valid {:.3}, boxes {:.3}",
        mean(&zero_valid),
        mean(&zero_boxes)
    );
    assert!(valid < 0.6 * mean(&zero_valid), "{}", eval.summary());
    assert_eq!(eval.vehicle_boxes, zero_boxes.len());
    let boxes = eval.mean_vehicle_box_epe.expect("vehicle boxes");
    assert!(boxes < 0.7 * mean(&zero_boxes), "{}", eval.summary());
    // Scoring again reads the cache only and gives the same numbers.
    assert_eq!(
        evaluate_cached_flow(&scenario, DisPreset::Medium).expect("again"),
        eval
    );
}
