//! The metrics fixture computed with scikit-learn, SciPy and NumPy
//! (`shared/parity/metrics.json`) is reproduced to 1e-9.

use std::path::PathBuf;

use serde_json::Value;
use vadscope::eval::{MeanStd, RobustStats, RocCurve, ScoreMetrics, macro_auroc, median_filter};

const TOL: f64 = 1e-9;

fn fixture() -> Option<Value> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/parity/metrics.json");
    if !path.exists() {
        eprintln!(
            "SKIPPED: {} not found (shared/ is not beside this checkout)",
            path.display()
        );
        return None;
    }
    Some(serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap())
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .flat_map(|x| match x {
            Value::Array(_) => floats(x),
            _ => vec![x.as_f64().unwrap()],
        })
        .collect()
}

fn flags(v: &Value) -> Vec<bool> {
    floats(v).into_iter().map(|x| x != 0.0).collect()
}

fn close(name: &str, got: f64, want: f64) {
    assert!(
        (got - want).abs() <= TOL,
        "{name}: got {got}, want {want} (diff {})",
        (got - want).abs()
    );
}

/// [`close`] for each `(name, got, field)`, against the number `want[field]`; the message
/// names it `{prefix}{name}`.
fn close_fields(prefix: &str, want: &Value, checks: &[(&str, f64, &str)]) {
    for &(name, got, field) in checks {
        close(
            &format!("{prefix}{name}"),
            got,
            want[field].as_f64().unwrap(),
        );
    }
}

fn check_metrics(name: &str, scores: &[f64], labels: &[bool], want: &Value) {
    let curve = RocCurve::compute(scores, labels).unwrap();
    let m = curve.metrics();
    close_fields(
        &format!("{name} "),
        want,
        &[
            ("auroc", m.auroc, "auroc"),
            ("AP", m.average_precision, "average_precision"),
        ],
    );
    for (key, c) in [
        ("roc_full", curve.clone()),
        ("roc_default", curve.without_intermediate()),
    ] {
        let roc = &want[key];
        assert_eq!(
            c.points.len() as u64,
            roc["n_roc_points"].as_u64().unwrap(),
            "{name} {key} point count"
        );
        let first = c.first_reaching_tpr(0.95);
        let closest = c.closest_to_tpr(0.95);
        close_fields(
            &format!("{name} {key} "),
            roc,
            &[
                ("fpr95", c.fpr(first), "fpr_at_first_tpr_ge_095"),
                ("tpr@first", c.tpr(first), "tpr_at_first"),
                ("thr@first", c.points[first].threshold, "threshold_at_first"),
                ("fpr95 closest", c.fpr(closest), "fpr_at_tpr_closest_095"),
                ("tpr@closest", c.tpr(closest), "tpr_at_closest"),
            ],
        );
    }
    close(
        &format!("{name} metrics.fpr95"),
        m.fpr95,
        want["roc_full"]["fpr_at_first_tpr_ge_095"]
            .as_f64()
            .unwrap(),
    );
}

#[test]
fn frame_level_metrics_match_sklearn() {
    let Some(fx) = fixture() else { return };
    let videos = fx["frame_level"]["videos"].as_array().unwrap();
    let (mut all_scores, mut all_filtered, mut all_labels) = (vec![], vec![], vec![]);
    let mut per_video = vec![];
    for v in videos {
        let scores = floats(&v["scores"]);
        let labels = flags(&v["labels"]);
        let filtered = median_filter(&scores, 17);
        let want = floats(&v["scores_medfilt17"]);
        assert_eq!(filtered.len(), want.len());
        for (i, (g, w)) in filtered.iter().zip(&want).enumerate() {
            close(&format!("medfilt[{i}]"), *g, *w);
        }
        all_scores.extend_from_slice(&scores);
        all_filtered.extend_from_slice(&filtered);
        all_labels.extend_from_slice(&labels);
        per_video.push((scores, filtered, labels));
    }
    let fl = &fx["frame_level"];
    check_metrics("raw", &all_scores, &all_labels, &fl["metrics_on_scores"]);
    check_metrics(
        "medfilt",
        &all_filtered,
        &all_labels,
        &fl["metrics_on_scores_medfilt17"],
    );

    for (key, pick) in [
        ("metrics_on_scores", 0usize),
        ("metrics_on_scores_medfilt17", 1),
    ] {
        let want = &fl[key];
        let groups: Vec<(&[f64], &[bool])> = per_video
            .iter()
            .map(|(s, f, l)| {
                (
                    if pick == 0 {
                        s.as_slice()
                    } else {
                        f.as_slice()
                    },
                    l.as_slice(),
                )
            })
            .collect();
        for ((scores, labels), w) in groups
            .iter()
            .zip(want["auroc_per_video"].as_array().unwrap())
        {
            match w.as_f64() {
                Some(w) => close(
                    "per-video auroc",
                    RocCurve::compute(scores, labels).unwrap().auroc(),
                    w,
                ),
                None => assert!(
                    RocCurve::compute(scores, labels).is_err(),
                    "single-class video must not score"
                ),
            }
        }
        let (mean, used) = macro_auroc(groups).unwrap().unwrap();
        close("macro auroc", mean, want["auroc_macro"].as_f64().unwrap());
        assert_eq!(
            used as u64,
            want["auroc_macro_n_videos_used"].as_u64().unwrap()
        );
    }
}

