//! `vadscope train`: turns the command line into a [`TrainRequest`], runs the three training
//! stages with progress bars and per-epoch lines, and prints where the checkpoint went.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use vadscope::flow::FlowSource;
use vadscope::model::{BoxFilter, FlowUnits, ModelConfig, ScoreScale, read_checkpoint_meta};
use vadscope::score::ValidationSet;
use vadscope::sequence::Scenario;
use vadscope::train::scenarios::{
    CubeExtraction, TrainRequest, scenario_folders, train_from_scenarios,
};
use vadscope::train::{AnomalySelection, EpochJudge, TrainConfig, WeightAveraging};

use crate::cli::score::parse_flow_source;

mod progress;

use progress::{Progress, bar, print_report};

/// Name of the extracted-cube cache inside the output folder.
const CUBE_FILE: &str = "cubes.safetensors";
/// Name of the resume state inside the output folder (written by the library).
const STATE_FILE: &str = "state.json";

/// Options of `vadscope train`.
#[derive(Debug, Args)]
pub struct TrainArgs {
    /// Scenario folders, or folders holding `Scenario_*` folders, of normal driving (e.g. the
    /// output of `vadscope generate --preset train`). Repeat or list several.
    #[arg(long, required = true, num_args = 1..)]
    data: Vec<PathBuf>,
    /// Output folder: extracted cubes (`cubes.safetensors`), per-epoch checkpoints
    /// (`last_model.bpk`, `stageN_best.bpk`), the resume state (`state.json`) and the final
    /// checkpoint with training statistics (`model.safetensors`).
    #[arg(long)]
    out: PathBuf,
    /// Which stage to train: `memae` (1: ML-MemAE-SC on the last flow), `cvae` (2: the CVAE
    /// with ML-MemAE-SC frozen), `finetune` (3: everything together) or `all` three in order.
    /// The stages not chosen run for 0 epochs.
    #[arg(long, value_enum, default_value_t = StageArg::All)]
    stage: StageArg,
    /// Model sizes: `compact` (the bundled CPU model, ≈ 9.9 M parameters; the default) or
    /// `paper` (the reference configuration, 69 M parameters).
    #[arg(long, value_enum, value_name = "compact|paper")]
    preset: Option<PresetArg>,
    /// Start from this vadscope checkpoint instead of random weights, with its model config
    /// (e.g. `--stage cvae --init RUN1/model.safetensors` after a `--stage memae` run RUN1).
    #[arg(long, value_name = "CHECKPOINT", conflicts_with_all = ["preset", "model_config"])]
    init: Option<PathBuf>,
    /// Model sizes as JSON (a `ModelConfig`: patch size, widths, memory slots, ...) instead
    /// of a preset.
    #[arg(long, value_name = "FILE", conflicts_with = "preset")]
    model_config: Option<PathBuf>,
    /// Training settings as JSON (a `TrainConfig`: per-stage epochs, batch sizes, learning
    /// rates and schedules, Adam ε, loss weights, seed, validation split). Options given on
    /// the command line override it. Default: the reference's schedules.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Epochs of every chosen stage (reference: 80).
    #[arg(long, value_name = "N")]
    epochs: Option<usize>,
    /// Epochs of stage 1 (overrides --epochs).
    #[arg(long, value_name = "N")]
    memae_epochs: Option<usize>,
    /// Epochs of stage 2 (overrides --epochs).
    #[arg(long, value_name = "N")]
    cvae_epochs: Option<usize>,
    /// Epochs of stage 3 (overrides --epochs).
    #[arg(long, value_name = "N")]
    finetune_epochs: Option<usize>,
    /// Batch size of every stage (reference: 256 flows in stage 1, 128 cubes in 2 and 3).
    #[arg(long, value_name = "B")]
    batch: Option<usize>,
    /// Batch size of stage 1 (overrides --batch).
    #[arg(long, value_name = "B")]
    memae_batch: Option<usize>,
    /// Batch size of stage 2 (overrides --batch).
    #[arg(long, value_name = "B")]
    cvae_batch: Option<usize>,
    /// Batch size of stage 3 (overrides --batch).
    #[arg(long, value_name = "B")]
    finetune_batch: Option<usize>,
    /// Base learning rate of stage 1 (reference 1e-4).
    #[arg(long, value_name = "LR")]
    memae_lr: Option<f64>,
    /// Base learning rate of stage 2 (reference 1e-4).
    #[arg(long, value_name = "LR")]
    cvae_lr: Option<f64>,
    /// Base learning rate of stage 3 (reference 8e-5).
    #[arg(long, value_name = "LR")]
    finetune_lr: Option<f64>,
    /// Stop every epoch after this many optimiser steps (default: a full pass).
    #[arg(long, value_name = "N")]
    max_steps: Option<usize>,
    /// Fraction of the scenarios held out as normal validation data for model selection
    /// (default 0.1; at least one scenario when there are several).
    #[arg(long, value_name = "F")]
    val_fraction: Option<f64>,
    /// Batch size of the validation and statistics passes (default 64).
    #[arg(long, value_name = "B")]
    eval_batch: Option<usize>,
    /// Seed of initialisation, shuffling, dropout, latent noise and the split (default 0).
    #[arg(long, value_name = "S")]
    seed: Option<u64>,
    /// Use every n-th frame of each scenario as a cube target, from frame `clip_hist` on
    /// (default 1: every frame).
    #[arg(long, value_name = "N", default_value_t = 1)]
    frame_stride: usize,
    /// Which boxes give cubes, recorded in the model so scoring keeps the same ones:
    /// `keep-all` (the reference) or `driving` (at least 1/400 of the frame area, not cut by
    /// the image edge). Default: the preset's.
    #[arg(long, value_enum, conflicts_with = "init")]
    box_filter: Option<BoxFilterArg>,
    /// Smallest box area kept, as a fraction of the frame area (overrides the fraction of
    /// --box-filter).
    #[arg(long, value_name = "F", conflicts_with = "init")]
    min_box_area: Option<f32>,
    /// Units of the flows the model sees: `native` pixels (the reference), `patch` pixels
    /// (each box's motion divided by its size, so near and far objects compare) or
    /// `frame-width` (native pixels rescaled to the width of the training frames, so the
    /// model reads the same motion at any resolution). With --init only `frame-width`, and
    /// only for a model trained on native pixels of frames as wide as --data's: it names
    /// the units those cubes already have, for scoring at other resolutions.
    #[arg(long, value_enum)]
    flow_units: Option<FlowUnitsArg>,
    /// ML-MemAE-SC reconstructs a cube's flows jointly (all of them in one pass) instead of
    /// each on its own as the reference does.
    #[arg(long, conflicts_with = "init")]
    joint_flows: bool,
    /// Keep the training score statistics per N equal vertical bands of the image (by box
    /// centre), so each object is z-scored against the normal objects at its place (1: one
    /// global statistic, the reference). Allowed with --init: it only changes the
    /// statistics, so `--init RUN/model.safetensors --epochs 0 --score-bands 5` re-derives
    /// them for a trained model.
    #[arg(long, value_name = "N")]
    score_bands: Option<usize>,
    /// How objects' S_r and S_p are normalised before the fusion weights: `z` (z-scores
    /// with the training moments, the reference) or `tail` (the surprisal −ln P(S' ≥ S)
    /// among the training cubes' scores, robust to S_r's heavy tail). Allowed with --init
    /// like --score-bands: `--init RUN/model.safetensors --epochs 0 --score-scale tail`
    /// re-derives the statistics of a trained model.
    #[arg(long, value_enum)]
    score_scale: Option<ScoreScaleArg>,
    /// Where the cubes' flows come from: `stored` (the scenarios' OPTICAL_FLOW, the
    /// default), `dis[:preset]` (estimated with DIS as scoring estimates the flow of data
    /// without stored flow, cached in each scenario's `.vadscope/flow/`), `auto[:preset]`
    /// (stored where present, else DIS).
    #[arg(long, default_value = "stored", value_name = "stored|dis[:preset]", value_parser = parse_flow_source)]
    flow: FlowSource,
    /// Keep each stage's epoch by the pooled frame AUROC (ground-truth boxes, the reference
    /// protocol, default weights) on these validation scenarios with anomalies — e.g.
    /// `vadscope generate --preset test --count 6 --seed 1`, never the test set — instead of
    /// the loss on held-out normal cubes. Their cubes are cut once with the model's box
    /// filter and flows from --flow; each judged epoch's statistics come from 2,048 training
    /// cubes (`anomaly_selection.stats_cubes` in --config).
    #[arg(long, num_args = 1.., value_name = "DIR")]
    select_on: Vec<PathBuf>,
    /// With --select-on: judge every n-th epoch and the last (default 1, every epoch; a
    /// judgement costs about one inference pass over the sample and the validation objects).
    #[arg(long, value_name = "N", requires = "select_on")]
    select_every: Option<usize>,
    /// With --select-on: worker threads of each judgement (the sample's statistics and the
    /// validation scoring; default: those of --threads). Inference gives the same numbers on
    /// any number of threads, so a one-thread run can judge on all cores.
    #[arg(long, value_name = "N", requires = "select_on")]
    select_threads: Option<usize>,
    /// Average the weights of each trained stage's epochs from the N-th (counted from 1) on
    /// (stochastic weight averaging): from there, each epoch's candidate for selection is
    /// the running mean of the weights (BatchNorm statistics recomputed over 2,048 training
    /// cubes), while training goes on from the epoch's own weights.
    #[arg(long, value_name = "N")]
    average_from: Option<usize>,
    /// Worker threads of the CPU backend (default: all cores).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Continue the unfinished run in --out from its last finished epoch (same options
    /// required); the cubes are read back from the output folder.
    #[arg(long)]
    resume: bool,
}

