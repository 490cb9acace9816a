//! The viewer's responsiveness, through the real egui layer in an egui_kittest harness
//! (no display; the views are drawn by `render` on the CPU as in the window):
//!
//! * stepping through cached frames of a sample scenario: one → key and the frame that
//!   redraws the main view (frame with heatmap and boxes), the timeline and the panels —
//!   target ≤ 16 ms per frame;
//! * a weight slider change on a 10,000-frame synthetic score table: re-fusing, metrics,
//!   failure cases, and redrawing timeline, ROC chart and panels — target ≤ 16 ms; and the
//!   re-fusion alone through the GUI-free core;
//! * startup to the first frame: opening `sample_sequences/` (cached scores), building the
//!   window's first frame with the main view drawn — target ≤ 2 s;
//! * scrubbing a 10,000-frame scenario (a generated 160×96 clip repeated, scored with stored
//!   flow): one seek to a random, mostly undecoded frame and its redraw; then every frame
//!   in order, each rendered through the GPU renderer as a window would, with the process's
//!   resident memory printed before, during and after (the target: it stays bounded, i.e.
//!   levels off instead of growing with the frames visited). `VADSCOPE_SCRUB_FRAMES` changes
//!   the length, `VADSCOPE_SCRUB_DATA=DIR` keeps the scenario and its scores in DIR for the
//!   next run.
//!
//! The sample scenario is copied to a temporary folder and scored once with a tiny random
//! model (flow by DIS, as the samples ship without flow), so the bench needs no bundled
//! model. Run: `cargo bench --bench app`.

#[path = "../tests/support/app.rs"]
mod app_common;

use std::hint::black_box;
use std::path::{Path, PathBuf};

use criterion::{Criterion, criterion_group, criterion_main};
use egui::Key;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use rayon::prelude::*;
use vadscope::app::{Action, AppState, Layout, ScoringSetup, ViewSettings, ViewerApp};
use vadscope::score::{BoxSource, FlowSource, ScoreRequest};
use vadscope::sequence::{Domain, FrameId, ScenarioWriter, Weather};
use vadscope::synth::{Scenario, ScenarioKind, ScenarioSpec};

/// Copies the braking sample scenario into `dir` and returns the data-set root.
fn sample_copy(dir: &Path) -> PathBuf {
    let source = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("sample_sequences")
        .join("Scenario_0000_braking_city_sun_b55dae386ce69990");
    let root = dir.join("samples");
    copy_dir(&source, &root.join(source.file_name().expect("name")));
    root
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for entry in std::fs::read_dir(from).expect("read_dir").flatten() {
        let path = entry.path();
        let target = to.join(entry.file_name());
        if path.is_dir() {
            if entry.file_name() != ".vadscope" {
                copy_dir(&path, &target);
            }
        } else {
            std::fs::copy(&path, &target).expect("copy");
        }
    }
}

fn setup(model: &Path) -> ScoringSetup {
    ScoringSetup {
        model: Some(model.to_path_buf()),
        request: ScoreRequest::new(BoxSource::GroundTruth, FlowSource::default()),
    }
}

fn harness_of(app: ViewerApp) -> Harness<'static, ViewerApp> {
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .wgpu()
        .build_ui_state(|ui, app: &mut ViewerApp| app.show(ui), app);
    harness.run();
    // kittest starts its renderer at the first render and queues every texture upload
    // until then; rendering once makes uploads reach the GPU textures as in the window
    // (and keeps the queue from growing by one main-view image per frame).
    harness.render().expect("render the first frame");
    harness
}

fn bench_app(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("tempdir");
    let model = app_common::tiny_checkpoint(dir.path());
    let root = sample_copy(dir.path());
    // Scores once (the cache lands in the copy's .vadscope/).
    let state = app_common::scored_state(&root, &model);
    let mut h = harness_of(ViewerApp::with_state(state, Layout::default()));
    c.bench_function("step one cached frame (sample scenario, GUI)", |b| {
        b.iter(|| {
            let last = h.state().state().frame() + 1 >= h.state().state().playback().len();
            h.key_press(if last { Key::Home } else { Key::ArrowRight });
            h.run();
            black_box(h.state().state().frame())
        });
    });

    let frames = 10_000;
    let labels: Vec<bool> = (0..frames).map(|i| (i / 250) % 5 == 4).collect();
    let wobble = |i: usize| ((i * 7919) % 101) as f32 / 101.0;
    let anomalous = labels.clone();
    let table = app_common::table(
        frames,
        |i| 2.0 + wobble(i) + if anomalous[i] { 2.0 } else { 0.0 },
        |i| 0.5 + 0.25 * wobble(i * 3),
    );
    let mut state = app_common::state_of_tables(vec![("10,000 frames", table, labels)]);
    let mut weights = [0.5, 10.0];
    c.bench_function("re-fuse 10,000 frames (core)", |b| {
        b.iter(|| {
            weights.swap(0, 1);
            let mut s = state.settings().clone();
            s.weights.w_r = weights[0];
            state.set_settings(s);
            black_box(state.dataset_metrics().micro)
        });
    });
    let mut h = harness_of(ViewerApp::with_state(state, Layout::default()));
    c.bench_function("slider change, 10,000 frames (GUI)", |b| {
        b.iter(|| {
            weights.swap(0, 1);
            h.get_all_by_label("w_r")
                .next()
                .expect("slider")
                .set_value_accesskit(weights[0]);
            h.run();
            black_box(h.state().state().dataset_metrics().micro)
        });
    });

    let mut startup = c.benchmark_group("startup");
    startup.sample_size(10);
    startup.bench_function("open sample scenario to first frame (GUI)", |b| {
        b.iter(|| {
            let mut state = AppState::new(setup(&model), ViewSettings::default());
            state.open(&root);
            state.wait_for_scoring();
            let h = harness_of(ViewerApp::with_state(state, Layout::default()));
            black_box(h.state().state().frame_info())
        });
    });
    startup.finish();
}

