//! Night lights at a surface point: the street lamps and headlights that reach a tile, laid
//! out lane by lane so that all of them are evaluated together for each of its pixels.
//!
//! A light adds `colour · (n·l) · spot · fade / (d² + 9)` within its range and cone: the
//! spot term fades quadratically from the axis to the cone's edge, the range fade is
//! `(1 − d²/r²)²`, and the `+ 9` softens the near field of a lamp that is not a point.

use super::math::{Rgb, V3};
use super::render::{FrameView, Light, LightsInReach};

/// Lights evaluated side by side; a multiple of the vector width.
const LANES: usize = 8;

/// [`LANES`] lights, one field per array.
#[derive(Debug, Clone, Copy, Default)]
struct Lanes {
    pos: [[f32; LANES]; 3],
    dir: [[f32; LANES]; 3],
    /// Whether the light shines in every direction (no cone).
    omni: [bool; LANES],
    cos_outer: [f32; LANES],
    /// Squared range; 0 for an unused lane, which therefore lights nothing.
    range2: [f32; LANES],
    colour: [[f32; LANES]; 3],
}

/// The night lights of one tile, in the tile's order.
#[derive(Debug, Clone, Default)]
pub struct LightBank {
    lanes: Vec<Lanes>,
    len: usize,
}

impl LightBank {
    /// Refills the bank with `lights` of `view`, the ego's headlight last when it may reach.
    pub fn fill(&mut self, view: &FrameView, lights: LightsInReach) {
        self.lanes.clear();
        self.len = 0;
        for &i in lights.lights {
            self.push(&view.lights[i as usize]);
        }
        if lights.ego_headlight {
            self.push(&view.ego_headlight);
        }
    }

    fn push(&mut self, l: &Light) {
        let j = self.len % LANES;
        if j == 0 {
            self.lanes.push(Lanes::default());
        }
        let Some(lanes) = self.lanes.last_mut() else {
            unreachable!("a lane group was just pushed");
        };
        for (axis, (p, d)) in [(l.pos.x, l.dir.x), (l.pos.y, l.dir.y), (l.pos.z, l.dir.z)]
            .into_iter()
            .enumerate()
        {
            lanes.pos[axis][j] = p;
            lanes.dir[axis][j] = d;
        }
        lanes.omni[j] = l.dir == V3::default();
        lanes.cos_outer[j] = l.cos_outer;
        lanes.range2[j] = l.range * l.range;
        lanes.colour[0][j] = l.colour.r;
        lanes.colour[1][j] = l.colour.g;
        lanes.colour[2][j] = l.colour.b;
        self.len += 1;
    }

