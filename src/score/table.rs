//! Renders evaluation rows ([`EvalRow`], [`SweepRow`]) as aligned text, Markdown or CSV.
//!
//! Text and Markdown show metrics as percentages with one decimal and `-` where a metric
//! is undefined; CSV keeps full precision (fractions, not percentages) and leaves undefined
//! cells empty, for spreadsheets and scripts. Pixel columns appear only when some row has
//! pixel metrics.

use serde::{Deserialize, Serialize};

use super::evaluate::{EvalRow, SweepRow};

/// How a table is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TableFormat {
    /// Columns padded with spaces, text left-aligned and numbers right-aligned.
    Text,
    /// A GitHub Markdown table with padded columns (readable as it is, too).
    #[default]
    Markdown,
    /// Comma-separated values with a header line.
    Csv,
}

/// A metric cell: a percentage with one decimal (`-` when undefined) or, for CSV, the
/// plain fraction (empty when undefined).
fn metric(value: Option<f64>, format: TableFormat) -> String {
    match (value, format) {
        (None, TableFormat::Csv) => String::new(),
        (None, _) => "-".into(),
        (Some(v), TableFormat::Csv) => v.to_string(),
        (Some(v), _) => format!("{:.1}", 100.0 * v),
    }
}

fn condition_name<T: std::fmt::Debug>(value: Option<T>) -> String {
    value.map_or_else(|| "all".into(), |v| format!("{v:?}").to_lowercase())
}

/// The frame-metric cells shared by both tables: AUROC, macro AUROC, AUPR, FPR95, FPR95
/// (closest), then the pixel cells when `pixel` is set.
fn metric_cells(row: &EvalRow, pixel: bool, format: TableFormat) -> Vec<String> {
    let m = row.metrics;
    let mut cells = vec![
        metric(m.map(|m| m.auroc), format),
        metric(row.auroc_macro, format),
        metric(m.map(|m| m.average_precision), format),
        metric(m.map(|m| m.fpr95), format),
        metric(m.map(|m| m.fpr95_closest), format),
    ];
    if pixel {
        let p = row.pixel;
        cells.extend([
            metric(p.map(|p| p.auroc), format),
            metric(p.map(|p| p.average_precision), format),
            metric(p.map(|p| p.fpr95), format),
        ]);
    }
    cells
}

const METRIC_HEADER: [&str; 5] = ["AUROC", "AUROC macro", "AUPR", "FPR95", "FPR95 closest"];
const PIXEL_HEADER: [&str; 3] = ["pixel AUROC", "pixel AUPR", "pixel FPR95"];

/// The evaluation table (Table 2): box source, condition, counts, frame metrics, pixel
/// metrics when present, box IoU and recall.
pub fn render_eval_table(rows: &[EvalRow], format: TableFormat) -> String {
    let pixel = rows.iter().any(|r| r.pixel.is_some());
    let mut header: Vec<&str> = vec!["box source", "domain", "weather", "scen.", "frames"];
    header.push("anom.");
    header.extend(METRIC_HEADER);
    if pixel {
        header.extend(PIXEL_HEADER);
    }
    header.extend(["mIoU", "recall"]);
    let body = rows
        .iter()
        .map(|r| {
            let mut cells = vec![
                r.box_source.clone(),
                condition_name(r.domain),
                condition_name(r.weather),
                r.scenarios.to_string(),
                r.frames.to_string(),
                r.anomalous_frames.to_string(),
            ];
            cells.extend(metric_cells(r, pixel, format));
            cells.push(metric(r.mean_iou, format));
            cells.push(metric(r.box_recall, format));
            cells
        })
        .collect();
    render(&header, body, 3, format)
}

/// The weight study (Table 3): box source, the preset the weights are (if any), the four
/// weights, frame metrics, pixel metrics when present.
pub fn render_sweep_table(rows: &[SweepRow], format: TableFormat) -> String {
    let pixel = rows.iter().any(|r| r.row.pixel.is_some());
    let mut header: Vec<&str> = vec!["box source", "preset", "w_r", "w_p", "w_r_p", "w_p_p"];
    header.extend(METRIC_HEADER);
    if pixel {
        header.extend(PIXEL_HEADER);
    }
    let body = rows
        .iter()
        .map(|r| {
            let w = r.weights;
            let mut cells = vec![
                r.row.box_source.clone(),
                r.preset
                    .unwrap_or(if format == TableFormat::Csv { "" } else { "-" })
                    .to_string(),
                w.w_r.to_string(),
                w.w_p.to_string(),
                w.w_r_p.to_string(),
                w.w_p_p.to_string(),
            ];
            cells.extend(metric_cells(&r.row, pixel, format));
            cells
        })
        .collect();
    render(&header, body, 2, format)
}

/// The evaluation table as aligned text, one row per line (see [`render_eval_table`]).
pub fn format_eval_table(rows: &[EvalRow]) -> String {
    render_eval_table(rows, TableFormat::Text)
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(cell: &str) -> String {
    if cell.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", cell.replace('"', "\"\""))
    } else {
        cell.to_string()
    }
}

/// Writes `header` and `body`; the first `text_columns` columns are left-aligned.
fn render(
    header: &[&str],
    body: Vec<Vec<String>>,
    text_columns: usize,
    format: TableFormat,
) -> String {
    let mut cells: Vec<Vec<String>> = vec![header.iter().map(|h| h.to_string()).collect()];
    cells.extend(body);
    let mut out = String::new();
    if format == TableFormat::Csv {
        for row in &cells {
            let fields: Vec<String> = row.iter().map(|c| csv_field(c)).collect();
            out.push_str(&fields.join(","));
            out.push('\n');
        }
        return out;
    }
    let widths: Vec<usize> = (0..header.len())
        .map(|c| {
            cells
                .iter()
                .map(|row| row[c].chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let pad = |c: usize, cell: &str| {
        let w = widths[c];
        if c < text_columns {
            format!("{cell:<w$}")
        } else {
            format!("{cell:>w$}")
        }
    };
    for (r, row) in cells.iter().enumerate() {
        let padded: Vec<String> = row
            .iter()
            .enumerate()
            .map(|(c, cell)| pad(c, cell))
            .collect();
        match format {
            TableFormat::Markdown => {
                out.push_str(&format!("| {} |\n", padded.join(" | ")));
                if r == 0 {
                    let rule: Vec<String> = widths
                        .iter()
                        .enumerate()
                        .map(|(c, &w)| {
                            let dashes = "-".repeat(w.saturating_sub(1).max(2));
                            if c < text_columns {
                                format!("{dashes}-")
                            } else {
                                format!("{dashes}:")
                            }
                        })
                        .collect();
                    out.push_str(&format!("| {} |\n", rule.join(" | ")));
                }
            }
            _ => {
                out.push_str(padded.join("  ").trim_end());
                out.push('\n');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_fields_are_quoted_only_when_needed() {
        assert_eq!(csv_field("gt"), "gt");
        assert_eq!(csv_field("mot a,b.txt"), "\"mot a,b.txt\"");
        assert_eq!(csv_field("say \"x\""), "\"say \"\"x\"\"\"");
    }

    #[test]
    fn markdown_tables_have_a_rule_line_of_the_column_widths() {
        let out = render(
            &["name", "v"],
            vec![vec!["long name".into(), "12.5".into()]],
            1,
            TableFormat::Markdown,
        );
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines[0], "| name      |    v |");
        assert_eq!(lines[1], "| --------- | ---: |");
        assert_eq!(lines[2], "| long name | 12.5 |");
    }
}
