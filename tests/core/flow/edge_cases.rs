//! DIS flow on degenerate input: constant frames, tiny frames, size mismatches, bad
//! parameters and priors; plus the guarantees that hold for any input (thread-count
//! independence, grey/RGB equivalence, temporal prior handling).

use image::{GrayImage, RgbImage};
use vadscope::flow::{DisFlow, DisParams, DisPreset, FlowError, FlowField};

use crate::support::flow::{Texture, flow_from_fn, region_epe, render};

fn textured_pair(width: u32, height: u32, shift: [f64; 2]) -> (GrayImage, GrayImage) {
    let tex = Texture::new(21, 128.0);
    (
        render(width, height, (1, 1.0), |x, y| tex.at(x, y)),
        render(width, height, (2, 1.0), |x, y| {
            tex.at(x - shift[0], y - shift[1])
        }),
    )
}

#[test]
fn constant_frames_give_zero_flow() {
    for preset in DisPreset::ALL {
        let frame = GrayImage::from_pixel(64, 48, image::Luma([90]));
        let flow = DisFlow::from_preset(preset)
            .estimate(&frame, &frame, None)
            .unwrap();
        assert_eq!((flow.width, flow.height), (64, 48));
        assert!(flow.uv.iter().all(|&v| v == 0.0), "{preset}");
    }
    // Two different constants (a global brightness change): still no motion, no NaN.
    let a = GrayImage::from_pixel(64, 48, image::Luma([90]));
    let b = GrayImage::from_pixel(64, 48, image::Luma([180]));
    let flow = DisFlow::from_preset(DisPreset::Medium)
        .estimate(&a, &b, None)
        .unwrap();
    assert!(
        flow.uv.iter().all(|v| v.abs() < 1e-3),
        "constant pair moved"
    );
}

#[test]
fn frames_smaller_than_a_patch_are_an_error_and_a_patch_is_enough() {
    let tiny = GrayImage::from_pixel(7, 30, image::Luma([10]));
    let err = DisFlow::default().estimate(&tiny, &tiny, None).unwrap_err();
    assert!(matches!(
        err,
        FlowError::FrameTooSmall {
            width: 7,
            height: 30,
            patch_size: 8
        }
    ));
    assert!(err.to_string().contains("7×30"));
    let empty = GrayImage::new(0, 0);
    assert!(DisFlow::default().estimate(&empty, &empty, None).is_err());

    // Exactly one patch, and a thin strip: valid input with a finite result.
    for (w, h) in [(8, 8), (9, 200), (200, 9)] {
        let (a, b) = textured_pair(w, h, [0.5, 0.25]);
        for preset in DisPreset::ALL {
            let flow = DisFlow::from_preset(preset).estimate(&a, &b, None).unwrap();
            assert_eq!((flow.width, flow.height), (w, h));
            assert!(
                flow.uv.iter().all(|v| v.is_finite() && v.abs() < 8.0),
                "{w}×{h} {preset}"
            );
        }
    }
}

#[test]
fn frames_of_different_sizes_are_an_error() {
    let a = GrayImage::new(64, 48);
    let b = GrayImage::new(48, 64);
    let err = DisFlow::default().estimate(&a, &b, None).unwrap_err();
    assert!(matches!(
        err,
        FlowError::FrameSizeMismatch {
            prev_width: 64,
            prev_height: 48,
            next_width: 48,
            next_height: 64
        }
    ));
}

#[test]
fn bad_parameters_are_rejected() {
    let base = DisParams::from_preset(DisPreset::Fast);
    for bad in [
        DisParams {
            patch_size: 0,
            ..base
        },
        DisParams {
            patch_size: 10,
            ..base
        },
        DisParams {
            patch_stride: 0,
            ..base
        },
        DisParams {
            patch_stride: 9,
            ..base
        },
        DisParams {
            sor_omega: 2.0,
            ..base
        },
        DisParams {
            alpha: f32::NAN,
            ..base
        },
        DisParams {
            delta: -1.0,
            ..base
        },
    ] {
        assert!(
            matches!(DisFlow::new(bad), Err(FlowError::InvalidParams { .. })),
            "{bad:?}"
        );
    }
    for ps in [4, 8, 12, 16] {
        let params = DisParams {
            patch_size: ps,
            patch_stride: ps / 2,
            ..base
        };
        let (a, b) = textured_pair(96, 64, [1.0, 0.0]);
        let flow = DisFlow::new(params)
            .unwrap()
            .estimate(&a, &b, None)
            .unwrap();
        assert!(flow.uv.iter().all(|v| v.is_finite()), "patch size {ps}");
    }
}

