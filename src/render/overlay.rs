//! What the views draw on top of a frame: scored object boxes with their labels, the
//! ground-truth anomaly mask as a contour, and the placement of a frame inside a view.

use image::GrayImage;

use crate::score::ObjectMaps;

use super::canvas::Canvas;
use super::colormap::Colormap;

/// One object of a frame as the views show it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneObject<'a> {
    /// The box, [x1, y1, x2, y2] in frame pixels (x2/y2 exclusive).
    pub bbox: [f32; 4],
    /// Track id (0 when the box source has none).
    pub track_id: u64,
    /// The fused object score, if scored.
    pub score: Option<f64>,
    /// The model's maps of this object (predicted patch, errors, reconstructed flow), if
    /// scored.
    pub maps: Option<&'a ObjectMaps>,
}

/// How object scores become box colours: the colormap over `range`, so the threshold sits
/// where the analyst expects it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoreScale {
    /// Score drawn in the colormap's first colour.
    pub low: f64,
    /// Score drawn in the colormap's last colour.
    pub high: f64,
}

impl Default for ScoreScale {
    /// 0 to 60: the paper-text weights' default threshold (30) in the middle.
    fn default() -> Self {
        Self {
            low: 0.0,
            high: 60.0,
        }
    }
}

impl ScoreScale {
    /// A scale that puts `threshold` in the middle (0 … 2·threshold, or −1 … 1 when the
    /// threshold is not positive).
    pub fn around(threshold: f64) -> Self {
        if threshold.is_finite() && threshold > 0.0 {
            Self {
                low: 0.0,
                high: 2.0 * threshold,
            }
        } else {
            Self {
                low: threshold - 1.0,
                high: threshold + 1.0,
            }
        }
    }

    /// Position of `score` on the scale, in [0, 1].
    pub fn position(&self, score: f64) -> f32 {
        let span = self.high - self.low;
        if !(span.is_finite() && span > 0.0 && score.is_finite()) {
            return 0.0;
        }
        ((score - self.low) / span).clamp(0.0, 1.0) as f32
    }
}

/// Colour of a box without a score.
pub(crate) const UNSCORED_BOX: [u8; 3] = [200, 200, 200];

/// Where a frame of `frame_w`×`frame_h` lands inside a view: offset and scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Placement {
    /// Left edge on the canvas.
    pub x: i32,
    /// Top edge on the canvas.
    pub y: i32,
    /// Drawn width.
    pub w: u32,
    /// Drawn height.
    pub h: u32,
    /// Canvas pixels per frame pixel, horizontally.
    pub sx: f32,
    /// Canvas pixels per frame pixel, vertically.
    pub sy: f32,
}

impl Placement {
    /// The largest aspect-preserving fit of `frame` (w, h) centred in the box at (x, y) of
    /// `area` (w, h).
    pub(crate) fn fit(frame: (u32, u32), x: i32, y: i32, area: (u32, u32)) -> Self {
        let (fw, fh) = (frame.0.max(1) as f32, frame.1.max(1) as f32);
        let scale = (area.0 as f32 / fw).min(area.1 as f32 / fh);
        let w = ((fw * scale).round() as u32).clamp(1, area.0.max(1));
        let h = ((fh * scale).round() as u32).clamp(1, area.1.max(1));
        Self {
            x: x + (area.0.saturating_sub(w) / 2) as i32,
            y: y + (area.1.saturating_sub(h) / 2) as i32,
            w,
            h,
            sx: w as f32 / fw,
            sy: h as f32 / fh,
        }
    }

    /// Canvas rectangle (x0, y0, x1, y1) of a frame box [x1, y1, x2, y2].
    pub(crate) fn rect(&self, bbox: [f32; 4]) -> (i32, i32, i32, i32) {
        let f = |v: f32, s: f32, o: i32| o + (v * s).round() as i32;
        (
            f(bbox[0], self.sx, self.x),
            f(bbox[1], self.sy, self.y),
            f(bbox[2], self.sx, self.x),
            f(bbox[3], self.sy, self.y),
        )
    }
}

/// Font size of box labels for a view `height` pixels tall.
pub(crate) fn label_size(height: u32) -> f64 {
    (f64::from(height) / 36.0).clamp(9.0, 16.0)
}

