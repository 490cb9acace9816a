//! Type setting in the shipped DejaVu Sans: one line of text laid out along a baseline with
//! kerning and each glyph's own side bearing, rasterised at sub-pixel positions into a
//! coverage list, and cached per thread. Views and charts (through
//! [`ChartBackend`](super::chart_backend::ChartBackend)) both set type here, so a "0.5" has
//! its point on the baseline wherever it is drawn.

use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use plotters_backend::text_anchor::{HPos, Pos, VPos};

/// The font every view writes with.
const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// The parsed shipped font; `None` only if the compiled-in file were corrupt, which leaves
/// text blank rather than failing a render.
fn font() -> Option<&'static FontRef<'static>> {
    static PARSED: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    PARSED
        .get_or_init(|| FontRef::try_from_slice(FONT).ok())
        .as_ref()
}

/// A line of text rasterised once: its layout box (advance width by line height, the
/// baseline at the font's ascent) and the coverage of every pixel it touches, relative to
/// the box's top-left corner.
pub(crate) struct RasterText {
    /// Width of the layout box: the sum of advances and kerning, rounded up.
    pub(crate) width: u32,
    /// Height of the layout box: ascent minus descent, rounded up.
    pub(crate) height: u32,
    /// (x, y, coverage in (0, 1]) of every touched pixel.
    pub(crate) coverage: Vec<(i32, i32, f32)>,
}

impl RasterText {
    /// Where the box's top-left corner lies relative to the anchor point `pos` names.
    pub(crate) fn anchor_offset(&self, pos: Pos) -> (i32, i32) {
        let (w, h) = (self.width as i32, self.height as i32);
        let dx = match pos.h_pos {
            HPos::Left => 0,
            HPos::Center => -w / 2,
            HPos::Right => -w,
        };
        let dy = match pos.v_pos {
            VPos::Top => 0,
            VPos::Center => -h / 2,
            VPos::Bottom => -h,
        };
        (dx, dy)
    }
}

/// Texts rasterised at most before the cache starts afresh (views draw a few hundred).
const RASTER_CACHE: usize = 4096;

thread_local! {
    /// Rasterised texts by size (its bits) and text: views redraw the same titles, labels
    /// and numbers every frame, and glyph outlines are the expensive part of text.
    static RASTERS: RefCell<HashMap<u64, HashMap<String, Rc<RasterText>>>> =
        RefCell::new(HashMap::new());
}

/// `text` at `size` pixels (ascent minus descent), from the cache or rasterised now; `None`
/// when the font is unavailable.
pub(crate) fn rasterized(text: &str, size: f64) -> Option<Rc<RasterText>> {
    let cached = RASTERS.with_borrow(|cache| {
        cache
            .get(&size.to_bits())
            .and_then(|texts| texts.get(text).cloned())
    });
    if cached.is_some() {
        return cached;
    }
    let raster = Rc::new(rasterize(font()?, text, size as f32));
    RASTERS.with_borrow_mut(|cache| {
        if cache.values().map(HashMap::len).sum::<usize>() >= RASTER_CACHE {
            cache.clear();
        }
        cache
            .entry(size.to_bits())
            .or_default()
            .insert(text.to_string(), Rc::clone(&raster));
    });
    Some(raster)
}

/// Lays `text` out on a baseline at the font's ascent and rasterises every glyph at its
/// exact (fractional) pen position; glyph pixels are placed by their own pixel bounds, so
/// a full stop sits on the baseline and narrow glyphs keep their side bearings.
fn rasterize(font: &FontRef<'static>, text: &str, size: f32) -> RasterText {
    let scale = PxScale::from(size.max(0.0));
    let scaled = font.as_scaled(scale);
    let ascent = scaled.ascent();
    let mut caret = 0.0f32;
    let mut previous = None;
    let mut coverage = Vec::new();
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(prev) = previous {
            caret += scaled.kern(prev, id);
        }
        let glyph = id.with_scale_and_position(scale, point(caret, ascent));
        if let Some(outline) = font.outline_glyph(glyph) {
            let bounds = outline.px_bounds();
            let (left, top) = (bounds.min.x as i32, bounds.min.y as i32);
            outline.draw(|x, y, alpha| {
                if alpha > 0.0 {
                    coverage.push((left + x as i32, top + y as i32, alpha.min(1.0)));
                }
            });
        }
        caret += scaled.h_advance(id);
        previous = Some(id);
    }
    RasterText {
        width: caret.max(0.0).ceil() as u32,
        // Ascent minus descent is the pixel size by construction; the margin keeps float
        // noise from rounding it up a pixel.
        height: (ascent - scaled.descent() - 1e-3).max(0.0).ceil() as u32,
        coverage,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lowest row a text's ink reaches, relative to its box top.
    fn ink_bottom(raster: &RasterText) -> i32 {
        raster
            .coverage
            .iter()
            .filter(|&&(_, _, a)| a > 0.25)
            .map(|&(_, y, _)| y)
            .max()
            .unwrap_or(-1)
    }

    #[test]
    fn full_stop_sits_on_the_same_baseline_as_digits() {
        for size in [11.0, 12.0, 12.5, 15.0, 22.0, 31.0] {
            let digit = rasterized("0", size).expect("font");
            let stop = rasterized(".", size).expect("font");
            assert_eq!(
                ink_bottom(&digit),
                ink_bottom(&stop),
                "size {size}: the point must end on the digits' baseline row"
            );
        }
    }

    #[test]
    fn layout_box_grows_with_text_and_size() {
        let short = rasterized("0.5", 12.0).expect("font");
        let long = rasterized("0.5 0.5", 12.0).expect("font");
        let big = rasterized("0.5", 24.0).expect("font");
        assert!(long.width > short.width);
        assert!(big.width > short.width && big.height > short.height);
        assert_eq!(short.height, 12, "line height is the pixel size");
        assert!(
            short
                .coverage
                .iter()
                .all(|&(x, y, _)| x >= 0 && y >= 0 && (y as u32) < short.height),
            "ink stays inside the line box vertically"
        );
    }

    #[test]
    fn glyphs_keep_their_side_bearings() {
        let stop = rasterized(".", 20.0).expect("font");
        let leftmost = stop.coverage.iter().map(|&(x, _, _)| x).min().expect("ink");
        assert!(
            leftmost > 0,
            "a full stop starts after its left side bearing"
        );
    }
}
