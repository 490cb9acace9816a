//! The per-object gallery shared by the prediction and flow views: for the highest-scoring
//! objects a group of equally sized tiles (e.g. actual, model output, error) under a header
//! that names them, laid out in as many rows and columns as make the tiles largest.

use image::RgbImage;

use crate::score::ObjectMaps;

use super::canvas::{Anchor, Canvas};
use super::colormap::Colormap;
use super::legend::{LEGEND_TEXT, colour_bar};
use super::overlay::SceneObject;

/// One object's tiles and its label.
pub(crate) struct GalleryItem {
    /// Label above the tiles ("#3 score 12.1").
    pub label: String,
    /// The tiles, drawn left to right.
    pub tiles: Vec<RgbImage>,
}

/// Largest tile side drawn (6× a 32-pixel patch).
const MAX_TILE: u32 = 192;

/// Objects shown at most, the highest-scoring first.
pub(crate) const GALLERY_OBJECTS: usize = 6;

/// A per-object gallery whose last tile of each object is an error map: the items, the
/// tile titles and the colour bar of the error tiles.
pub(crate) struct ErrorGallery<'a> {
    /// The objects' tiles, chosen by [`gallery_items`].
    pub items: Vec<GalleryItem>,
    /// How many objects have maps (the items may be fewer).
    pub total: usize,
    /// Titles of the tile columns.
    pub titles: &'a [&'a str],
    /// Colormap of the error tiles.
    pub colormap: Colormap,
    /// Value range of the error tiles.
    pub range: (f32, f32),
    /// Title of the colour bar.
    pub bar_title: &'a str,
}

/// Draws `gallery` into the rectangle (x, y, w, h) with, when there is room and something
/// to show, the colour bar of its error tiles at the right edge.
pub(crate) fn draw_error_gallery(
    canvas: &mut Canvas,
    (x, y, w, h): (i32, i32, u32, u32),
    gallery: &ErrorGallery<'_>,
) {
    let bar_w = if w >= 200 && !gallery.items.is_empty() {
        (w / 14).clamp(44, 80)
    } else {
        0
    };
    draw_gallery(
        canvas,
        (x, y, w.saturating_sub(bar_w), h),
        &gallery.items,
        gallery.total,
        gallery.titles,
        "no scored object in this frame",
    );
    if bar_w > 0 {
        colour_bar(
            canvas,
            x + (w - bar_w) as i32,
            y,
            bar_w,
            h,
            gallery.colormap,
            (f64::from(gallery.range.0), f64::from(gallery.range.1)),
            gallery.bar_title,
        );
    }
}

/// Draws `items` (chosen by [`gallery_items`] from `total` objects) into the rectangle
/// (x, y, w, h), tile columns titled `titles`; says so when there is no object.
fn draw_gallery(
    canvas: &mut Canvas,
    (x, y, w, h): (i32, i32, u32, u32),
    items: &[GalleryItem],
    total: usize,
    titles: &[&str],
    empty_message: &str,
) {
    let font = (f64::from(h) / 14.0).clamp(8.0, 13.0);
    let line = Canvas::text_size("Ag", font).1 + 4;
    if items.is_empty() {
        canvas.text(
            x + w as i32 / 2,
            y + h as i32 / 2,
            empty_message,
            font,
            LEGEND_TEXT,
            Anchor::Center,
        );
        return;
    }
    let header = if total > items.len() {
        format!(
            "{} highest-scoring of {total} objects (#track · object score): {}",
            items.len(),
            titles.join(" | ")
        )
    } else {
        format!("per object (#track · object score): {}", titles.join(" | "))
    };
    let (header, size) = Canvas::fitted(&header, font, w.saturating_sub(8));
    canvas.text(x + 4, y, &header, size, LEGEND_TEXT, Anchor::TopLeft);
    let (y, h) = (y + line as i32, h.saturating_sub(line));
    let per = titles.len().max(1) as u32;
    let gap = 4u32;
    let n = items.len() as u32;
    let mut best = (0u32, 1u32);
    for rows in 1..=n {
        let cols = n.div_ceil(rows);
        let by_w = (w.saturating_sub(cols * 2 * gap) / cols.max(1)).saturating_sub(per * gap) / per;
        let by_h = (h / rows).saturating_sub(line + gap);
        let tile = by_w.min(by_h).min(MAX_TILE);
        if tile > best.0 {
            best = (tile, rows);
        }
    }
    let (tile, rows) = best;
    if tile < 4 {
        return;
    }
    let cols = n.div_ceil(rows);
    let group_w = per * (tile + gap) + 2 * gap;
    let row_h = line + tile + gap;
    for (k, item) in items.iter().enumerate() {
        let (r, c) = (k as u32 / cols, k as u32 % cols);
        let gx = x + (c * group_w) as i32 + gap as i32;
        let gy = y + (r * row_h) as i32;
        canvas.text(gx, gy, &item.label, font, LEGEND_TEXT, Anchor::TopLeft);
        for (t, image) in item.tiles.iter().enumerate() {
            let tx = gx + (t as u32 * (tile + gap)) as i32;
            canvas.blit_scaled_nearest(image, tx, gy + line as i32, tile, tile);
        }
    }
}

/// The gallery items of the highest-scoring objects with maps (at most
/// [`GALLERY_OBJECTS`]), each with the tiles `tiles` makes from the object's index, the
/// object and its maps (`None` leaves the object out); and how many objects have maps.
pub(crate) fn gallery_items(
    objects: &[SceneObject<'_>],
    mut tiles: impl FnMut(usize, &SceneObject<'_>, &ObjectMaps) -> Option<Vec<RgbImage>>,
) -> (Vec<GalleryItem>, usize) {
    let mut order: Vec<usize> = (0..objects.len())
        .filter(|&k| objects[k].maps.is_some())
        .collect();
    let total = order.len();
    order.sort_by(|&a, &b| {
        let key = |k: usize| objects[k].score.unwrap_or(f64::NEG_INFINITY);
        key(b).total_cmp(&key(a))
    });
    order.truncate(GALLERY_OBJECTS);
    let items = order
        .into_iter()
        .filter_map(|k| {
            let object = &objects[k];
            Some(GalleryItem {
                label: object_label(object),
                tiles: tiles(k, object, object.maps?)?,
            })
        })
        .collect();
    (items, total)
}

/// "#track · score" of a gallery entry.
fn object_label(object: &SceneObject<'_>) -> String {
    match object.score {
        Some(s) => format!("#{} · {s:.1}", object.track_id),
        None => format!("#{}", object.track_id),
    }
}
