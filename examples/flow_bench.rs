//! Benchmark driver for vadscope's DIS optical flow, used by `benches/flow_opencv/run.sh` to
//! compare it with OpenCV's DIS on the same frames. It only uses the vadscope library.
//!
//! A *pair folder* holds `manifest.json`, grey PNG frames, KITTI 16-bit ground-truth flow
//! and vehicle boxes. It is written by `benches/flow_opencv/make_pairs.py` (affine synthetic
//! pairs) or by `export-pairs` below (pairs from generated driving scenarios). Commands:
//!
//! * `generate`: generates the driving scenarios of the benchmark (city and highway, sun
//!   and rain) with vadscope's generator, exact flow included;
//! * `export-pairs`: turns scenarios into a pair folder;
//! * `accuracy`: EPE over all pixels, over valid pixels, and on 32×32 vehicle patches (crop
//!   and bilinear resize as HF²-VAD does) for vadscope's flow or for flows computed
//!   elsewhere and stored as Middlebury `.flo` files (`--external DIR`, files
//!   `DIR/<preset>/<pair>.flo`), so both tools are scored by the same code;
//! * `time`: milliseconds per frame pair on a given number of threads.
//!
//! Scoring a scenario's flow cache against its stored flow is `vadscope flow --evaluate`.
//!
//! `accuracy` and `time` print one JSON object per line.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use image::GrayImage;
use serde::{Deserialize, Serialize};
use serde_json::json;
use vadscope::flow::{
    DisFlow, DisParams, DisPreset, FlowField, FlowFrame, PixelBox, box_endpoint_error,
    endpoint_error,
};
use vadscope::sequence::flow_file::{read_flo, write_flo, write_kitti_png};
use vadscope::sequence::palette::is_vehicle_id;
use vadscope::sequence::{Domain, Modality, Scenario, Weather};
use vadscope::synth::{ScenarioKind, ScenarioSpec, generate_scenario_without};

#[derive(Parser)]
#[command(about = "vadscope DIS flow benchmark driver (see benches/flow_opencv/run.sh)")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate the benchmark's driving scenarios: {city, highway} × {sun, rain}.
    Generate {
        /// Folder to create the scenarios in.
        #[arg(long)]
        out: PathBuf,
        /// Frame size, WIDTHxHEIGHT.
        #[arg(long, default_value = "768x512", value_parser = parse_size)]
        size: (u32, u32),
        /// Frames per scenario.
        #[arg(long, default_value_t = 16)]
        frames: u32,
        /// Seed of the first scenario (the others use the following seeds).
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Write a pair folder from scenarios with stored (ground-truth) flow.
    ExportPairs {
        /// Scenario folders.
        #[arg(long, num_args = 1.., required = true)]
        scenarios: Vec<PathBuf>,
        /// Pair folder to write.
        #[arg(long)]
        out: PathBuf,
        /// Take the flow into every K-th frame.
        #[arg(long, default_value_t = 4)]
        every: usize,
        /// Smallest vehicle box side kept, in pixels.
        #[arg(long, default_value_t = 8.0)]
        min_box: f32,
    },
    /// Print EPE figures per pair and preset.
    Accuracy {
        /// Folder with manifest.json.
        #[arg(long)]
        pairs: PathBuf,
        /// Presets to evaluate.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "ultrafast,fast,medium,quality"
        )]
        presets: Vec<DisPreset>,
        /// Score flows stored as DIR/<preset>/<pair>.flo instead of computing them.
        #[arg(long)]
        external: Option<PathBuf>,
        /// Tool name written into the output.
        #[arg(long, default_value = "vadscope")]
        label: String,
        /// Also write every computed flow as DIR/<preset>/<pair>.flo.
        #[arg(long)]
        write_flo: Option<PathBuf>,
        /// JSON object overriding fields of the preset's DisParams (experiments).
        #[arg(long)]
        params: Option<String>,
    },
    /// Print milliseconds per frame pair.
    Time {
        /// Folder with manifest.json.
        #[arg(long)]
        pairs: PathBuf,
        /// Presets to time.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "ultrafast,fast,medium,quality"
        )]
        presets: Vec<DisPreset>,
        /// Rayon threads.
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Timed repetitions per pair.
        #[arg(long, default_value_t = 10)]
        reps: usize,
        /// Time only the first N pairs.
        #[arg(long)]
        max_pairs: Option<usize>,
    },
}

fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once('x')
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, got {text:?}"))?;
    let parse = |s: &str| s.parse::<u32>().map_err(|e| format!("{s:?}: {e}"));
    Ok((parse(w)?, parse(h)?))
}

#[derive(Serialize, Deserialize)]
struct Manifest {
    /// Who wrote the folder.
    source: String,
    /// Whether the ground truth holds the true motion at every pixel (the affine pairs) or
    /// only where it is marked valid (scenario flow: unknown pixels read as zero).
    #[serde(default)]
    truth_everywhere: bool,
    pairs: Vec<PairEntry>,
}

#[derive(Serialize, Deserialize)]
struct PairEntry {
    name: String,
    frame0: String,
    frame1: String,
    flow: String,
    boxes: Vec<[f32; 4]>,
}

