//! `vadscope score`: runs the model over scenarios into their score caches
//! (`<scenario>/.vadscope/scores/`) with a progress bar, reusing caches that are current.
//! Also the scoring step of `vadscope eval`, `render` and `export` ([`Scorer`]: the loop of
//! `score::Scorer` with a progress bar and a line per scenario), and the parsing of the box
//! and flow source options the commands share.
//!
//! Ctrl-C cancels the run in progress: its temporary file is removed and no cache appears
//! under the real name (caches are written to a scratch name and renamed when complete, so
//! even a second Ctrl-C, which exits at once, never leaves a cache that looks complete).

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use vadscope::flow::DisPreset;
use vadscope::model::{bundled_model, read_checkpoint_meta};
use vadscope::score::{
    self, BoxSource, CacheLookup, DetectionFile, FlowSource, MotionParams, ScoreCache,
    ScoreProgress, ScoreRequest,
};
use vadscope::sequence::{Scenario, discover_scenarios};

/// Options of `vadscope score`.
#[derive(Debug, Args)]
pub struct ScoreArgs {
    /// Scenario folders, or data-set roots holding `Scenario_*` folders.
    #[arg(required = true, value_name = "SCENARIOS")]
    scenarios: Vec<PathBuf>,
    /// Where the boxes of the scored objects come from: `gt` (ground truth), `det` (the
    /// scenario's BBOX_2D_DET), `motion` (detector-free motion boxes), `gt+motion` or
    /// `det+motion` (boxes plus motion boxes outside them, as the original HF²-VAD), or a
    /// detection file (MOT `.txt`, COCO `.json`, a YOLO folder, `boxes.csv`).
    #[arg(long, default_value = "gt", value_name = "gt|det|motion|FILE", value_parser = parse_box_source)]
    boxes: BoxSource,
    #[command(flatten)]
    run: RunArgs,
    /// Score again even where a current cache exists.
    #[arg(long)]
    force: bool,
}

/// Model and scoring options shared by `score` and `eval`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The checkpoint to score with (default: the bundled model, or `$VADSCOPE_MODEL`).
    #[arg(long, value_name = "M")]
    model: Option<PathBuf>,
    /// Where the flows of the cubes come from: `stored` (the scenario's OPTICAL_FLOW; a
    /// missing flow is an error), `dis[:preset]` (estimated with DIS, ignoring stored
    /// flows), `auto[:preset]` (stored where present, else DIS). Presets: ultrafast, fast,
    /// medium (default), quality.
    #[arg(long, default_value = "auto", value_name = "stored|dis[:preset]", value_parser = parse_flow_source)]
    pub flow: FlowSource,
    /// Cubes sent to the model at once (the reference's per-batch pixel statistics are
    /// gathered over 128 cubes whatever this is).
    #[arg(long, default_value_t = 128, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=65536))]
    batch: u64,
}

/// Parses a `--boxes` value.
pub fn parse_box_source(text: &str) -> Result<BoxSource, String> {
    let keyword = |word: &str| match word {
        "gt" => Some(BoxSource::GroundTruth),
        "det" => Some(BoxSource::Detections),
        _ => None,
    };
    if text == "motion" {
        return Ok(BoxSource::Motion(MotionParams::default()));
    }
    if let Some(base) = text.strip_suffix("+motion") {
        let base = keyword(base).ok_or_else(|| {
            format!("'{text}': only gt+motion and det+motion combine with motion boxes")
        })?;
        return Ok(BoxSource::WithMotion {
            base: Box::new(base),
            motion: MotionParams::default(),
        });
    }
    if let Some(source) = keyword(text) {
        return Ok(source);
    }
    let path = Path::new(text);
    if !path.exists() {
        return Err(format!(
            "'{text}' is neither gt, det, motion, gt+motion, det+motion nor an existing detection file"
        ));
    }
    DetectionFile::guess(path)
        .map(BoxSource::Imported)
        .map_err(|e| e.to_string())
}

/// Parses a `--flow` value.
pub fn parse_flow_source(text: &str) -> Result<FlowSource, String> {
    let (kind, preset) = match text.split_once(':') {
        Some((kind, preset)) => (
            kind,
            preset
                .parse::<DisPreset>()
                .map_err(|e| format!("'{text}': {e}"))?,
        ),
        None => (text, DisPreset::default()),
    };
    match (kind, text.contains(':')) {
        ("stored", false) => Ok(FlowSource::Stored),
        ("stored", true) => Err(format!("'{text}': stored flows take no DIS preset")),
        ("dis", _) => Ok(FlowSource::Estimated(preset)),
        ("auto", _) => Ok(FlowSource::StoredElseEstimated(preset)),
        _ => Err(format!(
            "'{text}': expected stored, dis[:preset] or auto[:preset]"
        )),
    }
}

/// Every scenario under `paths` (scenario folders or data-set roots), opened, in order and
/// without repeats.
pub fn open_scenarios(paths: &[PathBuf]) -> anyhow::Result<Vec<Scenario>> {
    let mut folders: Vec<PathBuf> = Vec::new();
    for path in paths {
        let found = discover_scenarios(path)
            .with_context(|| format!("no scenario at {}", path.display()))?;
        for folder in found {
            if !folders.contains(&folder) {
                folders.push(folder);
            }
        }
    }
    folders
        .iter()
        .map(|f| Scenario::open(f).with_context(|| format!("cannot open scenario {}", f.display())))
        .collect()
}

