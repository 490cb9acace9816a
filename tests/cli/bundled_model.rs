//! The bundled model detects sudden braking: a regression floor. One AnoVox-style braking
//! scenario is generated at the model's training size (768×512, stored flow) and scored by
//! `vadscope eval` with the bundled model and the reference protocol; its frame AUROC and
//! how often the braking lead sets an anomaly frame's score must stay above floors set a
//! margin below the figures measured when the model was bundled (`assets/model/MODEL.md`),
//! so a model or scoring change that loses the detection shows here.

use serde_json::Value;

use crate::support::cli::{text, vadscope};

/// Frame AUROC floor (measured when bundled: see `FLOOR_NOTE`).
const AUROC_FLOOR: f64 = 0.70;
/// Floor on the fraction of anomaly frames whose top-scoring object is the braking lead.
const LEAD_TOP_FLOOR: f64 = 0.55;
/// Where the floors come from.
const FLOOR_NOTE: &str = "measured at bundling: frame AUROC 0.792, the lead on top in 19 of 31 anomaly frames (0.61); assets/model/MODEL.md";

#[test]
fn the_bundled_model_detects_a_generated_sudden_braking() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let generated = vadscope(&[
        "generate",
        "--out",
        data.to_str().unwrap(),
        "--kind",
        "braking",
        "--domain",
        "city",
        "--weather",
        "sun",
        "--frames",
        "80",
        "--seed",
        "21",
        "--omit",
        "depth,semantic,instance",
    ]);
    assert!(generated.status.success(), "{}", text(&generated.stderr));

    let out = vadscope(&[
        "eval",
        data.to_str().unwrap(),
        "--flow",
        "stored",
        "--by",
        "none",
        "--format",
        "json",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: Value = serde_json::from_str(&text(&out.stdout)).expect("JSON");
    let auroc = report["table2"][0]["metrics"]["auroc"]
        .as_f64()
        .expect("an AUROC");
    let hits = &report["top_object"][0][1];
    let lead_top = hits["hits"].as_f64().unwrap() / hits["frames"].as_f64().unwrap();
    assert!(
        auroc >= AUROC_FLOOR,
        "frame AUROC {auroc:.3} fell below {AUROC_FLOOR} ({FLOOR_NOTE})"
    );
    assert!(
        lead_top >= LEAD_TOP_FLOOR,
        "the braking lead tops {lead_top:.2} of the anomaly frames, below {LEAD_TOP_FLOOR} ({FLOOR_NOTE})"
    );
}
