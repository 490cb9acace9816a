//! The frame view: the camera frame with switchable overlays (pixel heatmap with its colour
//! bar, score-coloured boxes, the ground-truth anomaly contour) under a caption strip that
//! says which frame this is and how it scored.

use image::{GrayImage, RgbImage, RgbaImage};

use crate::score::{FusionWeights, Heatmap};

use super::canvas::{Anchor, Canvas, render_view};
use super::colormap::Colormap;
use super::legend::{LEGEND_TEXT, colour_bar};
use super::overlay::{Placement, SceneObject, ScoreScale, draw_boxes, draw_mask_contour};

/// Colour of the ground-truth anomaly contour.
pub const MASK_COLOR: [u8; 3] = [255, 64, 255];

/// Robust-scaled error of both maps (in IQRs above the training median) at which the
/// reference heatmap range ends.
pub const REFERENCE_RANGE_IQR: f32 = 10.0;

/// The value range the heatmap's colormap spans.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HeatRange {
    /// A fixed range (comparable across frames).
    Fixed {
        /// Value drawn in the colormap's first colour.
        low: f32,
        /// Value drawn in the colormap's last colour.
        high: f32,
    },
    /// From the threshold (or 0) to the largest value of this frame; labelled as such.
    AutoPerFrame,
}

impl HeatRange {
    /// The range fixed by the model's reference statistics: from the training median (0)
    /// to the score of a pixel whose two errors both lie [`REFERENCE_RANGE_IQR`] IQRs above
    /// their training medians, for the pixel weights of `weights`.
    pub fn reference(weights: &FusionWeights) -> Self {
        let span = (weights.w_r_p.abs() + weights.w_p_p.abs()) as f32 * REFERENCE_RANGE_IQR;
        Self::Fixed {
            low: 0.0,
            high: if span > 0.0 { span } else { 1.0 },
        }
    }
}

impl Default for HeatRange {
    fn default() -> Self {
        Self::reference(&FusionWeights::default())
    }
}

/// What the caption strip says about a frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Caption {
    /// Scenario name.
    pub scenario: String,
    /// Frame index (0-based position).
    pub index: usize,
    /// AnoVox frame id.
    pub frame_id: Option<u64>,
    /// The frame score shown (median-filtered when the threshold applies to it).
    pub frame_score: Option<f64>,
    /// The decision threshold on `frame_score`.
    pub threshold: Option<f64>,
    /// Fusion weights in use.
    pub weights: Option<FusionWeights>,
    /// Ground truth: whether the frame is anomalous.
    pub truth: Option<bool>,
}

impl Caption {
    /// The two lines of the strip.
    pub fn lines(&self) -> [String; 2] {
        let id = self
            .frame_id
            .map_or(String::new(), |id| format!(" (AnoVox id {id})"));
        let truth = match self.truth {
            Some(true) => " · ground truth: ANOMALY",
            Some(false) => " · ground truth: normal",
            None => "",
        };
        let first = format!("{} · frame {}{id}{truth}", self.scenario, self.index);
        let score = match (self.frame_score, self.threshold) {
            (Some(s), Some(t)) if s >= t => {
                format!("frame score {s:.2} ≥ threshold {t:.2}: ANOMALY")
            }
            (Some(s), Some(t)) => format!("frame score {s:.2} < threshold {t:.2}: normal"),
            (Some(s), None) => format!("frame score {s:.2}"),
            (None, _) => "frame not scored".to_string(),
        };
        let weights = self.weights.map_or(String::new(), |w| {
            format!(
                " · weights w_r {} w_p {} (pixels: {}, {})",
                w.w_r, w.w_p, w.w_r_p, w.w_p_p
            )
        });
        [first, format!("{score}{weights}")]
    }
}

/// The data of one frame view; everything is borrowed.
#[derive(Debug, Clone, Copy)]
pub struct FrameViewInput<'a> {
    /// The camera frame.
    pub frame: &'a RgbImage,
    /// Its objects (boxes, scores).
    pub objects: &'a [SceneObject<'a>],
    /// The pixel heatmap (any grid; it is stretched over the frame).
    pub heatmap: Option<&'a Heatmap>,
    /// The ground-truth anomaly mask (non-zero = anomalous), any size.
    pub anomaly_mask: Option<&'a GrayImage>,
    /// The caption strip's content.
    pub caption: Option<&'a Caption>,
}