#[test]
fn presets_parse_from_their_names() {
    for preset in DisPreset::ALL {
        assert_eq!(preset.name().parse::<DisPreset>().unwrap(), preset);
        let json = serde_json::to_string(&preset).unwrap();
        assert_eq!(json, format!("\"{}\"", preset.name()));
    }
    assert!("turbo".parse::<DisPreset>().is_err());
    assert_eq!(
        DisFlow::default().params(),
        &DisParams::from_preset(DisPreset::Medium)
    );
}

#[test]
fn result_does_not_depend_on_the_thread_count() {
    let (a, b) = textured_pair(160, 120, [2.4, -1.1]);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                DisFlow::from_preset(DisPreset::Medium)
                    .estimate(&a, &b, None)
                    .unwrap()
            })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(5));
}

#[test]
fn rgb_frames_are_converted_to_luma() {
    let (a, b) = textured_pair(96, 64, [1.5, 0.5]);
    let to_rgb = |g: &GrayImage| {
        RgbImage::from_fn(g.width(), g.height(), |x, y| {
            let v = g.get_pixel(x, y).0[0];
            image::Rgb([v, v, v])
        })
    };
    let dis = DisFlow::from_preset(DisPreset::Fast);
    let grey = dis.estimate(&a, &b, None).unwrap();
    let rgb = dis.estimate(&to_rgb(&a), &to_rgb(&b), None).unwrap();
    let max_diff = grey
        .uv
        .iter()
        .zip(&rgb.uv)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0f32, f32::max);
    assert!(max_diff < 1e-3, "grey and RGB differ by {max_diff}");
}

#[test]
fn temporal_prior_is_checked_and_helps_with_motion_beyond_the_pyramid() {
    let (w, h) = (160u32, 40u32);
    // The pyramid of a 160×40 frame stops at 1/4 scale, where 44 px are 11 px: more than a
    // patch search can travel from zero.
    let shift = [44.0, 1.0];
    let (a, b) = textured_pair(w, h, shift);
    let truth = flow_from_fn(w, h, |_, _| shift);
    let dis = DisFlow::from_preset(DisPreset::Medium);
    // Judge the columns whose content stays in view.
    let (xs, ys) = ((4, w - 48), (4, h - 4));
    let without = region_epe(&dis.estimate(&a, &b, None).unwrap(), &truth, xs, ys);
    let near = flow_from_fn(w, h, |_, _| [42.5, 0.0]);
    let with = region_epe(&dis.estimate(&a, &b, Some(&near)).unwrap(), &truth, xs, ys);
    eprintln!("EPE without prior {without:.3}, with prior {with:.3}");
    assert!(
        with < 0.2 && with < 0.5 * without,
        "prior did not help: {with} vs {without}"
    );

    // A prior of the wrong size is an error; a prior full of NaN or marked invalid is
    // ignored.
    let wrong = FlowField::zeros(w + 1, h);
    assert!(matches!(
        dis.estimate(&a, &b, Some(&wrong)),
        Err(FlowError::FlowSizeMismatch { .. })
    ));
    let mut broken = FlowField::zeros(w, h);
    broken.uv.truncate(10);
    assert!(matches!(
        dis.estimate(&a, &b, Some(&broken)),
        Err(FlowError::MalformedFlow { .. })
    ));
    let nan = flow_from_fn(w, h, |_, _| [f64::NAN, f64::NAN]);
    let invalid = FlowField {
        valid: Some(vec![false; (w * h) as usize]),
        ..near.clone()
    };
    let plain = dis.estimate(&a, &b, None).unwrap();
    assert_eq!(dis.estimate(&a, &b, Some(&nan)).unwrap(), plain);
    assert_eq!(dis.estimate(&a, &b, Some(&invalid)).unwrap(), plain);
}
