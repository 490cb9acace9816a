//! Looking at the generator's output: renders a few frames of each domain × condition to
//! PNG files (RGB, semantic palette, flow colour wheel) for a human to inspect.
//!
//! Ignored by default; run with
//! `cargo test --test synth_look -- --ignored --nocapture`
//! (`SYNTH_LOOK_DIR`, `SYNTH_LOOK_SIZE=WxH`, `SYNTH_LOOK_FRAMES=a,b,c`,
//! `SYNTH_LOOK_KINDS=normal,braking` override the defaults).

use std::path::PathBuf;

use vadscope::sequence::{Domain, FlowField, Weather};
use vadscope::synth::{Scenario, ScenarioKind, ScenarioSpec};

fn env_or(key: &str, default: &str) -> String {
    std::env::var(key).unwrap_or_else(|_| default.to_string())
}

/// Middlebury-style colour wheel: hue = direction, saturation = magnitude / max.
fn flow_to_rgb(flow: &FlowField) -> image::RgbImage {
    let (w, h) = (flow.width, flow.height);
    let mut mags: Vec<f32> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let [u, v] = flow.at(x, y);
            if flow.is_valid(x, y) {
                mags.push((u * u + v * v).sqrt());
            }
        }
    }
    mags.sort_by(f32::total_cmp);
    let max_mag = mags
        .get(mags.len() * 95 / 100)
        .copied()
        .unwrap_or(1.0)
        .max(1e-3);
    image::RgbImage::from_fn(w, h, |x, y| {
        if !flow.is_valid(x, y) {
            return image::Rgb([0, 0, 0]);
        }
        let [u, v] = flow.at(x, y);
        let mag = ((u * u + v * v).sqrt() / max_mag).min(1.0);
        let ang = v.atan2(u);
        let hue = (ang / std::f32::consts::TAU + 1.0).fract() * 6.0;
        let c = mag;
        let xk = c * (1.0 - ((hue % 2.0) - 1.0).abs());
        let (r, g, b) = match hue as u32 {
            0 => (c, xk, 0.0),
            1 => (xk, c, 0.0),
            2 => (0.0, c, xk),
            3 => (0.0, xk, c),
            4 => (xk, 0.0, c),
            _ => (c, 0.0, xk),
        };
        let m = 1.0 - c;
        let to8 = |f: f32| ((f + m) * 255.0) as u8;
        image::Rgb([to8(r), to8(g), to8(b)])
    })
}

fn semantic_to_rgb(sem: &image::GrayImage) -> image::RgbImage {
    image::RgbImage::from_fn(sem.width(), sem.height(), |x, y| {
        let c = match sem.get_pixel(x, y)[0] {
            1 => [128, 64, 128],
            2 => [244, 35, 232],
            3 => [70, 70, 70],
            6 => [153, 153, 153],
            7 => [250, 170, 30],
            9 => [107, 142, 35],
            10 => [152, 251, 152],
            11 => [70, 130, 180],
            14 => [0, 0, 142],
            15 => [0, 0, 70],
            16 => [0, 60, 100],
            24 => [157, 234, 50],
            28 => [180, 165, 180],
            100 => [245, 0, 0],
            114 => [3, 0, 143],
            _ => [0, 0, 0],
        };
        image::Rgb(c)
    })
}

