//! Generator speed at AnoVox's 768×512: rendering frames with every modality (ray casting,
//! shading, anti-aliasing, exact flow, labels) and writing them as scenario folders through
//! `ScenarioWriter`, for each city condition and highway rain; the slowest condition in
//! memory as well. Throughput is reported in frames per second. The process keeps freed
//! frame buffers, as `vadscope generate` does.
//!
//! Scenes of one condition differ in cost by up to 17 % (city night), so each
//! condition is measured over the first [`SCENES`] scenes that `vadscope generate --count 4
//! --seed 2024` draws for it, not over one seed. `heaviest_scene/city_night` keeps the
//! heaviest city-night scene found so far (docs/perf-history.md) as the worst case.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use vadscope::sequence::{Domain, Weather};
use vadscope::synth::{
    DatasetRequest, DomainChoice, KindChoice, Scenario, ScenarioKind, ScenarioSpec, WeatherChoice,
    generate_scenario, plan_dataset,
};

/// Frames of each scene (`render_all` renders a chunk of them on each core).
const FRAMES: u32 = 24;

/// Scenes per condition.
const SCENES: usize = 4;

/// The data set seed the scenes are drawn from.
const SEED: u64 = 2024;

/// The scenes `vadscope generate --out DIR --kind normal --domain D --weather W --count 4
/// --frames 24 --size 768x512 --seed 2024` renders.
fn scenes(domain: DomainChoice, weather: WeatherChoice) -> Vec<ScenarioSpec> {
    let mut request = DatasetRequest::new(SCENES, SEED);
    request.kind = Some(KindChoice::Only(ScenarioKind::Normal));
    request.domain = Some(domain);
    request.weather = Some(weather);
    request.frames = Some(FRAMES);
    request.size = Some((768, 512));
    plan_dataset(&request).expect("a valid request")
}

/// Renders and writes every scene of `specs` into a fresh folder.
fn render_and_write(specs: &[ScenarioSpec]) {
    let tmp = tempfile::tempdir().expect("tmp");
    for spec in specs {
        black_box(generate_scenario(spec, tmp.path(), |_| {}).expect("generate"));
    }
}

fn bench(c: &mut Criterion) {
    vadscope::synth::keep_freed_frame_buffers();
    let mut group = c.benchmark_group("synth_768x512");
    group.sample_size(10);
    // (name, domain, weather, also rendered in memory to show what writing costs)
    for (name, domain, weather, in_memory) in [
        ("city_sun", DomainChoice::City, WeatherChoice::Sun, false),
        ("city_rain", DomainChoice::City, WeatherChoice::Rain, false),
        ("city_fog", DomainChoice::City, WeatherChoice::Fog, false),
        // The slowest: lamps and headlights light every pixel they reach.
        ("city_night", DomainChoice::City, WeatherChoice::Night, true),
        (
            "highway_rain",
            DomainChoice::Highway,
            WeatherChoice::Rain,
            false,
        ),
    ] {
        let specs = scenes(domain, weather);
        group.throughput(Throughput::Elements(FRAMES as u64 * specs.len() as u64));
        if in_memory {
            let built: Vec<Scenario> = specs
                .iter()
                .map(|s| Scenario::build(s).expect("build"))
                .collect();
            group.bench_function(format!("render/{name}"), |b| {
                b.iter(|| {
                    for scenario in &built {
                        scenario
                            .render_all(|record| {
                                black_box(&record);
                                Ok::<(), ()>(())
                            })
                            .expect("render")
                    }
                })
            });
        }
        group.bench_function(format!("render_and_write/{name}"), |b| {
            b.iter(|| render_and_write(&specs))
        });
    }
    // `ScenarioSpec::new`'s seed 2024 (not drawn through `plan_dataset`): a wet city night,
    // the heaviest of the scenes measured.
    let mut heaviest = ScenarioSpec::new(ScenarioKind::Normal, Domain::City, Weather::Night, SEED);
    heaviest.frames = FRAMES;
    group.throughput(Throughput::Elements(FRAMES as u64));
    group.bench_function("heaviest_scene/city_night", |b| {
        b.iter(|| render_and_write(std::slice::from_ref(&heaviest)))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