/// The stages `--stage` can choose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum StageArg {
    Memae,
    Cvae,
    Finetune,
    All,
}

impl StageArg {
    /// Whether stage `n` (1–3) runs.
    fn includes(self, n: usize) -> bool {
        match self {
            StageArg::Memae => n == 1,
            StageArg::Cvae => n == 2,
            StageArg::Finetune => n == 3,
            StageArg::All => true,
        }
    }
}

/// The box filters `--box-filter` can choose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum BoxFilterArg {
    KeepAll,
    Driving,
}

/// The flow units `--flow-units` can choose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum FlowUnitsArg {
    Native,
    Patch,
    FrameWidth,
}

/// The score normalisations `--score-scale` can choose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ScoreScaleArg {
    Z,
    Tail,
}

/// The model presets `--preset` can choose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum PresetArg {
    Compact,
    Paper,
}

impl PresetArg {
    fn config(self) -> ModelConfig {
        match self {
            PresetArg::Compact => ModelConfig::compact(),
            PresetArg::Paper => ModelConfig::paper(),
        }
    }
}

/// `model` with the options beyond the paper that the command line sets.
fn with_model_options(mut model: ModelConfig, args: &TrainArgs) -> anyhow::Result<ModelConfig> {
    match args.box_filter {
        Some(BoxFilterArg::KeepAll) => model.box_filter = BoxFilter::KEEP_ALL,
        Some(BoxFilterArg::Driving) => model.box_filter = BoxFilter::DRIVING,
        None => {}
    }
    if let Some(f) = args.min_box_area {
        model.box_filter.min_area_fraction = f;
    }
    match args.flow_units {
        Some(FlowUnitsArg::Native) => model.conventions.flow_units = FlowUnits::NativePixels,
        Some(FlowUnitsArg::Patch) => model.conventions.flow_units = FlowUnits::Patch,
        Some(FlowUnitsArg::FrameWidth) => {
            model.conventions.flow_units = FlowUnits::FrameWidth {
                width: training_frame_width(&args.data)?,
            }
        }
        None => {}
    }
    if args.joint_flows {
        model.joint_flows = true;
    }
    if let Some(bands) = args.score_bands {
        model.score_bands = bands;
    }
    match args.score_scale {
        Some(ScoreScaleArg::Z) => model.score_scale = ScoreScale::ZScore,
        Some(ScoreScaleArg::Tail) => model.score_scale = ScoreScale::TailSurprisal,
        None => {}
    }
    model
        .validate()
        .context("the model options do not describe a usable model")?;
    Ok(model)
}

