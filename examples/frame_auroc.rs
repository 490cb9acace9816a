//! Frame-level AUROC of a checkpoint on a folder of scenarios, with ground-truth boxes and
//! the scenarios' stored flow, through the library's own scoring and evaluation
//! (`score::score_scenario`, `score::evaluate_dataset`, HF²-VAD_AD paper-text weights, the
//! reference's median filter). This is how `assets/model/MODEL.md`'s AUROC is measured:
//!
//! ```sh
//! cargo run --release --example frame_auroc -- DATASET [CHECKPOINT]
//! ```
//!
//! CHECKPOINT defaults to the bundled model. Score caches are written to each scenario's
//! `.vadscope/` and reused on the next run.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use vadscope::model::{Detector, bundled_model};
use vadscope::score::{
    BoxSource, FlowSource, FrameMetricOptions, FusionWeights, ModelKey, ScenarioScores,
    ScoreRequest, evaluate_dataset, format_eval_table, score_scenario,
};
use vadscope::sequence::{Scenario, discover_scenarios};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args_os().skip(1);
    let dataset = PathBuf::from(
        args.next()
            .ok_or("usage: frame_auroc DATASET [CHECKPOINT]")?,
    );
    let checkpoint = match args.next() {
        Some(path) => PathBuf::from(path),
        None => bundled_model()?,
    };
    let detector = Detector::from_checkpoint(&checkpoint)?;
    let model = ModelKey::of_checkpoint(&checkpoint)?;
    let request = ScoreRequest::new(BoxSource::GroundTruth, FlowSource::Stored);
    let cancel = AtomicBool::new(false);
    let mut items = Vec::new();
    for folder in discover_scenarios(&dataset)? {
        let scenario = Scenario::open(&folder)?;
        let cached = ScenarioScores::from_cache(&scenario, &request, model, None)?;
        let scores = match cached {
            Some(scores) => scores,
            None => {
                let started = std::time::Instant::now();
                score_scenario(&scenario, &detector, model, &request, &mut |_| {}, &cancel)?;
                eprintln!(
                    "scored {} in {:.0} s",
                    scenario.name(),
                    started.elapsed().as_secs_f64()
                );
                ScenarioScores::from_cache(&scenario, &request, model, None)?
                    .ok_or("the score cache just written cannot be found")?
            }
        };
        items.push(scores);
    }
    let rows = evaluate_dataset(
        &items,
        &FusionWeights::PAPER_TEXT,
        &FrameMetricOptions::default(),
    )?;
    println!("model {}", checkpoint.display());
    print!("{}", format_eval_table(&rows));
    Ok(())
}
