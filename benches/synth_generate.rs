//! Generator speed at AnoVox's 768×512: rendering frames with every modality in memory
//! (ray casting, shading, anti-aliasing, exact flow, labels), and rendering plus writing a
//! scenario folder through `ScenarioWriter`. Throughput is reported in frames per second.
//! The process keeps freed frame buffers, as `vadscope generate` does.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use vadscope::sequence::{Domain, Weather};
use vadscope::synth::{Scenario, ScenarioKind, ScenarioSpec, generate_scenario};

const FRAMES: u32 = 24;

fn spec(domain: Domain, weather: Weather) -> ScenarioSpec {
    let mut s = ScenarioSpec::new(ScenarioKind::Normal, domain, weather, 2024);
    s.frames = FRAMES;
    s
}

fn bench(c: &mut Criterion) {
    vadscope::synth::keep_freed_frame_buffers();
    let mut group = c.benchmark_group("synth_768x512");
    group.sample_size(10);
    group.throughput(Throughput::Elements(FRAMES as u64));
    for (name, domain, weather) in [
        ("city_sun", Domain::City, Weather::Sun),
        ("highway_rain", Domain::Highway, Weather::Rain),
        // The slowest condition: lamps and headlights light every pixel they reach. Seed
        // 2024's city-night scene is also heavier than most (docs/perf-history.md).
        ("city_night", Domain::City, Weather::Night),
    ] {
        let s = spec(domain, weather);
        let scenario = Scenario::build(&s).expect("build");
        group.bench_function(format!("render/{name}"), |b| {
            b.iter(|| {
                scenario
                    .render_all(|record| {
                        black_box(&record);
                        Ok::<(), ()>(())
                    })
                    .expect("render")
            })
        });
        group.bench_function(format!("render_and_write/{name}"), |b| {
            b.iter(|| {
                let tmp = tempfile::tempdir().expect("tmp");
                black_box(generate_scenario(&s, tmp.path(), |_| {}).expect("generate"));
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