#[test]
#[ignore]
fn render_look_images() {
    let dir = PathBuf::from(env_or("SYNTH_LOOK_DIR", "/tmp/synth_look"));
    std::fs::create_dir_all(&dir).expect("output folder");
    let size = env_or("SYNTH_LOOK_SIZE", "384x256");
    let (w, h) = size.split_once('x').expect("WxH");
    let (w, h): (u32, u32) = (w.parse().expect("width"), h.parse().expect("height"));
    let frames: Vec<usize> = env_or("SYNTH_LOOK_FRAMES", "0,110")
        .split(',')
        .map(|f| f.parse().expect("frame"))
        .collect();
    let kinds: Vec<ScenarioKind> = env_or("SYNTH_LOOK_KINDS", "normal")
        .split(',')
        .map(|k| match k {
            "braking" => ScenarioKind::Braking,
            "turning" => ScenarioKind::Turning,
            "cut-in" => ScenarioKind::CutIn,
            _ => ScenarioKind::Normal,
        })
        .collect();
    let domains = env_or("SYNTH_LOOK_DOMAINS", "city,highway");
    let weathers = env_or("SYNTH_LOOK_WEATHERS", "sun,rain,fog,night");
    let seed: u64 = env_or("SYNTH_LOOK_SEED", "7").parse().expect("seed");
    for kind in kinds {
        for dom in domains.split(',') {
            let domain = if dom == "city" {
                Domain::City
            } else {
                Domain::Highway
            };
            for wea in weathers.split(',') {
                let weather = match wea {
                    "rain" => Weather::Rain,
                    "fog" => Weather::Fog,
                    "night" => Weather::Night,
                    _ => Weather::Sun,
                };
                let mut spec = ScenarioSpec::new(kind, domain, weather, seed);
                spec.width = w;
                spec.height = h;
                let scenario = Scenario::build(&spec).expect("build");
                for &f in &frames {
                    let rec = scenario.render_frame(f).expect("render");
                    let stem = format!("{:?}_{dom}_{wea}_{f:03}", kind).to_lowercase();
                    rec.rgb
                        .save(dir.join(format!("{stem}_rgb.png")))
                        .expect("save");
                    if let Some(s) = &rec.semantic {
                        semantic_to_rgb(s)
                            .save(dir.join(format!("{stem}_sem.png")))
                            .expect("save");
                    }
                    if let Some(fl) = &rec.flow {
                        flow_to_rgb(fl)
                            .save(dir.join(format!("{stem}_flow.png")))
                            .expect("save");
                    }
                    println!("{stem}: {} boxes", rec.boxes.len());
                }
            }
        }
    }
}

/// Breaks the flow warping error down by semantic class and by whether the pixel lies on an
/// object boundary; prints a table (diagnostic, ignored by default).
#[test]
#[ignore]
fn flow_error_breakdown() {
    let size = env_or("SYNTH_LOOK_SIZE", "128x96");
    let (w, h) = size.split_once('x').expect("WxH");
    let (w, h): (u32, u32) = (w.parse().expect("width"), h.parse().expect("height"));
    let domain = if env_or("SYNTH_LOOK_DOMAINS", "city") == "city" {
        Domain::City
    } else {
        Domain::Highway
    };
    let weather = match env_or("SYNTH_LOOK_WEATHERS", "sun").as_str() {
        "rain" => Weather::Rain,
        "fog" => Weather::Fog,
        "night" => Weather::Night,
        _ => Weather::Sun,
    };
    let mut spec = ScenarioSpec::new(
        ScenarioKind::Normal,
        domain,
        weather,
        env_or("SYNTH_LOOK_SEED", "3").parse().expect("seed"),
    );
    spec.width = w;
    spec.height = h;
    spec.frames = 40;
    let scenario = Scenario::build(&spec).expect("build");
    let recs = scenario.render_range(20..22);
    let (a, b) = (&recs[0], &recs[1]);
    let flow = b.flow.as_ref().expect("flow");
    let sem = a.semantic.as_ref().expect("sem");
    let inst = a.instance.as_ref().expect("inst");
    let ident = |x: u32, y: u32| (sem.get_pixel(x, y)[0], *inst.get_pixel(x, y));
    let mut table: std::collections::BTreeMap<(u8, bool), (f64, usize)> = Default::default();
    let mut err_img = image::GrayImage::new(w, h);
    for y in 0..h {
        for x in 0..w {
            if !flow.is_valid(x, y) {
                continue;
            }
            let [u, v] = flow.at(x, y);
            let mut e = 0.0;
            for c in 0..3 {
                let pa = a.rgb.get_pixel(x, y)[c] as f32;
                let fx = x as f32 + u;
                let fy = y as f32 + v;
                let (x0, y0) = (fx.floor(), fy.floor());
                let (tx, ty) = (fx - x0, fy - y0);
                let g = |xi: f32, yi: f32| {
                    b.rgb.get_pixel(
                        (xi as i64).clamp(0, w as i64 - 1) as u32,
                        (yi as i64).clamp(0, h as i64 - 1) as u32,
                    )[c] as f32
                };
                let pb = (g(x0, y0) * (1.0 - tx) + g(x0 + 1.0, y0) * tx) * (1.0 - ty)
                    + (g(x0, y0 + 1.0) * (1.0 - tx) + g(x0 + 1.0, y0 + 1.0) * tx) * ty;
                e += (pa - pb).abs() / 3.0;
            }
            let me = ident(x, y);
            let mut edge = false;
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx >= 0
                        && ny >= 0
                        && nx < w as i64
                        && ny < h as i64
                        && ident(nx as u32, ny as u32) != me
                    {
                        edge = true;
                    }
                }
            }
            let entry = table.entry((me.0, edge)).or_default();
            entry.0 += e as f64;
            entry.1 += 1;
            err_img.put_pixel(x, y, image::Luma([(e * 8.0).min(255.0) as u8]));
        }
    }
    let total: usize = table.values().map(|v| v.1).sum();
    let total_err: f64 = table.values().map(|v| v.0).sum();
    println!(
        "overall MAE {:.2} over {total} px",
        total_err / total as f64
    );
    for ((s, edge), (e, n)) in &table {
        println!(
            "class {s:3} edge {edge:5}: n {n:6} mean {:.2} share of total error {:.1}%",
            e / *n as f64,
            100.0 * e / total_err
        );
    }
    let dir = PathBuf::from(env_or("SYNTH_LOOK_DIR", "/tmp/synth_look"));
    std::fs::create_dir_all(&dir).expect("dir");
    err_img.save(dir.join("flow_error.png")).expect("save");
    a.rgb.save(dir.join("flow_error_prev.png")).expect("save");
}

