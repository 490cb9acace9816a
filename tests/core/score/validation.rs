//! The validation judge of model selection: its in-memory frame AUROC is the one
//! `vadscope eval` reports for the same model on the same scenarios, and scenarios without
//! anomalies are refused.

use std::sync::atomic::AtomicBool;

use vadscope::model::Detector;
use vadscope::score::{
    BoxSource, FlowSource, FrameMetricOptions, FusionWeights, Grouping, ModelKey, ScenarioScores,
    ScoreRequest, ValidationSet, evaluate_table, score_scenario,
};
use vadscope::sequence::{Scenario, discover_scenarios};

use crate::support::app::{generate_dataset, tiny_checkpoint};

#[test]
fn validation_auroc_is_the_evaluation_of_the_scored_scenarios() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = generate_dataset(dir.path());
    let checkpoint = tiny_checkpoint(dir.path());
    let detector = Detector::from_checkpoint(&checkpoint).expect("model");
    let folders = discover_scenarios(&root).expect("scenarios");
    let mut loaded = 0;
    let set = ValidationSet::load(
        &folders,
        detector.config(),
        FlowSource::Stored,
        &mut |d, _| loaded = d,
    )
    .expect("validation set");
    assert_eq!((set.len(), loaded), (2, 2));
    assert!(set.cubes() > 0);
    let judged = set.frame_auroc(&detector).expect("judged");

    // The same model scored to caches and evaluated as `vadscope eval` does.
    let request = ScoreRequest::new(BoxSource::GroundTruth, FlowSource::Stored);
    let key = ModelKey::of_checkpoint(&checkpoint).expect("key");
    let cancel = AtomicBool::new(false);
    let items: Vec<ScenarioScores> = folders
        .iter()
        .map(|folder| {
            let scenario = Scenario::open(folder).expect("scenario");
            let cache = score_scenario(&scenario, &detector, key, &request, &mut |_| {}, &cancel)
                .expect("scored");
            ScenarioScores::from_table(&scenario, "ground truth", cache.into_table(), None)
                .expect("scores")
        })
        .collect();
    let rows = evaluate_table(
        &items,
        None,
        &FusionWeights::default(),
        &FrameMetricOptions::default(),
        Grouping::NONE,
    )
    .expect("table");
    let evaluated = rows[0].metrics.as_ref().expect("both classes").auroc;
    assert!(
        (judged - evaluated).abs() <= 1e-12,
        "judged {judged}, evaluated {evaluated}"
    );
}

#[test]
fn validation_scenarios_without_anomalies_are_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = generate_dataset(dir.path());
    let checkpoint = tiny_checkpoint(dir.path());
    let detector = Detector::from_checkpoint(&checkpoint).expect("model");
    let normal: Vec<_> = discover_scenarios(&root)
        .expect("scenarios")
        .into_iter()
        .filter(|f| f.to_string_lossy().contains("highway"))
        .collect();
    assert_eq!(normal.len(), 1);
    let err = ValidationSet::load(
        &normal,
        detector.config(),
        FlowSource::Stored,
        &mut |_, _| {},
    )
    .err()
    .expect("refused");
    assert!(err.to_string().contains("0 anomalous"), "{err}");
}