/// The frame width of the first training scenario under `data`: the reference width of
/// `--flow-units frame-width`.
fn training_frame_width(data: &[PathBuf]) -> anyhow::Result<u32> {
    let folders = scenario_folders(data)?;
    let first = folders
        .first()
        .with_context(|| "--flow-units frame-width needs at least one training scenario")?;
    let scenario = Scenario::open(first)
        .with_context(|| format!("cannot open the training scenario {}", first.display()))?;
    Ok(scenario.resolution().0)
}

/// Refuses `--flow-units` with `--init` unless it only names the units the initial model's
/// cubes already have: native pixels of frames as wide as the training data's.
fn check_init_flow_units(initial: &ModelConfig, args: &TrainArgs) -> anyhow::Result<()> {
    if args.flow_units.is_none() {
        return Ok(());
    }
    // Any width stands for the data's here: only the kind of units decides.
    let frame_width = FlowUnits::FrameWidth { width: 1 };
    if args.flow_units != Some(FlowUnitsArg::FrameWidth)
        || !initial.conventions.flow_units.relabels_as(frame_width)
    {
        bail!(
            "--flow-units with --init only turns native-pixel flows into frame-width units \
             (the initial model's are {:?}); train a new model to change units",
            initial.conventions.flow_units
        );
    }
    Ok(())
}

