//! Band-limited procedural texture primitives: value noise with octaves that fade out once
//! they are finer than the pixel footprint, and analytically box-filtered stripes and boxes.
//!
//! Every texture is evaluated at a surface point in world or object coordinates, so a
//! texture moves exactly with its geometry. Filtering by the footprint (the width of one
//! pixel on the surface) keeps a pixel's colour close to the average of the texture over the
//! pixel, which is what makes the exact ground-truth flow reproduce the images under
//! bilinear warping instead of fighting aliasing.

use super::math::{floor, floor_int, wrap};
use super::rng::{hash2, hash32};

/// Side of the table of random lattice values (noise repeats every 256 lattice cells, far
/// beyond what one octave shows).
const TABLE: usize = 256;

/// Random values in [0, 1) for a 256×256 lattice, computed at compile time from the
/// integer hash.
static TABLE_VALUES: [f32; TABLE * TABLE] = {
    let mut t = [0.0f32; TABLE * TABLE];
    let mut i = 0;
    while i < TABLE * TABLE {
        t[i] = (hash32(i as u32 ^ 0x9e37_79b9) >> 8) as f32 * (1.0 / 16_777_216.0);
        i += 1;
    }
    t
};

/// Value noise on the unit lattice in [0, 1], smoothly interpolated.
#[inline]
pub fn value2(x: f32, y: f32, salt: u32) -> f32 {
    let (xf, ix) = floor_int(x);
    let (yf, iy) = floor_int(y);
    let (fx, fy) = (x - xf, y - yf);
    let ux = fx * fx * (3.0 - 2.0 * fx);
    let uy = fy * fy * (3.0 - 2.0 * fy);
    // The salt selects a pseudo-random window of the lattice table; indices wrap at 256 so
    // that they always fit the table (a `u16` index needs no bounds check).
    let h = salt.wrapping_mul(0x9e37_79b9);
    let x0 = (ix as u32).wrapping_add(h) & 255;
    let y0 = (iy as u32).wrapping_add(h >> 16) & 255;
    let x1 = (x0 + 1) & 255;
    let y1 = (y0 + 1) & 255;
    let t = &TABLE_VALUES;
    let at = |x: u32, y: u32| t[((y << 8) | x) as u16 as usize];
    let a = at(x0, y0);
    let b = at(x1, y0);
    let c = at(x0, y1);
    let d = at(x1, y1);
    let top = a + (b - a) * ux;
    let bottom = c + (d - c) * ux;
    top + (bottom - top) * uy
}

/// Value noise on the unit 3D lattice in [0, 1].
pub fn value3(x: f32, y: f32, z: f32, salt: u32) -> f32 {
    let zf = floor(z);
    let iz = zf as i32;
    let fz = z - zf;
    let uz = fz * fz * (3.0 - 2.0 * fz);
    let s0 = salt ^ hash2(iz, 17, 0x51ed);
    let s1 = salt ^ hash2(iz.wrapping_add(1), 17, 0x51ed);
    let a = value2(x, y, s0);
    let b = value2(x, y, s1);
    a + (b - a) * uz
}

/// How much of an octave with cells of size `cell` survives a footprint of `footprint`
/// (same unit): 1 while a cell spans about three pixels or more, 0 once it is one pixel.
#[inline]
pub fn octave_weight(cell: f32, footprint: f32) -> f32 {
    let r = footprint / cell;
    if r <= 0.33 {
        1.0
    } else if r >= 1.0 {
        0.0
    } else {
        let t = (1.0 - r) / 0.67;
        t * t * (3.0 - 2.0 * t)
    }
}

