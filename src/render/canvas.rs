//! The drawing surface of every view: an opaque RGB raster with alpha-blended rectangles,
//! lines, scaled image blits and text in the shipped DejaVu Sans font (no system fonts, so
//! the same inputs give the same bytes everywhere, set by [`super::text`]). Charts draw on
//! it through plotters ([`Canvas::plotters`]).

use image::{RgbImage, RgbaImage};
use plotters::backend::BitMapBackend;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::chart_backend::ChartBackend;
use super::text::rasterized;

/// Where a text's anchor point lies on the text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Anchor {
    /// Anchor at the top-left corner.
    TopLeft,
    /// Anchor at the middle of the top edge.
    TopCenter,
    /// Anchor at the middle of the left edge.
    MiddleLeft,
    /// Anchor at the middle of the right edge.
    MiddleRight,
    /// Anchor at the centre.
    Center,
}

impl Anchor {
    fn pos(self) -> Pos {
        match self {
            Self::TopLeft => Pos::new(HPos::Left, VPos::Top),
            Self::TopCenter => Pos::new(HPos::Center, VPos::Top),
            Self::MiddleLeft => Pos::new(HPos::Left, VPos::Center),
            Self::MiddleRight => Pos::new(HPos::Right, VPos::Center),
            Self::Center => Pos::new(HPos::Center, VPos::Center),
        }
    }
}

/// Background of every view.
pub(crate) const BACKGROUND: [u8; 3] = [24, 26, 30];

/// A view of `size` (width, height): a canvas on [`BACKGROUND`] that `draw` fills, given
/// the whole canvas as a rectangle (x, y, w, h).
pub(crate) fn render_view(
    size: (u32, u32),
    draw: impl FnOnce(&mut Canvas, (i32, i32, u32, u32)),
) -> RgbaImage {
    let mut canvas = Canvas::new(size.0, size.1, BACKGROUND);
    let rect = (0, 0, canvas.width(), canvas.height());
    draw(&mut canvas, rect);
    canvas.into_rgba()
}

/// An RGB raster, row-major, 3 bytes per pixel.
pub(crate) struct Canvas {
    width: u32,
    height: u32,
    pixels: Vec<u8>,
}

impl Canvas {
    /// A canvas of `width`×`height` (at least 1×1) filled with `background`.
    pub(crate) fn new(width: u32, height: u32, background: [u8; 3]) -> Self {
        let (width, height) = (width.max(1), height.max(1));
        let pixels = background.repeat(width as usize * height as usize);
        Self {
            width,
            height,
            pixels,
        }
    }

    /// Width in pixels.
    pub(crate) fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub(crate) fn height(&self) -> u32 {
        self.height
    }

    /// The finished image, fully opaque.
    pub(crate) fn into_rgba(self) -> RgbaImage {
        let mut out = vec![255u8; 4 * self.width as usize * self.height as usize];
        for (rgba, rgb) in out.chunks_exact_mut(4).zip(self.pixels.chunks_exact(3)) {
            rgba[..3].copy_from_slice(rgb);
        }
        RgbaImage::from_raw(self.width, self.height, out).expect("buffer matches its size")
    }

    fn offset(&self, x: i32, y: i32) -> Option<usize> {
        (x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height)
            .then(|| 3 * (y as usize * self.width as usize + x as usize))
    }

    /// Sets pixel (x, y); outside pixels are ignored.
    pub(crate) fn put(&mut self, x: i32, y: i32, color: [u8; 3]) {
        if let Some(o) = self.offset(x, y) {
            self.pixels[o..o + 3].copy_from_slice(&color);
        }
    }

    /// Blends `color` over pixel (x, y) with opacity `alpha` in [0, 1].
    pub(crate) fn blend(&mut self, x: i32, y: i32, color: [u8; 3], alpha: f32) {
        if let Some(o) = self.offset(x, y) {
            blend_into(&mut self.pixels[o..o + 3], color, alpha);
        }
    }

    /// Blends, at opacity `alpha`, the colour `color_of(k)` (`None` = nothing) over pixel
    /// (x + k, y) for k in `0..len`; clipped to the canvas.
    pub(crate) fn blend_row(
        &mut self,
        x: i32,
        y: i32,
        len: u32,
        alpha: f32,
        mut color_of: impl FnMut(usize) -> Option<[u8; 3]>,
    ) {
        let first = (-x).clamp(0, len as i32) as usize;
        let a = fixed_alpha(alpha);
        let span = self.row_span(y, x + first as i32, x + len as i32);
        for (k, px) in span.chunks_exact_mut(3).enumerate() {
            if let Some(color) = color_of(first + k) {
                blend_fixed(px, color, a);
            }
        }
    }

