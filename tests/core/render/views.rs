//! Every view at tiny, ordinary and huge sizes, with and without boxes, scores, flow or
//! heatmap; determinism; what the pixels must show (transparent heatmap below the range,
//! the cursor at its frame, a single spike surviving decimation); colormaps; the timeline's
//! hit-testing.

use image::RgbaImage;
use vadscope::render::{
    self, Caption, Colormap, DashboardInput, DashboardOptions, FlowViewInput, FlowViewOptions,
    FrameViewInput, FrameViewOptions, PredViewInput, PredViewOptions, ScoreLabels, TimelineInput,
    TimelineLayout, TimelineOptions,
};
use vadscope::score::FusionWeights;

use crate::support::render::{boxes, flow, frame, heatmap, maps, mask, objects, series};

const SIZES: [(u32, u32); 5] = [(1, 1), (8, 8), (192, 128), (1600, 1000), (2600, 1700)];

fn caption() -> Caption {
    Caption {
        scenario: "Scenario_test".into(),
        index: 7,
        frame_id: Some(107),
        frame_score: Some(42.0),
        threshold: Some(30.3),
        weights: Some(FusionWeights::default()),
        truth: Some(true),
    }
}

/// Renders every view of the hand-made frame (`full`: with boxes, scores, maps, flow,
/// heatmap, mask; else none of them) at `size`.
fn all_views(full: bool, size: (u32, u32)) -> Vec<RgbaImage> {
    let (w, h) = (96, 64);
    let image = frame(w, h);
    let maps = [maps(1.0), maps(5.0)];
    let objects = if full {
        objects(w, h, &maps)
    } else {
        Vec::new()
    };
    let heat = heatmap(w, h);
    let truth_mask = mask(w, h);
    let flow_field = flow(w, h);
    let caption = caption();
    let frame_input = FrameViewInput {
        frame: &image,
        objects: &objects,
        heatmap: full.then_some(&heat),
        anomaly_mask: full.then_some(&truth_mask),
        caption: full.then_some(&caption),
    };
    let s = series(if full { 500 } else { 0 });
    let timeline = TimelineInput {
        fused: &s.fused,
        filtered: &s.filtered,
        z_r: &s.z_r,
        z_p: &s.z_p,
        surprisals: false,
        truth: &s.truth,
        labels: &s.labels,
        threshold: full.then_some(30.0),
        cursor: full.then_some(250),
    };
    let evaluation = ScoreLabels {
        scores: &s.filtered,
        labels: &s.truth,
        threshold: Some(30.0),
    };
    let pred = PredViewInput {
        frame: &image,
        objects: &objects,
    };
    let flow_input = FlowViewInput {
        frame: &image,
        flow: full.then_some(&flow_field),
        objects: &objects,
    };
    let dashboard = DashboardInput {
        frame: frame_input,
        flow: full.then_some(&flow_field),
        timeline,
        evaluation: Some(evaluation),
    };
    vec![
        render::frame_view(&frame_input, &FrameViewOptions::default(), size),
        render::pred_view(&pred, &PredViewOptions::default(), size),
        render::flow_view(&flow_input, &FlowViewOptions::default(), size),
        render::timeline(&timeline, &TimelineOptions::default(), size),
        render::roc_chart(&evaluation, size),
        render::histogram(&evaluation, size),
        render::dashboard(&dashboard, &DashboardOptions::default(), size),
    ]
}

#[test]
fn every_view_renders_at_every_size_with_and_without_data() {
    for size in SIZES {
        for full in [true, false] {
            for (k, image) in all_views(full, size).iter().enumerate() {
                assert_eq!(
                    image.dimensions(),
                    size,
                    "view {k} at {size:?} (full: {full})"
                );
                assert!(image.pixels().all(|p| p[3] == 255), "view {k} is opaque");
            }
        }
    }
}

#[test]
fn the_same_inputs_give_the_same_bytes() {
    let first = all_views(true, (640, 400));
    let second = all_views(true, (640, 400));
    for (k, (a, b)) in first.iter().zip(&second).enumerate() {
        assert!(
            a.as_raw() == b.as_raw(),
            "view {k} differs between two renders"
        );
    }
}

