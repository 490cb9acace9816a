//! Frame fusion and pixel heatmaps on hand-built score tables: weights and presets, empty
//! frames, metric preparation, overlapping boxes, boxes at the image border, the reference's
//! per-batch mode and grids of other sizes.

use vadscope::eval::median_filter;
use vadscope::model::{BandStats, ScoreStats, ScoreTails};
use vadscope::score::{
    FrameFusion, FusionWeights, Heatmap, HeatmapScratch, ObjectMaps, PixelReferenceMode,
    ScoreSeries, compose_heatmap, frame_scores, metric_frames,
};

use crate::support::score::{constant_maps, object, table};

const SIZE: (u32, u32) = (64, 48);

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9 * (1.0 + a.abs().max(b.abs()))
}

fn weights(w_r: f64, w_p: f64, w_r_p: f64, w_p_p: f64) -> FusionWeights {
    FusionWeights {
        w_r,
        w_p,
        w_r_p,
        w_p_p,
    }
}

#[test]
fn frame_score_is_the_max_of_weighted_z_scores_and_presets_change_the_winner() {
    // μ_r 10, σ_r 2, μ_p 1, σ_p 0.5. Object A: z_r 2, z_p 1. Object B: z_r 0, z_p 4.
    let t = table(
        &[vec![
            object([0.0, 0.0, 8.0, 8.0], 14.0, 1.5),
            object([10.0, 0.0, 18.0, 8.0], 10.0, 3.0),
        ]],
        SIZE,
        4,
        128,
    );
    let original = frame_scores(&t, &FusionWeights::ORIGINAL);
    assert!(
        close(original[0], 2.0 + 0.1),
        "A wins under 1 / 0.1: {}",
        original[0]
    );
    let code = frame_scores(&t, &FusionWeights::AD_CODE);
    assert!(
        close(code[0], 10.0 * 4.0),
        "B wins under 0.1 / 10: {}",
        code[0]
    );
    let paper = frame_scores(&t, &FusionWeights::PAPER_TEXT);
    assert!(close(paper[0], 10.0 * 2.0 + 0.1), "{}", paper[0]);
    assert_eq!(FusionWeights::default(), FusionWeights::PAPER_TEXT);
    assert_eq!(FusionWeights::PRESETS.len(), 3);
}

#[test]
fn frames_without_objects_score_a_zero_error_object() {
    let t = table(
        &[vec![], vec![object([0.0, 0.0, 8.0, 8.0], 0.0, 0.0)], vec![]],
        SIZE,
        4,
        128,
    );
    let w = weights(3.0, 0.5, 0.0, 0.0);
    let scores = frame_scores(&t, &w);
    let zero_error = 3.0 * (-10.0 / 2.0) + 0.5 * (-1.0 / 0.5);
    assert_eq!(scores.len(), 3);
    for s in scores {
        assert!(close(s, zero_error), "{s} vs {zero_error}");
    }
    let fusion = FrameFusion::of_table(&t, &w);
    assert!(close(fusion.empty_frame_score(), zero_error));
    let mut o = t.objects[0];
    (o.s_r, o.s_p) = (12.0, 1.0);
    assert!(close(fusion.object_score(&o), 3.0));
}

#[test]
fn score_bands_z_score_each_object_against_the_training_objects_of_its_band() {
    // Frames 64 px wide in 2 bands. Left band: μ_r 100, σ_r 50 (objects there err a lot in
    // normal driving); right band: too few cubes, so the global μ_r 10, σ_r 2 applies.
    let left = object([0.0, 0.0, 16.0, 8.0], 150.0, 1.0);
    let right = object([40.0, 0.0, 56.0, 8.0], 14.0, 1.0);
    let mut t = table(&[vec![left, right]], SIZE, 4, 128);
    let band = |cubes, mean, std| BandStats {
        cubes,
        flow_score: ScoreStats { mean, std },
        frame_score: ScoreStats {
            mean: 1.0,
            std: 0.5,
        },
        tails: None,
    };
    t.meta.training.bands = vec![band(500, 100.0, 50.0), band(3, 999.0, 1.0)];
    let w = weights(1.0, 0.0, 0.0, 0.0);
    let fusion = FrameFusion::of_table(&t, &w);
    let (l, r) = (&t.objects[0], &t.objects[1]);
    assert!(close(fusion.object_score(l), 1.0), "(150 − 100) / 50");
    assert!(close(fusion.object_score(r), 2.0), "(14 − 10) / 2, global");
    // The viewer's and the timeline's z-scores read the same moments.
    assert!(close(l.z_scores(&t.meta.training, SIZE.0).0, 1.0));
    assert!(close(r.z_scores(&t.meta.training, SIZE.0).0, 2.0));
    // Without bands the left object's large error sets the frame's score; with them the
    // right one does.
    assert!(close(frame_scores(&t, &w)[0], 2.0));
    t.meta.training.bands.clear();
    assert!(close(frame_scores(&t, &w)[0], 70.0), "(150 − 10) / 2");
}

