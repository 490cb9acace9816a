//! `vadscope generate`: plans a data set of synthetic scenarios and renders it to disk with
//! a progress bar.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicU64, Ordering};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use vadscope::sequence::Modality;
use vadscope::synth::{
    DatasetRequest, DomainChoice, KindChoice, Preset, WeatherChoice, check_generated,
    generate_scenario_without, parse_size, plan_dataset,
};

/// Options of `vadscope generate`.
#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// Folder to write `Scenario_*` folders into (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// A data-set preset shaped like the paper's data: `train` (normal driving, city and
    /// highway, sun and rain, 24 scenarios) or `test` (13 sudden-braking scenarios).
    #[arg(long, value_name = "train|test")]
    preset: Option<Preset>,
    /// Number of scenarios (default: 24 for train, 13 for test, else 1).
    #[arg(long)]
    count: Option<usize>,
    /// What happens in each scenario; `mixed` draws a kind per scenario from the seed.
    #[arg(long, value_name = "normal|braking|mixed|turning|cut-in")]
    kind: Option<KindChoice>,
    /// Road environment; `any` draws one per scenario from the seed.
    #[arg(long, value_name = "city|highway|any")]
    domain: Option<DomainChoice>,
    /// Weather; `any` draws one per scenario from the seed.
    #[arg(long, value_name = "sun|rain|fog|night|any")]
    weather: Option<WeatherChoice>,
    /// Frames per scenario at 10 fps (default 200, as AnoVox; at most 2000).
    #[arg(long)]
    frames: Option<u32>,
    /// Image size as WIDTHxHEIGHT (default 768x512, AnoVox's camera).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Seed of the data set: the same seed and options give identical bytes.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Modalities to leave out of the written files, e.g. `--omit depth,flow` for a small
    /// bundle (RGB frames, boxes, labels and metadata are always written).
    #[arg(long, value_enum, value_delimiter = ',')]
    omit: Vec<OmitArg>,
    /// Replace scenario folders that already exist instead of stopping.
    #[arg(long, conflicts_with = "resume")]
    force: bool,
    /// Keep scenario folders that already exist and hold what this run would write (as an
    /// interrupted run leaves them), and generate the rest.
    #[arg(long)]
    resume: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum OmitArg {
    Semantic,
    Instance,
    Depth,
    Flow,
    Action,
    Anomaly,
}

impl OmitArg {
    fn modality(self) -> Modality {
        match self {
            OmitArg::Semantic => Modality::Semantic,
            OmitArg::Instance => Modality::Instance,
            OmitArg::Depth => Modality::Depth,
            OmitArg::Flow => Modality::Flow,
            OmitArg::Action => Modality::Action,
            OmitArg::Anomaly => Modality::Anomaly,
        }
    }
}

fn request_of(args: &GenerateArgs) -> DatasetRequest {
    DatasetRequest {
        preset: args.preset,
        count: args.count,
        kind: args.kind,
        domain: args.domain,
        weather: args.weather,
        frames: args.frames,
        size: args.size,
        seed: args.seed,
    }
}

/// Runs `vadscope generate`.
pub fn run(args: GenerateArgs) -> anyhow::Result<ExitCode> {
    vadscope::synth::keep_freed_frame_buffers();
    let specs = plan_dataset(&request_of(&args))?;
    let omit: Vec<Modality> = args.omit.iter().map(|o| o.modality()).collect();
    // Every existing folder is dealt with before anything is rendered, so that a mismatch
    // stops the run at once rather than after the scenarios before it.
    let mut kept: Vec<Option<PathBuf>> = vec![None; specs.len()];
    for (spec, kept) in specs.iter().zip(&mut kept) {
        let dir = spec.folder_in(&args.out);
        if !dir.exists() {
            continue;
        }
        if args.resume {
            *kept = Some(check_generated(spec, &args.out, &omit)?);
        } else if args.force {
            std::fs::remove_dir_all(&dir)
                .with_context(|| format!("cannot remove {}", dir.display()))?;
        } else {
            bail!(
                "{} already exists; pass --resume to keep the scenarios that are complete or \
                 --force to replace them",
                dir.display()
            );
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;

    let total: u64 = specs.iter().map(|s| u64::from(s.frames)).sum();
    let bar = ProgressBar::new(total).with_style(
        ProgressStyle::with_template(
            "{prefix:>24} [{bar:40}] {pos}/{len} frames ({per_sec}, eta {eta}) {msg}",
        )
        .expect("static progress template")
        .progress_chars("=> "),
    );
    bar.set_prefix("generating");
    // Above the bar on a terminal, and in the output as well when it is piped to a log
    // (where the bar does not draw).
    let say = |line: &str| bar.suspend(|| println!("{line}"));
    let done = AtomicU64::new(0);
    for (i, spec) in specs.iter().enumerate() {
        if let Some(dir) = &kept[i] {
            done.fetch_add(u64::from(spec.frames), Ordering::Relaxed);
            bar.set_position(done.load(Ordering::Relaxed));
            say(&format!("kept {} (complete)", dir.display()));
            continue;
        }
        bar.set_message(format!("scenario {}/{}: {}", i + 1, specs.len(), spec.name));
        let dir = generate_scenario_without(spec, &args.out, &omit, |_| {
            done.fetch_add(1, Ordering::Relaxed);
            bar.set_position(done.load(Ordering::Relaxed));
        })
        .with_context(|| format!("generating scenario {}", spec.name))?;
        say(&format!("wrote {}", dir.display()));
    }
    bar.finish_with_message("done");
    Ok(ExitCode::SUCCESS)
}