#[test]
fn views_with_data_draw_something_the_empty_ones_do_not() {
    let full = all_views(true, (480, 320));
    let empty = all_views(false, (480, 320));
    for (k, (a, b)) in full.iter().zip(&empty).enumerate() {
        assert!(
            a.as_raw() != b.as_raw(),
            "view {k} looks the same without data"
        );
    }
}

#[test]
fn the_heatmap_is_transparent_below_its_range_and_coloured_inside_boxes() {
    let (w, h) = (96, 64);
    let image = frame(w, h);
    let heat = heatmap(w, h);
    let input = FrameViewInput {
        frame: &image,
        objects: &[],
        heatmap: Some(&heat),
        anomaly_mask: None,
        caption: None,
    };
    let options = FrameViewOptions::default();
    // 96 + colour bar: the frame is drawn 1:1 at the top-left.
    let size = render::natural_size(
        (w, h),
        &FrameViewOptions {
            caption: false,
            ..options
        },
    );
    let out = render::frame_view(&input, &options, size);
    let at = |x: u32, y: u32| out.get_pixel(x, y).0;
    // Outside every box the heatmap is 0: the frame shows through unchanged.
    let src = image.get_pixel(80, 5).0;
    assert_eq!(&at(80, 5)[..3], &src[..], "pixel outside the boxes changed");
    // Inside the anomaly's box the heat is high: the pixel is tinted.
    let b = boxes(w, h)[1];
    let (x, y) = ((b[2] - 2.0) as u32, (b[1] + 3.0) as u32);
    assert_ne!(
        &at(x, y)[..3],
        &image.get_pixel(x, y).0[..],
        "heat inside the box not drawn"
    );
}

#[test]
fn colormaps_match_their_published_end_and_middle_colours() {
    let close = |a: [u8; 3], b: [u8; 3]| {
        a.iter()
            .zip(&b)
            .all(|(x, y)| (i16::from(*x) - i16::from(*y)).abs() <= 4)
    };
    let cases = [
        (Colormap::Viridis, 0.0, [68, 1, 84]),
        (Colormap::Viridis, 0.5, [33, 145, 140]),
        (Colormap::Viridis, 1.0, [253, 231, 37]),
        (Colormap::Inferno, 0.0, [0, 0, 4]),
        (Colormap::Inferno, 1.0, [252, 255, 164]),
        (Colormap::Jet, 0.0, [0, 0, 128]),
        (Colormap::Jet, 0.5, [128, 255, 128]),
        (Colormap::Jet, 1.0, [128, 0, 0]),
    ];
    for (map, t, want) in cases {
        let got = map.colorize(t);
        assert!(
            close(got, want),
            "{map} at {t}: {got:?}, expected about {want:?}"
        );
    }
    // Turbo's polynomial: dark at 0, green in the middle, dark red at 1.
    let [r0, g0, b0] = Colormap::Turbo.colorize(0.0).map(i32::from);
    assert!(r0 + g0 + b0 < 120, "turbo 0: {r0} {g0} {b0}");
    let [r5, g5, b5] = Colormap::Turbo.colorize(0.5).map(i32::from);
    assert!(g5 > 200 && g5 > r5 && g5 > b5, "turbo 0.5: {r5} {g5} {b5}");
    let [r1, g1, b1] = Colormap::Turbo.colorize(1.0).map(i32::from);
    assert!(
        r1 > 100 && r1 > 4 * (g1 + b1).max(1) / 2,
        "turbo 1: {r1} {g1} {b1}"
    );
    assert_eq!(
        Colormap::Turbo.colorize(f32::NAN),
        Colormap::Turbo.colorize(0.0)
    );
    assert_eq!(Colormap::Jet.colorize(7.0), Colormap::Jet.colorize(1.0));
    for map in Colormap::ALL {
        assert_eq!(map.name().parse::<Colormap>(), Ok(map));
    }
    assert!("plasma".parse::<Colormap>().is_err());
}

