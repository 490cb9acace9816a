//! The timeline's geometry: where the plot, the lanes and the axes lie in the image, the
//! pixel ↔ frame mapping (for drawing and for hit-testing clicks) and the value ↔ row
//! mapping of the score plot.

use std::ops::Range;

use super::super::canvas::Canvas;
use super::{TimelineInput, TimelineOptions};

/// Where the parts of a timeline lie, and the pixel ↔ frame mapping.
#[derive(Debug, Clone, PartialEq)]
pub struct TimelineLayout {
    /// Image size.
    pub size: (u32, u32),
    /// Visible frames.
    pub frames: Range<usize>,
    /// Plot columns `x0..x1` (the same for every panel).
    pub plot_x: Range<i32>,
    /// Rows of the fused-score panel.
    pub score_y: Range<i32>,
    /// Rows of the z-score panel (empty when not shown).
    pub components_y: Range<i32>,
    /// Rows of the ground-truth lane.
    pub truth_y: Range<i32>,
    /// Rows of the analyst-label lane.
    pub labels_y: Range<i32>,
    /// Rows of the frame axis labels.
    pub axis_y: Range<i32>,
    /// Font size of labels.
    pub font: f64,
}

impl TimelineLayout {
    /// The layout of a timeline of `frames` frames at `size` with `options`.
    pub fn new(frames: usize, options: &TimelineOptions, size: (u32, u32)) -> Self {
        let (w, h) = (size.0.max(1) as i32, size.1.max(1) as i32);
        let font = (f64::from(h) / 24.0).clamp(8.0, 13.0);
        let line = font.ceil() as i32 + 6;
        let window = match &options.window {
            Some(r) if r.start < r.end && r.start < frames => r.start..r.end.min(frames),
            _ => 0..frames,
        };
        // Room for the rotated axis title, a tick label like "40.0" and the tick gap, but
        // never more than a third of a narrow timeline.
        let needed = font.ceil() as i32 + Canvas::text_size("00.00", font).0 as i32 + 10;
        let left = needed.max((w / 8).min(64)).min(w / 3);
        let right = (w / 50).clamp(0, 12);
        let legend = line;
        let axis = line + 2;
        let lane = (h / 16).clamp(2, 16);
        let free = (h - legend - axis - 2 * lane - 4).max(2);
        let (score_h, comp_h) = if options.components {
            (free * 3 / 5, free - free * 3 / 5)
        } else {
            (free, 0)
        };
        let score_y = legend..legend + score_h;
        let components_y = score_y.end..score_y.end + comp_h;
        let truth_y = components_y.end + 2..components_y.end + 2 + lane;
        let labels_y = truth_y.end + 2..truth_y.end + 2 + lane;
        let axis_y = labels_y.end..h;
        Self {
            size: (w as u32, h as u32),
            frames: window,
            plot_x: left..(w - right).max(left + 1),
            score_y,
            components_y,
            truth_y,
            labels_y,
            axis_y,
            font,
        }
    }

    fn span(&self) -> (usize, usize) {
        (self.frames.start, self.frames.len().max(1))
    }

    pub(super) fn width(&self) -> usize {
        (self.plot_x.end - self.plot_x.start).max(1) as usize
    }

    /// The frame under pixel column `x`, or `None` outside the plot (or with no frames).
    pub fn frame_at(&self, x: f32) -> Option<usize> {
        if self.frames.is_empty() || !(x >= self.plot_x.start as f32 && x < self.plot_x.end as f32)
        {
            return None;
        }
        let (f0, n) = self.span();
        let k = ((x - self.plot_x.start as f32) as f64 * n as f64 / self.width() as f64) as usize;
        Some(f0 + k.min(n - 1))
    }

    /// The pixel column at the centre of `frame` (may lie outside the plot when the frame
    /// is outside the window).
    pub fn x_of(&self, frame: usize) -> f32 {
        let (f0, n) = self.span();
        self.plot_x.start as f32
            + ((frame as f64 - f0 as f64 + 0.5) * self.width() as f64 / n as f64) as f32
    }

    /// The value range of the fused-score panel as drawn for `input` with `options`.
    pub fn score_range(&self, input: &TimelineInput<'_>, options: &TimelineOptions) -> (f64, f64) {
        let mut scored: Vec<&[f64]> = Vec::new();
        if options.raw {
            scored.push(input.fused);
        }
        if options.filtered {
            scored.push(input.filtered);
        }
        value_range(&scored, &self.frames, input.threshold)
    }

    /// The pixel row of score `value` in the fused-score panel (`range` from
    /// [`Self::score_range`]).
    pub fn score_row(&self, value: f64, range: (f64, f64)) -> i32 {
        row_of(value, &self.score_y, range)
    }

    /// The score at pixel row `y` of the fused-score panel (the inverse of
    /// [`Self::score_row`], not clamped to the panel).
    pub fn score_at(&self, y: f32, (lo, hi): (f64, f64)) -> f64 {
        let rows = f64::from(self.score_y.end - self.score_y.start - 1).max(1.0);
        let t = (f64::from(self.score_y.end - 1) - f64::from(y)) / rows;
        lo + t * (hi - lo)
    }

    /// Frames `a..b` drawn in plot column `c` (at least one frame).
    pub(super) fn column_frames(&self, c: usize) -> Range<usize> {
        let (f0, n) = self.span();
        let w = self.width();
        let a = c * n / w;
        let b = ((c + 1) * n / w).max(a + 1).min(n);
        f0 + a.min(n - 1)..f0 + b
    }
}

/// Value range over the finite values of `series` in `frames`, plus `extra`, padded.
pub(super) fn value_range(
    series: &[&[f64]],
    frames: &Range<usize>,
    extra: Option<f64>,
) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for s in series {
        let end = frames.end.min(s.len());
        for &v in s.get(frames.start.min(end)..end).unwrap_or(&[]) {
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    if let Some(t) = extra.filter(|t| t.is_finite()) {
        lo = lo.min(t);
        hi = hi.max(t);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    let pad = if hi > lo { 0.06 * (hi - lo) } else { 1.0 };
    (lo - pad, hi + pad)
}

/// Row of value `v` in `rows` for the value range (lo, hi).
pub(super) fn row_of(v: f64, rows: &Range<i32>, (lo, hi): (f64, f64)) -> i32 {
    let t = ((v - lo) / (hi - lo)).clamp(0.0, 1.0);
    rows.end - 1 - (t * f64::from(rows.end - rows.start - 1).max(0.0)).round() as i32
}
