//! The timeline chart: fused frame score (raw and median-filtered) with the threshold, the
//! z-scores of S_r and S_p of each frame's top object, the ground-truth anomaly intervals
//! and the analyst's labels as lanes, and the cursor. Any number of frames: each pixel
//! column draws the min/max of the frames it covers, so 100,000 frames cost one pass.
//!
//! [`TimelineLayout`] (in `layout`) is the chart's geometry and pixel ↔ frame mapping, also
//! for hit-testing clicks.

use std::ops::Range;

use image::RgbaImage;
use plotters::prelude::*;

use crate::score::ScoreSeries;

mod layout;

pub use layout::TimelineLayout;
use layout::{row_of, value_range};

use super::canvas::{Anchor, Canvas, render_view};
use super::chart_backend::FAMILY;
use super::legend::{LEGEND_TEXT, short_number};

/// The series of one timeline, one value per frame index; slices may be empty (not drawn).
#[derive(Debug, Clone, Copy, Default)]
pub struct TimelineInput<'a> {
    /// Raw fused frame scores (NaN = not scored).
    pub fused: &'a [f64],
    /// Median-filtered fused frame scores.
    pub filtered: &'a [f64],
    /// z-score of S_r (flow reconstruction) of each frame's top object (NaN = none).
    pub z_r: &'a [f64],
    /// z-score of S_p (frame prediction) of each frame's top object (NaN = none).
    pub z_p: &'a [f64],
    /// Whether `z_r` and `z_p` are tail surprisals (a model that scores by tail tables)
    /// rather than z-scores; only the labels change.
    pub surprisals: bool,
    /// Ground truth: anomalous frames.
    pub truth: &'a [bool],
    /// The analyst's labels (`None` = not labelled).
    pub labels: &'a [Option<bool>],
    /// Decision threshold on the filtered score.
    pub threshold: Option<f64>,
    /// The current frame.
    pub cursor: Option<usize>,
}

impl<'a> TimelineInput<'a> {
    /// The timeline of `series` with the analyst's `labels`, `threshold` and the cursor on
    /// `cursor`.
    pub fn of_series(
        series: &'a ScoreSeries,
        labels: &'a [Option<bool>],
        threshold: Option<f64>,
        cursor: Option<usize>,
    ) -> Self {
        Self {
            fused: &series.fused,
            filtered: &series.filtered,
            z_r: &series.z_r,
            z_p: &series.z_p,
            surprisals: series.surprisals,
            truth: &series.truth,
            labels,
            threshold,
            cursor,
        }
    }
}

impl TimelineInput<'_> {
    /// Number of frames: the longest series.
    pub fn frames(&self) -> usize {
        [
            self.fused.len(),
            self.filtered.len(),
            self.z_r.len(),
            self.z_p.len(),
            self.truth.len(),
            self.labels.len(),
        ]
        .into_iter()
        .max()
        .unwrap_or(0)
    }
}

/// What the timeline shows.
#[derive(Debug, Clone, PartialEq)]
pub struct TimelineOptions {
    /// Visible frames (zoom); `None` = all.
    pub window: Option<Range<usize>>,
    /// Draw the raw fused score.
    pub raw: bool,
    /// Draw the filtered fused score.
    pub filtered: bool,
    /// Draw the panel of the z-scores of S_r and S_p.
    pub components: bool,
}

impl Default for TimelineOptions {
    fn default() -> Self {
        Self {
            window: None,
            raw: true,
            filtered: true,
            components: true,
        }
    }
}

/// Colour of the raw fused score.
const RAW: [u8; 3] = [120, 150, 200];
/// Colour of the filtered fused score.
const FILTERED: [u8; 3] = [255, 255, 255];
/// Colour of the threshold line.
const THRESHOLD: [u8; 3] = [255, 80, 60];
/// Colour of z(S_r).
const Z_R: [u8; 3] = [80, 200, 255];
/// Colour of z(S_p).
const Z_P: [u8; 3] = [255, 190, 60];
/// Colour of ground-truth anomalies (lane and shading).
const TRUTH: [u8; 3] = [230, 60, 60];
/// Colour of analyst "anomaly" labels.
const LABEL_ANOMALY: [u8; 3] = [255, 150, 40];
/// Colour of analyst "normal" labels.
const LABEL_NORMAL: [u8; 3] = [70, 170, 90];
/// Colour of the cursor.
const CURSOR: [u8; 3] = [255, 240, 100];

