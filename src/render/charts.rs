//! Evaluation charts by plotters: the ROC curve with its FPR95 point and AUROC, and the
//! histogram of frame scores of normal vs anomalous frames with the threshold.

use std::ops::Range;

use image::RgbaImage;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::eval::RocCurve;

use super::canvas::{Anchor, Canvas, render_view};
use super::chart_backend::{ChartBackend, FAMILY};
use super::legend::{LEGEND_TEXT, short_number};

/// Colour of normal frames in the histogram.
const NORMAL: RGBColor = RGBColor(90, 160, 255);
/// Colour of anomalous frames in the histogram and the ROC curve.
const ANOMALOUS: RGBColor = RGBColor(240, 80, 70);
/// Colour of the threshold and the FPR95 marker.
const MARK: RGBColor = RGBColor(255, 230, 90);
/// Axis and grid colours.
const GRID: RGBColor = RGBColor(60, 62, 68);
const AXIS: RGBColor = RGBColor(130, 130, 130);

/// Frame scores against ground truth, for the ROC chart and the histogram.
#[derive(Debug, Clone, Copy)]
pub struct ScoreLabels<'a> {
    /// One score per frame (non-finite scores are left out).
    pub scores: &'a [f64],
    /// Ground truth per frame (anomalous = true); same length as `scores`.
    pub labels: &'a [bool],
    /// Decision threshold, marked in the histogram.
    pub threshold: Option<f64>,
}

impl ScoreLabels<'_> {
    /// The finite scores with their labels.
    fn finite(&self) -> (Vec<f64>, Vec<bool>) {
        self.scores
            .iter()
            .zip(self.labels)
            .filter(|(s, _)| s.is_finite())
            .map(|(&s, &l)| (s, l))
            .unzip()
    }
}

fn font(size: (u32, u32)) -> f64 {
    (f64::from(size.1.min(size.0)) / 26.0).clamp(8.0, 13.0)
}

fn label_style(size: f64) -> TextStyle<'static> {
    (FAMILY, size)
        .into_font()
        .color(&RGBColor(LEGEND_TEXT[0], LEGEND_TEXT[1], LEGEND_TEXT[2]))
}

/// The chart area both charts draw into.
type Chart<'a, 'b> =
    ChartContext<'a, ChartBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The frame of a chart: title, axis ranges, descriptions and tick labels (six on x).
struct Axes<'a> {
    title: &'a str,
    x: Range<f64>,
    y: Range<f64>,
    x_desc: &'a str,
    y_desc: &'a str,
    y_labels: usize,
    /// Tick label formats (`None` = plotters' own).
    x_format: Option<&'a dyn Fn(&f64) -> String>,
    y_format: Option<&'a dyn Fn(&f64) -> String>,
}

/// A chart over the whole of `root` with the title, axes, grid and tick labels of `axes`
/// drawn, ready for its content; `None` when the area is too small for one.
fn chart_on<'a, 'b>(
    root: &'a DrawingArea<ChartBackend<'b>, Shift>,
    axes: &Axes<'_>,
) -> Option<Chart<'a, 'b>> {
    let size = root.dim_in_pixel();
    let f = font(size);
    // Tick labels sit two tick lengths (10 px) off the axis, the description beyond them;
    // a small chart gets the room they need, up to a third of its side.
    let text_h = Canvas::text_size("Ag", f).1;
    let needed_left = Canvas::text_size("0000", f).0 + text_h + 16;
    let needed_bottom = 2 * text_h + 16;
    let left = needed_left.max((size.0 / 7).min(56)).min(size.0 / 3);
    let bottom = needed_bottom.max((size.1 / 7).min(40)).min(size.1 / 3);
    let mut builder = ChartBuilder::on(root);
    builder
        .margin(6)
        .caption(axes.title, label_style(f + 1.0))
        .x_label_area_size(bottom)
        .y_label_area_size(left);
    let mut chart = builder
        .build_cartesian_2d(axes.x.clone(), axes.y.clone())
        .ok()?;
    let mut mesh = chart.configure_mesh();
    mesh.x_labels(6)
        .y_labels(axes.y_labels)
        .bold_line_style(GRID)
        .light_line_style(TRANSPARENT)
        .axis_style(AXIS)
        .label_style(label_style(f))
        .axis_desc_style(label_style(f))
        .x_desc(axes.x_desc)
        .y_desc(axes.y_desc);
    if let Some(format) = axes.x_format {
        mesh.x_label_formatter(format);
    }
    if let Some(format) = axes.y_format {
        mesh.y_label_formatter(format);
    }
    let _ = mesh.draw();
    Some(chart)
}

/// Renders the ROC curve at `size`, with AUROC, AP and the FPR95 point (first threshold
/// whose TPR reaches 0.95) in its title; says why when the curve is undefined.
pub fn roc_chart(input: &ScoreLabels<'_>, size: (u32, u32)) -> RgbaImage {
    render_view(size, |canvas, _| draw_roc(canvas, input))
}

