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
//!   window's first frame with the main view drawn — target ≤ 2 s.
//!
//! The sample scenario is copied to a temporary folder and scored once with a tiny random
//! model (flow by DIS, as the samples ship without flow), so the bench needs no bundled
//! model. Run: `cargo bench --bench app`.

#[path = "../tests/app_common/mod.rs"]
mod app_common;

use std::hint::black_box;
use std::path::{Path, PathBuf};

use criterion::{Criterion, criterion_group, criterion_main};
use egui::Key;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use vadscope::app::{AppState, Layout, ScoringSetup, ViewSettings, ViewerApp};
use vadscope::score::{BoxSource, FlowSource, ScoreRequest};

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

criterion_group!(benches, bench_app);
criterion_main!(benches);
