//! `vadscope eval`: scores whatever is not cached yet (as `vadscope score` does), then
//! prints the paper's Table 2 (rows per box source and per condition: frame AUROC micro and
//! macro, AUPR, FPR95, pixel metrics with `--pixel`, box IoU against the ground truth) and,
//! with `--sweep`, Table 3 (the weight study), as Markdown, text, CSV or JSON.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use rayon::prelude::*;
use serde::Serialize;
use vadscope::score::{
    Baseline, BoxSource, EvalRow, FlowProvider, FlowSource, FrameMetricOptions, FrameSeries,
    FusionWeights, Grouping, PixelReferenceMode, PixelRoc, ScenarioScores, ScoreCache, SweepRow,
    TableFormat, TopObjectHits, add_scenario_pixels_each, baseline_frame_scores, evaluate_series,
    evaluate_table, object_rows, render_eval_table, render_sweep_table, sweep_grid, sweep_weights,
    top_object_hits, write_object_csv,
};
use vadscope::sequence::Scenario;

use super::score::{Report, RunArgs, Scorer, open_scenarios, parse_box_source};
use super::score_cache::{PresetArg, parse_weights};

/// Options of `vadscope eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// A data-set root holding `Scenario_*` folders (or a single scenario folder).
    #[arg(value_name = "DATASET")]
    dataset: PathBuf,
    #[command(flatten)]
    run: RunArgs,
    /// Box sources to evaluate, comma-separated, each as `vadscope score --boxes` takes it
    /// (e.g. `gt,motion`).
    #[arg(long, default_value = "gt", value_name = "gt,motion,...", value_delimiter = ',', value_parser = parse_box_source)]
    boxes: Vec<BoxSource>,
    /// Fusion weights w_r,w_p,w_r_p,w_p_p (frame level, then pixel level). Default: the
    /// HF²-VAD_AD paper text, 10,0.1,10,0.1.
    #[arg(long, value_name = "wr,wp,wrp,wpp", value_parser = parse_weights, conflicts_with = "preset")]
    weights: Option<FusionWeights>,
    /// A weight preset: `paper-text` (10 / 0.1), `ad-code` or `paper-code` (the AD code's
    /// 0.1 / 10), `original` (HF²-VAD's 1 / 0.1).
    #[arg(long, value_enum)]
    preset: Option<PresetArg>,
    /// Median-filter kernel over each scenario's frame scores (0 or 1: no filter).
    #[arg(long, default_value_t = 17, value_name = "K")]
    median: usize,
    /// Conditions that get rows of their own, comma-separated: `domain`, `weather`, both
    /// (one row per domain × weather), or `none` (only the row over all scenarios).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "domain,weather"
    )]
    by: Vec<ByKey>,
    /// Also print the weight study (Table 3): one row per (w_r, w_p) of the grid
    /// {0.1, 1, 10}², the pixel weights equal to the frame weights.
    #[arg(long)]
    sweep: bool,
    /// Also compute pixel-level metrics (AUROC, AUPR, FPR95) of the full-resolution heatmaps
    /// against the anomaly masks (SEMANTIC_IMG).
    #[arg(long)]
    pixel: bool,
    /// Statistics that robust-scale the pixel error maps: the model's training cubes, the
    /// scored scenario, or the reference code's per-batch statistics.
    #[arg(long, value_enum, default_value = "training")]
    pixel_reference: PixelReferenceArg,
    /// Also evaluate trivial baselines on the same scored boxes and protocol (flow energy,
    /// looming, frame difference; the ego's deceleration where ACTION data exists) and say
    /// by how much the model beats the best image-only one.
    #[arg(long)]
    baselines: bool,
    /// Also write every scored object to this CSV file (scenario, frame, box, S_r, S_p,
    /// fused score, whether it sets its frame's score and whether it is the anomalous
    /// object): which object a model flags, frame by frame.
    #[arg(long, value_name = "FILE")]
    objects: Option<PathBuf>,
    /// IoU at which a scored box counts as finding a ground-truth box.
    #[arg(long, default_value_t = 0.5, value_name = "IOU")]
    iou: f32,
    /// Output format.
    #[arg(long, value_enum, default_value = "md")]
    format: FormatArg,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ByKey {
    Domain,
    Weather,
    None,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum PixelReferenceArg {
    Training,
    Scenario,
    Reference,
}

impl PixelReferenceArg {
    fn mode(self) -> PixelReferenceMode {
        match self {
            Self::Training => PixelReferenceMode::Training,
            Self::Scenario => PixelReferenceMode::Scenario,
            Self::Reference => PixelReferenceMode::ReferenceBatches,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum FormatArg {
    Md,
    Text,
    Csv,
    Json,
}

/// What `--format json` prints.
#[derive(Serialize)]
struct JsonReport<'a> {
    weights: FusionWeights,
    median_kernel: usize,
    grouping: Grouping,
    table2: &'a [EvalRow],
    /// Per box source: anomaly frames whose top-scoring object is the anomalous one.
    top_object: &'a [(String, TopObjectHits)],
    #[serde(skip_serializing_if = "Option::is_none")]
    table3: Option<&'a [SweepRow]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    baselines: Option<&'a [EvalRow]>,
}

/// The row label of `baseline` scored on the boxes of `box_source` (a box source label).
fn baseline_label(baseline: Baseline, box_source: &str) -> String {
    format!("baseline: {} ({box_source})", baseline.name())
}

/// The baseline rows over the scored scenarios: `items[k]` holds the scores of
/// `scored[k]`. Rows come baseline by baseline, each with its box sources in order.
fn baseline_rows(
    items: &[ScenarioScores],
    scored: &[Scored],
    flow: FlowSource,
    options: &FrameMetricOptions,
    grouping: Grouping,
) -> anyhow::Result<Vec<EvalRow>> {
    let series: Vec<Vec<(usize, FrameSeries)>> = items
        .par_iter()
        .zip(scored)
        .map(|(item, s)| {
            let mut flows = FlowProvider::new(s.scenario, flow);
            let mut out = Vec::new();
            for (b, baseline) in Baseline::ALL.into_iter().enumerate() {
                let raw = baseline_frame_scores(baseline, s.scenario, &item.table, &mut flows)
                    .with_context(|| {
                        format!(
                            "baseline {} of {}",
                            baseline.name(),
                            s.scenario.root().display()
                        )
                    })?;
                if let Some(raw) = raw {
                    out.push((
                        b,
                        FrameSeries {
                            name: item.name.clone(),
                            domain: item.domain,
                            weather: item.weather,
                            source: baseline_label(baseline, &item.box_source),
                            labels: item.labels.clone(),
                            raw,
                            skip_first: item.table.meta.clip_hist as usize,
                        },
                    ));
                }
            }
            s.scenario.release_decoded();
            Ok(out)
        })
        .collect::<anyhow::Result<_>>()?;
    // Stable: within a baseline, box sources and scenarios keep their order.
    let mut tagged: Vec<(usize, FrameSeries)> = series.into_iter().flatten().collect();
    tagged.sort_by_key(|(b, _)| *b);
    let flat: Vec<FrameSeries> = tagged.into_iter().map(|(_, s)| s).collect();
    Ok(evaluate_series(&flat, options, grouping)?)
}

/// One line per model row over all scenarios: its AUROC against the best image-only
/// baseline's on the same box source, in points.
fn margin_lines(rows: &[EvalRow], baselines: &[EvalRow]) -> Vec<String> {
    let auroc = |r: &EvalRow| r.metrics.as_ref().map(|m| m.auroc);
    rows.iter()
        .filter(|r| r.domain.is_none() && r.weather.is_none())
        .filter_map(|r| {
            let model = auroc(r)?;
            let best = baselines
                .iter()
                .filter(|b| b.domain.is_none() && b.weather.is_none())
                .filter(|b| {
                    Baseline::ALL
                        .into_iter()
                        .filter(|x| !x.uses_ego_data())
                        .any(|x| b.box_source == baseline_label(x, &r.box_source))
                })
                .filter_map(|b| Some((auroc(b)?, b.box_source.as_str())))
                .max_by(|a, b| a.0.total_cmp(&b.0))?;
            Some(format!(
                "{}: model frame AUROC {:.1} %, best image-only baseline {:.1} % ({}): {:+.1} points",
                r.box_source,
                100.0 * model,
                100.0 * best.0,
                best.1,
                100.0 * (model - best.0)
            ))
        })
        .collect()
}

/// One scored scenario for one box source.
struct Scored<'a> {
    scenario: &'a Scenario,
    cache: ScoreCache,
}

/// Pixel accumulators per weights point of `weights` (outer) and scored scenario (inner).
/// Point 0 (the table's weights) keeps one accumulator per scenario, which the table groups
/// by condition. The other points (the weight study, whose rows span every scenario of a box
/// source) are merged as scenarios finish into the first scenario of each box source
/// (`sources[i]` names scenario `i`'s), the others left empty: merging them again gives the
/// same rows, and memory holds one histogram per source and point instead of one per
/// scenario and point (at 768×512 the latter outgrew 23 GiB on the test preset).
fn pixel_counts(
    scored: &[Scored],
    sources: &[&str],
    weights: &[FusionWeights],
    mode: PixelReferenceMode,
) -> anyhow::Result<Vec<Vec<PixelRoc>>> {
    let mut per_point: Vec<Vec<PixelRoc>> =
        vec![vec![PixelRoc::new(); scored.len()]; weights.len()];
    let first_of_source = |i: usize| sources.iter().position(|s| *s == sources[i]).unwrap_or(i);
    // Scenarios in batches of the worker count: at most one batch's histograms in flight.
    let batch = rayon::current_num_threads().max(1);
    for (b, chunk) in scored.chunks(batch).enumerate() {
        let counted: Vec<Vec<PixelRoc>> = chunk
            .par_iter()
            .map(|s| {
                let mut rocs = vec![PixelRoc::new(); weights.len()];
                let skip = s.cache.table().meta.clip_hist as usize;
                let frames =
                    add_scenario_pixels_each(&mut rocs, s.scenario, &s.cache, weights, mode, skip)
                        .with_context(|| {
                            format!("pixel metrics of {}", s.scenario.root().display())
                        })?;
                s.scenario.release_decoded();
                if frames == 0 {
                    eprintln!(
                        "{}: no anomaly masks (SEMANTIC_IMG), no pixel metrics",
                        s.scenario.name()
                    );
                }
                Ok(rocs)
            })
            .collect::<anyhow::Result<_>>()?;
        for (j, rocs) in counted.into_iter().enumerate() {
            let i = b * batch + j;
            for (k, roc) in rocs.into_iter().enumerate() {
                if k == 0 {
                    per_point[0][i] = roc;
                } else {
                    per_point[k][first_of_source(i)].merge(&roc);
                }
            }
        }
    }
    Ok(per_point)
}

/// Runs `vadscope eval`.
pub fn run(args: EvalArgs) -> anyhow::Result<ExitCode> {
    if args.by.contains(&ByKey::None) && args.by.len() > 1 {
        bail!("--by none cannot be combined with domain or weather");
    }
    if !(args.iou > 0.0 && args.iou <= 1.0) {
        bail!("--iou {} must lie in (0, 1]", args.iou);
    }
    let grouping = Grouping {
        domain: args.by.contains(&ByKey::Domain),
        weather: args.by.contains(&ByKey::Weather),
    };
    let weights = args
        .weights
        .or(args.preset.map(PresetArg::weights))
        .unwrap_or_default();
    let options = FrameMetricOptions {
        median_kernel: args.median,
        skip_first: None,
    };
    let mut sources: Vec<BoxSource> = Vec::new();
    for source in args.boxes {
        if !sources.contains(&source) {
            sources.push(source);
        }
    }

    let scenarios = open_scenarios(std::slice::from_ref(&args.dataset))?;
    let mut scorer = Scorer::new(&args.run, Report::Stderr)?;
    let mut items = Vec::new();
    let mut scored = Vec::new();
    for source in &sources {
        for scenario in &scenarios {
            let cache = scorer.cache_for(scenario, source, false)?;
            items.push(ScenarioScores::from_table(
                scenario,
                source.label(),
                cache.table().clone(),
                Some(args.iou),
            )?);
            scored.push(Scored { scenario, cache });
        }
    }

    // Pixel counts per weights point: the table's weights first, then the sweep grid.
    let grid = if args.sweep { sweep_grid() } else { Vec::new() };
    let (table_pixels, grid_pixels) = if args.pixel {
        let points: Vec<FusionWeights> = std::iter::once(weights).chain(grid.clone()).collect();
        let sources: Vec<&str> = items.iter().map(|i| i.box_source.as_str()).collect();
        let mut per_point = pixel_counts(&scored, &sources, &points, args.pixel_reference.mode())?;
        let table = per_point.remove(0);
        (Some(table), Some(per_point))
    } else {
        (None, None)
    };
    let rows = evaluate_table(
        &items,
        table_pixels.as_deref(),
        &weights,
        &options,
        grouping,
    )?;
    let sweep = if args.sweep {
        Some(sweep_weights(
            &items,
            grid_pixels.as_deref(),
            &grid,
            &options,
        )?)
    } else {
        None
    };

    let mut top_object: Vec<(String, TopObjectHits)> = Vec::new();
    for (item, s) in items.iter().zip(&scored) {
        let skip = options
            .skip_first
            .unwrap_or(item.table.meta.clip_hist as usize);
        let hits = top_object_hits(s.scenario, &item.table, &weights, skip)?;
        match top_object.iter_mut().find(|(k, _)| *k == item.box_source) {
            Some((_, total)) => total.merge(hits),
            None => top_object.push((item.box_source.clone(), hits)),
        }
    }

    if let Some(path) = &args.objects {
        let mut rows = Vec::new();
        for (item, s) in items.iter().zip(&scored) {
            rows.extend(object_rows(
                s.scenario,
                &item.box_source,
                &item.table,
                &weights,
            )?);
        }
        write_object_csv(path, &rows)?;
        eprintln!("{} scored objects -> {}", rows.len(), path.display());
    }

    let baselines = if args.baselines {
        Some(baseline_rows(
            &items,
            &scored,
            args.run.flow,
            &options,
            grouping,
        )?)
    } else {
        None
    };

    let format = match args.format {
        FormatArg::Json => {
            let report = JsonReport {
                weights,
                median_kernel: args.median,
                grouping,
                table2: &rows,
                top_object: &top_object,
                table3: sweep.as_deref(),
                baselines: baselines.as_deref(),
            };
            println!("{}", serde_json::to_string_pretty(&report)?);
            return Ok(ExitCode::SUCCESS);
        }
        FormatArg::Md => TableFormat::Markdown,
        FormatArg::Text => TableFormat::Text,
        FormatArg::Csv => TableFormat::Csv,
    };
    let heading = |title: &str| {
        if format == TableFormat::Csv {
            String::new()
        } else {
            format!("{title}\n\n")
        }
    };
    print!(
        "{}{}",
        heading(&format!(
            "Table 2: frame metrics{} by box source and condition (w_r {}, w_p {}, w_r_p {}, w_p_p {}; median filter {}; first {} frames of each scenario skipped; AUROC micro over all frames, macro = mean over scenarios; FPR95 at the first threshold reaching TPR 0.95; mIoU and recall of ground-truth boxes at IoU {})",
            if args.pixel { " and pixel metrics" } else { "" },
            weights.w_r,
            weights.w_p,
            weights.w_r_p,
            weights.w_p_p,
            args.median,
            items.first().map_or(0, |i| i.table.meta.clip_hist),
            args.iou
        )),
        render_eval_table(&rows, format)
    );
    if format != TableFormat::Csv {
        println!();
        for (source, hits) in &top_object {
            if let Some(rate) = hits.rate() {
                println!(
                    "{source}: the anomalous object scores highest in {} of {} anomaly frames with scored objects ({:.1} %)",
                    hits.hits,
                    hits.frames,
                    100.0 * rate
                );
            }
        }
    }
    if let Some(sweep) = &sweep {
        println!();
        print!(
            "{}{}",
            heading(
                "Table 3: the weight study over (w_r, w_p) in {0.1, 1, 10}², pixel weights equal to the frame weights, all scenarios of each box source"
            ),
            render_sweep_table(sweep, format)
        );
    }
    if let Some(baselines) = &baselines {
        println!();
        print!(
            "{}{}",
            heading(
                "Baselines: trivial frame scores on the same scored boxes, frames, median filter and metrics (the ego's deceleration uses ego data the method does not see)"
            ),
            render_eval_table(baselines, format)
        );
        if format != TableFormat::Csv {
            println!();
            for line in margin_lines(&rows, baselines) {
                println!("{line}");
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