    /// Row `y`, columns `x0..x1`, clipped to the canvas; empty outside.
    fn row_span(&mut self, y: i32, x0: i32, x1: i32) -> &mut [u8] {
        if y < 0 || y as u32 >= self.height {
            return &mut [];
        }
        let x0 = x0.clamp(0, self.width as i32) as usize;
        let x1 = x1.clamp(0, self.width as i32) as usize;
        let row = 3 * y as usize * self.width as usize;
        if x1 <= x0 {
            return &mut [];
        }
        &mut self.pixels[row + 3 * x0..row + 3 * x1]
    }

    /// Fills columns `x0..x1`, rows `y0..y1` with `color` at opacity `alpha`.
    pub(crate) fn fill_rect(
        &mut self,
        x0: i32,
        y0: i32,
        x1: i32,
        y1: i32,
        color: [u8; 3],
        alpha: f32,
    ) {
        let a = fixed_alpha(alpha);
        for y in y0.max(0)..y1.min(self.height as i32) {
            let span = self.row_span(y, x0, x1);
            if a >= 256 {
                for px in span.chunks_exact_mut(3) {
                    px.copy_from_slice(&color);
                }
            } else {
                for px in span.chunks_exact_mut(3) {
                    blend_fixed(px, color, a);
                }
            }
        }
    }

    /// Draws the outline of columns `x0..x1`, rows `y0..y1`, `thickness` pixels inwards.
    pub(crate) fn outline_rect(
        &mut self,
        x0: i32,
        y0: i32,
        x1: i32,
        y1: i32,
        color: [u8; 3],
        thickness: i32,
    ) {
        let t = thickness.max(1);
        self.fill_rect(x0, y0, x1, (y0 + t).min(y1), color, 1.0);
        self.fill_rect(x0, (y1 - t).max(y0), x1, y1, color, 1.0);
        self.fill_rect(x0, y0, (x0 + t).min(x1), y1, color, 1.0);
        self.fill_rect((x1 - t).max(x0), y0, x1, y1, color, 1.0);
    }

    /// A vertical line in column `x` from row `y0` to row `y1`, both included; clipped.
    pub(crate) fn vline(&mut self, x: i32, y0: i32, y1: i32, color: [u8; 3]) {
        if x < 0 || x as u32 >= self.width {
            return;
        }
        let (top, bottom) = (y0.min(y1).max(0), y0.max(y1).min(self.height as i32 - 1));
        let stride = 3 * self.width as usize;
        for y in top..=bottom {
            let o = y as usize * stride + 3 * x as usize;
            self.pixels[o..o + 3].copy_from_slice(&color);
        }
    }

