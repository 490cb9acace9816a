//! Flow vs reconstruction: the optical flow on the colour wheel, the memory autoencoder's
//! reconstruction of it pasted into the boxes, and the reconstruction error, for the full
//! frame and per object.

use image::{Rgb, RgbImage, RgbaImage};

use crate::sequence::FlowField;

use super::canvas::{Canvas, render_view};
use super::colormap::Colormap;
use super::comparison::{Backdrop, BoxStyle, Panel, draw_comparison};
use super::gallery::{ErrorGallery, gallery_items};
use super::legend::short_number;
use super::overlay::{SceneObject, ScoreScale};
use super::patches::{colorized_map, flow_crop, max_or, patch_side, planar_flow};

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

/// Colour where there is no flow.
const NO_FLOW: [u8; 3] = [40, 40, 40];

/// Renders the flow view at `size` (width, height).
pub fn flow_view(
    input: &FlowViewInput<'_>,
    options: &FlowViewOptions,
    size: (u32, u32),
) -> RgbaImage {
    render_view(size, |canvas, rect| {
        draw_flow_view(canvas, input, options, rect)
    })
}

/// Magnitudes of planar (u, v) flow.
fn magnitude(planes: &[f32]) -> impl Iterator<Item = f32> + '_ {
    let area = planes.len() / 2;
    (0..area).map(move |i| (planes[i] * planes[i] + planes[area + i] * planes[area + i]).sqrt())
}

/// Draws the flow view into the rectangle (x, y, w, h) of `canvas`.
pub(crate) fn draw_flow_view(
    canvas: &mut Canvas,
    input: &FlowViewInput<'_>,
    options: &FlowViewOptions,
    rect: (i32, i32, u32, u32),
) {
    let dims = input.frame.dimensions();
    let flow = input.flow.filter(|f| {
        f.width > 0 && f.height > 0 && f.uv.len() >= 2 * f.width as usize * f.height as usize
    });
    let range = options
        .flow_range
        .filter(|r| r.is_finite() && *r > 0.0)
        .unwrap_or_else(|| {
            let from_flow = flow.map_or(0.0, |f| {
                max_or(
                    f.uv.chunks_exact(2).map(|uv| uv[0] * uv[0] + uv[1] * uv[1]),
                    0.0,
                )
                .sqrt()
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

    let flow_backdrop = || match flow {
        Some(f) => Backdrop::Flow(f, range),
        None => Backdrop::Fill(NO_FLOW),
    };
    let flow_title = if flow.is_some() {
        format!(
            "flow (colour wheel, full colour at {} px)",
            short_number(f64::from(range))
        )
    } else {
        "no flow for this frame".to_string()
    };
    let panels = [
        Panel {
            title: &flow_title,
            backdrop: flow_backdrop(),
            patches: Vec::new(),
        },
        Panel {
            title: "reconstruction (memory autoencoder)",
            backdrop: flow_backdrop(),
            patches: input
                .objects
                .iter()
                .map(|o| o.maps.map(|m| planar_flow(&m.recon_flow, range)))
                .collect(),
        },
        Panel {
            title: "reconstruction error",
            backdrop: Backdrop::Fill(options.colormap.colorize(0.0)),
            patches: input
                .objects
                .iter()
                .map(|o| {
                    o.maps
                        .map(|m| colorized_map(&m.flow_error, options.colormap, error_range))
                })
                .collect(),
        },
    ];

    let (items, total) = gallery_items(input.objects, |_, object, maps| {
        let p = patch_side(maps.recon_flow.len(), 2).max(1);
        let actual = flow
            .and_then(|f| flow_crop(f, object.bbox, dims, p))
            .map_or_else(
                || RgbImage::from_pixel(p, p, Rgb(NO_FLOW)),
                |c| planar_flow(&c, range),
            );
        Some(vec![
            actual,
            planar_flow(&maps.recon_flow, range),
            colorized_map(&maps.flow_error, options.colormap, error_range),
        ])
    });
    let gallery = ErrorGallery {
        items,
        total,
        titles: &["flow", "reconstruction", "error"],
        colormap: options.colormap,
        range: error_range,
        bar_title: if auto {
            "squared error, px² (auto range)"
        } else {
            "squared error, px²"
        },
    };
    let boxes = BoxStyle {
        colormap: options.colormap,
        scale: options.box_scale,
    };
    draw_comparison(canvas, rect, dims, &panels, input.objects, boxes, &gallery);
}
