//! The layout the prediction and flow views share: a row of equally wide panels of the
//! frame (each under its title, some with a model output painted into the object boxes, all
//! with the scored boxes on top) above the per-object error gallery.

use image::RgbImage;

use crate::flow::{FlowColorRange, colorize_flow};
use crate::sequence::FlowField;

use super::canvas::{Anchor, Canvas};
use super::colormap::Colormap;
use super::gallery::{ErrorGallery, draw_error_gallery};
use super::legend::LEGEND_TEXT;
use super::overlay::{Placement, SceneObject, ScoreScale, draw_boxes};
use super::patches::crop_range;

/// What fills a panel before the patches are painted into the boxes.
pub(crate) enum Backdrop<'a> {
    /// An image of the frame's size, scaled into the panel.
    Image(&'a RgbImage),
    /// A flow field (at least as many values as its size says) on the colour wheel at full
    /// colour at this many pixels, sampled at the panel's own resolution (nearest grid
    /// point).
    Flow(&'a FlowField, f32),
    /// One colour.
    Fill([u8; 3]),
    /// The backdrop of the earlier panel with this index, copied rather than drawn again.
    SameAs(usize),
}

/// One panel of the row.
pub(crate) struct Panel<'a> {
    /// Title above the panel.
    pub title: &'a str,
    /// What fills it.
    pub backdrop: Backdrop<'a>,
    /// Per object (in the order of the objects), a patch scaled into its box, or `None`.
    pub patches: Vec<Option<RgbImage>>,
    /// A key drawn in the panel's top-right corner, a quarter of its height (e.g. the flow's
    /// colour wheel).
    pub key: Option<RgbImage>,
}

/// How the panels draw the boxes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BoxStyle {
    /// Colormap of the box colours.
    pub colormap: Colormap,
    /// Box colours by object score.
    pub scale: ScoreScale,
}

/// Draws `panels` of a frame of size `frame` side by side in the upper part of the rectangle
/// (x, y, w, h) and `gallery` below them.
pub(crate) fn draw_comparison(
    canvas: &mut Canvas,
    (x, y, w, h): (i32, i32, u32, u32),
    frame: (u32, u32),
    panels: &[Panel<'_>],
    objects: &[SceneObject<'_>],
    boxes: BoxStyle,
    gallery: &ErrorGallery<'_>,
) {
    let font = (f64::from(h) / 30.0).clamp(9.0, 14.0);
    let title_h = Canvas::text_size("Ag", font).1 + 6;
    let top_h = (h * 11 / 20).saturating_sub(title_h);
    let each = w / panels.len().max(1) as u32;
    let mut places: Vec<Placement> = Vec::with_capacity(panels.len());
    for (k, panel) in panels.iter().enumerate() {
        let px = x + (k as u32 * each) as i32;
        let (title, size) = Canvas::fitted(panel.title, font, each.saturating_sub(6));
        canvas.text(
            px + each as i32 / 2,
            y + 2,
            &title,
            size,
            LEGEND_TEXT,
            Anchor::TopCenter,
        );
        let place = Placement::fit(
            frame,
            px + 2,
            y + title_h as i32,
            (each.saturating_sub(4), top_h),
        );
        match panel.backdrop {
            Backdrop::SameAs(earlier) if earlier < k => {
                let from = places[earlier];
                canvas.copy_within((from.x, from.y, from.w, from.h), place.x, place.y);
            }
            _ => draw_backdrop(canvas, &place, &panel.backdrop),
        }
        places.push(place);
        for (object, patch) in objects.iter().zip(&panel.patches) {
            let (Some(patch), Some((x0, y0, x1, y1))) = (patch, crop_range(object.bbox, frame))
            else {
                continue;
            };
            let (cx0, cy0, cx1, cy1) = place.rect([x0 as f32, y0 as f32, x1 as f32, y1 as f32]);
            if cx1 > cx0 && cy1 > cy0 {
                canvas.blit_scaled(patch, cx0, cy0, (cx1 - cx0) as u32, (cy1 - cy0) as u32);
            }
        }
        draw_boxes(canvas, &place, objects, boxes.colormap, &boxes.scale);
        if let Some(key) = &panel.key {
            let side = (place.h / 4).min(place.w / 4);
            if side >= 12 {
                let kx = place.x + (place.w - side) as i32 - 3;
                canvas.fill_rect(
                    kx - 1,
                    place.y + 2,
                    kx + side as i32 + 1,
                    place.y + side as i32 + 4,
                    [20, 20, 20],
                    0.8,
                );
                canvas.blit_scaled(key, kx, place.y + 3, side, side);
            }
        }
    }
    let gallery_y = y + (title_h + top_h) as i32 + 4;
    let gallery_h = (h as i32 - (gallery_y - y)).max(0) as u32;
    draw_error_gallery(canvas, (x, gallery_y, w, gallery_h), gallery);
}

/// Fills the placed frame with `backdrop`.
fn draw_backdrop(canvas: &mut Canvas, place: &Placement, backdrop: &Backdrop<'_>) {
    match backdrop {
        Backdrop::Image(image) => canvas.blit_scaled(image, place.x, place.y, place.w, place.h),
        // A panel can only copy an earlier one; anything else leaves it empty.
        Backdrop::SameAs(_) => {}
        Backdrop::Fill(color) => canvas.fill_rect(
            place.x,
            place.y,
            place.x + place.w as i32,
            place.y + place.h as i32,
            *color,
            1.0,
        ),
        Backdrop::Flow(flow, max_px) => {
            let sampled = sample_flow(flow, place.w, place.h);
            let image = colorize_flow(&sampled, FlowColorRange::Fixed(*max_px));
            canvas.blit(&image, place.x, place.y);
        }
    }
}

/// `flow` sampled at `w`×`h` (nearest grid point), validity included.
fn sample_flow(flow: &FlowField, w: u32, h: u32) -> FlowField {
    let columns: Vec<usize> = (0..w).map(|c| grid_index(c, w, flow.width)).collect();
    let cells = w as usize * h as usize;
    let mut uv = Vec::with_capacity(2 * cells);
    let mut valid = flow.valid.as_ref().map(|_| Vec::with_capacity(cells));
    for r in 0..h {
        let row = grid_index(r, h, flow.height) * flow.width as usize;
        for &c in &columns {
            let i = row + c;
            uv.extend_from_slice(&flow.uv[2 * i..2 * i + 2]);
            if let (Some(out), Some(mask)) = (valid.as_mut(), flow.valid.as_ref()) {
                out.push(mask.get(i).copied().unwrap_or(false));
            }
        }
    }
    FlowField {
        width: w,
        height: h,
        uv,
        valid,
    }
}

/// The grid cell (of `cells`) under the centre of pixel `pixel` of `pixels`.
fn grid_index(pixel: u32, pixels: u32, cells: u32) -> usize {
    (((pixel as f32 + 0.5) / pixels.max(1) as f32 * cells as f32) as usize)
        .min(cells.max(1) as usize - 1)
}
