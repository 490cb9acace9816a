//! `vadscope flow`: fills the DIS flow cache of one or more scenarios (frames without stored
//! flow, or every frame with `--every-frame`) and, with `--evaluate`, scores the cached flow
//! against the scenario's stored ground truth.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use vadscope::flow::DisPreset;
use vadscope::flow::cache::{CacheReport, CacheScope, FlowCacheOptions, fill_flow_cache};
use vadscope::flow::evaluate::{FlowEvaluation, evaluate_cached_flow};
use vadscope::sequence::{Scenario, discover_scenarios};

/// Options of `vadscope flow`.
#[derive(Debug, Args)]
pub struct FlowArgs {
    /// Scenario folders or data-set roots holding `Scenario_*` folders.
    #[arg(required = true)]
    scenarios: Vec<PathBuf>,
    /// DIS preset: `ultrafast`, `fast`, `medium` (OpenCV's parameters) or `quality`
    /// (medium at full resolution). Each preset has its own cache folder.
    #[arg(long, default_value = "medium")]
    preset: DisPreset,
    /// Worker threads (0: one per core). Results do not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Compute every frame, also those whose flow the scenario stores (implied by
    /// `--evaluate`).
    #[arg(long)]
    every_frame: bool,
    /// Compare the cached flow with the scenario's stored flow and print the end-point
    /// error: over all pixels, over valid pixels, and inside vehicle boxes after the 32×32
    /// crop-and-resize HF²-VAD applies.
    #[arg(long)]
    evaluate: bool,
    /// Print the evaluation as JSON (one object per scenario) instead of text.
    #[arg(long, requires = "evaluate")]
    json: bool,
}

/// Runs `vadscope flow`.
pub fn run(args: FlowArgs) -> anyhow::Result<ExitCode> {
    let mut folders = Vec::new();
    for path in &args.scenarios {
        let found = discover_scenarios(path)
            .with_context(|| format!("cannot find scenarios in {}", path.display()))?;
        if found.is_empty() {
            bail!("{} holds no scenario", path.display());
        }
        folders.extend(found);
    }
    let options = FlowCacheOptions {
        preset: args.preset,
        threads: args.threads,
        scope: if args.every_frame || args.evaluate {
            CacheScope::EveryFrame
        } else {
            CacheScope::MissingOnly
        },
    };
    let mut evaluations = Vec::new();
    for folder in &folders {
        let scenario = Scenario::open(folder)
            .with_context(|| format!("cannot open scenario {}", folder.display()))?;
        let started = Instant::now();
        let report = fill_with_progress(&scenario, &options)?;
        let seconds = started.elapsed().as_secs_f64();
        eprintln!("{}", report_line(&scenario, &report, seconds));
        if args.evaluate {
            let evaluation = evaluate_cached_flow(&scenario, args.preset)
                .with_context(|| format!("cannot evaluate the flow of {}", folder.display()))?;
            if !args.json {
                println!("{}", evaluation.summary());
            }
            evaluations.push(evaluation);
        }
    }
    if args.evaluate {
        if args.json {
            println!("{}", serde_json::to_string_pretty(&evaluations)?);
        } else if evaluations.len() > 1 {
            println!("{}", overall_summary(&evaluations));
        }
        if evaluations.iter().all(|e| e.frames.is_empty()) {
            eprintln!("no scenario stores ground-truth flow: nothing to compare against");
            return Ok(ExitCode::FAILURE);
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn fill_with_progress(
    scenario: &Scenario,
    options: &FlowCacheOptions,
) -> anyhow::Result<CacheReport> {
    let bar = ProgressBar::new(0).with_style(
        ProgressStyle::with_template(
            "{prefix:>24} [{bar:40}] {pos}/{len} frames ({per_sec}, eta {eta})",
        )
        .expect("static progress template")
        .progress_chars("=> "),
    );
    bar.set_prefix(format!("flow {}", options.preset));
    let report = fill_flow_cache(scenario, options, |p| {
        bar.set_length(p.total as u64);
        bar.set_position(p.done as u64);
    })
    .with_context(|| format!("cannot compute the flow of {}", scenario.root().display()))?;
    bar.finish_and_clear();
    Ok(report)
}

fn report_line(scenario: &Scenario, report: &CacheReport, seconds: f64) -> String {
    let rate = if report.computed > 0 {
        format!(
            ", {:.1} frames/s",
            report.computed as f64 / seconds.max(1e-9)
        )
    } else {
        String::new()
    };
    format!(
        "{}: {} computed, {} already cached, {} stored in the scenario, in {:.1} s{rate} -> {}",
        scenario.name(),
        report.computed,
        report.already_cached,
        report.stored_in_scenario,
        seconds,
        report.folder.display()
    )
}

/// Frame-weighted means over all evaluated scenarios.
fn overall_summary(evaluations: &[FlowEvaluation]) -> String {
    let frames: Vec<_> = evaluations.iter().flat_map(|e| &e.frames).collect();
    let mean = |values: Vec<f64>| {
        if values.is_empty() {
            "–".to_string()
        } else {
            format!("{:.3}", values.iter().sum::<f64>() / values.len() as f64)
        }
    };
    let all = mean(frames.iter().map(|f| f.epe_all).collect());
    let valid = mean(frames.iter().filter_map(|f| f.epe_valid).collect());
    let boxes: Vec<f64> = frames
        .iter()
        .flat_map(|f| f.vehicle_boxes.iter().copied())
        .collect();
    let box_count = boxes.len();
    format!(
        "all {} scenarios: {} frames, EPE all {all} px, valid {valid} px, vehicle 32×32 {} px ({box_count} boxes)",
        evaluations.len(),
        frames.len(),
        mean(boxes)
    )
}
