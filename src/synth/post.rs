//! Image post-processing: glow halos around light sources, rain streaks, exposure, tone
//! mapping (ACES fit) and sRGB encoding to 8 bits.

use std::sync::OnceLock;

use rayon::prelude::*;

use super::gbuffer::GBuffer;
use super::keys::KEY_GROUND;
use super::math::Rgb;
use super::render::FrameView;
use super::rng::Rng;
use super::world::World;
use crate::sequence::Weather;

/// Linear → sRGB 8-bit lookup over [0, 1] in 4096 steps.
fn srgb_lut() -> &'static [u8; 4096] {
    static LUT: OnceLock<[u8; 4096]> = OnceLock::new();
    LUT.get_or_init(|| {
        let mut t = [0u8; 4096];
        for (i, v) in t.iter_mut().enumerate() {
            let x = i as f64 / 4095.0;
            let s = if x <= 0.003_130_8 {
                12.92 * x
            } else {
                1.055 * x.powf(1.0 / 2.4) - 0.055
            };
            *v = (s * 255.0).round().clamp(0.0, 255.0) as u8;
        }
        t
    })
}

#[inline]
fn aces(x: f32) -> f32 {
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

/// Adds a Gaussian halo of standard deviations `(sx, sy)` pixels centred at `(u, v)`.
fn splat(hdr: &mut [Rgb], w: i64, h: i64, (u, v): (f32, f32), (sx, sy): (f32, f32), colour: Rgb) {
    let rx = (3.0 * sx).min(80.0) as i64;
    let ry = (3.0 * sy).min(120.0) as i64;
    let (cx, cy) = (u.floor() as i64, v.floor() as i64);
    for y in (cy - ry).max(0)..=(cy + ry).min(h - 1) {
        for x in (cx - rx).max(0)..=(cx + rx).min(w - 1) {
            let dx = (x as f32 + 0.5 - u) / sx;
            let dy = (y as f32 + 0.5 - v) / sy;
            hdr[(y * w + x) as usize] += colour * (-0.5 * (dx * dx + dy * dy)).exp();
        }
    }
}

fn add_glows(world: &World, view: &FrameView, gbuf: &GBuffer, hdr: &mut [Rgb]) {
    let (w, h) = (gbuf.width as i64, gbuf.height as i64);
    let spread = match world.lighting.weather {
        Weather::Fog => 2.5,
        Weather::Rain => 1.6,
        _ => 1.0,
    };
    let wet = world.lighting.wetness;
    // A wet road mirrors lights as long vertical streaks below them.
    if wet > 0.0 {
        for g in &view.glows {
            let mirrored = super::math::V3::new(g.pos.x, g.pos.y, -g.pos.z);
            let Some(q) = view.cam.project_relative(mirrored) else {
                continue;
            };
            let (cx, cy) = (q.u.floor() as i64, q.v.floor() as i64);
            if cx < 0 || cy < 0 || cx >= w || cy >= h {
                continue;
            }
            if gbuf.key[(cy * w + cx) as usize] != KEY_GROUND {
                continue;
            }
            let sigma = (g.size * view.cam.fx / q.z * 0.6).max(0.8);
            let colour = g.colour * (0.35 * wet * (-q.z / world.lighting.haze_distance).exp());
            splat(hdr, w, h, (q.u, q.v), (sigma * 1.2, sigma * 6.0), colour);
        }
    }
    for g in &view.glows {
        let Some(q) = view.cam.project_relative(g.pos) else {
            continue;
        };
        let (cx, cy) = (q.u.floor() as i64, q.v.floor() as i64);
        if cx < 0 || cy < 0 || cx >= w || cy >= h {
            continue;
        }
        let depth = gbuf.depth[(cy * w + cx) as usize];
        if depth < q.z - (0.03 * q.z).max(0.4) {
            continue;
        }
        let sigma = (g.size * view.cam.fx / q.z * 0.6).max(0.8) * spread;
        let halo = 4.0 * sigma;
        let radius = (3.0 * halo).min(80.0) as i64;
        // Haze swallows distant lights too.
        let colour = g.colour * (-q.z / world.lighting.haze_distance).exp().max(0.1);
        for y in (cy - radius).max(0)..=(cy + radius).min(h - 1) {
            for x in (cx - radius).max(0)..=(cx + radius).min(w - 1) {
                let dx = x as f32 + 0.5 - q.u;
                let dy = y as f32 + 0.5 - q.v;
                let r2 = dx * dx + dy * dy;
                let k =
                    (-r2 / (2.0 * sigma * sigma)).exp() + 0.08 * (-r2 / (2.0 * halo * halo)).exp();
                hdr[(y * w + x) as usize] += colour * k;
            }
        }
    }
}

fn add_rain(world: &World, frame: usize, w: usize, h: usize, hdr: &mut [Rgb]) {
    let mut rng =
        Rng::new(world.spec.seed ^ 0x7a1e ^ (frame as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    let count = (w * h) / 1400;
    let colour = (world.lighting.haze + Rgb::grey(0.25)) * (1.0 / world.lighting.exposure.max(0.1));
    for _ in 0..count {
        let x0 = rng.range(0.0, w as f32);
        let y0 = rng.range(-0.1 * h as f32, h as f32);
        let len = rng.range(0.03, 0.1) * h as f32;
        let ang = rng.range(0.1, 0.2);
        let strength = rng.range(0.03, 0.08);
        let (dx, dy) = (ang.sin(), ang.cos());
        let steps = (len * 2.0) as usize;
        for k in 0..steps {
            let t = k as f32 * 0.5;
            let (x, y) = (x0 + dx * t, y0 + dy * t);
            if x < 0.0 || y < 0.0 {
                continue;
            }
            let (xi, yi) = (x as usize, y as usize);
            if xi >= w || yi >= h {
                continue;
            }
            let fade = 1.0 - (2.0 * t / len - 1.0).abs();
            hdr[yi * w + xi] += colour * (strength * fade * 0.5);
        }
    }
}

/// Applies glows and rain, then tone-maps to an 8-bit sRGB image.
pub fn finish(
    world: &World,
    view: &FrameView,
    gbuf: &GBuffer,
    mut hdr: Vec<Rgb>,
) -> image::RgbImage {
    let (w, h) = (gbuf.width, gbuf.height);
    add_glows(world, view, gbuf, &mut hdr);
    if world.lighting.rain {
        add_rain(world, view.frame, w, h, &mut hdr);
    }
    let lut = srgb_lut();
    let exposure = world.lighting.exposure;
    let desat = world.lighting.desaturate;
    let mut bytes = vec![0u8; w * h * 3];
    // Rows in parallel, so that the other cores are not idle here when they have no
    // frames of their own left to render.
    bytes
        .par_chunks_mut(3 * w)
        .zip(hdr.par_chunks(w))
        .for_each(|(out, row)| {
            let linear: Vec<f32> = row
                .iter()
                .flat_map(|c| {
                    let c = (*c * exposure).desaturate(desat);
                    [c.r, c.g, c.b]
                })
                .collect();
            // The tone curve runs as a pass of its own over the channels, where the compiler
            // vectorises its division; the table lookups follow.
            let steps: Vec<u32> = linear
                .iter()
                .map(|v| (aces(v.max(0.0)) * 4095.0) as u32)
                .collect();
            for (byte, &step) in out.iter_mut().zip(&steps) {
                *byte = lut[(step as usize).min(4095)];
            }
        });
    image::RgbImage::from_raw(w as u32, h as u32, bytes)
        .unwrap_or_else(|| image::RgbImage::new(w as u32, h as u32))
}