#[test]
fn tail_tables_score_objects_by_the_rarity_of_their_errors_in_their_band() {
    // Left band: S_r of 1..=1000 (so 150 is at its 15th percentile); the global set, which
    // the right band (too few cubes) falls back to: S_r of 1..=20.
    let left = object([0.0, 0.0, 16.0, 8.0], 150.0, 0.0);
    let right = object([40.0, 0.0, 56.0, 8.0], 14.0, 0.0);
    let mut t = table(&[vec![left, right]], SIZE, 4, 128);
    let range = |n: usize| (1..=n).map(|v| v as f64).collect::<Vec<_>>();
    let tails = |n| ScoreTails::of(&range(n), &vec![1.0; n]).expect("tables");
    let band = |cubes: u64, tails| BandStats {
        cubes,
        flow_score: ScoreStats {
            mean: 0.0,
            std: 1.0,
        },
        frame_score: ScoreStats {
            mean: 0.0,
            std: 1.0,
        },
        tails: Some(tails),
    };
    t.meta.training.bands = vec![band(1000, tails(1000)), band(3, tails(3))];
    t.meta.training.tails = Some(tails(20));
    let w = weights(2.0, 0.0, 0.0, 0.0);
    let fusion = FrameFusion::of_table(&t, &w);
    let (l, r) = (&t.objects[0], &t.objects[1]);
    // −ln P(S ≥ s): 150 of 1..=1000 is exceeded by 85 %, 14 of 1..=20 by 30 %.
    let (expected_l, expected_r) = (-(0.85f64.ln()), -(0.3158f64.ln()));
    assert!((fusion.object_score(l) / 2.0 - expected_l).abs() < 0.01);
    assert!((fusion.object_score(r) / 2.0 - expected_r).abs() < 0.03);
    // The viewer's and the timeline's values read the same tables.
    assert!((l.z_scores(&t.meta.training, SIZE.0).0 - expected_l).abs() < 0.01);
    // The right object is the rarer, so it sets the frame's score; a frame without objects
    // scores as one object without error: 0.
    assert!(close(frame_scores(&t, &w)[0], fusion.object_score(r)));
    assert!(close(fusion.empty_frame_score(), 0.0));
    // The timeline's lanes carry the surprisals and say so.
    let series = ScoreSeries::compute(&t, &[], &w, 1);
    assert!(series.surprisals);
    assert!((series.z_r[0] - expected_r).abs() < 0.03);
    assert_eq!(t.meta.training.component_symbol(), "t");
    t.meta.training.tails = None;
    t.meta.training.bands.clear();
    assert!(!ScoreSeries::compute(&t, &[], &w, 1).surprisals);
    assert_eq!(t.meta.training.component_symbol(), "z");
}

#[test]
fn a_constant_training_score_contributes_nothing() {
    let mut t = table(
        &[vec![object([0.0, 0.0, 8.0, 8.0], 50.0, 2.0)]],
        SIZE,
        4,
        128,
    );
    t.meta.training.flow_score.std = 0.0;
    let scores = frame_scores(&t, &weights(1.0, 1.0, 0.0, 0.0));
    assert!(
        close(scores[0], 2.0),
        "only z_p = (2 − 1) / 0.5 counts: {}",
        scores[0]
    );
}

#[test]
fn metric_frames_drop_the_history_then_median_filter() {
    let raw: Vec<f64> = (0..12).map(|i| ((i * 7) % 5) as f64).collect();
    let labels: Vec<bool> = (0..12).map(|i| i >= 8).collect();
    let (scores, kept) = metric_frames(&raw, &labels, 4, 3).expect("same lengths");
    assert_eq!(scores, median_filter(&raw[4..], 3));
    assert_eq!(kept, labels[4..].to_vec());
    let (unfiltered, _) = metric_frames(&raw, &labels, 0, 0).expect("same lengths");
    assert_eq!(unfiltered, raw);
    let (short, _) = metric_frames(&raw[..2], &labels[..2], 4, 17).expect("same lengths");
    assert!(short.is_empty());
    assert!(metric_frames(&raw, &labels[..3], 4, 17).is_err());
}

fn compose(
    t: &vadscope::score::ScoreTable,
    frame: usize,
    maps: &[ObjectMaps],
    w: &FusionWeights,
    mode: PixelReferenceMode,
    grid: (u32, u32),
) -> Heatmap {
    let mut out = Heatmap::new(grid.0, grid.1);
    compose_heatmap(
        t,
        frame,
        maps,
        w,
        mode,
        &mut out,
        &mut HeatmapScratch::default(),
    )
    .expect("compose");
    out
}

