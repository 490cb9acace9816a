//! Predicted vs actual: the actual frame beside the same frame with the model's predicted
//! patches pasted into their boxes, and a per-object gallery of actual patch, predicted
//! patch and prediction error.

use image::{RgbImage, RgbaImage};

use super::canvas::{Anchor, Canvas};
use super::colormap::Colormap;
use super::frame_view::BACKGROUND;
use super::gallery::{GalleryItem, draw_error_gallery, gallery_order};
use super::legend::LEGEND_TEXT;
use super::overlay::{Placement, SceneObject, ScoreScale, draw_boxes};
use super::patches::{colorized_map, crop_range, frame_crop, max_or, patch_side, planar_rgb};

/// The data of the prediction view; everything is borrowed.
#[derive(Debug, Clone, Copy)]
pub struct PredViewInput<'a> {
    /// The actual camera frame.
    pub frame: &'a RgbImage,
    /// Its objects; those with maps show their predicted patch.
    pub objects: &'a [SceneObject<'a>],
}

/// How the prediction view draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredViewOptions {
    /// Colormap of the error tiles and the boxes.
    pub colormap: Colormap,
    /// Error range of the tiles (squared error of RGB in [0, 1]); `None` = 0 to the largest
    /// error among this frame's objects (labelled as such).
    pub error_range: Option<(f32, f32)>,
    /// Box colours by object score.
    pub box_scale: ScoreScale,
}

impl Default for PredViewOptions {
    fn default() -> Self {
        Self {
            colormap: Colormap::Turbo,
            error_range: None,
            box_scale: ScoreScale::default(),
        }
    }
}

/// The frame with every object's predicted patch resized into its box (the cube's crop).
pub(crate) fn paste_predictions(frame: &RgbImage, objects: &[SceneObject<'_>]) -> RgbImage {
    let mut out = frame.clone();
    for object in objects {
        let Some(maps) = object.maps else { continue };
        let Some((x0, y0, x1, y1)) = crop_range(object.bbox, frame.dimensions()) else {
            continue;
        };
        let patch = planar_rgb(&maps.predicted);
        let mut canvas = Canvas::new(x1 - x0, y1 - y0, [0, 0, 0]);
        canvas.blit_scaled(&patch, 0, 0, x1 - x0, y1 - y0);
        for y in y0..y1 {
            for x in x0..x1 {
                if let Some(px) = canvas.get((x - x0) as i32, (y - y0) as i32) {
                    out.put_pixel(x, y, image::Rgb(px));
                }
            }
        }
    }
    out
}

/// Renders the prediction view at `size` (width, height).
pub fn pred_view(
    input: &PredViewInput<'_>,
    options: &PredViewOptions,
    size: (u32, u32),
) -> RgbaImage {
    let mut canvas = Canvas::new(size.0, size.1, BACKGROUND);
    let (w, h) = (canvas.width(), canvas.height());
    draw_pred_view(&mut canvas, input, options, (0, 0, w, h));
    canvas.into_rgba()
}

/// Draws the prediction view into the rectangle (x, y, w, h) of `canvas`.
pub(crate) fn draw_pred_view(
    canvas: &mut Canvas,
    input: &PredViewInput<'_>,
    options: &PredViewOptions,
    (x, y, w, h): (i32, i32, u32, u32),
) {
    let font = (f64::from(h) / 30.0).clamp(9.0, 14.0);
    let title_h = Canvas::text_size("Ag", font).1 + 6;
    let top_h = (h * 11 / 20).saturating_sub(title_h);
    let half = w / 2;
    let predicted = paste_predictions(input.frame, input.objects);
    for (k, (image, title)) in [
        (input.frame, "actual frame"),
        (
            &predicted,
            "predicted: model's patches pasted into the boxes",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let px = x + (k as u32 * half) as i32;
        canvas.text(
            px + half as i32 / 2,
            y + 2,
            title,
            font,
            LEGEND_TEXT,
            Anchor::TopCenter,
        );
        let place = Placement::fit(
            image.dimensions(),
            px + 2,
            y + title_h as i32,
            (half.saturating_sub(4), top_h),
        );
        canvas.blit_scaled(image, place.x, place.y, place.w, place.h);
        draw_boxes(
            canvas,
            &place,
            input.objects,
            options.colormap,
            &options.box_scale,
        );
    }

    let scored: Vec<&SceneObject<'_>> = input.objects.iter().filter(|o| o.maps.is_some()).collect();
    let (range, auto) = match options.error_range {
        Some(r) => (r, false),
        None => {
            let max = max_or(
                scored.iter().flat_map(|o| {
                    o.maps
                        .into_iter()
                        .flat_map(|m| m.frame_error.iter().copied())
                }),
                1.0,
            );
            ((0.0, max), true)
        }
    };
    let (order, total) = gallery_order(input.objects);
    let items: Vec<GalleryItem> = order
        .iter()
        .filter_map(|&k| {
            let o = &input.objects[k];
            let maps = o.maps?;
            let p = patch_side(maps.predicted.len(), 3);
            let actual = frame_crop(input.frame, o.bbox, p)?;
            Some(GalleryItem {
                label: object_label(o),
                tiles: vec![
                    actual,
                    planar_rgb(&maps.predicted),
                    colorized_map(&maps.frame_error, options.colormap, range),
                ],
            })
        })
        .collect();
    let gallery_y = y + (title_h + top_h) as i32 + 4;
    let gallery_h = (h as i32 - (gallery_y - y)).max(0) as u32;
    let bar_title = if auto {
        "squared error (auto range)"
    } else {
        "squared error"
    };
    draw_error_gallery(
        canvas,
        (x, gallery_y, w, gallery_h),
        &items,
        total,
        &["actual", "predicted", "error"],
        options.colormap,
        range,
        bar_title,
    );
}

/// "#track score" of a gallery entry.
pub(crate) fn object_label(object: &SceneObject<'_>) -> String {
    match object.score {
        Some(s) => format!("#{} {s:.1}", object.track_id),
        None => format!("#{}", object.track_id),
    }
}
