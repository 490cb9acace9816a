//! Small vector and colour types for the ray caster: 3D vectors in metres and linear-light
//! RGB radiance. Plain `f32` arithmetic only, so results are bit-identical on every thread.

use std::ops::{Add, AddAssign, Mul, Neg, Sub};

/// A 3D vector or point (metres): x east/forward, y north/left, z up.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct V3 {
    /// First component.
    pub x: f32,
    /// Second component.
    pub y: f32,
    /// Third component (up).
    pub z: f32,
}

impl V3 {
    /// A vector from its components.
    #[inline]
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        Self { x, y, z }
    }

    /// Dot product.
    #[inline]
    pub fn dot(self, o: V3) -> f32 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Cross product.
    #[inline]
    pub fn cross(self, o: V3) -> V3 {
        V3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// Euclidean length.
    #[inline]
    pub fn length(self) -> f32 {
        self.dot(self).sqrt()
    }

    /// The unit vector in this direction (zero stays zero).
    #[inline]
    pub fn normalized(self) -> V3 {
        let l = self.length();
        if l > 0.0 { self * (1.0 / l) } else { self }
    }

    /// Component-wise minimum.
    #[inline]
    pub fn min(self, o: V3) -> V3 {
        V3::new(self.x.min(o.x), self.y.min(o.y), self.z.min(o.z))
    }

    /// Component-wise maximum.
    #[inline]
    pub fn max(self, o: V3) -> V3 {
        V3::new(self.x.max(o.x), self.y.max(o.y), self.z.max(o.z))
    }

    /// Rotates the horizontal part by the angle whose cosine and sine are given (about z).
    #[inline]
    pub fn rotate_z(self, c: f32, s: f32) -> V3 {
        V3::new(c * self.x - s * self.y, s * self.x + c * self.y, self.z)
    }

    /// The inverse of [`V3::rotate_z`] with the same cosine and sine.
    #[inline]
    pub fn unrotate_z(self, c: f32, s: f32) -> V3 {
        V3::new(c * self.x + s * self.y, -s * self.x + c * self.y, self.z)
    }
}

impl Add for V3 {
    type Output = V3;
    #[inline]
    fn add(self, o: V3) -> V3 {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline]
    fn sub(self, o: V3) -> V3 {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f32> for V3 {
    type Output = V3;
    #[inline]
    fn mul(self, k: f32) -> V3 {
        V3::new(self.x * k, self.y * k, self.z * k)
    }
}

impl Neg for V3 {
    type Output = V3;
    #[inline]
    fn neg(self) -> V3 {
        V3::new(-self.x, -self.y, -self.z)
    }
}

/// Linear-light RGB radiance (1.0 is roughly a white surface in full daylight before
/// exposure and tone mapping).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rgb {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
}

impl Rgb {
    /// Black.
    pub const BLACK: Rgb = Rgb::new(0.0, 0.0, 0.0);

    /// A colour from its components.
    #[inline]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Self { r, g, b }
    }

    /// A grey level.
    #[inline]
    pub const fn grey(v: f32) -> Self {
        Self::new(v, v, v)
    }

    /// A colour from 8-bit sRGB components (approximate gamma 2.2 decode).
    pub fn from_srgb8(r: u8, g: u8, b: u8) -> Self {
        let f = |v: u8| (v as f32 / 255.0).powf(2.2);
        Self::new(f(r), f(g), f(b))
    }

    /// Component-wise product.
    #[inline]
    pub fn tint(self, o: Rgb) -> Rgb {
        Rgb::new(self.r * o.r, self.g * o.g, self.b * o.b)
    }

    /// Linear interpolation towards `o` by `t` in [0, 1].
    #[inline]
    pub fn lerp(self, o: Rgb, t: f32) -> Rgb {
        self + (o - self) * t
    }

    /// Rec. 709 luminance.
    #[inline]
    pub fn luminance(self) -> f32 {
        0.2126 * self.r + 0.7152 * self.g + 0.0722 * self.b
    }

    /// Moves the colour towards its own grey by `amount` in [0, 1].
    #[inline]
    pub fn desaturate(self, amount: f32) -> Rgb {
        self.lerp(Rgb::grey(self.luminance()), amount)
    }
}

impl Add for Rgb {
    type Output = Rgb;
    #[inline]
    fn add(self, o: Rgb) -> Rgb {
        Rgb::new(self.r + o.r, self.g + o.g, self.b + o.b)
    }
}

impl AddAssign for Rgb {
    #[inline]
    fn add_assign(&mut self, o: Rgb) {
        *self = *self + o;
    }
}

impl Sub for Rgb {
    type Output = Rgb;
    #[inline]
    fn sub(self, o: Rgb) -> Rgb {
        Rgb::new(self.r - o.r, self.g - o.g, self.b - o.b)
    }
}

impl Mul<f32> for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, k: f32) -> Rgb {
        Rgb::new(self.r * k, self.g * k, self.b * k)
    }
}

/// Hermite smoothstep of `x` between edges `a` and `b` (works for `a > b` too).
#[inline]
pub fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// 1.5·2^23: adding it to an `f32` of magnitude below 2^22 rounds it to an integer, which
/// then sits in the low mantissa bits.
const ROUND_MAGIC: f32 = 12_582_912.0;

/// `(x.floor(), x.floor() as i32)` without a library call or a saturating conversion (the
/// baseline x86-64 target has no rounding instruction, so `f32::floor` is a function call).
#[inline]
pub fn floor_int(x: f32) -> (f32, i32) {
    if x.abs() < 4_000_000.0 {
        let b = x + ROUND_MAGIC;
        let r = b - ROUND_MAGIC;
        let i = b.to_bits() as i32 - ROUND_MAGIC.to_bits() as i32;
        if r > x { (r - 1.0, i - 1) } else { (r, i) }
    } else {
        let f = x.floor();
        (f, f as i32)
    }
}

/// `x.floor()`; see [`floor_int`].
#[inline]
pub fn floor(x: f32) -> f32 {
    floor_int(x).0
}

/// Euclidean remainder of `x` by a positive `m`, in [0, m).
#[inline]
pub fn wrap(x: f32, m: f32) -> f32 {
    let r = x - m * floor(x / m);
    if r >= m { r - m } else { r.max(0.0) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_floor_matches_std() {
        for i in -20_000..20_000 {
            let x = i as f32 * 0.37 + 0.001 * (i % 7) as f32;
            let (f, n) = floor_int(x);
            assert_eq!(f, x.floor(), "{x}");
            assert_eq!(n, x.floor() as i32, "{x}");
        }
        for x in [-3.0f32, -0.5, 0.0, 0.5, 2.999_999_8, 5.0e6, -7.3e6] {
            assert_eq!(floor(x), x.floor(), "{x}");
        }
        assert!((wrap(-0.25, 2.0) - 1.75).abs() < 1e-6);
    }
}
