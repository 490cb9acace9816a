//! Benchmark driver for vadscope's DIS optical flow, used by `benches/flow_opencv/run.sh` to
//! compare it with OpenCV's DIS on the same frames.
//!
//! Reads a folder written by `benches/flow_opencv/make_pairs.py` (`manifest.json`, grey PNG
//! frames, KITTI 16-bit ground-truth flow, vehicle boxes) and prints one JSON object per
//! line:
//!
//! * `accuracy`: EPE over all pixels, over valid pixels, and on 32×32 vehicle patches (crop
//!   and bilinear resize as HF²-VAD does) for vadscope's flow or for flows computed
//!   elsewhere and stored as Middlebury `.flo` files (`--external DIR`, files
//!   `DIR/<preset>/<pair>.flo`), so both tools are scored by the same code;
//! * `time`: milliseconds per frame pair on a given number of threads.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use image::GrayImage;
use serde::Deserialize;
use serde_json::json;
use vadscope::flow::{
    DisFlow, DisParams, DisPreset, FlowField, PixelBox, box_endpoint_error, endpoint_error,
};

#[derive(Parser)]
#[command(about = "vadscope DIS flow benchmark driver (see benches/flow_opencv/run.sh)")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
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
    },
}

#[derive(Deserialize)]
struct Manifest {
    pairs: Vec<PairEntry>,
}

#[derive(Deserialize)]
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

fn load_pairs(dir: &Path) -> Result<Vec<Pair>> {
    let manifest_path = dir.join("manifest.json");
    let text = std::fs::read_to_string(&manifest_path)
        .with_context(|| format!("{}", manifest_path.display()))?;
    let manifest: Manifest =
        serde_json::from_str(&text).with_context(|| format!("{}", manifest_path.display()))?;
    manifest
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
                truth: read_kitti_flow(&dir.join(&p.flow))?,
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
        .collect()
}

/// KITTI flow PNG: 16-bit RGB, u = (R − 2¹⁵)/64, v = (G − 2¹⁵)/64, B = valid.
fn read_kitti_flow(path: &Path) -> Result<FlowField> {
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

/// Middlebury `.flo`: magic 202021.25, width, height, then interleaved little-endian f32.
fn read_flo(path: &Path) -> Result<FlowField> {
    let bytes = std::fs::read(path).with_context(|| format!("{}", path.display()))?;
    let word = |i: usize| -> Result<[u8; 4]> {
        bytes
            .get(4 * i..4 * i + 4)
            .and_then(|s| s.try_into().ok())
            .with_context(|| format!("{}: truncated", path.display()))
    };
    if f32::from_le_bytes(word(0)?) != 202021.25 {
        bail!("{}: not a .flo file", path.display());
    }
    let width = u32::from_le_bytes(word(1)?);
    let height = u32::from_le_bytes(word(2)?);
    let n = 2 * width as usize * height as usize;
    if bytes.len() != 12 + 4 * n {
        bail!("{}: size does not match {width}×{height}", path.display());
    }
    let uv = (0..n)
        .map(|i| word(3 + i).map(f32::from_le_bytes))
        .collect::<Result<Vec<_>>>()?;
    Ok(FlowField {
        width,
        height,
        uv,
        valid: None,
    })
}

fn write_flo(path: &Path, flow: &FlowField) -> Result<()> {
    let mut bytes = Vec::with_capacity(12 + 4 * flow.uv.len());
    bytes.extend_from_slice(&202021.25f32.to_le_bytes());
    bytes.extend_from_slice(&flow.width.to_le_bytes());
    bytes.extend_from_slice(&flow.height.to_le_bytes());
    for v in &flow.uv {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
    }
    std::fs::write(path, bytes).with_context(|| format!("{}", path.display()))
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

fn accuracy(pairs: &[Pair], args: AccuracyArgs) -> Result<()> {
    let AccuracyArgs {
        presets,
        overrides,
        external,
        label,
        write_to,
    } = args;
    for &preset in presets {
        let dis = preset_flow(preset, overrides)?;
        for pair in pairs {
            let flow = match external {
                Some(dir) => read_flo(&dir.join(preset.name()).join(format!("{}.flo", pair.name)))?,
                None => dis.estimate(&pair.prev, &pair.next, None)?,
            };
            if let Some(dir) = write_to {
                write_flo(
                    &dir.join(preset.name()).join(format!("{}.flo", pair.name)),
                    &flow,
                )?;
            }
            let epe = endpoint_error(&flow, &pair.truth)?;
            let patches = pair
                .boxes
                .iter()
                .map(|&b| box_endpoint_error(&flow, &pair.truth, b, 32))
                .collect::<Result<Vec<_>, _>>()?;
            println!(
                "{}",
                json!({
                    "kind": "accuracy", "tool": label, "preset": preset.name(),
                    "pair": pair.name, "epe_all": epe.mean_all, "epe_valid": epe.mean_valid,
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
                    "threads": threads, "reps": reps,
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
        } => time(&load_pairs(&pairs)?, &presets, threads, reps),
    }
}