/// Rough timing of the stages of one frame (diagnostic, ignored by default; meaningful only
/// with optimisation, e.g. `--config 'profile.dev.package.vadscope.opt-level=3'`).
#[test]
#[ignore]
fn stage_timing() {
    let size = env_or("SYNTH_LOOK_SIZE", "768x512");
    let (w, h) = size.split_once('x').expect("WxH");
    let (w, h): (u32, u32) = (w.parse().expect("width"), h.parse().expect("height"));
    let frames: u32 = env_or("SYNTH_TIMING_FRAMES", "24").parse().expect("frames");
    for (domain, weather) in [
        (Domain::City, Weather::Sun),
        (Domain::Highway, Weather::Rain),
        (Domain::City, Weather::Night),
    ] {
        let mut spec = ScenarioSpec::new(ScenarioKind::Normal, domain, weather, 2024);
        spec.width = w;
        spec.height = h;
        spec.frames = frames;
        let t0 = std::time::Instant::now();
        let scenario = Scenario::build(&spec).expect("build");
        let t1 = std::time::Instant::now();
        let n = std::sync::atomic::AtomicUsize::new(0);
        scenario
            .render_all(|_| {
                n.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                Ok::<(), ()>(())
            })
            .expect("render");
        let t2 = std::time::Instant::now();
        let tmp = std::env::temp_dir().join("synth_stage_timing");
        let _ = std::fs::remove_dir_all(&tmp);
        vadscope::synth::generate_scenario(&spec, &tmp, |_| {}).expect("generate");
        let t3 = std::time::Instant::now();
        let _ = std::fs::remove_dir_all(&tmp);
        println!(
            "{domain:?} {weather:?} {w}x{h}: build {:.2}s, render {:.1} fps, render+write {:.1} fps ({} threads)",
            (t1 - t0).as_secs_f32(),
            frames as f32 / (t2 - t1).as_secs_f32(),
            frames as f32 / (t3 - t2).as_secs_f32(),
            rayon::current_num_threads()
        );
    }
}
