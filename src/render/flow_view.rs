//! Flow vs reconstruction: the optical flow on the colour wheel, the memory autoencoder's
//! reconstruction of it pasted into the boxes, and the reconstruction error, for the full
//! frame and per object.

use image::{Rgb, RgbImage, RgbaImage};

use crate::flow::{FlowColorRange, colorize_flow};
use crate::sequence::FlowField;

use super::canvas::{Anchor, Canvas};
use super::colormap::Colormap;
use super::frame_view::BACKGROUND;
use super::gallery::{GalleryItem, draw_error_gallery, gallery_order};
use super::legend::{LEGEND_TEXT, short_number};
use super::overlay::{Placement, SceneObject, ScoreScale, draw_boxes};
use super::patches::{colorized_map, crop_range, flow_crop, max_or, patch_side, planar_flow};
use super::pred_view::object_label;

/// The data of the flow view; everything is borrowed.
#[derive(Debug, Clone, Copy)]
pub struct FlowViewInput<'a> {
    /// The camera frame (for its size, and as the backdrop where flow is missing).
    pub frame: &'a RgbImage,
    /// The flow stored at (leading into) this frame, if any.
    pub flow: Option<&'a FlowField>,
    /// Its objects; those with maps show their reconstruction.
    pub objects: &'a [SceneObject<'a>],
}

/// How the flow view draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowViewOptions {
    /// Colormap of the error panels and the boxes.
    pub colormap: Colormap,
    /// Flow magnitude (pixels) at full colour saturation; `None` = the largest motion of
    /// this frame (flow and reconstructions).
    pub flow_range: Option<f32>,
    /// Error range (squared flow error, pixels²); `None` = 0 to this frame's largest error.
    pub error_range: Option<(f32, f32)>,
    /// Box colours by object score.
    pub box_scale: ScoreScale,
}

impl Default for FlowViewOptions {
    fn default() -> Self {
        Self {
            colormap: Colormap::Turbo,
            flow_range: None,
            error_range: None,
            box_scale: ScoreScale::default(),
        }
    }
}

/// Renders the flow view at `size` (width, height).
pub fn flow_view(
    input: &FlowViewInput<'_>,
    options: &FlowViewOptions,
    size: (u32, u32),
) -> RgbaImage {
    let mut canvas = Canvas::new(size.0, size.1, BACKGROUND);
    let (w, h) = (canvas.width(), canvas.height());
    draw_flow_view(&mut canvas, input, options, (0, 0, w, h));
    canvas.into_rgba()
}

/// Magnitudes of planar (u, v) flow.
fn magnitude(planes: &[f32]) -> impl Iterator<Item = f32> + '_ {
    let area = planes.len() / 2;
    (0..area).map(move |i| (planes[i] * planes[i] + planes[area + i] * planes[area + i]).sqrt())
}