struct Pair {
    name: String,
    prev: GrayImage,
    next: GrayImage,
    truth: FlowField,
    boxes: Vec<PixelBox>,
}

struct PairSet {
    truth_everywhere: bool,
    pairs: Vec<Pair>,
}

fn load_pairs(dir: &Path) -> Result<PairSet> {
    let manifest_path = dir.join("manifest.json");
    let text = std::fs::read_to_string(&manifest_path)
        .with_context(|| format!("{}", manifest_path.display()))?;
    let manifest: Manifest =
        serde_json::from_str(&text).with_context(|| format!("{}", manifest_path.display()))?;
    let pairs = manifest
        .pairs
        .into_iter()
        .map(|p| {
            let grey = |f: &str| -> Result<GrayImage> {
                let path = dir.join(f);
                Ok(image::open(&path)
                    .with_context(|| format!("{}", path.display()))?
                    .into_luma8())
            };
            Ok(Pair {
                prev: grey(&p.frame0)?,
                next: grey(&p.frame1)?,
                truth: read_kitti_values(&dir.join(&p.flow))?,
                boxes: p
                    .boxes
                    .iter()
                    .map(|b| PixelBox {
                        x1: b[0],
                        y1: b[1],
                        x2: b[2],
                        y2: b[3],
                    })
                    .collect(),
                name: p.name,
            })
        })
        .collect::<Result<_>>()?;
    Ok(PairSet {
        truth_everywhere: manifest.truth_everywhere,
        pairs,
    })
}

/// A KITTI flow PNG with the stored values kept at every pixel, also where the valid flag
/// is off (the affine pairs store their true motion there; `sequence`'s reader zeroes it).
fn read_kitti_values(path: &Path) -> Result<FlowField> {
    let img = image::open(path)
        .with_context(|| format!("{}", path.display()))?
        .into_rgb16();
    let (width, height) = img.dimensions();
    let mut uv = Vec::with_capacity(2 * (width * height) as usize);
    let mut valid = Vec::with_capacity((width * height) as usize);
    for p in img.pixels() {
        uv.push((f32::from(p.0[0]) - 32768.0) / 64.0);
        uv.push((f32::from(p.0[1]) - 32768.0) / 64.0);
        valid.push(p.0[2] > 0);
    }
    Ok(FlowField {
        width,
        height,
        uv,
        valid: Some(valid),
    })
}

fn generate(out: &Path, (width, height): (u32, u32), frames: u32, seed: u64) -> Result<()> {
    let combos = [
        (Domain::City, Weather::Sun),
        (Domain::City, Weather::Rain),
        (Domain::Highway, Weather::Sun),
        (Domain::Highway, Weather::Rain),
    ];
    for (k, (domain, weather)) in combos.into_iter().enumerate() {
        let mut spec = ScenarioSpec::new(ScenarioKind::Normal, domain, weather, seed + k as u64);
        spec.frames = frames;
        spec.width = width;
        spec.height = height;
        spec.name = spec.default_name(k);
        let dir = generate_scenario_without(&spec, out, &[Modality::Depth], |_| {})?;
        println!("{}", dir.display());
    }
    Ok(())
}

fn export_pairs(scenarios: &[PathBuf], out: &Path, every: usize, min_box: f32) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("{}", out.display()))?;
    let mut entries = Vec::new();
    for root in scenarios {
        let scenario = Scenario::open(root)?;
        for index in (every.max(1)..scenario.len()).step_by(every.max(1)) {
            let Some(truth) = scenario.flow(index)? else {
                continue;
            };
            let name = format!("{}_{index:04}", scenario.name());
            let grey = |i: usize| -> Result<GrayImage> {
                let rgb = scenario.rgb(i)?;
                let (w, h) = rgb.frame_size();
                let luma = rgb.luma();
                Ok(GrayImage::from_fn(w, h, |x, y| {
                    let v = luma[(y * w + x) as usize];
                    image::Luma([v.round().clamp(0.0, 255.0) as u8])
                }))
            };
            let files = [
                format!("{name}_0.png"),
                format!("{name}_1.png"),
                format!("{name}_gt.png"),
            ];
            for (file, frame) in files.iter().zip([index - 1, index]) {
                let path = out.join(file);
                grey(frame)?
                    .save(&path)
                    .with_context(|| format!("{}", path.display()))?;
            }
            write_kitti_png(&out.join(&files[2]), &truth)?;
            let boxes = scenario
                .boxes(index)?
                .into_iter()
                .filter(|b| u8::try_from(b.class).is_ok_and(is_vehicle_id))
                .filter(|b| b.width() >= min_box && b.height() >= min_box)
                .map(|b| [b.x1, b.y1, b.x2, b.y2])
                .collect();
            let [frame0, frame1, flow] = files;
            entries.push(PairEntry {
                name,
                frame0,
                frame1,
                flow,
                boxes,
            });
        }
    }
    let manifest = Manifest {
        source: "flow_bench export-pairs".into(),
        truth_everywhere: false,
        pairs: entries,
    };
    let path = out.join("manifest.json");
    std::fs::write(&path, serde_json::to_string_pretty(&manifest)?)
        .with_context(|| format!("{}", path.display()))?;
    println!("{} pairs in {}", manifest.pairs.len(), out.display());
    Ok(())
}

