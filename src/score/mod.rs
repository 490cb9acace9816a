//! Scores: per-object errors from the model, a persistent score cache, and fusion of the
//! cached errors into frame scores, pixel heatmaps and metrics for any weights.
//!
//! The split that makes the viewer interactive: the model runs once per scenario, model,
//! box source and flow source ([`run`]) and its outputs are stored ([`cache`]); every
//! change of weights only re-runs [`fusion`], which is pure and cheap.
//!
//! Entry points:
//! - [`BoxSource`] / [`BoxProvider`]: ground truth, the scenario's detections, imported
//!   detection files (read by `sequence::detections`: MOT, COCO, YOLO, `boxes.csv`) and the detector-free
//!   motion boxes ([`motion`]); [`match_boxes`] / [`BoxMatchStats`] / [`match_scenario`] for
//!   box IoU and recall against the ground truth.
//! - [`FlowSource`] / [`FlowProvider`] (from [`crate::flow`]): stored flows, or DIS estimates.
//! - [`score_scenario`]: the scoring run (cubes by `model::stc`, progress callback,
//!   cancellation flag) writing a [`ScoreCache`] at [`CacheKey::path_in`];
//!   [`score_scenario_with`] / [`run_scoring`] take any cube source and model.
//! - [`ScoreCache::open`] / [`ScoreCache::lookup`] / [`ScoreCache::find`]: the cache;
//!   [`ScoreTable`] is its scalar part, [`ScoreCache::frame_maps`] reads one frame's maps.
//! - [`fusion::frame_scores`], [`fusion::metric_frames`], [`fusion::compose_heatmap`] with
//!   [`FusionWeights`] (presets [`FusionWeights::PRESETS`]) and [`PixelReferenceMode`].
//! - [`ScenarioScores::from_cache`] + [`evaluate_dataset`] / [`evaluate_table`]: the
//!   table by box source and domain × weather (AUROC micro and macro, AP, FPR95, pixel
//!   metrics, box IoU and recall); [`sweep_weights`] over [`sweep_grid`]: the weight study;
//!   [`PixelRoc`] + [`add_scenario_pixels`] for pixel-level metrics; [`table`] renders the
//!   rows as text, Markdown or CSV.
//! - [`Baseline`] + [`baseline_frame_scores`]: trivial frame scores (flow energy, looming,
//!   frame difference, the ego's deceleration) on the scored boxes, evaluated beside the
//!   model by [`evaluate_series`].
//! - [`ValidationSet`]: validation scenarios with anomalies, cut once, whose frame AUROC
//!   judges a model in training (`vadscope train --select-on`; [`score_table`] scores in
//!   memory).

pub mod baselines;
pub mod boxes;
pub mod cache;
mod error;
pub mod evaluate;
pub mod fusion;
pub mod motion;
pub mod objects;
pub mod pixel_roc;
pub mod run;
mod scorer;
pub mod series;
pub mod table;
pub mod validation;

pub use crate::flow::{FlowProvider, FlowSource};
pub use crate::sequence::detections::{DetectionFile, DetectionFormat, FrameNumbering};
pub use baselines::{Baseline, baseline_frame_scores};
pub use boxes::{
    BoxMatch, BoxMatchStats, BoxProvider, BoxSource, box_iou, match_boxes, match_scenario,
};
pub use cache::{
    CacheKey, CacheLookup, CacheWriter, FrameEntry, FrameState, ModelKey, ObjectMaps, ObjectScore,
    PixelReference, ScoreCache, ScoreMeta, ScoreTable, write_cache,
};
pub use error::ScoreError;
pub use evaluate::{
    EvalRow, FrameSeries, Grouping, SWEEP_VALUES, ScenarioScores, SweepRow, TopObjectHits,
    evaluate_dataset, evaluate_series, evaluate_table, sweep_grid, sweep_weights, top_object_hits,
};
pub use fusion::{
    FrameFusion, FrameMetricOptions, FusionWeights, Heatmap, HeatmapScratch, PixelReferenceMode,
    compose_heatmap, frame_scores, frame_scores_into, metric_frames,
};
pub use motion::MotionParams;
pub use objects::{ObjectRow, object_rows, write_object_csv};
pub use pixel_roc::{PixelRoc, add_scenario_pixels, add_scenario_pixels_each};
pub use run::{
    CubeScorer, CubeSource, FrameBoxes, ScenarioCubes, ScoreProgress, ScoreRequest, ScoringPlan,
    run_scoring, score_scenario, score_scenario_with, score_table,
};
pub use scorer::Scorer;
pub use series::{FusionParams, REFERENCE_THRESHOLD_SIGMA, ScoreSeries, reference_threshold};
pub use table::{TableFormat, format_eval_table, render_eval_table, render_sweep_table};
pub use validation::ValidationSet;
