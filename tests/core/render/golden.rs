//! Golden images: a few views of the hand-made frame at 192×128 compared with the committed
//! references in `tests/golden/` (per channel within 6 levels, at most 0.5 % of pixels
//! further off, so font rasteriser rounding passes and a moved box does not).
//!
//! After an intended change of the drawing, look at the new images and refresh them with
//! `VADSCOPE_UPDATE_GOLDEN=1 cargo test --test core render::golden`.

use std::path::PathBuf;

use image::RgbaImage;
use vadscope::render::{
    self, Caption, FlowViewInput, FlowViewOptions, FrameViewInput, FrameViewOptions, PredViewInput,
    PredViewOptions, ScoreLabels, TimelineInput, TimelineOptions,
};
use vadscope::score::FusionWeights;

use crate::support::render::{flow, frame, heatmap, maps, mask, objects, series};

const SIZE: (u32, u32) = (192, 128);

fn golden_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(format!("{name}.png"))
}

/// Compares `image` with the golden file `name` (or writes it when refreshing).
fn check(name: &str, image: &RgbaImage) {
    let path = golden_path(name);
    if std::env::var_os("VADSCOPE_UPDATE_GOLDEN").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        image.save(&path).unwrap();
        return;
    }
    let golden = image::open(&path)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e}; create it with VADSCOPE_UPDATE_GOLDEN=1 cargo test --test core render::golden",
                path.display()
            )
        })
        .to_rgba8();
    assert_eq!(golden.dimensions(), image.dimensions(), "{name}: size");
    let mut far = 0usize;
    let mut worst = 0i16;
    for (a, b) in golden.pixels().zip(image.pixels()) {
        let d =
            a.0.iter()
                .zip(&b.0)
                .map(|(x, y)| (i16::from(*x) - i16::from(*y)).abs())
                .max()
                .unwrap();
        worst = worst.max(d);
        if d > 6 {
            far += 1;
        }
    }
    let allowed = (golden.width() * golden.height()) as usize / 200;
    if far > allowed {
        let actual = path.with_extension("actual.png");
        image.save(&actual).unwrap();
        panic!(
            "{name}: {far} pixels differ by more than 6 (worst {worst}), {allowed} allowed; see {}",
            actual.display()
        );
    }
}

fn scene() -> (image::RgbImage, [vadscope::score::ObjectMaps; 2]) {
    (frame(96, 64), [maps(1.0), maps(5.0)])
}

#[test]
fn frame_view_matches_its_golden_image() {
    let (image, maps) = scene();
    let objects = objects(96, 64, &maps);
    let heat = heatmap(96, 64);
    let truth = mask(96, 64);
    let caption = Caption {
        scenario: "golden".into(),
        index: 3,
        frame_id: Some(103),
        frame_score: Some(42.0),
        threshold: Some(30.3),
        weights: Some(FusionWeights::default()),
        truth: Some(true),
    };
    let input = FrameViewInput {
        frame: &image,
        objects: &objects,
        heatmap: Some(&heat),
        anomaly_mask: Some(&truth),
        caption: Some(&caption),
    };
    check(
        "frame_view",
        &render::frame_view(&input, &FrameViewOptions::default(), SIZE),
    );
}

#[test]
fn pred_and_flow_views_match_their_golden_images() {
    let (image, maps) = scene();
    let objects = objects(96, 64, &maps);
    let pred = PredViewInput {
        frame: &image,
        objects: &objects,
    };
    check(
        "pred_view",
        &render::pred_view(&pred, &PredViewOptions::default(), SIZE),
    );
    let field = flow(96, 64);
    let input = FlowViewInput {
        frame: &image,
        flow: Some(&field),
        objects: &objects,
    };
    check(
        "flow_view",
        &render::flow_view(&input, &FlowViewOptions::default(), SIZE),
    );
}

#[test]
fn timeline_and_roc_match_their_golden_images() {
    let s = series(400);
    let input = TimelineInput {
        fused: &s.fused,
        filtered: &s.filtered,
        z_r: &s.z_r,
        z_p: &s.z_p,
        surprisals: false,
        truth: &s.truth,
        labels: &s.labels,
        threshold: Some(30.0),
        cursor: Some(200),
    };
    check(
        "timeline",
        &render::timeline(&input, &TimelineOptions::default(), SIZE),
    );
    let evaluation = ScoreLabels {
        scores: &s.filtered,
        labels: &s.truth,
        threshold: Some(30.0),
    };
    check("roc", &render::roc_chart(&evaluation, SIZE));
}