#[test]
fn pixel_level_metrics_and_robust_scaling_match_numpy() {
    let Some(fx) = fixture() else { return };
    let px = &fx["pixel_level"];
    let maps = px["maps"].as_array().unwrap();
    let scores: Vec<f64> = maps.iter().flat_map(|m| floats(&m["scores"])).collect();
    let labels: Vec<bool> = maps.iter().flat_map(|m| flags(&m["mask"])).collect();
    check_metrics("pixel raw", &scores, &labels, &px["metrics_raw"]);

    let global = &px["robust_scale_global"];
    let stats = RobustStats::of(&scores).unwrap();
    close_fields(
        "",
        global,
        &[
            ("median", stats.median, "median"),
            ("q25", stats.q25, "q25"),
            ("q75", stats.q75, "q75"),
            ("iqr", stats.iqr(), "iqr"),
        ],
    );
    for (g, w) in scores
        .iter()
        .map(|&s| stats.scale(s))
        .zip(floats(&global["scaled"]))
    {
        close("scaled", g, w);
    }

    let mut per_map_scaled = vec![];
    for (m, want) in maps
        .iter()
        .zip(px["robust_scale_per_map"].as_array().unwrap())
    {
        let s = floats(&m["scores"]);
        let st = RobustStats::of(&s).unwrap();
        close_fields(
            "map ",
            want,
            &[("median", st.median, "median"), ("iqr", st.iqr(), "iqr")],
        );
        let scaled: Vec<f64> = s.iter().map(|&v| st.scale(v)).collect();
        for (g, w) in scaled.iter().zip(floats(&want["scaled"])) {
            close("map scaled", *g, w);
        }
        per_map_scaled.extend(scaled);
    }
    check_metrics(
        "pixel per-map",
        &per_map_scaled,
        &labels,
        &px["metrics_per_map_scaled"],
    );
}

#[test]
fn z_scores_use_population_std() {
    let Some(fx) = fixture() else { return };
    let z = &fx["zscore_example"];
    let r = MeanStd::of(&floats(&z["S_r_train"])).unwrap();
    let p = MeanStd::of(&floats(&z["S_p_train"])).unwrap();
    close_fields(
        "",
        z,
        &[
            ("mean_r", r.mean, "mean_r"),
            ("std_r", r.std, "std_r_ddof0"),
            ("mean_p", p.mean, "mean_p"),
            ("std_p", p.std, "std_p_ddof0"),
        ],
    );
    let (wr, wp) = (z["w_r"].as_f64().unwrap(), z["w_p"].as_f64().unwrap());
    let sr = floats(&z["S_r_test"]);
    let sp = floats(&z["S_p_test"]);
    for ((a, b), want) in sr.iter().zip(&sp).zip(floats(&z["object_scores"])) {
        close("object score", wr * r.z(*a) + wp * p.z(*b), want);
    }
    close(
        "empty frame",
        wr * r.z(0.0) + wp * p.z(0.0),
        z["empty_frame_score"].as_f64().unwrap(),
    );
}

#[test]
fn metrics_reject_bad_input() {
    assert!(ScoreMetrics::compute(&[1.0, 2.0], &[true]).is_err());
    assert!(ScoreMetrics::compute(&[1.0, f64::NAN], &[true, false]).is_err());
    assert!(ScoreMetrics::compute(&[1.0, 2.0], &[true, true]).is_err());
    let m = ScoreMetrics::compute(&[0.1, 0.9, 0.8, 0.2], &[false, true, true, false]).unwrap();
    assert_eq!(m.auroc, 1.0);
    assert_eq!(m.fpr95, 0.0);
    assert_eq!(m.f1_max, 1.0);
    assert_eq!(m.f1_threshold, 0.8);
}