#[test]
fn one_box_gets_its_scaled_map_and_the_rest_stays_zero() {
    // Box columns ⌈10.5⌉ = 11 … 29, rows 5 … 24.
    let t = table(
        &[vec![object([10.5, 5.0, 30.0, 25.0], 0.0, 0.0)]],
        SIZE,
        4,
        128,
    );
    let w = weights(0.0, 0.0, 2.0, 3.0);
    // Training reference: flow median 1, IQR 2; frame median 0.1, IQR 0.5.
    let h = compose(
        &t,
        0,
        &[constant_maps(5.0, 0.6)],
        &w,
        PixelReferenceMode::Training,
        SIZE,
    );
    let inside = 2.0 * (5.0 - 1.0) / 2.0 + 3.0 * (0.6 - 0.1) / 0.5;
    assert!(
        (h.at(11, 5) - inside as f32).abs() < 1e-5,
        "{}",
        h.at(11, 5)
    );
    assert!((h.at(29, 24) - inside as f32).abs() < 1e-5);
    for (x, y) in [(10, 5), (30, 5), (11, 4), (11, 25), (0, 0), (63, 47)] {
        assert_eq!(h.at(x, y), 0.0, "({x}, {y}) is outside the box");
    }
    let covered = h.values.iter().filter(|&&v| v != 0.0).count();
    assert_eq!(covered, 19 * 20);
}

#[test]
fn overlapping_boxes_take_the_maximum_even_below_zero() {
    let t = table(
        &[vec![
            object([0.0, 0.0, 20.0, 20.0], 0.0, 0.0),
            object([10.0, 10.0, 30.0, 30.0], 0.0, 0.0),
        ]],
        SIZE,
        4,
        128,
    );
    let w = weights(0.0, 0.0, 1.0, 0.0);
    // Scaled flow errors: (0 − 1)/2 = −0.5 for the first box, (−3 − 1)/2 = −2 for the second.
    let maps = [constant_maps(0.0, 0.0), constant_maps(-3.0, 0.0)];
    let h = compose(&t, 0, &maps, &w, PixelReferenceMode::Training, SIZE);
    assert_eq!(h.at(5, 5), -0.5);
    assert_eq!(h.at(15, 15), -0.5, "overlap: max(−0.5, −2)");
    assert_eq!(
        h.at(25, 25),
        -2.0,
        "a negative score inside a box is kept, not clamped to 0"
    );
    assert_eq!(h.at(40, 40), 0.0);
}

#[test]
fn boxes_at_and_beyond_the_border_are_clipped() {
    let t = table(
        &[vec![
            object([-10.0, -5.0, 6.0, 4.0], 0.0, 0.0),
            object([60.0, 40.0, 90.0, 70.0], 0.0, 0.0),
            object([100.0, 0.0, 120.0, 10.0], 0.0, 0.0),
        ]],
        SIZE,
        4,
        128,
    );
    let w = weights(0.0, 0.0, 1.0, 0.0);
    let maps = [
        constant_maps(3.0, 0.0),
        constant_maps(5.0, 0.0),
        constant_maps(7.0, 0.0),
    ];
    let h = compose(&t, 0, &maps, &w, PixelReferenceMode::Training, SIZE);
    assert_eq!(h.at(0, 0), 1.0);
    assert_eq!(h.at(5, 3), 1.0);
    assert_eq!(h.at(6, 3), 0.0);
    assert_eq!(h.at(63, 47), 2.0);
    assert_eq!(h.at(60, 40), 2.0);
    let covered = h.values.iter().filter(|&&v| v != 0.0).count();
    assert_eq!(
        covered,
        6 * 4 + 4 * 8,
        "the box outside the image paints nothing"
    );
}

#[test]
fn maps_are_resized_bilinearly_into_the_box() {
    let t = table(
        &[vec![object([0.0, 0.0, 16.0, 8.0], 0.0, 0.0)]],
        SIZE,
        4,
        128,
    );
    let w = weights(0.0, 0.0, 1.0, 0.0);
    // Flow error = 1 + 2·column, so scaled values are the column index (median 1, IQR 2).
    let mut maps = constant_maps(0.0, 0.0);
    for (i, v) in maps.flow_error.iter_mut().enumerate() {
        *v = 1.0 + 2.0 * (i % 8) as f32;
    }
    let h = compose(&t, 0, &[maps], &w, PixelReferenceMode::Training, SIZE);
    // 8 → 16 columns: destination x samples source (x + 0.5)/2 − 0.5, clamped at the ends.
    let expected = [
        0.0, 0.25, 0.75, 1.25, 1.75, 2.25, 2.75, 3.25, 3.75, 4.25, 4.75, 5.25, 5.75, 6.25, 6.75,
        7.0,
    ];
    for (x, e) in expected.iter().enumerate() {
        assert!(
            (h.at(x as u32, 3) - e).abs() < 1e-5,
            "column {x}: {} vs {e}",
            h.at(x as u32, 3)
        );
    }
}