/// Min, max and last finite value of `values` over `frames`.
fn column_stats(values: &[f64], frames: Range<usize>) -> Option<(f64, f64, f64)> {
    let slice = values.get(frames.start.min(values.len())..frames.end.min(values.len()))?;
    let mut out: Option<(f64, f64, f64)> = None;
    for &v in slice {
        if v.is_finite() {
            out = Some(match out {
                None => (v, v, v),
                Some((lo, hi, _)) => (lo.min(v), hi.max(v), v),
            });
        }
    }
    out
}

/// Draws `values` in `rows`: with more frames than columns, per column a vertical segment
/// over the min and max of its frames, extended to the previous column's last value so the
/// line stays connected; else a polyline through the frames. `thick` doubles the line.
#[allow(clippy::too_many_arguments)]
fn draw_series(
    canvas: &mut Canvas,
    layout: &TimelineLayout,
    values: &[f64],
    rows: &Range<i32>,
    range: (f64, f64),
    color: [u8; 3],
    thick: bool,
) {
    if values.is_empty() || rows.is_empty() {
        return;
    }
    if layout.frames.len() <= layout.width() {
        // Fewer frames than columns: straight segments between frame centres.
        let end = layout.frames.end.min(values.len());
        let mut previous: Option<(i32, i32)> = None;
        let start = layout.frames.start.min(end);
        for (k, &v) in values[start..end]
            .iter()
            .enumerate()
            .map(|(i, v)| (start + i, v))
        {
            if !v.is_finite() {
                previous = None;
                continue;
            }
            let point = (layout.x_of(k).floor() as i32, row_of(v, rows, range));
            let from = previous.unwrap_or(point);
            canvas.line(from.0, from.1, point.0, point.1, color);
            if thick {
                canvas.line(from.0, from.1 - 1, point.0, point.1 - 1, color);
            }
            previous = Some(point);
        }
        return;
    }
    let mut previous: Option<f64> = None;
    for c in 0..layout.width() {
        let x = layout.plot_x.start + c as i32;
        let Some((mut lo, mut hi, last)) = column_stats(values, layout.column_frames(c)) else {
            previous = None;
            continue;
        };
        if let Some(p) = previous {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let (y_lo, y_hi) = (row_of(lo, rows, range), row_of(hi, rows, range));
        // Thick lines extend one row upwards, as the polyline's second stroke does.
        canvas.vline(x, y_lo, y_hi - i32::from(thick), color);
        previous = Some(last);
    }
}

/// The colour `pick` gives the frames of each plot column (`None` = nothing).
fn column_colors(
    layout: &TimelineLayout,
    mut pick: impl FnMut(Range<usize>) -> Option<[u8; 3]>,
) -> Vec<Option<[u8; 3]>> {
    (0..layout.width())
        .map(|c| pick(layout.column_frames(c)))
        .collect()
}

/// Fills the plot columns of `rows` with their `colors` at opacity `alpha`, each run of
/// equal colours as one rectangle.
fn draw_lane(
    canvas: &mut Canvas,
    layout: &TimelineLayout,
    rows: &Range<i32>,
    alpha: f32,
    colors: &[Option<[u8; 3]>],
) {
    let mut c = 0;
    while c < colors.len() {
        let run = colors[c..].iter().take_while(|k| **k == colors[c]).count();
        if let Some(color) = colors[c] {
            let x = layout.plot_x.start + c as i32;
            canvas.fill_rect(x, rows.start, x + run as i32, rows.end, color, alpha);
        }
        c += run;
    }
}

/// Axes and value labels of one panel, by plotters.
fn draw_axes(
    canvas: &mut Canvas,
    layout: &TimelineLayout,
    rows: &Range<i32>,
    range: (f64, f64),
    x_labels: bool,
    title: &str,
) {
    let (w, _) = layout.size;
    let top = rows.start.max(0) as u32;
    let height = (rows.end - rows.start).max(1) as u32;
    let left = layout.plot_x.start.max(0) as u32;
    let right = (w as i32 - layout.plot_x.end).max(0) as u32;
    let axis_h = if x_labels {
        (layout.axis_y.end - layout.axis_y.start).max(0) as u32
    } else {
        0
    };
    let (f0, f1) = (
        layout.frames.start as f64,
        layout.frames.end.max(layout.frames.start + 1) as f64,
    );
    let label_style = (FAMILY, layout.font).into_font().color(&RGBColor(
        LEGEND_TEXT[0],
        LEGEND_TEXT[1],
        LEGEND_TEXT[2],
    ));
    let backend = canvas.plotters();
    let root = backend.into_drawing_area();
    let area = root.shrink((0, top), (w, height + axis_h));
    let mut builder = ChartBuilder::on(&area);
    builder
        .margin_right(right)
        .y_label_area_size(left)
        .x_label_area_size(axis_h);
    let Ok(mut chart) = builder.build_cartesian_2d(f0..f1, range.0..range.1) else {
        return;
    };
    let y_labels = if title.is_empty() {
        0
    } else {
        (height / 28).clamp(2, 6) as usize
    };
    let _ = chart
        .configure_mesh()
        .disable_x_mesh()
        .y_labels(y_labels)
        .x_labels(if x_labels {
            ((w / 90).clamp(2, 12) as usize).min(layout.frames.len() + 1)
        } else {
            0
        })
        .bold_line_style(RGBColor(60, 62, 68))
        .light_line_style(TRANSPARENT)
        .axis_style(RGBColor(120, 120, 120))
        .label_style(label_style.clone())
        .y_label_formatter(&|v| short_number(*v))
        .x_label_formatter(&|v| {
            if (v - v.round()).abs() < 1e-6 {
                format!("{}", v.round() as i64)
            } else {
                String::new()
            }
        })
        .y_desc(title)
        .axis_desc_style(label_style)
        .draw();
}

/// Draws a dashed horizontal line at row `y` over the plot columns.
fn dashed(canvas: &mut Canvas, layout: &TimelineLayout, y: i32, color: [u8; 3]) {
    let mut x = layout.plot_x.start;
    while x < layout.plot_x.end {
        canvas.line(x, y, (x + 5).min(layout.plot_x.end - 1), y, color);
        x += 9;
    }
}

/// Draws a legend row of (colour, text) swatches starting at (x, y).
fn legend_row(canvas: &mut Canvas, mut x: i32, y: i32, font: f64, items: &[([u8; 3], &str)]) {
    for (color, text) in items {
        canvas.fill_rect(
            x,
            y + font as i32 / 2 - 1,
            x + 14,
            y + font as i32 / 2 + 2,
            *color,
            1.0,
        );
        canvas.text(x + 18, y, text, font, LEGEND_TEXT, Anchor::TopLeft);
        x += 30 + Canvas::text_size(text, font).0 as i32;
    }
}

/// Renders the timeline at `size` (width, height).
pub fn timeline(
    input: &TimelineInput<'_>,
    options: &TimelineOptions,
    size: (u32, u32),
) -> RgbaImage {
    render_view(size, |canvas, _| draw_timeline(canvas, input, options))
}

/// Draws the timeline over the whole of `canvas`.
pub(crate) fn draw_timeline(
    canvas: &mut Canvas,
    input: &TimelineInput<'_>,
    options: &TimelineOptions,
) {
    let layout = TimelineLayout::new(input.frames(), options, (canvas.width(), canvas.height()));
    if layout.frames.is_empty() {
        let (w, h) = layout.size;
        canvas.text(
            w as i32 / 2,
            h as i32 / 2,
            "no frames",
            layout.font,
            LEGEND_TEXT,
            Anchor::Center,
        );
        return;
    }
    let frames = layout.frames.clone();
    let score_range = layout.score_range(input, options);
    let comp_range = value_range(&[input.z_r, input.z_p], &frames, None);
    let has_components = options.components && !layout.components_y.is_empty();

    draw_axes(
        canvas,
        &layout,
        &layout.score_y,
        score_range,
        false,
        "frame score",
    );
    if has_components {
        draw_axes(
            canvas,
            &layout,
            &layout.components_y,
            comp_range,
            false,
            if input.surprisals {
                "surprisal"
            } else {
                "z-score"
            },
        );
    }
    let lanes = layout.truth_y.start..layout.labels_y.end;
    draw_axes(canvas, &layout, &lanes, (0.0, 1.0), true, "");

    // Ground-truth anomalies shade the score panels and fill their lane.
    let truth = |r: Range<usize>| {
        input
            .truth
            .get(r.start.min(input.truth.len())..r.end.min(input.truth.len()))
            .is_some_and(|s| s.iter().any(|&t| t))
    };
    let panels = layout.score_y.start..if has_components {
        layout.components_y.end
    } else {
        layout.score_y.end
    };
    let truth_colors = column_colors(&layout, |r| truth(r).then_some(TRUTH));
    draw_lane(canvas, &layout, &panels, 0.16, &truth_colors);
    draw_lane(canvas, &layout, &layout.truth_y, 0.9, &truth_colors);
    let label_colors = column_colors(&layout, |r| {
        let slice = input
            .labels
            .get(r.start.min(input.labels.len())..r.end.min(input.labels.len()))?;
        if slice.contains(&Some(true)) {
            Some(LABEL_ANOMALY)
        } else if slice.contains(&Some(false)) {
            Some(LABEL_NORMAL)
        } else {
            None
        }
    });
    draw_lane(canvas, &layout, &layout.labels_y, 0.9, &label_colors);
    let labels_name = if label_colors.iter().any(Option::is_some) {
        "labels"
    } else {
        "no labels"
    };
    for (rows, name) in [
        (&layout.truth_y, "truth"),
        (&layout.labels_y, labels_name),
        (&layout.axis_y, "frame"),
    ] {
        if rows.end - rows.start >= 8 {
            let font = f64::from(rows.end - rows.start).min(layout.font);
            canvas.text(
                layout.plot_x.start - 4,
                (rows.start + rows.end) / 2,
                name,
                font,
                LEGEND_TEXT,
                Anchor::MiddleRight,
            );
        }
    }

    if options.raw {
        draw_series(
            canvas,
            &layout,
            input.fused,
            &layout.score_y,
            score_range,
            RAW,
            false,
        );
    }
    if options.filtered {
        draw_series(
            canvas,
            &layout,
            input.filtered,
            &layout.score_y,
            score_range,
            FILTERED,
            true,
        );
    }
    let mut threshold_label = None;
    if let Some(t) = input.threshold.filter(|t| t.is_finite()) {
        let y = row_of(t, &layout.score_y, score_range);
        dashed(canvas, &layout, y, THRESHOLD);
        let text = format!("threshold {}", short_number(t));
        let (lw, lh) = Canvas::label_size(&text, layout.font);
        let (lx, ly) = (
            layout.plot_x.end - lw - 2,
            (y - lh - 2).max(layout.score_y.start),
        );
        canvas.label(lx, ly, &text, layout.font, THRESHOLD, [20, 20, 20]);
        threshold_label = Some((lx, ly, lw, lh));
    }
    if has_components {
        draw_series(
            canvas,
            &layout,
            input.z_r,
            &layout.components_y,
            comp_range,
            Z_R,
            false,
        );
        draw_series(
            canvas,
            &layout,
            input.z_p,
            &layout.components_y,
            comp_range,
            Z_P,
            false,
        );
    }
    let mut items: Vec<([u8; 3], &str)> = Vec::new();
    if options.raw {
        items.push((RAW, "fused score (raw)"));
    }
    if options.filtered {
        items.push((FILTERED, "fused (median-filtered)"));
    }
    if has_components {
        if input.surprisals {
            items.push((Z_R, "t(S_r) flow"));
            items.push((Z_P, "t(S_p) frame"));
        } else {
            items.push((Z_R, "z(S_r) flow"));
            items.push((Z_P, "z(S_p) frame"));
        }
    }
    items.push((TRUTH, "ground-truth anomaly"));
    if label_colors.contains(&Some(LABEL_ANOMALY)) {
        items.push((LABEL_ANOMALY, "label: anomaly"));
    }
    if label_colors.contains(&Some(LABEL_NORMAL)) {
        items.push((LABEL_NORMAL, "label: normal"));
    }
    legend_row(canvas, layout.plot_x.start, 2, layout.font, &items);

    if let Some(cursor) = input.cursor.filter(|c| frames.contains(c)) {
        let x = layout.x_of(cursor).floor() as i32;
        canvas.line(x, layout.score_y.start, x, layout.labels_y.end, CURSOR);
        let text = format!("frame {cursor}");
        let (lw, lh) = Canvas::label_size(&text, layout.font);
        let top = layout.score_y.start + 2;
        // Right of the cursor, else left of it, else at the foot of the score band: the
        // first place that keeps clear of the threshold's label.
        let candidates = [
            ((x + 3).min(layout.plot_x.end - lw - 2), top),
            ((x - lw - 3).max(layout.plot_x.start), top),
            (
                (x + 3).min(layout.plot_x.end - lw - 2),
                (layout.score_y.end - lh - 2).max(top),
            ),
        ];
        let clear = |&(cx, cy): &(i32, i32)| {
            threshold_label.is_none_or(|(lx, ly, w, h)| {
                cx + lw <= lx || lx + w <= cx || cy + lh <= ly || ly + h <= cy
            })
        };
        let (tx, ty) = candidates
            .iter()
            .copied()
            .find(clear)
            .unwrap_or(candidates[0]);
        canvas.label(tx, ty, &text, layout.font, CURSOR, [20, 20, 20]);
    }
}