/// The training settings: `--config` (or the defaults), then the command-line overrides.
fn train_config(args: &TrainArgs) -> anyhow::Result<TrainConfig> {
    let mut config = match &args.config {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            serde_json::from_str(&text)
                .with_context(|| format!("{} is not a valid training config", path.display()))?
        }
        None => TrainConfig::default(),
    };
    let per_stage = [
        (args.memae_epochs, args.memae_batch, args.memae_lr),
        (args.cvae_epochs, args.cvae_batch, args.cvae_lr),
        (args.finetune_epochs, args.finetune_batch, args.finetune_lr),
    ];
    for (i, (epochs, batch, lr)) in per_stage.into_iter().enumerate() {
        let stage = match i {
            0 => &mut config.stage1,
            1 => &mut config.stage2,
            _ => &mut config.stage3,
        };
        if let Some(e) = epochs.or(args.epochs) {
            stage.epochs = e;
        }
        if !args.stage.includes(i + 1) {
            stage.epochs = 0;
        }
        if let Some(b) = batch.or(args.batch) {
            stage.batch_size = b;
        }
        if let Some(lr) = lr {
            stage.lr = lr;
        }
        if args.max_steps.is_some() {
            stage.max_steps_per_epoch = args.max_steps;
        }
    }
    if let Some(f) = args.val_fraction {
        config.val_fraction = f;
    }
    if let Some(b) = args.eval_batch {
        config.eval_batch = b;
    }
    if let Some(s) = args.seed {
        config.seed = s;
    }
    if !args.select_on.is_empty() {
        let base = config
            .anomaly_selection
            .unwrap_or(AnomalySelection::EVERY_EPOCH);
        let every = args.select_every.unwrap_or(base.every);
        if every == 0 || args.select_threads == Some(0) {
            bail!("--select-every and --select-threads must be at least 1");
        }
        config.anomaly_selection = Some(AnomalySelection {
            every,
            threads: args.select_threads.or(base.threads),
            ..base
        });
    } else if config.anomaly_selection.is_some() {
        bail!(
            "the training config selects epochs by anomaly detection; name the validation \
             scenarios with --select-on"
        );
    }
    if let Some(from) = args.average_from {
        if from == 0 {
            bail!("--average-from counts epochs from 1");
        }
        let base = config
            .averaging
            .unwrap_or(WeightAveraging::from_epoch(from - 1));
        config.averaging = Some(WeightAveraging {
            from_epoch: from - 1,
            ..base
        });
    }
    Ok(config)
}

/// A model config read from a JSON file and checked.
fn model_config(path: &Path) -> anyhow::Result<ModelConfig> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let config: ModelConfig = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a valid model config", path.display()))?;
    config
        .validate()
        .with_context(|| format!("{} is not a usable model config", path.display()))?;
    Ok(config)
}