/// Set by Ctrl-C; every scoring run of the process checks it.
static CANCEL: AtomicBool = AtomicBool::new(false);

/// Where a [`Scorer`] reports what it did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Report {
    /// On standard output (`vadscope score`: the report is the output).
    Stdout,
    /// On standard error (`vadscope eval`: standard output holds the table).
    Stderr,
}

/// Scores scenarios with one checkpoint through `score::Scorer` (the model loaded only when
/// some scenario has no current cache), showing a progress bar and a line per scenario.
pub struct Scorer {
    scorer: score::Scorer,
    flow: FlowSource,
    batch: usize,
    report: Report,
}

impl Scorer {
    /// A scorer for `run`'s model and flow source. Reads the checkpoint's header (so a file
    /// that is no checkpoint fails here, naming it) and hashes it for the cache keys.
    pub fn new(run: &RunArgs, report: Report) -> anyhow::Result<Self> {
        let checkpoint = match &run.model {
            Some(path) => path.clone(),
            None => bundled_model()?,
        };
        read_checkpoint_meta(&checkpoint)?;
        let scorer = score::Scorer::new(checkpoint)?;
        ctrlc::set_handler(|| {
            // The first Ctrl-C cancels cleanly; a second one exits at once.
            if CANCEL.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        })
        .context("cannot install the Ctrl-C handler")?;
        Ok(Self {
            scorer,
            flow: run.flow,
            batch: run.batch as usize,
            report,
        })
    }

    /// The checkpoint this scorer scores with.
    pub fn checkpoint(&self) -> &Path {
        self.scorer.checkpoint()
    }

    fn say(&self, line: &str) {
        match self.report {
            Report::Stdout => println!("{line}"),
            Report::Stderr => eprintln!("{line}"),
        }
    }

    /// The request for `boxes` with this scorer's flow source and batch size.
    pub fn request(&self, boxes: &BoxSource) -> ScoreRequest {
        ScoreRequest {
            batch_size: self.batch,
            ..ScoreRequest::new(boxes.clone(), self.flow)
        }
    }

    /// The score cache of `scenario` for `boxes`: the current one, or (when there is none,
    /// it cannot be used, or `force` is set) a new one scored now. Prints one line per
    /// scenario: frames, objects, time, frames/s and the cache path.
    pub fn cache_for(
        &mut self,
        scenario: &Scenario,
        boxes: &BoxSource,
        force: bool,
    ) -> anyhow::Result<ScoreCache> {
        let request = self.request(boxes);
        let name = scenario.name().to_string();
        match self.scorer.find(scenario, &request)? {
            CacheLookup::Current(cache) if !force => {
                let t = cache.table();
                self.say(&format!(
                    "{name}: cache is current ({} frames, {} objects, {}) -> {}",
                    t.frames.len(),
                    t.objects.len(),
                    boxes.label(),
                    cache.path().display()
                ));
                return Ok(*cache);
            }
            CacheLookup::Unusable { error, .. } => {
                self.say(&format!("{name}: scoring again: {error}"));
            }
            CacheLookup::Current(_) | CacheLookup::Missing(_) => {}
        }
        self.scorer.load_model()?;
        let frames = scenario.len() as u64;
        let bar = ProgressBar::new(frames).with_style(
            ProgressStyle::with_template(
                "{prefix} [{bar:30}] {pos}/{len} frames ({per_sec}, eta {eta}) {msg}",
            )
            .expect("static progress template")
            .progress_chars("=> "),
        );
        bar.set_prefix(name.clone());
        let started = Instant::now();
        let cache = self.scorer.score(
            scenario,
            &request,
            &mut |p: ScoreProgress| {
                bar.set_position(p.frames_done as u64);
                bar.set_message(format!("{} objects", p.objects));
            },
            &CANCEL,
        );
        bar.finish_and_clear();
        let cache = cache.with_context(|| {
            format!(
                "scoring {} with {}",
                scenario.root().display(),
                self.scorer.checkpoint().display()
            )
        })?;
        let seconds = started.elapsed().as_secs_f64();
        let t = cache.table();
        self.say(&format!(
            "{name}: scored {} frames, {} objects ({}) in {seconds:.1} s, {:.2} frames/s -> {}",
            t.frames.len(),
            t.objects.len(),
            boxes.label(),
            t.frames.len() as f64 / seconds.max(1e-9),
            cache.path().display()
        ));
        Ok(cache)
    }
}

/// Runs `vadscope score`.
pub fn run(args: ScoreArgs) -> anyhow::Result<ExitCode> {
    let scenarios = open_scenarios(&args.scenarios)?;
    let mut scorer = Scorer::new(&args.run, Report::Stdout)?;
    for scenario in &scenarios {
        scorer.cache_for(scenario, &args.boxes, args.force)?;
    }
    Ok(ExitCode::SUCCESS)
}
