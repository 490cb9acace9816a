//! Predicted vs actual: the actual frame beside the same frame with the model's predicted
//! patches pasted into their boxes, and a per-object gallery of actual patch, predicted
//! patch and prediction error.

use image::{RgbImage, RgbaImage};

use super::canvas::{Canvas, render_view};
use super::colormap::Colormap;
use super::comparison::{Backdrop, BoxStyle, Panel, draw_comparison};
use super::gallery::{ErrorGallery, gallery_items};
use super::overlay::{SceneObject, ScoreScale};
use super::patches::{colorized_map, frame_crop, max_or, patch_side, planar_rgb};

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

/// Renders the prediction view at `size` (width, height).
pub fn pred_view(
    input: &PredViewInput<'_>,
    options: &PredViewOptions,
    size: (u32, u32),
) -> RgbaImage {
    render_view(size, |canvas, rect| {
        draw_pred_view(canvas, input, options, rect)
    })
}

/// Draws the prediction view into the rectangle (x, y, w, h) of `canvas`.
pub(crate) fn draw_pred_view(
    canvas: &mut Canvas,
    input: &PredViewInput<'_>,
    options: &PredViewOptions,
    rect: (i32, i32, u32, u32),
) {
    let predicted: Vec<Option<RgbImage>> = input
        .objects
        .iter()
        .map(|o| o.maps.map(|m| planar_rgb(&m.predicted)))
        .collect();
    let panels = [
        Panel {
            title: "actual frame",
            backdrop: Backdrop::Image(input.frame),
            patches: Vec::new(),
        },
        Panel {
            title: "predicted: model's patches pasted into the boxes",
            backdrop: Backdrop::Image(input.frame),
            patches: predicted,
        },
    ];
    let (range, auto) = match options.error_range {
        Some(r) => (r, false),
        None => {
            let max = max_or(
                input
                    .objects
                    .iter()
                    .filter_map(|o| o.maps)
                    .flat_map(|m| m.frame_error.iter().copied()),
                1.0,
            );
            ((0.0, max), true)
        }
    };
    let (items, total) = gallery_items(input.objects, |_, object, maps| {
        let p = patch_side(maps.predicted.len(), 3);
        Some(vec![
            frame_crop(input.frame, object.bbox, p)?,
            planar_rgb(&maps.predicted),
            colorized_map(&maps.frame_error, options.colormap, range),
        ])
    });
    let gallery = ErrorGallery {
        items,
        total,
        titles: &["actual", "predicted", "error"],
        colormap: options.colormap,
        range,
        bar_title: if auto {
            "squared error (auto range)"
        } else {
            "squared error"
        },
    };
    let boxes = BoxStyle {
        colormap: options.colormap,
        scale: options.box_scale,
    };
    draw_comparison(
        canvas,
        rect,
        input.frame.dimensions(),
        &panels,
        input.objects,
        boxes,
        &gallery,
    );
}
