//! The plotters backend charts draw through: plotters' bitmap backend over a
//! [`Canvas`](super::canvas::Canvas) for every shape, and our own type setting
//! ([`super::text`]) for every text and its measurement, because plotters' glyph placement
//! truncates each glyph's offsets (points float above the baseline, bearings are lost).

use plotters::backend::{BitMapBackend, DrawingBackend};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
};

use super::text::rasterized;

/// The family name charts' text styles carry; [`ChartBackend`] sets all their text in the
/// shipped font whatever the family says.
pub(crate) const FAMILY: &str = "sans-serif";

/// [`BitMapBackend`] with text set by [`super::text`].
pub(crate) struct ChartBackend<'a> {
    inner: BitMapBackend<'a>,
}

impl<'a> ChartBackend<'a> {
    /// Wraps a bitmap backend.
    pub(crate) fn new(inner: BitMapBackend<'a>) -> Self {
        Self { inner }
    }
}

type Failure<'a> = DrawingErrorKind<<BitMapBackend<'a> as DrawingBackend>::ErrorType>;

impl<'a> DrawingBackend for ChartBackend<'a> {
    type ErrorType = <BitMapBackend<'a> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), Failure<'a>> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), Failure<'a>> {
        self.inner.present()
    }

    fn draw_pixel(&mut self, point: BackendCoord, color: BackendColor) -> Result<(), Failure<'a>> {
        self.inner.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), Failure<'a>> {
        self.inner.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), Failure<'a>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), Failure<'a>> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), Failure<'a>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let Some(raster) = rasterized(text, style.size()) else {
            return Ok(());
        };
        let (dx, dy) = raster.anchor_offset(style.anchor());
        let transform = style.transform();
        let (width, height) = self.get_size();
        for &(px, py, coverage) in &raster.coverage {
            let (x, y) = transform.transform(px + dx, py + dy);
            let (x, y) = (pos.0 + x, pos.1 + y);
            if x >= 0 && y >= 0 && (x as u32) < width && (y as u32) < height {
                let ink = BackendColor {
                    alpha: color.alpha * f64::from(coverage),
                    rgb: color.rgb,
                };
                self.inner.draw_pixel((x, y), ink)?;
            }
        }
        Ok(())
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), Failure<'a>> {
        Ok(rasterized(text, style.size()).map_or((0, 0), |r| (r.width, r.height)))
    }
}