/// Resident and peak resident memory of this process in MiB, from `/proc/self/status`
/// (`None` off Linux).
fn resident_mib() -> Option<(f64, f64)> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| {
        status
            .lines()
            .find_map(|line| line.strip_prefix(name))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
            .map(|kib| kib / 1024.0)
    };
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

fn report_memory(when: &str) {
    if let Some((rss, peak)) = resident_mib() {
        eprintln!("memory {when}: resident {rss:.0} MiB, peak {peak:.0} MiB");
    }
}

/// Writes a `frames`-frame scenario to `dir`: a generated 100-frame sudden braking (160×96,
/// RGB, semantic, flow, boxes, labels) played over and over under consecutive frame ids. The
/// generator simulates the traffic of the whole route up front, which for 10,000 frames
/// costs minutes; repeating a clip gives the viewer the same work per frame.
fn write_long_scenario(dir: &Path, frames: usize) {
    let mut spec = ScenarioSpec::new(ScenarioKind::Braking, Domain::City, Weather::Sun, 11);
    spec.frames = 100;
    spec.width = 160;
    spec.height = 96;
    let scenario = Scenario::build(&spec).expect("build");
    let clip = std::sync::Mutex::new(Vec::new());
    scenario
        .render_all(|mut record| {
            record.depth_m = None;
            record.instance = None;
            clip.lock().expect("clip").push(record);
            Ok::<(), ()>(())
        })
        .expect("render");
    let mut clip = clip.into_inner().expect("clip");
    clip.sort_by_key(|r| r.id);
    let writer = ScenarioWriter::create(dir, &scenario.meta()).expect("writer");
    (0..frames).into_par_iter().for_each(|k| {
        let mut record = clip[k % clip.len()].clone();
        record.id = FrameId(k as u64);
        writer.write_frame(&record).expect("write frame");
    });
    writer.finish().expect("finish");
}

fn bench_long_scrub(c: &mut Criterion) {
    let frames: u32 = std::env::var("VADSCOPE_SCRUB_FRAMES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    let dir = tempfile::tempdir().expect("tempdir");
    // VADSCOPE_SCRUB_DATA keeps the scenario, the model and the score cache between runs
    // (scoring 10,000 frames with the tiny model takes minutes); written when missing.
    let root = std::env::var_os("VADSCOPE_SCRUB_DATA")
        .map_or_else(|| dir.path().join("long"), PathBuf::from);
    let model = root.join("tiny.safetensors");
    if !model.exists() {
        std::fs::create_dir_all(&root).expect("mkdir");
        std::fs::copy(app_common::tiny_checkpoint(dir.path()), &model).expect("keep model");
    }
    let scenario = root.join(format!("Scenario_long_braking_{frames}"));
    if !scenario.exists() {
        write_long_scenario(&scenario, frames as usize);
    }
    let state = app_common::scored_state(&root, &model);
    let mut h = harness_of(ViewerApp::with_state(state, Layout::default()));
    report_memory(&format!("after opening and scoring {frames} frames"));

    let mut next = 0x2545_f491_u64;
    let name = format!("seek to a random frame, {frames}-frame scenario (GUI)");
    c.bench_function(&name, |b| {
        b.iter(|| {
            next = next.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let frame = (next >> 33) as usize % frames as usize;
            h.state_mut().state_mut().apply(Action::Seek(frame));
            h.run();
            black_box(h.state().state().frame())
        });
    });
    // kittest hands a frame to the GPU only when it renders (a window does every frame), and
    // wgpu frees replaced textures at submission: render to measure what a window holds.
    h.render().expect("render");
    report_memory("after the random seeks (and one render)");
    for frame in 0..frames as usize {
        h.state_mut().state_mut().apply(Action::Seek(frame));
        h.run();
        h.render().expect("render");
        if (frame + 1) % (frames as usize / 4).max(1) == 0 {
            report_memory(&format!("after scrubbing to frame {}", frame + 1));
        }
    }
}

criterion_group!(benches, bench_app, bench_long_scrub);
criterion_main!(benches);