/// Which overlays the frame view draws, and how.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameViewOptions {
    /// Draw the heatmap (and its colour bar).
    pub heatmap: bool,
    /// Draw the boxes with their labels.
    pub boxes: bool,
    /// Draw the ground-truth anomaly contour.
    pub mask: bool,
    /// Draw the caption strip.
    pub caption: bool,
    /// Colormap of the heatmap and the boxes.
    pub colormap: Colormap,
    /// Heatmap opacity in [0, 1].
    pub opacity: f32,
    /// The heatmap's value range.
    pub range: HeatRange,
    /// Heatmap values below this are transparent; `None` = below the range's low end.
    pub transparent_below: Option<f32>,
    /// Box colours by object score.
    pub box_scale: ScoreScale,
}

impl Default for FrameViewOptions {
    fn default() -> Self {
        Self {
            heatmap: true,
            boxes: true,
            mask: true,
            caption: true,
            colormap: Colormap::Turbo,
            opacity: 0.6,
            range: HeatRange::default(),
            transparent_below: None,
            box_scale: ScoreScale::default(),
        }
    }
}

/// Renders the frame view at `size` (width, height).
pub fn frame_view(
    input: &FrameViewInput<'_>,
    options: &FrameViewOptions,
    size: (u32, u32),
) -> RgbaImage {
    render_view(size, |canvas, rect| {
        draw_frame_view(canvas, input, options, rect)
    })
}

/// The size at which a frame of `frame` (width, height) is drawn 1:1 with a caption strip
/// and a colour bar (as `options` ask).
pub fn natural_size(frame: (u32, u32), options: &FrameViewOptions) -> (u32, u32) {
    let bar = if options.heatmap {
        (44..=76)
            .find(|&b| colour_bar_width(frame.0 + b + 6) == b)
            .map_or(0, |b| b + 6)
    } else {
        0
    };
    let strip = if options.caption {
        (0..=64)
            .find(|&s| caption_height(frame.1 + s) == s)
            .unwrap_or(0)
    } else {
        0
    };
    (frame.0 + bar, frame.1 + strip)
}

/// Width of the colour bar in a view `width` pixels wide (0 when it does not fit).
fn colour_bar_width(width: u32) -> u32 {
    if width >= 160 {
        (width / 12).clamp(44, 76)
    } else {
        0
    }
}

/// Height of the caption strip in a view `height` pixels tall (0 when it does not fit).
pub(crate) fn caption_height(height: u32) -> u32 {
    if height < 60 {
        0
    } else {
        2 * caption_font(height).ceil() as u32 + 12
    }
}

/// Contour width in display pixels: one pixel is lost in the texture of a full-size frame.
fn contour_thickness(width: u32) -> u32 {
    if width >= 320 { 2 } else { 1 }
}

fn caption_font(height: u32) -> f64 {
    (f64::from(height) / 40.0).clamp(9.0, 15.0)
}

/// Draws the frame view into the rectangle (x, y, w, h) of `canvas`.
pub(crate) fn draw_frame_view(
    canvas: &mut Canvas,
    input: &FrameViewInput<'_>,
    options: &FrameViewOptions,
    (x, y, w, h): (i32, i32, u32, u32),
) {
    let strip = if options.caption && input.caption.is_some() {
        caption_height(h)
    } else {
        0
    };
    let show_heat = options.heatmap && input.heatmap.is_some();
    let bar_w = if show_heat { colour_bar_width(w) } else { 0 };
    let area = (
        w.saturating_sub(bar_w + if bar_w > 0 { 6 } else { 0 }),
        h.saturating_sub(strip),
    );
    let frame = input.frame;
    let place = Placement::fit(frame.dimensions(), x, y + strip as i32, area);
    canvas.blit_scaled(frame, place.x, place.y, place.w, place.h);

    let mut range = None;
    if let (true, Some(heat)) = (show_heat, input.heatmap) {
        let (low, high, title) = heat_range(heat, options);
        draw_heatmap(canvas, &place, heat, options, low, high);
        range = Some((low, high, title));
    }
    // The truth contour goes over the boxes: an anomalous vehicle's tight box runs along its
    // silhouette, and the box outline would otherwise hide the contour exactly where it matters.
    if options.boxes {
        draw_boxes(
            canvas,
            &place,
            input.objects,
            options.colormap,
            &options.box_scale,
        );
    }
    let mut contour_drawn = false;
    if options.mask
        && let Some(mask) = input.anomaly_mask
    {
        contour_drawn = mask.as_raw().iter().any(|&v| v > 0);
        let mask_place = Placement {
            sx: place.w as f32 / mask.width().max(1) as f32,
            sy: place.h as f32 / mask.height().max(1) as f32,
            ..place
        };
        draw_mask_contour(
            canvas,
            &mask_place,
            mask,
            MASK_COLOR,
            contour_thickness(place.w),
        );
    }
    if let (Some((low, high, title)), true) = (range, bar_w > 0) {
        let bx = x + w as i32 - bar_w as i32;
        colour_bar(
            canvas,
            bx,
            y + strip as i32 + 4,
            bar_w,
            h.saturating_sub(strip + 8),
            options.colormap,
            (f64::from(low), f64::from(high)),
            title,
        );
    }
    if strip > 0
        && let Some(caption) = input.caption
    {
        let size = caption_font(h);
        let [first, second] = caption.lines();
        let line = (strip as i32 - 8) / 2;
        canvas.text(x + 6, y + 4, &first, size, LEGEND_TEXT, Anchor::TopLeft);
        let alarm =
            matches!((caption.frame_score, caption.threshold), (Some(s), Some(t)) if s >= t);
        let color = if alarm { [255, 120, 90] } else { LEGEND_TEXT };
        canvas.text(
            x + 6,
            y + 4 + line + 2,
            &second,
            size,
            color,
            Anchor::TopLeft,
        );
        if contour_drawn {
            let _ = contour_key(canvas, (x, w), y + 4, &first, size)
                || contour_key(canvas, (x, w), y + 4 + line + 2, &second, size);
        }
    }
}