/// Paints `patches` (one P×P image per object, `None` to skip) into their boxes on `base`.
fn paste_patches(base: &mut RgbImage, objects: &[SceneObject<'_>], patches: &[Option<RgbImage>]) {
    let dims = base.dimensions();
    for (object, patch) in objects.iter().zip(patches) {
        let (Some(patch), Some((x0, y0, x1, y1))) = (patch, crop_range(object.bbox, dims)) else {
            continue;
        };
        let mut canvas = Canvas::new(x1 - x0, y1 - y0, [0, 0, 0]);
        canvas.blit_scaled(patch, 0, 0, x1 - x0, y1 - y0);
        for y in y0..y1 {
            for x in x0..x1 {
                if let Some(px) = canvas.get((x - x0) as i32, (y - y0) as i32) {
                    base.put_pixel(x, y, Rgb(px));
                }
            }
        }
    }
}

/// Draws the flow view into the rectangle (x, y, w, h) of `canvas`.
pub(crate) fn draw_flow_view(
    canvas: &mut Canvas,
    input: &FlowViewInput<'_>,
    options: &FlowViewOptions,
    (x, y, w, h): (i32, i32, u32, u32),
) {
    let dims = input.frame.dimensions();
    let flow = input.flow.filter(|f| {
        f.width > 0 && f.height > 0 && f.uv.len() >= 2 * f.width as usize * f.height as usize
    });
    let crops: Vec<Option<Vec<f32>>> = input
        .objects
        .iter()
        .map(|o| {
            let p = patch_side(o.maps?.recon_flow.len(), 2);
            flow_crop(flow?, o.bbox, dims, p)
        })
        .collect();
    let range = options
        .flow_range
        .filter(|r| r.is_finite() && *r > 0.0)
        .unwrap_or_else(|| {
            let from_flow = flow.map_or(0.0, |f| {
                max_or(
                    f.uv.chunks_exact(2)
                        .map(|uv| (uv[0] * uv[0] + uv[1] * uv[1]).sqrt()),
                    0.0,
                )
            });
            let from_recon = max_or(
                input
                    .objects
                    .iter()
                    .filter_map(|o| o.maps)
                    .flat_map(|m| magnitude(&m.recon_flow)),
                0.0,
            );
            max_or([from_flow, from_recon], 1.0)
        });
    let (error_range, auto) = match options.error_range {
        Some(r) => (r, false),
        None => {
            let max = max_or(
                input
                    .objects
                    .iter()
                    .filter_map(|o| o.maps)
                    .flat_map(|m| m.flow_error.iter().copied()),
                1.0,
            );
            ((0.0, max), true)
        }
    };

    let flow_image = match flow {
        Some(f) => colorize_flow(f, FlowColorRange::Fixed(range)),
        None => RgbImage::from_pixel(dims.0.max(1), dims.1.max(1), Rgb([40, 40, 40])),
    };
    let mut recon_image = flow_image.clone();
    let recon_patches: Vec<Option<RgbImage>> = input
        .objects
        .iter()
        .map(|o| o.maps.map(|m| planar_flow(&m.recon_flow, range)))
        .collect();
    paste_patches(&mut recon_image, input.objects, &recon_patches);
    let mut error_image = RgbImage::from_pixel(
        dims.0.max(1),
        dims.1.max(1),
        Rgb(options.colormap.colorize(0.0)),
    );
    let error_patches: Vec<Option<RgbImage>> = input
        .objects
        .iter()
        .map(|o| {
            o.maps
                .map(|m| colorized_map(&m.flow_error, options.colormap, error_range))
        })
        .collect();
    paste_patches(&mut error_image, input.objects, &error_patches);

    let font = (f64::from(h) / 30.0).clamp(9.0, 14.0);
    let title_h = Canvas::text_size("Ag", font).1 + 6;
    let top_h = (h * 11 / 20).saturating_sub(title_h);
    let third = w / 3;
    let flow_title = if flow.is_some() {
        format!(
            "flow (colour wheel, full colour at {} px)",
            short_number(f64::from(range))
        )
    } else {
        "no flow for this frame".to_string()
    };
    let titles = [
        flow_title.as_str(),
        "reconstruction (memory autoencoder)",
        "reconstruction error",
    ];
    for (k, image) in [&flow_image, &recon_image, &error_image]
        .into_iter()
        .enumerate()
    {
        let px = x + (k as u32 * third) as i32;
        canvas.text(
            px + third as i32 / 2,
            y + 2,
            titles[k],
            font,
            LEGEND_TEXT,
            Anchor::TopCenter,
        );
        let place = Placement::fit(
            image.dimensions(),
            px + 2,
            y + title_h as i32,
            (third.saturating_sub(4), top_h),
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

    let (order, total) = gallery_order(input.objects);
    let items: Vec<GalleryItem> = order
        .iter()
        .filter_map(|&k| {
            let (o, crop) = (&input.objects[k], &crops[k]);
            let maps = o.maps?;
            let p = patch_side(maps.recon_flow.len(), 2).max(1);
            let actual = crop.as_ref().map_or_else(
                || RgbImage::from_pixel(p, p, Rgb([40, 40, 40])),
                |c| planar_flow(c, range),
            );
            Some(GalleryItem {
                label: object_label(o),
                tiles: vec![
                    actual,
                    planar_flow(&maps.recon_flow, range),
                    colorized_map(&maps.flow_error, options.colormap, error_range),
                ],
            })
        })
        .collect();
    let gallery_y = y + (title_h + top_h) as i32 + 4;
    let gallery_h = (h as i32 - (gallery_y - y)).max(0) as u32;
    let bar_title = if auto {
        "squared error, px² (auto range)"
    } else {
        "squared error, px²"
    };
    draw_error_gallery(
        canvas,
        (x, gallery_y, w, gallery_h),
        &items,
        total,
        &["flow", "reconstruction", "error"],
        options.colormap,
        error_range,
        bar_title,
    );
}