#[test]
fn scenario_reference_uses_the_scenarios_statistics() {
    let t = table(
        &[vec![object([0.0, 0.0, 8.0, 8.0], 0.0, 0.0)]],
        SIZE,
        4,
        128,
    );
    let w = weights(0.0, 0.0, 1.0, 0.0);
    // Scenario flow reference: median 2, IQR 4.
    let h = compose(
        &t,
        0,
        &[constant_maps(10.0, 0.0)],
        &w,
        PixelReferenceMode::Scenario,
        SIZE,
    );
    assert_eq!(h.at(3, 3), 2.0);
}

#[test]
fn reference_mode_uses_batch_statistics_and_the_last_objects_map_everywhere() {
    // Batches of 2 objects: frame 0 holds objects 0, 1 (batch 0); frame 1 objects 2, 3
    // (batch 1: flow median 1, IQR 2).
    let t = table(
        &[
            vec![
                object([0.0, 0.0, 8.0, 8.0], 0.0, 0.0),
                object([20.0, 0.0, 28.0, 8.0], 0.0, 0.0),
            ],
            vec![
                object([0.0, 0.0, 8.0, 8.0], 0.0, 0.0),
                object([4.0, 4.0, 12.0, 12.0], 0.0, 0.0),
            ],
        ],
        SIZE,
        4,
        2,
    );
    let w = weights(0.0, 0.0, 1.0, 0.0);
    let maps = [constant_maps(100.0, 0.0), constant_maps(5.0, 0.0)];
    let h = compose(&t, 1, &maps, &w, PixelReferenceMode::ReferenceBatches, SIZE);
    assert_eq!(
        h.at(1, 1),
        2.0,
        "first box shows the last object's map, (5 − 1)/2"
    );
    assert_eq!(h.at(10, 10), 2.0);
    let own = compose(&t, 1, &maps, &w, PixelReferenceMode::Training, SIZE);
    assert_eq!(own.at(1, 1), 49.5, "vadscope gives each box its own map");
    // Frame 0, batch 0: flow median 0, IQR 2.
    let h0 = compose(&t, 0, &maps, &w, PixelReferenceMode::ReferenceBatches, SIZE);
    assert_eq!(h0.at(21, 1), 2.5);
    assert_eq!(h0.at(1, 1), 2.5);
}

#[test]
fn smaller_grids_scale_the_boxes() {
    let t = table(
        &[vec![object([8.0, 8.0, 24.0, 24.0], 0.0, 0.0)]],
        SIZE,
        4,
        128,
    );
    let w = weights(0.0, 0.0, 1.0, 0.0);
    let h = compose(
        &t,
        0,
        &[constant_maps(3.0, 0.0)],
        &w,
        PixelReferenceMode::Training,
        (16, 12),
    );
    assert_eq!((h.width, h.height, h.values.len()), (16, 12, 192));
    let covered: Vec<(u32, u32)> = (0..12)
        .flat_map(|y| (0..16).map(move |x| (x, y)))
        .filter(|&(x, y)| h.at(x, y) != 0.0)
        .collect();
    assert_eq!(covered.len(), 16, "the box becomes columns 2..6, rows 2..6");
    assert!(
        covered
            .iter()
            .all(|&(x, y)| (2..6).contains(&x) && (2..6).contains(&y))
    );
}

#[test]
fn map_count_and_size_mismatches_are_errors() {
    let t = table(
        &[vec![object([0.0, 0.0, 8.0, 8.0], 0.0, 0.0)]],
        SIZE,
        4,
        128,
    );
    let mut out = Heatmap::new(SIZE.0, SIZE.1);
    let w = FusionWeights::default();
    let mut scratch = HeatmapScratch::default();
    assert!(
        compose_heatmap(
            &t,
            0,
            &[],
            &w,
            PixelReferenceMode::Training,
            &mut out,
            &mut scratch
        )
        .is_err()
    );
    let mut small = constant_maps(0.0, 0.0);
    small.flow_error.truncate(10);
    assert!(
        compose_heatmap(
            &t,
            0,
            &[small],
            &w,
            PixelReferenceMode::Training,
            &mut out,
            &mut scratch
        )
        .is_err()
    );
    // A frame outside the table has no objects: an empty map, no error.
    compose_heatmap(
        &t,
        9,
        &[],
        &w,
        PixelReferenceMode::Training,
        &mut out,
        &mut scratch,
    )
    .expect("empty");
    assert!(out.values.iter().all(|&v| v == 0.0));
}