/// Boxes labelled at most, the highest-scoring first (crowded scenes stay readable).
pub const LABELLED_BOXES: usize = 6;

/// Draws the boxes of `objects` coloured by score, and "#track score" labels on the
/// [`LABELLED_BOXES`] highest-scoring ones whose label does not cover another label.
pub(crate) fn draw_boxes(
    canvas: &mut Canvas,
    place: &Placement,
    objects: &[SceneObject<'_>],
    colormap: Colormap,
    scale: &ScoreScale,
) {
    let size = label_size(place.h);
    let thickness = if place.h >= 240 { 2 } else { 1 };
    let color_of = |object: &SceneObject<'_>| {
        object
            .score
            .map_or(UNSCORED_BOX, |s| colormap.colorize(scale.position(s)))
    };
    for object in objects {
        let (x0, y0, x1, y1) = place.rect(object.bbox);
        if x1 > x0 && y1 > y0 {
            canvas.outline_rect(x0, y0, x1, y1, color_of(object), thickness);
        }
    }
    if place.h < 48 {
        return;
    }
    let mut order: Vec<&SceneObject<'_>> = objects.iter().collect();
    order.sort_by(|a, b| {
        let key = |o: &SceneObject<'_>| o.score.unwrap_or(f64::NEG_INFINITY);
        key(b).total_cmp(&key(a))
    });
    let mut taken: Vec<(i32, i32, i32, i32)> = Vec::new();
    for object in order {
        if taken.len() >= LABELLED_BOXES {
            break;
        }
        let (x0, y0, x1, y1) = place.rect(object.bbox);
        if x1 <= x0 || y1 <= y0 {
            continue;
        }
        let text = match object.score {
            Some(s) => format!("#{} {s:.1}", object.track_id),
            None => format!("#{}", object.track_id),
        };
        let (w, h) = Canvas::label_size(&text, size);
        let ly = if y0 - h >= place.y { y0 - h } else { y1 };
        let rect = (x0, ly, x0 + w, ly + h);
        let overlaps = taken
            .iter()
            .any(|r| rect.0 < r.2 && r.0 < rect.2 && rect.1 < r.3 && r.1 < rect.3);
        if overlaps {
            continue;
        }
        taken.push(rect);
        let plate = color_of(object);
        let luminance =
            0.299 * f32::from(plate[0]) + 0.587 * f32::from(plate[1]) + 0.114 * f32::from(plate[2]);
        let ink = if luminance > 140.0 {
            [0, 0, 0]
        } else {
            [255, 255, 255]
        };
        canvas.label(x0, ly, &text, size, ink, plate);
    }
}

/// Draws the outline of the non-zero region of `mask` (frame pixels) in `color`, `thickness`
/// display pixels wide on the inside of the region.
pub(crate) fn draw_mask_contour(
    canvas: &mut Canvas,
    place: &Placement,
    mask: &GrayImage,
    color: [u8; 3],
    thickness: u32,
) {
    let (mw, mh) = mask.dimensions();
    if mw == 0 || mh == 0 {
        return;
    }
    let inside = |x: i64, y: i64| -> bool {
        x >= 0
            && y >= 0
            && x < i64::from(mw)
            && y < i64::from(mh)
            && mask.get_pixel(x as u32, y as u32)[0] > 0
    };
    let reach = thickness.max(1) as f32;
    for cy in 0..place.h as i64 {
        for cx in 0..place.w as i64 {
            let mx = ((cx as f32 + 0.5) / place.sx) as i64;
            let my = ((cy as f32 + 0.5) / place.sy) as i64;
            if !inside(mx, my) {
                continue;
            }
            let step_x = ((cx as f32 + 0.5 + reach) / place.sx).floor() as i64;
            let step_y = ((cy as f32 + 0.5 + reach) / place.sy).floor() as i64;
            let back_x = ((cx as f32 + 0.5 - reach) / place.sx).floor() as i64;
            let back_y = ((cy as f32 + 0.5 - reach) / place.sy).floor() as i64;
            let edge = !inside(step_x, my)
                || !inside(back_x, my)
                || !inside(mx, step_y)
                || !inside(mx, back_y);
            if edge {
                canvas.put(place.x + cx as i32, place.y + cy as i32, color);
            }
        }
    }
}