/// The preset's parameters with the fields of `overrides` (a JSON object) replaced.
fn preset_flow(preset: DisPreset, overrides: Option<&str>) -> Result<DisFlow> {
    let base = DisParams::from_preset(preset);
    let Some(text) = overrides else {
        return Ok(DisFlow::new(base)?);
    };
    let mut value = serde_json::to_value(base)?;
    let patch: serde_json::Value = serde_json::from_str(text).context("--params")?;
    let (Some(fields), Some(changes)) = (value.as_object_mut(), patch.as_object()) else {
        bail!("--params must be a JSON object");
    };
    for (k, v) in changes {
        if !fields.contains_key(k) {
            bail!("--params: DisParams has no field {k}");
        }
        fields.insert(k.clone(), v.clone());
    }
    Ok(DisFlow::new(serde_json::from_value(value)?)?)
}

struct AccuracyArgs<'a> {
    presets: &'a [DisPreset],
    overrides: Option<&'a str>,
    external: Option<&'a Path>,
    label: &'a str,
    write_to: Option<&'a Path>,
}

fn accuracy(set: &PairSet, args: AccuracyArgs) -> Result<()> {
    let AccuracyArgs {
        presets,
        overrides,
        external,
        label,
        write_to,
    } = args;
    for &preset in presets {
        let dis = preset_flow(preset, overrides)?;
        for pair in &set.pairs {
            let flow = match external {
                Some(dir) => read_flo(&dir.join(preset.name()).join(format!("{}.flo", pair.name)))?,
                None => dis.estimate(&pair.prev, &pair.next, None)?,
            };
            if let Some(dir) = write_to {
                let folder = dir.join(preset.name());
                std::fs::create_dir_all(&folder)
                    .with_context(|| format!("{}", folder.display()))?;
                write_flo(&folder.join(format!("{}.flo", pair.name)), &flow)?;
            }
            let epe = endpoint_error(&flow, &pair.truth)?;
            // Where the truth holds true motion everywhere, patches count every resized
            // pixel (as in the design study); otherwise only pixels with known motion.
            let truth = if set.truth_everywhere {
                FlowField {
                    valid: None,
                    ..pair.truth.clone()
                }
            } else {
                pair.truth.clone()
            };
            let patches = pair
                .boxes
                .iter()
                .map(|&b| box_endpoint_error(&flow, &truth, b, 32))
                .collect::<Result<Vec<_>, _>>()?;
            println!(
                "{}",
                json!({
                    "kind": "accuracy", "tool": label, "preset": preset.name(),
                    "pair": pair.name,
                    "epe_all": set.truth_everywhere.then_some(epe.mean_all),
                    "epe_valid": epe.mean_valid,
                    "epe_patch32": patches,
                })
            );
        }
    }
    Ok(())
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

fn time(pairs: &[Pair], presets: &[DisPreset], threads: usize, reps: usize) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot build the thread pool")?;
    pool.install(|| -> Result<()> {
        for &preset in presets {
            let dis = DisFlow::from_preset(preset);
            let (mut medians, mut mins) = (Vec::new(), Vec::new());
            for pair in pairs {
                dis.estimate(&pair.prev, &pair.next, None)?;
                let mut ms = Vec::with_capacity(reps);
                for _ in 0..reps.max(1) {
                    let start = Instant::now();
                    let flow = dis.estimate(&pair.prev, &pair.next, None)?;
                    ms.push(start.elapsed().as_secs_f64() * 1e3);
                    std::hint::black_box(flow);
                }
                mins.push(ms.iter().copied().fold(f64::INFINITY, f64::min));
                medians.push(median(&mut ms));
            }
            let n = pairs.len().max(1) as f64;
            println!(
                "{}",
                json!({
                    "kind": "time", "tool": "vadscope", "preset": preset.name(),
                    "threads": threads, "reps": reps, "pairs": pairs.len(),
                    "ms_median": medians.iter().sum::<f64>() / n,
                    "ms_min": mins.iter().sum::<f64>() / n,
                })
            );
        }
        Ok(())
    })
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Generate {
            out,
            size,
            frames,
            seed,
        } => generate(&out, size, frames, seed),
        Command::ExportPairs {
            scenarios,
            out,
            every,
            min_box,
        } => export_pairs(&scenarios, &out, every, min_box),
        Command::Accuracy {
            pairs,
            presets,
            external,
            label,
            write_flo,
            params,
        } => accuracy(
            &load_pairs(&pairs)?,
            AccuracyArgs {
                presets: &presets,
                overrides: params.as_deref(),
                external: external.as_deref(),
                label: &label,
                write_to: write_flo.as_deref(),
            },
        ),
        Command::Time {
            pairs,
            presets,
            threads,
            reps,
            max_pairs,
        } => {
            let mut set = load_pairs(&pairs)?;
            set.pairs.truncate(max_pairs.unwrap_or(usize::MAX));
            time(&set.pairs, &presets, threads, reps)
        }
    }
}