/// Fractal value noise in [0, 1] (mean 0.5): `octaves` octaves starting at cells of size
/// `cell`, each half the size and `gain` times the amplitude of the one before; octaves
/// finer than the footprint fade to their mean.
pub fn fbm2(x: f32, y: f32, salt: u32, cell: f32, octaves: u32, gain: f32, footprint: f32) -> f32 {
    let mut total = 0.0;
    let mut amp = 1.0;
    for _ in 0..octaves {
        total += amp;
        amp *= gain;
    }
    let mut sum = 0.0;
    let mut amp = 1.0;
    let mut c = cell;
    for i in 0..octaves {
        let w = octave_weight(c, footprint);
        if w <= 0.0 {
            // Finer octaves vanish too; they keep their share of `total` as their mean.
            break;
        }
        sum += amp * w * (value2(x / c, y / c, salt.wrapping_add(i * 0x9e37)) - 0.5);
        amp *= gain;
        c *= 0.5;
    }
    if total > 0.0 { 0.5 + sum / total } else { 0.5 }
}

/// Integral from 0 to `x` of a pulse train of period `p` that is 1 on `[0, w)` of each period,
/// returned as (whole periods, remainder) to keep precision for large `x`.
#[inline]
fn pulse_integral_parts(x: f32, p: f32, w: f32) -> (f32, f32) {
    let n = floor(x / p);
    let r = (x - n * p).clamp(0.0, p);
    (n, r.min(w))
}

/// The average over `[x - fw/2, x + fw/2]` of a pulse train of period `p` that is 1 on
/// `[0, w)` of each period: a box-filtered stripe pattern that never aliases.
#[inline]
pub fn filtered_pulse(x: f32, p: f32, w: f32, fw: f32) -> f32 {
    if fw < 1e-5 {
        let m = wrap(x, p);
        return if m < w { 1.0 } else { 0.0 };
    }
    let (n0, r0) = pulse_integral_parts(x - 0.5 * fw, p, w);
    let (n1, r1) = pulse_integral_parts(x + 0.5 * fw, p, w);
    (((n1 - n0) * w + r1 - r0) / fw).clamp(0.0, 1.0)
}

/// The average over `[x - fw/2, x + fw/2]` of the indicator of the interval `[a, b]`.
#[inline]
pub fn filtered_band(x: f32, a: f32, b: f32, fw: f32) -> f32 {
    if fw < 1e-5 {
        return if x >= a && x < b { 1.0 } else { 0.0 };
    }
    let lo = (x - 0.5 * fw).max(a);
    let hi = (x + 0.5 * fw).min(b);
    ((hi - lo) / fw).clamp(0.0, 1.0)
}

/// A box-filtered rectangle `[x0, x1] × [y0, y1]` with footprints `fx`, `fy`.
#[inline]
pub fn filtered_rect(x: f32, y: f32, r: [f32; 4], fx: f32, fy: f32) -> f32 {
    filtered_band(x, r[0], r[1], fx) * filtered_band(y, r[2], r[3], fy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filtered_pulse_matches_duty_cycle_when_blurred() {
        // A footprint of many periods averages to the duty cycle.
        let v = filtered_pulse(123.4, 2.0, 0.5, 40.0);
        assert!((v - 0.25).abs() < 0.02, "{v}");
        // Zero footprint is the plain indicator.
        assert_eq!(filtered_pulse(0.25, 2.0, 0.5, 0.0), 1.0);
        assert_eq!(filtered_pulse(1.25, 2.0, 0.5, 0.0), 0.0);
        // Half-covering footprint at an edge gives one half.
        assert!((filtered_pulse(0.5, 2.0, 0.5, 0.2) - 0.5).abs() < 1e-4);
    }

    #[test]
    fn fbm_stays_in_unit_range_and_flattens_with_footprint() {
        let mut spread_fine = 0.0f32;
        let mut spread_blurred = 0.0f32;
        for i in 0..200 {
            let x = i as f32 * 0.37;
            let a = fbm2(x, 1.3, 9, 1.0, 4, 0.5, 0.0);
            let b = fbm2(x, 1.3, 9, 1.0, 4, 0.5, 10.0);
            assert!((0.0..=1.0).contains(&a));
            spread_fine = spread_fine.max((a - 0.5).abs());
            spread_blurred = spread_blurred.max((b - 0.5).abs());
        }
        assert!(spread_fine > 0.1);
        assert!(spread_blurred < 1e-6);
    }
}