    /// A straight line from (x0, y0) to (x1, y1), both ends included (Bresenham).
    pub(crate) fn line(&mut self, x0: i32, y0: i32, x1: i32, y1: i32, color: [u8; 3]) {
        let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
        let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
        let (mut x, mut y, mut err) = (x0, y0, dx + dy);
        // A line is at most as long as the canvas allows; clip the walk to stay bounded.
        let limit = 4 * (self.width + self.height) as i64 + (dx - dy) as i64;
        for _ in 0..=limit {
            self.put(x, y, color);
            if x == x1 && y == y1 {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }

    /// Draws `image` scaled (bilinear) into columns `x..x+w`, rows `y..y+h`. Separable: each
    /// source row is interpolated horizontally once, then pairs of rows vertically.
    pub(crate) fn blit_scaled(&mut self, image: &RgbImage, x: i32, y: i32, w: u32, h: u32) {
        if image.width() == 0 || image.height() == 0 || w == 0 || h == 0 {
            return;
        }
        // Only the visible columns are computed.
        let (c0, c1) = (
            (-x).clamp(0, w as i32) as usize,
            (self.width as i32 - x).clamp(0, w as i32) as usize,
        );
        if c1 <= c0 {
            return;
        }
        let xs = &sample_taps(image.width(), w)[c0..c1];
        let ys = sample_taps(image.height(), h);
        let src = image.as_raw();
        let stride = 3 * image.width() as usize;
        let horizontal = |row: usize, out: &mut Vec<f32>| {
            out.clear();
            let line = &src[row * stride..(row + 1) * stride];
            for &(x0, x1, fx) in xs {
                for c in 0..3 {
                    let (a, b) = (f32::from(line[3 * x0 + c]), f32::from(line[3 * x1 + c]));
                    out.push(a * (1.0 - fx) + b * fx);
                }
            }
        };
        let (mut top, mut bottom) = (Vec::new(), Vec::new());
        let mut cached: (Option<usize>, Option<usize>) = (None, None);
        for (row, &(y0, y1, fy)) in ys.iter().enumerate() {
            let ty = y + row as i32;
            if ty < 0 || ty as u32 >= self.height {
                continue;
            }
            if cached.0 != Some(y0) {
                if cached.1 == Some(y0) {
                    std::mem::swap(&mut top, &mut bottom);
                    cached.1 = None;
                } else {
                    horizontal(y0, &mut top);
                }
                cached.0 = Some(y0);
            }
            if cached.1 != Some(y1) {
                horizontal(y1, &mut bottom);
                cached.1 = Some(y1);
            }
            let span = self.row_span(ty, x + c0 as i32, x + c1 as i32);
            for ((px, t), b) in span.iter_mut().zip(&top).zip(&bottom) {
                // Non-negative, so adding one half and truncating rounds.
                *px = (t * (1.0 - fy) + b * fy + 0.5) as u8;
            }
        }
    }

    /// Copies `image` 1:1 with its top-left corner at (x, y), clipped.
    pub(crate) fn blit(&mut self, image: &RgbImage, x: i32, y: i32) {
        let stride = 3 * image.width() as usize;
        let x0 = x.max(0);
        let x1 = (x + image.width() as i32).min(self.width as i32);
        if x1 <= x0 {
            return;
        }
        for row in 0..image.height() as i32 {
            let span = self.row_span(y + row, x0, x1);
            if span.is_empty() {
                continue;
            }
            let from = row as usize * stride + 3 * (x0 - x) as usize;
            span.copy_from_slice(&image.as_raw()[from..from + span.len()]);
        }
    }

    /// Draws `image` scaled with nearest-neighbour sampling (crisp patch pixels) into
    /// columns `x..x+w`, rows `y..y+h`.
    pub(crate) fn blit_scaled_nearest(&mut self, image: &RgbImage, x: i32, y: i32, w: u32, h: u32) {
        if image.width() == 0 || image.height() == 0 || w == 0 {
            return;
        }
        let first = (-x).clamp(0, w as i32) as u32;
        let columns: Vec<usize> = (first..w)
            .map(|col| 3 * (u64::from(col) * u64::from(image.width()) / u64::from(w)) as usize)
            .collect();
        let stride = 3 * image.width() as usize;
        for row in 0..h {
            let sy = (u64::from(row) * u64::from(image.height()) / u64::from(h)) as usize;
            let line = &image.as_raw()[sy * stride..(sy + 1) * stride];
            let span = self.row_span(y + row as i32, x + first as i32, x + w as i32);
            for (px, &sx) in span.chunks_exact_mut(3).zip(&columns) {
                px.copy_from_slice(&line[sx..sx + 3]);
            }
        }
    }

    /// Copies the rectangle (x, y, w, h) of this canvas to top-left corner (to_x, to_y);
    /// both clipped to the canvas.
    pub(crate) fn copy_within(&mut self, (x, y, w, h): (i32, i32, u32, u32), to_x: i32, to_y: i32) {
        let x0 = x.max(0).max(x - to_x);
        let x1 = (x + w as i32)
            .min(self.width as i32)
            .min(self.width as i32 + x - to_x);
        if x1 <= x0 {
            return;
        }
        let stride = 3 * self.width as usize;
        for row in 0..h as i32 {
            let (sy, dy) = (y + row, to_y + row);
            if sy < 0 || dy < 0 || sy as u32 >= self.height || dy as u32 >= self.height {
                continue;
            }
            let from = sy as usize * stride + 3 * x0 as usize;
            let to = dy as usize * stride + 3 * (x0 + to_x - x) as usize;
            self.pixels
                .copy_within(from..from + 3 * (x1 - x0) as usize, to);
        }
    }

    /// Copies `other` with its top-left corner at (x, y), clipped.
    pub(crate) fn paste(&mut self, other: &Canvas, x: i32, y: i32) {
        for row in 0..other.height as i32 {
            let src_row = 3 * row as usize * other.width as usize;
            let x0 = x.max(0);
            let x1 = (x + other.width as i32).min(self.width as i32);
            if x1 <= x0 {
                return;
            }
            let span = self.row_span(y + row, x0, x1);
            if span.is_empty() {
                continue;
            }
            let from = src_row + 3 * (x0 - x) as usize;
            span.copy_from_slice(&other.pixels[from..from + span.len()]);
        }
    }

    /// Width and height of `text` at `size` pixels.
    pub(crate) fn text_size(text: &str, size: f64) -> (u32, u32) {
        rasterized(text, size).map_or((0, 0), |r| (r.width, r.height))
    }

    /// `text` made to fit `width` pixels: drawn at the largest size at most `size` (and at
    /// least 7 pixels) at which it fits, and cut short with an ellipsis when even 7 pixels
    /// is too wide. Returns the text to draw and its size.
    pub(crate) fn fitted(text: &str, size: f64, width: u32) -> (String, f64) {
        let mut size = size;
        while size > 7.0 && Self::text_size(text, size).0 > width {
            size = (size - 1.0).max(7.0);
        }
        if Self::text_size(text, size).0 <= width {
            return (text.to_string(), size);
        }
        // Longest prefix first: drop one character at a time until prefix + "…" fits.
        for (end, _) in text.char_indices().rev() {
            let cut = format!("{}…", text[..end].trim_end());
            if Self::text_size(&cut, size).0 <= width {
                return (cut, size);
            }
        }
        (String::new(), size)
    }

    /// Draws `text` at `size` pixels with its `anchor` at (x, y); clipped to the canvas.
    pub(crate) fn text(
        &mut self,
        x: i32,
        y: i32,
        text: &str,
        size: f64,
        color: [u8; 3],
        anchor: Anchor,
    ) {
        if text.is_empty() || size < 1.0 {
            return;
        }
        let Some(raster) = rasterized(text, size) else {
            return;
        };
        let (dx, dy) = raster.anchor_offset(anchor.pos());
        for &(px, py, alpha) in &raster.coverage {
            self.blend(x + dx + px, y + dy + py, color, alpha);
        }
    }

    /// The padding around a label's text at `size` pixels.
    fn label_pad(size: f64) -> i32 {
        (size / 5.0).ceil() as i32
    }

    /// Width and height of the plate [`Canvas::label`] draws for `text` at `size` pixels.
    pub(crate) fn label_size(text: &str, size: f64) -> (i32, i32) {
        let (w, h) = Self::text_size(text, size);
        let pad = Self::label_pad(size);
        (w as i32 + 2 * pad, h as i32 + 2 * pad)
    }

    /// Draws `text` on a translucent dark plate (for labels over images), its top-left
    /// corner at (x, y).
    pub(crate) fn label(
        &mut self,
        x: i32,
        y: i32,
        text: &str,
        size: f64,
        color: [u8; 3],
        plate: [u8; 3],
    ) {
        let (w, h) = Self::label_size(text, size);
        let pad = Self::label_pad(size);
        self.fill_rect(x, y, x + w, y + h, plate, 0.8);
        self.text(x + pad, y + pad, text, size, color, Anchor::TopLeft);
    }

    /// A plotters backend over this canvas, for charts.
    pub(crate) fn plotters(&mut self) -> ChartBackend<'_> {
        ChartBackend::new(BitMapBackend::with_buffer(
            &mut self.pixels,
            (self.width, self.height),
        ))
    }
}

/// Blends `color` over the RGB pixel `px` with opacity `alpha`.
fn blend_into(px: &mut [u8], color: [u8; 3], alpha: f32) {
    blend_fixed(px, color, fixed_alpha(alpha));
}

/// Opacity in [0, 1] as a weight in 0..=256 for [`blend_fixed`].
fn fixed_alpha(alpha: f32) -> u32 {
    (alpha.clamp(0.0, 1.0) * 256.0 + 0.5) as u32
}

/// Blends `color` over the RGB pixel `px` with weight `a` in 0..=256 (integer arithmetic,
/// rounded).
fn blend_fixed(px: &mut [u8], color: [u8; 3], a: u32) {
    for c in 0..3 {
        px[c] = ((u32::from(px[c]) * (256 - a) + u32::from(color[c]) * a + 128) >> 8) as u8;
    }
}

/// Bilinear source taps (left, right, weight of right) for `out` samples of `len` source
/// pixels, half-pixel centres, clamped at the edges.
pub(crate) fn sample_taps(len: u32, out: u32) -> Vec<(usize, usize, f32)> {
    let scale = len as f32 / out.max(1) as f32;
    (0..out)
        .map(|d| {
            let f = ((d as f32 + 0.5) * scale - 0.5).max(0.0);
            let i = (f.floor() as usize).min(len as usize - 1);
            let j = (i + 1).min(len as usize - 1);
            (i, j, f - i as f32)
        })
        .collect()
}
