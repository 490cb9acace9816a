//! DIS flow on synthetic pairs with exactly known motion: sub-pixel shift, zoom about a
//! point, a moving box on a moving background, and a brightness change.

use vadscope::flow::{DisFlow, DisPreset, PixelBox, box_endpoint_error, endpoint_error};

use crate::support::flow::{Texture, flow_from_fn, interior_epe, render};

const W: u32 = 192;
const H: u32 = 144;

#[test]
fn subpixel_shift_is_recovered_by_every_preset() {
    let tex = Texture::new(11, 128.0);
    let (du, dv) = (1.37, -0.62);
    let prev = render(W, H, (1, 1.0), |x, y| tex.at(x, y));
    let next = render(W, H, (2, 1.0), |x, y| tex.at(x - du, y - dv));
    let truth = flow_from_fn(W, H, |_, _| [du, dv]);
    for (preset, bound) in [
        (DisPreset::Ultrafast, 0.1),
        (DisPreset::Fast, 0.08),
        (DisPreset::Medium, 0.05),
    ] {
        let flow = DisFlow::from_preset(preset)
            .estimate(&prev, &next, None)
            .unwrap();
        let epe = interior_epe(&flow, &truth, 8);
        eprintln!("shift {preset}: interior EPE {epe:.3}");
        assert!(epe < bound, "{preset}: EPE {epe:.3} ≥ {bound}");
        assert!(flow.uv.iter().all(|v| v.is_finite()));
    }
}

#[test]
fn zoom_about_a_point_is_recovered() {
    let tex = Texture::new(12, 120.0);
    let (cx, cy, s) = (110.0, 60.0, 1.04);
    let prev = render(W, H, (3, 1.0), |x, y| tex.at(x, y));
    let next = render(W, H, (4, 1.0), |x, y| {
        tex.at(cx + (x - cx) / s, cy + (y - cy) / s)
    });
    let truth = flow_from_fn(W, H, |x, y| [(s - 1.0) * (x - cx), (s - 1.0) * (y - cy)]);
    let flow = DisFlow::from_preset(DisPreset::Medium)
        .estimate(&prev, &next, None)
        .unwrap();
    let epe = interior_epe(&flow, &truth, 12);
    eprintln!("zoom medium: interior EPE {epe:.3}");
    assert!(epe < 0.15, "EPE {epe:.3}");
}

#[test]
fn moving_box_on_moving_background() {
    let bg = Texture::new(13, 130.0);
    let obj = Texture::new(14, 100.0);
    let (bg_d, box_d) = ([2.3, 0.4], [-1.6, 1.1]);
    let (x0, y0, x1, y1) = (70.0, 40.0, 142.0, 94.0);
    let inside = |x: f64, y: f64| x >= x0 && x < x1 && y >= y0 && y < y1;
    let prev = render(W, H, (5, 1.0), |x, y| {
        if inside(x, y) {
            obj.at(x, y)
        } else {
            bg.at(x, y)
        }
    });
    let next = render(W, H, (6, 1.0), |x, y| {
        let (ox, oy) = (x - box_d[0], y - box_d[1]);
        if inside(ox, oy) {
            obj.at(ox, oy)
        } else {
            bg.at(x - bg_d[0], y - bg_d[1])
        }
    });
    let truth = flow_from_fn(W, H, |x, y| if inside(x, y) { box_d } else { bg_d });
    let bbox = PixelBox {
        x1: x0 as f32,
        y1: y0 as f32,
        x2: x1 as f32,
        y2: y1 as f32,
    };
    for (preset, bound) in [
        (DisPreset::Fast, 1.0),
        (DisPreset::Medium, 0.4),
        (DisPreset::Quality, 0.3),
    ] {
        let flow = DisFlow::from_preset(preset)
            .estimate(&prev, &next, None)
            .unwrap();
        let patch = box_endpoint_error(&flow, &truth, bbox, 32)
            .unwrap()
            .unwrap();
        let all = endpoint_error(&flow, &truth).unwrap().mean_all;
        eprintln!("box {preset}: patch EPE {patch:.3}, all {all:.3}");
        assert!(patch < bound, "{preset}: patch EPE {patch:.3} ≥ {bound}");
    }
}

#[test]
fn brightness_change_does_not_break_the_estimate() {
    let tex = Texture::new(15, 125.0);
    let (du, dv, gain, offset) = (-2.2, 1.4, 1.08, -6.0);
    let prev = render(W, H, (7, 1.0), |x, y| tex.at(x, y));
    let next = render(W, H, (8, 1.0), |x, y| {
        gain * tex.at(x - du, y - dv) + offset
    });
    let truth = flow_from_fn(W, H, |_, _| [du, dv]);
    let flow = DisFlow::from_preset(DisPreset::Medium)
        .estimate(&prev, &next, None)
        .unwrap();
    let epe = interior_epe(&flow, &truth, 8);
    eprintln!("brightness medium: interior EPE {epe:.3}");
    assert!(epe < 0.1, "EPE {epe:.3}");
}

#[test]
fn large_motion_is_caught_by_the_pyramid() {
    let tex = Texture::new(16, 128.0);
    let (du, dv) = (11.3, -5.2);
    let prev = render(W, H, (9, 1.0), |x, y| tex.at(x, y));
    let next = render(W, H, (10, 1.0), |x, y| tex.at(x - du, y - dv));
    let truth = flow_from_fn(W, H, |_, _| [du, dv]);
    let flow = DisFlow::from_preset(DisPreset::Medium)
        .estimate(&prev, &next, None)
        .unwrap();
    // Content within ~12 px of the border leaves the frame; judge the rest.
    let epe = interior_epe(&flow, &truth, 16);
    eprintln!("large shift medium: interior EPE {epe:.3}");
    assert!(epe < 0.1, "EPE {epe:.3}");
}