/// Makes sure `out` exists and can be written before any expensive work starts.
fn check_out_dir(out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create the output folder {}", out.display()))?;
    let probe = out.join(".vadscope-write-test");
    std::fs::write(&probe, b"")
        .with_context(|| format!("the output folder {} is not writable", out.display()))?;
    std::fs::remove_file(&probe).with_context(|| format!("cannot clean up {}", probe.display()))?;
    Ok(())
}

/// Refuses to start over an existing run without `--resume`, and to resume nothing.
fn check_resume(out: &Path, resume: bool) -> anyhow::Result<()> {
    let started = out.join(STATE_FILE).is_file() || out.join(CUBE_FILE).is_file();
    if resume && !started {
        bail!(
            "{} holds no run to resume (no {STATE_FILE} or {CUBE_FILE})",
            out.display()
        );
    }
    if !resume && started {
        bail!(
            "{} already holds a training run; pass --resume to continue it or choose an \
             empty folder",
            out.display()
        );
    }
    Ok(())
}

/// Runs `vadscope train`.
pub fn run(args: TrainArgs) -> anyhow::Result<ExitCode> {
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("cannot set up the worker threads")?;
    }
    let model = match (&args.init, &args.model_config) {
        (Some(path), _) => {
            let initial = read_checkpoint_meta(path)?.config;
            check_init_flow_units(&initial, &args)?;
            initial
        }
        (None, Some(path)) => model_config(path)?,
        (None, None) => args.preset.unwrap_or(PresetArg::Compact).config(),
    };
    let model = with_model_options(model, &args)?;
    let train = train_config(&args)?;
    if args.frame_stride == 0 {
        bail!("--frame-stride must be at least 1");
    }
    let cube_file = args.out.join(CUBE_FILE);
    if !cube_file.is_file() {
        let folders = scenario_folders(&args.data)?;
        println!(
            "{} scenarios under {}",
            folders.len(),
            args.data
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    check_out_dir(&args.out)?;
    check_resume(&args.out, args.resume)?;
    let request = TrainRequest {
        data: args.data.clone(),
        out_dir: args.out.clone(),
        extraction: CubeExtraction {
            frame_stride: args.frame_stride,
            flow: args.flow,
            ..CubeExtraction::for_model(&model)
        },
        model,
        train,
        cube_file: Some(cube_file),
        initial: args.init.clone(),
    };

    let mut judge = selection_set(&args, &request.model)?;
    let extract_bar = bar("{prefix:>12} [{bar:40}] {pos}/{len} scenarios ({elapsed})");
    extract_bar.set_prefix("cubes");
    let mut progress = Progress::default();
    let report = train_from_scenarios(
        &request,
        judge.as_mut().map(|j| j as &mut dyn EpochJudge),
        &mut |event| progress.on_event(event),
        &mut |done, total| {
            extract_bar.set_length(total as u64);
            extract_bar.set_position(done as u64);
        },
    )?;
    extract_bar.finish_and_clear();
    progress.finish();
    print_report(&report);
    Ok(ExitCode::SUCCESS)
}

/// The validation scenarios of `--select-on`, cut for `model`; `None` without the option.
fn selection_set(args: &TrainArgs, model: &ModelConfig) -> anyhow::Result<Option<ValidationSet>> {
    if args.select_on.is_empty() {
        return Ok(None);
    }
    let folders = scenario_folders(&args.select_on)?;
    let load_bar = bar("{prefix:>12} [{bar:40}] {pos}/{len} scenarios ({elapsed})");
    load_bar.set_prefix("selection");
    let set = ValidationSet::load(&folders, model, args.flow, &mut |done, total| {
        load_bar.set_length(total as u64);
        load_bar.set_position(done as u64);
    })
    .context("cannot prepare the --select-on scenarios")?;
    load_bar.finish_and_clear();
    println!(
        "model selection: frame AUROC on {} validation scenarios ({} cubes)",
        set.len(),
        set.cubes()
    );
    Ok(Some(set))
}