/// The key to the truth contour at the right end of the caption line `line` drawn at row
/// `top`, when it fits there: an outlined swatch and its meaning, in the contour's colour.
/// Whether it was drawn.
fn contour_key(canvas: &mut Canvas, (x, w): (i32, u32), top: i32, line: &str, size: f64) -> bool {
    const KEY: &str = "ground-truth anomaly mask";
    let used = Canvas::text_size(line, size).0;
    let (tw, th) = Canvas::text_size(KEY, size);
    let swatch = th as i32 * 2 / 3;
    let width = swatch + 6 + tw as i32;
    let left = x + w as i32 - 8 - width;
    if left < x + 6 + used as i32 + 16 {
        return false;
    }
    let swatch_top = top + (th as i32 - swatch) / 2 + 1;
    canvas.outline_rect(
        left,
        swatch_top,
        left + swatch,
        swatch_top + swatch,
        MASK_COLOR,
        2,
    );
    canvas.text(
        left + swatch + 6,
        top,
        KEY,
        size,
        MASK_COLOR,
        Anchor::TopLeft,
    );
    true
}

/// The range the heatmap's colours span, and the colour bar's title.
fn heat_range(heat: &Heatmap, options: &FrameViewOptions) -> (f32, f32, &'static str) {
    match options.range {
        HeatRange::Fixed { low, high } => (
            low,
            if high > low { high } else { low + 1.0 },
            "pixel score",
        ),
        HeatRange::AutoPerFrame => {
            let low = options.transparent_below.unwrap_or(0.0);
            let max = heat
                .values
                .iter()
                .copied()
                .filter(|v| v.is_finite())
                .fold(f32::NEG_INFINITY, f32::max);
            let high = if max > low { max } else { low + 1.0 };
            (low, high, "pixel score (auto range, this frame)")
        }
    }
}

/// Blends the heatmap over the placed frame.
fn draw_heatmap(
    canvas: &mut Canvas,
    place: &Placement,
    heat: &Heatmap,
    options: &FrameViewOptions,
    low: f32,
    high: f32,
) {
    if heat.width == 0
        || heat.height == 0
        || heat.values.len() != heat.width as usize * heat.height as usize
    {
        return;
    }
    let floor = options.transparent_below.unwrap_or(low);
    let lut = options.colormap.lut();
    let opacity = options.opacity.clamp(0.0, 1.0);
    let span = high - low;
    let columns: Vec<usize> = (0..place.w)
        .map(|cx| {
            (((cx as f32 + 0.5) / place.w as f32 * heat.width as f32) as usize)
                .min(heat.width as usize - 1)
        })
        .collect();
    for cy in 0..place.h {
        let hy = (((cy as f32 + 0.5) / place.h as f32 * heat.height as f32) as usize)
            .min(heat.height as usize - 1);
        let row = &heat.values[hy * heat.width as usize..(hy + 1) * heat.width as usize];
        canvas.blend_row(place.x, place.y + cy as i32, place.w, opacity, |cx| {
            let v = row[columns[cx]];
            (v.is_finite() && v >= floor && v > low)
                .then(|| lut[(((v - low) / span).clamp(0.0, 1.0) * 255.0).round() as usize])
        });
    }
}
