//! The `scores.csv` of an export: one row per frame (index, AnoVox id, S_r and S_p of the
//! top object, fused and filtered frame score, ground-truth label, prediction) under a `#`
//! header that records where the numbers came from.

use std::fmt::Write as _;

use crate::score::{FusionWeights, ScoreTable};

use crate::score::ScoreSeries;

/// Column header of `scores.csv`.
pub const SCORES_HEADER: &str = "frame,anovox_id,s_r,s_p,fused,filtered,label,prediction";

/// Where the scores of an export came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Provenance {
    /// vadscope's version.
    pub version: String,
    /// Scenario name.
    pub scenario: String,
    /// The checkpoint file.
    pub model: String,
    /// Hash of the checkpoint's bytes.
    pub model_hash: u64,
    /// Box source key.
    pub boxes: String,
    /// Flow source key.
    pub flow: String,
    /// Fusion weights.
    pub weights: FusionWeights,
    /// Median-filter kernel of the filtered score.
    pub median_kernel: usize,
    /// Decision threshold on the filtered score.
    pub threshold: f64,
}

impl Provenance {
    /// The `#` header lines.
    pub fn header(&self) -> String {
        let w = &self.weights;
        format!(
            "# vadscope {}\n# scenario: {}\n# model: {} (hash {:016x})\n# boxes: {}\n# flow: {}\n\
             # weights: w_r={} w_p={} w_r_p={} w_p_p={}\n# median filter kernel: {}\n\
             # threshold: {} (prediction = filtered >= threshold)\n\
             # s_r, s_p: raw errors of the frame's top-scoring object (empty: no object)\n\
             # filtered: empty for the first frames, which the metrics leave out\n",
            self.version,
            self.scenario,
            self.model,
            self.model_hash,
            self.boxes,
            self.flow,
            w.w_r,
            w.w_p,
            w.w_r_p,
            w.w_p_p,
            self.median_kernel,
            self.threshold,
        )
    }
}

/// The whole `scores.csv` of `series` (computed from `table`).
pub fn scores_csv(table: &ScoreTable, series: &ScoreSeries, provenance: &Provenance) -> String {
    let mut out = provenance.header();
    out.push_str(SCORES_HEADER);
    out.push('\n');
    for i in 0..series.len() {
        let id = table
            .frames
            .get(i)
            .map_or(String::new(), |f| f.id.0.to_string());
        let (s_r, s_p) = series.top_object[i]
            .and_then(|k| table.objects.get(k))
            .map_or((String::new(), String::new()), |o| {
                (o.s_r.to_string(), o.s_p.to_string())
            });
        let filtered = series.filtered[i];
        let (filtered, prediction) = if filtered.is_finite() {
            (
                filtered.to_string(),
                u8::from(filtered >= provenance.threshold).to_string(),
            )
        } else {
            (String::new(), String::new())
        };
        let _ = writeln!(
            out,
            "{i},{id},{s_r},{s_p},{},{filtered},{},{prediction}",
            series.fused[i],
            u8::from(series.truth[i])
        );
    }
    out
}