#[test]
fn timeline_pixels_and_frames_map_both_ways() {
    let options = TimelineOptions::default();
    for n in [1usize, 10, 500, 1000] {
        let layout = TimelineLayout::new(n, &options, (1200, 300));
        for k in 0..n {
            assert_eq!(
                layout.frame_at(layout.x_of(k)),
                Some(k),
                "{n} frames, frame {k}"
            );
        }
        assert_eq!(layout.frame_at(layout.plot_x.start as f32 - 1.0), None);
        assert_eq!(layout.frame_at(layout.plot_x.end as f32), None);
    }
    let layout = TimelineLayout::new(100_000, &options, (1200, 300));
    let mut last = 0;
    for x in layout.plot_x.clone() {
        let k = layout.frame_at(x as f32).expect("inside the plot");
        assert!(k >= last && k < 100_000);
        last = k;
    }
    assert!(last > 99_000, "the last column reaches the end ({last})");
    let zoomed = TimelineOptions {
        window: Some(200..300),
        ..TimelineOptions::default()
    };
    let layout = TimelineLayout::new(1000, &zoomed, (1200, 300));
    assert_eq!(layout.frame_at(layout.plot_x.start as f32), Some(200));
    assert_eq!(layout.frame_at(layout.plot_x.end as f32 - 1.0), Some(299));
}

#[test]
fn the_cursor_is_drawn_at_its_frame() {
    let s = series(300);
    let input = TimelineInput {
        fused: &s.fused,
        cursor: Some(123),
        ..TimelineInput::default()
    };
    let options = TimelineOptions::default();
    let size = (900, 260);
    let image = render::timeline(&input, &options, size);
    let layout = TimelineLayout::new(300, &options, size);
    let x = layout.x_of(123).floor() as u32;
    let y = (layout.score_y.end - 3) as u32;
    assert_eq!(
        &image.get_pixel(x, y).0[..3],
        &[255, 240, 100],
        "cursor colour at its column"
    );
    let without = render::timeline(
        &TimelineInput {
            cursor: None,
            ..input
        },
        &options,
        size,
    );
    assert_ne!(image.get_pixel(x, y), without.get_pixel(x, y));
}

#[test]
fn a_single_spike_among_100k_frames_survives_decimation() {
    let n = 100_000;
    let mut fused = vec![0.0; n];
    fused[54_321] = 100.0;
    fused[0] = -1.0;
    let input = TimelineInput {
        fused: &fused,
        ..TimelineInput::default()
    };
    let options = TimelineOptions {
        filtered: false,
        components: false,
        ..TimelineOptions::default()
    };
    let size = (800, 240);
    let image = render::timeline(&input, &options, size);
    let layout = TimelineLayout::new(n, &options, size);
    let x = layout.x_of(54_321).floor() as u32;
    let raw = [120u8, 150, 200];
    let top = layout.score_y.start as u32 + (layout.score_y.end - layout.score_y.start) as u32 / 10;
    let column_has_raw_near_top =
        (layout.score_y.start as u32..top).any(|y| image.get_pixel(x, y).0[..3] == raw);
    assert!(
        column_has_raw_near_top,
        "the spike's column reaches the top of the panel"
    );
    let elsewhere = layout.x_of(10_000).floor() as u32;
    assert!(
        !(layout.score_y.start as u32..top).any(|y| image.get_pixel(elsewhere, y).0[..3] == raw)
    );
}

#[test]
fn roc_of_one_class_says_so_instead_of_failing() {
    let scores = [1.0, 2.0, f64::NAN];
    let labels = [false, false, true];
    let input = ScoreLabels {
        scores: &scores,
        labels: &labels,
        threshold: None,
    };
    let image = render::roc_chart(&input, (300, 200));
    assert_eq!(image.dimensions(), (300, 200));
    let background = *image.get_pixel(0, 0);
    assert!(
        image.pixels().any(|p| *p != background),
        "the message is drawn"
    );
}