    /// Adds the light of every light of the bank, in order, to `irr` at camera-relative
    /// point `p` with unit normal `n`.
    pub fn add_irradiance(&self, irr: &mut Rgb, p: V3, n: V3) {
        for (g, lanes) in self.lanes.iter().enumerate() {
            let mut f = [0.0f32; LANES];
            // Branch-free, lane by lane, so that the compiler evaluates the lanes as vectors.
            for (j, f) in f.iter_mut().enumerate() {
                let tx = lanes.pos[0][j] - p.x;
                let ty = lanes.pos[1][j] - p.y;
                let tz = lanes.pos[2][j] - p.z;
                let d2 = tx * tx + ty * ty + tz * tz;
                let r2 = lanes.range2[j];
                let inv = 1.0 / d2.sqrt().max(1e-3);
                let (lx, ly, lz) = (tx * inv, ty * inv, tz * inv);
                let ndl = n.x * lx + n.y * ly + n.z * lz;
                let cos_outer = lanes.cos_outer[j];
                // Brightest on the axis, fading smoothly to nothing at the cone's edge.
                let c = -(lx * lanes.dir[0][j] + ly * lanes.dir[1][j] + lz * lanes.dir[2][j]);
                let k = ((c - cos_outer) / (1.0 - cos_outer)).clamp(0.0, 1.0);
                let spot = if lanes.omni[j] { 1.0 } else { k * k };
                let fade = (1.0 - d2 / r2) * (1.0 - d2 / r2);
                let lit = (d2 < r2) & (ndl > 0.0) & (spot > 0.0);
                let v = ndl * spot * fade / (d2 + 9.0);
                *f = if lit { v } else { 0.0 };
            }
            // Summed one light after the other: the order of a scalar loop, so the bits do
            // not depend on how the lanes were grouped. An unlit lane adds exactly zero, so
            // the unused lanes of the last group are left out of the sum.
            let used = (self.len - g * LANES).min(LANES);
            for (j, &f) in f.iter().enumerate().take(used) {
                *irr += Rgb::new(
                    lanes.colour[0][j] * f,
                    lanes.colour[1][j] * f,
                    lanes.colour[2][j] * f,
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;

    impl LightBank {
        fn of(lights: &[Light]) -> Self {
            let mut bank = Self::default();
            for l in lights {
                bank.push(l);
            }
            bank
        }
    }

    /// A point with every coordinate drawn uniformly from `lo..hi`.
    fn random_point(rng: &mut Rng, lo: V3, hi: V3) -> V3 {
        V3::new(
            rng.range(lo.x, hi.x),
            rng.range(lo.y, hi.y),
            rng.range(lo.z, hi.z),
        )
    }

    /// A point of the cube of half side `k` ranges around the light.
    fn near(rng: &mut Rng, l: &Light, k: f32) -> V3 {
        let e = V3::new(k, k, k);
        l.pos + random_point(rng, -e, e) * l.range
    }

    fn lit(l: &Light, p: V3, n: V3) -> bool {
        let mut irr = Rgb::BLACK;
        LightBank::of(std::slice::from_ref(l)).add_irradiance(&mut irr, p, n);
        irr != Rgb::BLACK
    }

    fn headlight() -> Light {
        Light {
            pos: V3::new(3.0, -1.0, 0.7),
            colour: Rgb::new(1.0, 1.0, 1.0),
            dir: V3::new(0.6, 0.8, -0.06).normalized(),
            cos_outer: 0.86,
            range: 35.0,
        }
    }

    fn lamp() -> Light {
        Light {
            pos: V3::new(0.0, 4.0, 8.0),
            colour: Rgb::new(1.0, 1.0, 1.0),
            dir: V3::new(0.0, 0.0, -1.0),
            cos_outer: 0.2,
            range: 20.0,
        }
    }

    /// Tiles are binned by `Light::reach_box`: a light must add nothing outside it.
    #[test]
    fn lights_add_nothing_outside_their_reach_box() {
        let mut rng = Rng::new(7);
        for l in [headlight(), lamp()] {
            let (lo, hi) = l.reach_box();
            // The cone cuts the box well below the range cube.
            let volume = (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z);
            assert!(volume < 0.75 * (2.0 * l.range).powi(3), "{volume}");
            let (mut lit_points, mut outside) = (0, 0);
            for _ in 0..20_000 {
                let p = near(&mut rng, &l, 1.2);
                let n = (l.pos - p).normalized();
                let inside = (lo.x..=hi.x).contains(&p.x)
                    && (lo.y..=hi.y).contains(&p.y)
                    && (lo.z..=hi.z).contains(&p.z);
                if lit(&l, p, n) {
                    lit_points += 1;
                    assert!(inside, "{p:?} is lit outside {lo:?}..{hi:?}");
                } else if !inside {
                    outside += 1;
                }
            }
            assert!(
                lit_points > 100 && outside > 1000,
                "{lit_points} lit, {outside} culled"
            );
        }
    }

    /// Tiles keep only the lights that `Light::may_reach` their box: a light it rejects
    /// must add nothing anywhere in the box, and boxes it accepts must include lit ones.
    #[test]
    fn lights_rejected_for_a_box_light_none_of_its_points() {
        let mut rng = Rng::new(11);
        let (mut rejected, mut accepted) = (0, 0);
        for l in [headlight(), lamp()] {
            for _ in 0..400 {
                let centre = near(&mut rng, &l, 1.1);
                let half = random_point(&mut rng, V3::new(0.1, 0.1, 0.1), V3::new(4.0, 4.0, 4.0));
                let (lo, hi) = (centre - half, centre + half);
                if l.may_reach(lo, hi) {
                    accepted += 1;
                    continue;
                }
                rejected += 1;
                for _ in 0..200 {
                    let p = random_point(&mut rng, lo, hi);
                    let n = (l.pos - p).normalized();
                    assert!(!lit(&l, p, n), "{p:?} lit in rejected box {lo:?}..{hi:?}");
                }
            }
        }
        assert!(
            rejected > 100 && accepted > 100,
            "{rejected} rejected, {accepted} accepted"
        );
    }

    /// However the lights are grouped into lanes, the sum is that of adding them one by one.
    #[test]
    fn a_bank_sums_its_lights_in_order() {
        let mut rng = Rng::new(3);
        let lights: Vec<Light> = (0..19)
            .map(|k| {
                let mut l = if k % 2 == 0 { lamp() } else { headlight() };
                l.pos = l.pos + V3::new(rng.range(-6.0, 6.0), rng.range(-6.0, 6.0), 0.0);
                l.colour = Rgb::new(
                    rng.range(1.0, 9.0),
                    rng.range(1.0, 9.0),
                    rng.range(1.0, 9.0),
                );
                if k == 5 {
                    l.dir = V3::default();
                }
                l
            })
            .collect();
        let bank = LightBank::of(&lights);
        assert_eq!(bank.len, lights.len());
        let mut lit_points = 0;
        for _ in 0..500 {
            let p = V3::new(rng.range(-10.0, 20.0), rng.range(-10.0, 20.0), 0.0);
            let n = V3::new(0.0, 0.0, 1.0);
            let base = Rgb::new(0.01, 0.02, 0.03);
            let mut together = base;
            bank.add_irradiance(&mut together, p, n);
            let mut one_by_one = base;
            for l in &lights {
                LightBank::of(std::slice::from_ref(l)).add_irradiance(&mut one_by_one, p, n);
            }
            assert_eq!(together, one_by_one);
            lit_points += usize::from(together != base);
        }
        assert!(lit_points > 100, "{lit_points}");
    }
}