/// Draws the ROC chart over the whole of `canvas`.
pub(crate) fn draw_roc(canvas: &mut Canvas, input: &ScoreLabels<'_>) {
    let size = (canvas.width(), canvas.height());
    let f = font(size);
    let (scores, labels) = input.finite();
    let curve = match RocCurve::compute(&scores, &labels) {
        Ok(curve) => curve,
        Err(e) => {
            let text = format!("ROC undefined: {e}");
            canvas.text(
                size.0 as i32 / 2,
                size.1 as i32 / 2,
                &text,
                f,
                LEGEND_TEXT,
                Anchor::Center,
            );
            return;
        }
    };
    let metrics = curve.metrics();
    let at95 = curve.first_reaching_tpr(0.95);
    let point95 = (curve.fpr(at95), curve.tpr(at95));
    let thin = curve.without_intermediate();
    let points: Vec<(f64, f64)> = (0..thin.points.len())
        .map(|i| (thin.fpr(i), thin.tpr(i)))
        .collect();
    let title = format!(
        "ROC · AUROC {:.3} · AP {:.3} · FPR95 {:.3}",
        metrics.auroc, metrics.average_precision, metrics.fpr95
    );
    let axes = Axes {
        title: &title,
        x: 0.0..1.0,
        y: 0.0..1.0,
        x_desc: "false positive rate",
        y_desc: "true positive rate",
        y_labels: 6,
        x_format: None,
        y_format: None,
    };
    let root = canvas.plotters().into_drawing_area();
    let Some(mut chart) = chart_on(&root, &axes) else {
        return;
    };
    let _ = chart.draw_series(DashedLineSeries::new(
        [(0.0, 0.0), (1.0, 1.0)],
        4,
        4,
        AXIS.into(),
    ));
    let _ = chart.draw_series(LineSeries::new(points, ANOMALOUS.stroke_width(2)));
    let _ = chart.draw_series(std::iter::once(Circle::new(
        point95,
        5,
        MARK.stroke_width(2),
    )));
    let _ = chart.draw_series(std::iter::once(Text::new(
        format!("TPR ≥ 0.95 at FPR {}", short_number(point95.0)),
        (point95.0.min(0.55) + 0.03, (point95.1 - 0.1).max(0.05)),
        label_style(f).color(&MARK),
    )));
}

/// Renders the histogram of frame scores of normal vs anomalous frames at `size`, with the
/// threshold as a vertical line.
pub fn histogram(input: &ScoreLabels<'_>, size: (u32, u32)) -> RgbaImage {
    render_view(size, |canvas, _| draw_histogram(canvas, input))
}

/// Bins of the histogram.
const BINS: usize = 40;

/// Draws the histogram over the whole of `canvas`.
pub(crate) fn draw_histogram(canvas: &mut Canvas, input: &ScoreLabels<'_>) {
    let size = (canvas.width(), canvas.height());
    let f = font(size);
    let (scores, labels) = input.finite();
    if scores.is_empty() {
        canvas.text(
            size.0 as i32 / 2,
            size.1 as i32 / 2,
            "no scored frames",
            f,
            LEGEND_TEXT,
            Anchor::Center,
        );
        return;
    }
    let mut lo = scores.iter().copied().fold(f64::INFINITY, f64::min);
    let mut hi = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if let Some(t) = input.threshold.filter(|t| t.is_finite()) {
        lo = lo.min(t);
        hi = hi.max(t);
    }
    if hi <= lo {
        hi = lo + 1.0;
    }
    let width = (hi - lo) / BINS as f64;
    let mut counts = [[0u32; BINS]; 2];
    for (&s, &l) in scores.iter().zip(&labels) {
        let bin = (((s - lo) / width) as usize).min(BINS - 1);
        counts[usize::from(l)][bin] += 1;
    }
    let top = counts.iter().flatten().copied().max().unwrap_or(1).max(1);
    let (normal, anomalous) = (
        labels.iter().filter(|l| !**l).count(),
        labels.iter().filter(|l| **l).count(),
    );
    let title = format!("frame scores · {normal} normal, {anomalous} anomalous");
    let axes = Axes {
        title: &title,
        x: lo..hi,
        y: 0.0..f64::from(top) * 1.1,
        x_desc: "fused frame score",
        y_desc: "frames",
        y_labels: 5,
        x_format: Some(&|v| short_number(*v)),
        y_format: Some(&|v| format!("{}", v.round() as i64)),
    };
    let root = canvas.plotters().into_drawing_area();
    let Some(mut chart) = chart_on(&root, &axes) else {
        return;
    };
    for (class, color, name) in [(0usize, NORMAL, "normal"), (1, ANOMALOUS, "anomalous")] {
        let bars = counts[class]
            .iter()
            .enumerate()
            .filter(|(_, c)| **c > 0)
            .map(move |(k, &c)| {
                let x0 = lo + k as f64 * width;
                Rectangle::new(
                    [(x0, 0.0), (x0 + width, f64::from(c))],
                    color.mix(0.55).filled(),
                )
            });
        if let Ok(series) = chart.draw_series(bars) {
            series.label(name).legend(move |(x, y)| {
                Rectangle::new([(x, y - 4), (x + 12, y + 4)], color.filled())
            });
        }
    }
    if let Some(t) = input.threshold.filter(|t| t.is_finite())
        && let Ok(series) = chart.draw_series(DashedLineSeries::new(
            [(t, 0.0), (t, f64::from(top) * 1.1)],
            5,
            4,
            MARK.stroke_width(2),
        ))
    {
        series
            .label(format!("threshold {}", short_number(t)))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 12, y)], MARK.stroke_width(2)));
    }
    let _ = chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(RGBColor(30, 32, 36).mix(0.9))
        .border_style(AXIS)
        .label_font(label_style(f))
        .draw();
}
