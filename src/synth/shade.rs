//! Materials and lighting: procedural textures of road, sidewalks, terrain, buildings,
//! street furniture, vegetation and vehicles (paint, glass, lights, wheels), evaluated at the
//! hit point in world or object coordinates, lit by sun, sky, street lamps and headlights,
//! with contact and sun shadows under vehicles, wet-road sky reflections and haze.

use super::keys::{KEY_BACKDROP, KEY_GROUND, KEY_SKY};
use super::light_bank::LightBank;
use super::math::{Rgb, V3, floor, smoothstep, wrap};
use super::render::{FrameView, Hit, PrimRef, WHEEL_PART, lamp_of};
use super::rng::unit2;
use super::road::{GroundRegion, LightState};
use super::scenery::{Shape, StaticKind, WALL_PALETTE};
use super::texture::{
    fbm2, filtered_band, filtered_pulse, filtered_rect, octave_weight, value2, value3,
};
use super::traffic::{LEAD, Role};
use super::vehicle::{BodyType, PartKind, VehicleModel};
use crate::sequence::Domain;

/// Width of the texture pre-filter in pixels.
const TEXTURE_FILTER_PX: f32 = 1.7;

/// Labels and radiance of one pixel.
#[derive(Debug, Clone, Copy, Default)]
pub struct Shaded {
    /// Linear radiance (before exposure).
    pub rgb: Rgb,
    /// AnoVox semantic id.
    pub semantic: u8,
    /// CARLA tag for the instance image's R channel.
    pub tag: u8,
    /// Instance id (track id for vehicles, 0 otherwise).
    pub id: u16,
}

/// Surface description produced by a material before lighting.
struct Surface {
    albedo: Rgb,
    emissive: Rgb,
    /// Strength of the mirror-like environment reflection (0 = matte).
    gloss: f32,
    /// Wraps diffuse lighting around (foliage).
    wrap: f32,
    semantic: u8,
    tag: u8,
    id: u16,
}

impl Surface {
    fn matte(albedo: Rgb, semantic: u8) -> Self {
        Surface {
            albedo,
            emissive: Rgb::BLACK,
            gloss: 0.0,
            wrap: 0.0,
            semantic,
            tag: semantic,
            id: 0,
        }
    }
}

/// The sky without clouds and sun: what glossy surfaces reflect (kept smooth so that
/// reflections change little as the camera moves).
fn sky_gradient(l: &super::lighting::Lighting, d: V3) -> Rgb {
    let dn = d.normalized();
    l.horizon.lerp(l.zenith, dn.z.max(0.0).sqrt())
}

/// Sky radiance in direction `d` (any length).
pub fn sky(view: &FrameView, d: V3) -> Rgb {
    let l = &view.world.lighting;
    let dn = d.normalized();
    let el = dn.z.max(0.0);
    let mut c = l.horizon.lerp(l.zenith, el.sqrt());
    if l.night {
        if matches!(view.world.road.domain, Domain::City) {
            // Light pollution over the city.
            c += Rgb::new(0.05, 0.032, 0.018) * (1.0 - el).powi(6);
        }
        return c;
    }
    if l.sun.luminance() > 1.0 {
        let cs = dn.dot(l.sun_dir).max(0.0);
        c += l.sun * (0.08 * cs.powi(8) + 0.6 * cs.powi(300));
        if cs > 0.99985 {
            c += Rgb::new(40.0, 38.0, 34.0);
        }
    }
    if dn.z > 0.01 && l.clouds > 0.0 {
        let k = 1200.0 / dn.z;
        let px = view.cam.x + dn.x * k;
        let py = view.cam.y + dn.y * k;
        let n = fbm2(px, py, view.world.cloud_salt, 1400.0, 3, 0.5, 0.0);
        let cover = smoothstep(1.05 - l.clouds, 1.3 - 0.6 * l.clouds, n + 0.15);
        let cloud = if l.weather == crate::sequence::Weather::Rain {
            Rgb::new(0.42, 0.43, 0.46) * (0.8 + 0.4 * n)
        } else {
            Rgb::new(1.05, 1.05, 1.1) * (0.75 + 0.35 * el)
        };
        c = c.lerp(cloud, cover * smoothstep(0.0, 0.12, dn.z));
    }
    c
}

#[inline]
fn fresnel(cos: f32) -> f32 {
    let m = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    0.04 + 0.96 * m
}

/// Shades the hit of camera ray `dir` in `tile`, lit at night by `lights` (which must hold
/// every light that reaches the hit).
pub fn shade(view: &FrameView, hit: &Hit, dir: V3, tile: usize, lights: &LightBank) -> Shaded {
    let world = view.world;
    let l = &world.lighting;
    match hit.key {
        KEY_SKY => {
            return Shaded {
                rgb: sky(view, dir),
                semantic: 11,
                tag: 11,
                id: 0,
            };
        }
        KEY_BACKDROP => {
            let city = matches!(world.road.domain, Domain::City);
            let base = if city {
                Rgb::new(0.30, 0.32, 0.36)
            } else {
                Rgb::new(0.10, 0.15, 0.09)
            };
            let lit = if l.night {
                base * 0.02
            } else {
                base.tint(l.sky_ambient + l.sun * 0.3)
            };
            let haze = if city { 0.55 } else { 0.6 };
            let semantic = if city { 3 } else { 9 };
            return Shaded {
                rgb: lit.lerp(l.haze, haze),
                semantic,
                tag: semantic,
                id: 0,
            };
        }
        _ => {}
    }
    let len = dir.length();
    let dist = hit.t * len;
    let dn = dir * (1.0 / len);
    // Width of the texture filter on a surface facing the camera at this distance: a little
    // wider than one pixel, like a camera's optics, so that textures stay band-limited and
    // bilinear warping with the exact flow reproduces them.
    let fw = TEXTURE_FILTER_PX * dist / view.cam.fx;
    let p_rel = view.cam.origin() + dir * hit.t;
    let (surface, normal, ao, sun_vis) = if hit.key == KEY_GROUND {
        ground(view, hit, dn, p_rel, tile)
    } else {
        let prim = &view.prims[hit.prim as usize];
        let n_world = hit.normal.rotate_z(prim.c, prim.s);
        let cos = (-dn.dot(n_world)).abs().max(0.05);
        let fu = (fw / cos).min(50.0);
        let s = match prim.what {
            PrimRef::Static(i) => static_surface(view, i as usize, hit, fu, fw),
            PrimRef::Vehicle(i) => vehicle_surface(view, i as usize, hit, fu, fw),
        };
        let sun_vis = if matches!(prim.what, PrimRef::Static(_)) {
            1.0
        } else {
            0.9
        };
        (s, n_world, 1.0, sun_vis)
    };
    // Lighting.
    let mut irr =
        l.sky_ambient * ((0.55 + 0.45 * normal.z) * ao) + l.ground_ambient * (0.5 - 0.5 * normal.z);
    if sun_vis > 0.0 {
        let ndl = normal.dot(l.sun_dir);
        let wrapped = ((ndl + surface.wrap) / (1.0 + surface.wrap)).max(0.0);
        irr += l.sun * (wrapped * sun_vis);
    }
    if l.night {
        lights.add_irradiance(&mut irr, p_rel, normal);
    }
    let mut rgb = surface.albedo.tint(irr) + surface.emissive;
    if surface.gloss > 0.0 {
        // Objects' reflections are kept from sweeping at grazing angles (they would change
        // between frames); the wet road keeps its full grazing-angle sheen.
        let cos = if hit.key == KEY_GROUND {
            -dn.dot(normal)
        } else {
            (-dn.dot(normal)).abs().max(0.5)
        };
        let r = dn - normal * (2.0 * dn.dot(normal));
        let env = if r.z > 0.0 {
            sky_gradient(l, r)
        } else {
            l.ground_ambient * 0.5
        };
        rgb += env * (fresnel(cos) * surface.gloss);
    }
    // Haze / fog.
    let f = 1.0 - (-dist / l.haze_distance).exp();
    rgb = rgb.lerp(l.haze, f);
    Shaded {
        rgb,
        semantic: surface.semantic,
        tag: surface.tag,
        id: surface.id,
    }
}

/// Ground material, normal, ambient occlusion and sun visibility.
fn ground(view: &FrameView, hit: &Hit, dn: V3, p_rel: V3, tile: usize) -> (Surface, V3, f32, f32) {
    let world = view.world;
    let road = &world.road;
    let l = &world.lighting;
    let (s, d) = (hit.local.x, hit.local.y);
    // Footprint of the pixel on the ground along and across the road, from the derivatives
    // of the ground point with respect to the image coordinates (a pixel seen at a grazing
    // angle covers a long, skewed parallelogram).
    let cam = &view.cam;
    let dir = dn * (1.0 / dn.dot(V3::new(cam.c, cam.s, 0.0)).max(1e-4));
    let b = (-dir.z).max(1e-4);
    let t = hit.t;
    let du = V3::new(cam.s, -cam.c, 0.0) * (t / cam.fx);
    let dv = V3::new(dir.x, dir.y, 0.0) * (t / (b * cam.fy));
    // The road direction at the camera is close enough for a footprint estimate.
    let (tx, ty) = view.road_tangent();
    let along = |v: V3| (v.x * tx + v.y * ty).abs();
    let across = |v: V3| (-v.x * ty + v.y * tx).abs();
    let fa = (TEXTURE_FILTER_PX * (along(du) + along(dv))).min(40.0);
    let fd = (TEXTURE_FILTER_PX * (across(du) + across(dv))).min(40.0);
    // Isotropic footprint for noise: geometric mean of the two axes.
    let fn_ = (fa * fd).sqrt();
    let salt = world.ground_salt;
    let region = if hit.part == 1 {
        GroundRegion::Kerb
    } else {
        road.region(s, d)
    };
    let mut gloss = 0.0;
    let (albedo, semantic) = match region {
        GroundRegion::Road => {
            let big = fbm2(s, d, salt, 7.0, 2, 0.5, fn_);
            let grain = fbm2(s, d, salt ^ 0xa5a5, 0.35, 3, 0.6, fn_);
            let mut a = 0.085 * (0.7 + 0.6 * big) * (0.78 + 0.44 * grain);
            // Repaired patches.
            let cell_s = floor(s / 14.0);
            let cell_d = floor(d / 3.5);
            let u = unit2(cell_s as i32, cell_d as i32, salt ^ 0x77);
            if u < 0.12 {
                let x0 = cell_s * 14.0 + 2.0 + 6.0 * u;
                let y0 = cell_d * 3.5 + 0.4;
                let cover = filtered_rect(s, d, [x0, x0 + 4.0 + 20.0 * u, y0, y0 + 2.2], fa, fd);
                a *= 1.0 - 0.3 * cover;
            }
            // Polished wheel tracks in the lanes.
            let ad = d.abs();
            if ad < road.inner + road.lane_width * road.lanes as f32 && ad > road.inner {
                let in_lane = wrap(ad - road.inner, road.lane_width) - 0.5 * road.lane_width;
                let track = smoothstep(0.5, 0.2, (in_lane.abs() - 0.85).abs());
                a *= 1.0 - 0.14 * track;
            }
            let m = road.marking(s, d, fa, fd);
            let paint_wear = 0.8 + 0.2 * grain;
            let base = Rgb::grey(a);
            let mut c = base.lerp(Rgb::grey(0.62 * paint_wear), m.white);
            c = c.lerp(Rgb::new(0.55, 0.36, 0.03) * paint_wear, m.yellow);
            let wet = l.wetness;
            if wet > 0.0 {
                let puddle = smoothstep(0.45, 0.65, fbm2(s, d, salt ^ 0x3131, 4.0, 3, 0.5, fn_));
                c = c * (1.0 - 0.5 * wet * (0.6 + 0.4 * puddle));
                gloss = wet * (0.35 + 0.65 * puddle);
            }
            // The label is the paint under the pixel centre, not the filtered coverage (which
            // only differs near paint edges).
            let cover = m.white + m.yellow;
            let painted = if cover <= 0.0 {
                false
            } else if cover >= 1.0 {
                true
            } else {
                let point = road.marking(s, d, 0.0, 0.0);
                point.white + point.yellow > 0.5
            };
            let sem = if painted { 24 } else { 1 };
            (c, sem)
        }
        GroundRegion::Kerb => {
            let n = fbm2(s, d, salt ^ 0x1111, 0.5, 3, 0.5, fn_);
            let joints = filtered_pulse(s, 1.0, 0.03, fa);
            (Rgb::grey(0.30 * (0.85 + 0.3 * n) * (1.0 - 0.4 * joints)), 2)
        }
        GroundRegion::Sidewalk => {
            let tile_size = 0.6;
            let tone = fbm2(s, d, salt ^ 0x2222, 1.2, 2, 0.5, fn_);
            let joint =
                filtered_pulse(s, tile_size, 0.03, fa).max(filtered_pulse(d, tile_size, 0.03, fd));
            let stain = fbm2(s, d, salt ^ 0x2323, 3.0, 3, 0.5, fn_);
            let a = 0.25 * (0.8 + 0.3 * tone) * (0.8 + 0.4 * stain) * (1.0 - 0.35 * joint);
            let mut c = Rgb::new(a, a * 0.98, a * 0.95);
            if l.wetness > 0.0 {
                c = c * (1.0 - 0.35 * l.wetness);
                gloss = 0.15 * l.wetness;
            }
            (c, 2)
        }
        GroundRegion::Terrain => {
            let edge = d.abs() - road.road_half;
            let n = fbm2(s, d, salt ^ 0x4444, 2.5, 3, 0.55, fn_);
            let dry = smoothstep(0.6, 0.8, value2(s / 12.0, d / 12.0, salt ^ 0x4545));
            let grass = Rgb::new(0.055, 0.085, 0.025).lerp(Rgb::new(0.12, 0.1, 0.05), dry)
                * (0.6 + 0.8 * n);
            let gravel = Rgb::grey(0.13 * (0.8 + 0.4 * n));
            let c = gravel.lerp(grass, smoothstep(0.6, 1.4, edge));
            (c, if edge < 1.0 { 1 } else { 10 })
        }
    };
    let normal = hit.normal;
    // Vehicle contact shadows and sun shadows.
    let mut ao = 1.0;
    let mut sun_vis = 1.0;
    // Vehicle shadows further away than this cover less than a pixel or two.
    let shadow_range = 25.0 * view.cam.fx / 192.0;
    for &pi in view.tile_vehicles(tile) {
        if hit.t > shadow_range {
            break;
        }
        let prim = &view.prims[pi as usize];
        let PrimRef::Vehicle(vi) = prim.what else {
            continue;
        };
        let m = &world.traffic.vehicles[vi as usize].model;
        let gl = (p_rel - prim.origin).unrotate_z(prim.c, prim.s);
        let out = ((gl.x.abs() - 0.5 * m.length + 0.15) / 1.2)
            .max((gl.y.abs() - 0.5 * m.width + 0.1) / 0.7);
        ao *= 1.0 - 0.8 * smoothstep(0.7, -0.4, out);
        if sun_vis > 0.0
            && let Some((kx, ky)) = view.shadow_step
        {
            // Quick reject: outside the footprint stretched by the longest shadow.
            let reach = m.height * (kx * kx + ky * ky).sqrt();
            if gl.x.abs() > 0.5 * m.length + reach || gl.y.abs() > 0.5 * m.width + reach {
                continue;
            }
            let sl = l.sun_dir.unrotate_z(prim.c, prim.s);
            if super::render::intersect_vehicle(m, gl + V3::new(0.0, 0.0, 0.01), sl, 60.0).is_some()
            {
                sun_vis = 0.0;
            }
        }
    }
    let surface = Surface {
        albedo,
        emissive: Rgb::BLACK,
        gloss,
        wrap: 0.0,
        semantic,
        tag: semantic,
        id: 0,
    };
    (surface, normal, ao, sun_vis)
}

/// Materials of static objects.
fn static_surface(view: &FrameView, index: usize, hit: &Hit, fu: f32, fw: f32) -> Surface {
    let world = view.world;
    let l = &world.lighting;
    let obj = &world.scenery.objects[index];
    let p = hit.local;
    let n = hit.normal;
    let salt = obj.salt;
    let sem = obj.semantic();
    match obj.kind {
        StaticKind::Building {
            palette,
            floor: floor_h,
            bay,
            window,
            facing,
        } => {
            let Shape::Box { hx, hy, z1, .. } = obj.shape else {
                return Surface::matte(Rgb::grey(0.3), sem);
            };
            if n.z > 0.5 {
                return Surface::matte(Rgb::grey(0.1), sem);
            }
            let front = n.y * facing > 0.5;
            let u = if n.y.abs() > 0.5 { p.x + hx } else { p.y + hy };
            let v = p.z;
            let wall_c = WALL_PALETTE[palette as usize % WALL_PALETTE.len()];
            let wall_n = fbm2(u, v, salt, 5.0, 3, 0.5, fu.max(fw));
            let mut albedo = Rgb::new(wall_c[0], wall_c[1], wall_c[2]) * (0.8 + 0.4 * wall_n);
            let mut emissive = Rgb::BLACK;
            let mut gloss = 0.0;
            let ground_floor = 4.2;
            // Upper-floor windows.
            let win_w = bay * window;
            let sill = 0.95;
            let win_h = floor_h * 0.47;
            // The costly pulses of a coverage product are skipped where another factor is
            // zero: the product is then exactly zero anyway.
            let upper = filtered_band(v, ground_floor, z1 - 1.2, fw);
            let (glass, frame) = if upper > 0.0 {
                let glass_u = filtered_pulse(u - 0.5 * (bay - win_w), bay, win_w, fu);
                let glass = if glass_u > 0.0 {
                    glass_u * (filtered_pulse(v - ground_floor - sill, floor_h, win_h, fw) * upper)
                } else {
                    0.0
                };
                let frame_u = filtered_pulse(u - 0.5 * (bay - win_w) + 0.1, bay, win_w + 0.2, fu);
                let frame = if frame_u > 0.0 {
                    let frame_v =
                        filtered_pulse(v - ground_floor - sill + 0.1, floor_h, win_h + 0.2, fw);
                    (frame_u * (frame_v * upper) - glass).max(0.0)
                } else {
                    0.0
                };
                (glass, frame)
            } else {
                (0.0, 0.0)
            };
            let iu = floor((u - 0.5 * (bay - win_w)) / bay) as i32;
            let iv = floor((v - ground_floor - sill) / floor_h) as i32;
            let wv = unit2(iu, iv, salt ^ 0x5151);
            let detail = octave_weight(bay, fu);
            let glass_tone = 0.05 + 0.06 * (0.5 + (wv - 0.5) * detail);
            let glass_c = Rgb::new(glass_tone * 0.8, glass_tone * 0.9, glass_tone * 1.1);
            albedo = albedo.lerp(Rgb::grey(0.5), frame * 0.8);
            albedo = albedo.lerp(glass_c, glass);
            gloss += 0.6 * glass;
            if l.night {
                let lit = smoothstep(0.55, 0.6, wv) * detail + 0.35 * (1.0 - detail);
                emissive += Rgb::new(1.0, 0.72, 0.4) * (0.5 * lit * glass);
            }
            // Shop fronts along the street.
            if front {
                let shop_v = filtered_band(v, 0.5, 3.3, fw);
                let shop = if shop_v > 0.0 {
                    filtered_pulse(u - 0.4, 2.0 * bay, 2.0 * bay - 0.8, fu) * shop_v
                } else {
                    0.0
                };
                let sign =
                    filtered_band(v, 3.5, 4.0, fw) * filtered_band(u, 0.5, 2.0 * hx - 0.5, fu);
                // Without the sign its colour would add exactly nothing.
                let sign_c = (sign > 0.0).then(|| {
                    Rgb::new(
                        0.1 + 0.5 * unit2(palette as i32, 1, salt),
                        0.1 + 0.4 * unit2(palette as i32, 2, salt),
                        0.1 + 0.5 * unit2(palette as i32, 3, salt),
                    )
                });
                if let Some(c) = sign_c {
                    albedo = albedo.lerp(c, sign);
                }
                albedo = albedo.lerp(Rgb::new(0.05, 0.055, 0.06), shop);
                gloss += 0.5 * shop;
                if l.night {
                    let shop_light = Rgb::new(1.0, 0.85, 0.6) * (0.8 * shop);
                    emissive += match sign_c {
                        Some(c) => shop_light + c * (1.5 * sign),
                        None => shop_light,
                    };
                }
            }
            // Cornice.
            let cornice = filtered_band(v, z1 - 0.6, z1, fw);
            albedo = albedo.lerp(albedo * 1.25 + Rgb::grey(0.05), cornice);
            Surface {
                albedo,
                emissive,
                gloss,
                wrap: 0.0,
                semantic: sem,
                tag: sem,
                id: 0,
            }
        }
        StaticKind::Pole => Surface {
            gloss: 0.1,
            ..Surface::matte(Rgb::grey(0.22), sem)
        },
        StaticKind::LampHead => {
            let mut s = Surface::matte(Rgb::grey(0.06), sem);
            if l.night && n.z < -0.5 {
                s.emissive = Rgb::new(1.0, 0.8, 0.55) * 8.0;
            }
            s
        }
        StaticKind::TrafficLight { intersection } => {
            let mut s = Surface::matte(Rgb::grey(0.025), sem);
            let Shape::Box { z0, .. } = obj.shape else {
                return s;
            };
            if n.x < -0.5 {
                let state = world.traffic.lights[view.frame]
                    .get(intersection as usize)
                    .copied()
                    .unwrap_or(LightState::Green);
                let (lit_z, colour) = lamp_of(state, z0);
                for (zc, c) in [
                    (z0 + 0.88, Rgb::new(1.0, 0.04, 0.02)),
                    (z0 + 0.55, Rgb::new(1.0, 0.5, 0.02)),
                    (z0 + 0.22, Rgb::new(0.05, 1.0, 0.45)),
                ] {
                    let r = (p.y * p.y + (p.z - zc) * (p.z - zc)).sqrt();
                    let cover = smoothstep(0.12 + fw, 0.12 - fw, r);
                    if cover > 0.0 {
                        s.albedo = s.albedo.lerp(c * 0.05, cover);
                        if (zc - lit_z).abs() < 1e-3 {
                            s.emissive += colour * (6.0 * cover);
                        }
                    }
                }
            }
            s
        }
        StaticKind::Trunk => {
            let bark = value2(p.z * 3.0, (p.x.atan2(p.y)) * 2.0, salt);
            Surface::matte(Rgb::new(0.07, 0.05, 0.035) * (0.7 + 0.6 * bark), sem)
        }
        StaticKind::Foliage => {
            let fine = if octave_weight(0.35, fw) > 0.0 {
                (value3(p.x / 0.35, p.y / 0.35, p.z / 0.35, salt) - 0.5) * octave_weight(0.35, fw)
            } else {
                0.0
            };
            let coarse = value3(p.x / 1.2, p.y / 1.2, p.z / 1.2, salt ^ 0x33) - 0.5;
            let tone = 0.75 + 0.5 * coarse + 0.6 * fine;
            let hue = unit2(salt as i32, 0, 0x1234);
            let base = Rgb::new(0.04, 0.085, 0.02).lerp(Rgb::new(0.07, 0.09, 0.025), hue);
            Surface {
                wrap: 0.4,
                ..Surface::matte(base * tone.max(0.2), sem)
            }
        }
        StaticKind::TreeLine => {
            let coarse = fbm2(p.x, p.z, salt, 3.0, 4, 0.6, fw);
            let trunk =
                filtered_pulse(p.x + 40.0, 3.7, 0.35, fu) * filtered_band(p.z, 0.0, 3.0, fw);
            let depth_shade = 0.55 + 0.45 * smoothstep(0.0, 6.0, p.z);
            let leaves = Rgb::new(0.035, 0.065, 0.018) * ((0.5 + coarse) * depth_shade);
            let c = leaves.lerp(Rgb::new(0.04, 0.03, 0.02), trunk * 0.7);
            Surface {
                wrap: 0.6,
                ..Surface::matte(c, sem)
            }
        }
        StaticKind::GuardRail => {
            if p.z >= 0.42 {
                let groove = filtered_band(p.z, 0.58, 0.64, fw);
                let n2 = fbm2(p.x, p.z, salt, 1.0, 2, 0.5, fu);
                Surface {
                    gloss: 0.15,
                    ..Surface::matte(
                        Rgb::grey(0.36 * (1.0 - 0.35 * groove) * (0.85 + 0.3 * n2)),
                        sem,
                    )
                }
            } else {
                Surface::matte(Rgb::grey(0.16), sem)
            }
        }
    }
}

/// Semantic id of vehicle `i` in this frame: lead in braking scenarios is 114 (agent_car),
/// 100 (anomaly) inside the anomaly window; others their CARLA tag.
pub fn vehicle_semantic(view: &FrameView, i: usize) -> u8 {
    let world = view.world;
    let v = &world.traffic.vehicles[i];
    if i == LEAD && world.labels_lead_as_agent {
        let in_window = world
            .traffic
            .anomaly
            .is_some_and(|w| w.contains(view.frame as u32));
        if in_window { 100 } else { 114 }
    } else {
        v.model.body.tag()
    }
}

/// Materials of vehicles.
fn vehicle_surface(view: &FrameView, i: usize, hit: &Hit, fu: f32, fw: f32) -> Surface {
    let world = view.world;
    let l = &world.lighting;
    let v = &world.traffic.vehicles[i];
    let st = &world.traffic.states[view.frame][i];
    let m: &VehicleModel = &v.model;
    let p = hit.local;
    let n = hit.normal;
    let semantic = vehicle_semantic(view, i);
    let tag = m.body.tag();
    let id = (v.track_id & 0xffff) as u16;
    let paint = m.paint;
    let mut s = Surface {
        albedo: paint,
        emissive: Rgb::BLACK,
        gloss: 0.45,
        wrap: 0.0,
        semantic,
        tag,
        id,
    };
    let moving = v.role != Role::Parked;
    if hit.part >= WHEEL_PART {
        let k = (hit.part - WHEEL_PART) as usize;
        s.gloss = 0.05;
        s.albedo = Rgb::grey(0.03);
        if let Some(w) = m.wheels.get(k)
            && n.y.abs() > 0.5
        {
            let r = ((p.x - w.x) * (p.x - w.x) + (p.z - w.r) * (p.z - w.r)).sqrt() / w.r;
            let rim = filtered_band(r, 0.12, 0.62, fw / w.r);
            let ring = filtered_band(r, 0.3, 0.36, fw / w.r);
            s.albedo = s.albedo.lerp(Rgb::grey(0.32 * (1.0 - 0.5 * ring)), rim);
            s.gloss = 0.2 * rim;
        }
        return s;
    }
    let Some(part) = m.parts.get(hit.part as usize) else {
        return s;
    };
    let rear = n.x < -0.75;
    let front = n.x > 0.75;
    let top = n.z > 0.85;
    let glass = Rgb::new(0.015, 0.018, 0.022);
    // Tail lights: on any rear face that covers the lamp rectangle.
    let lamp_cover = |r: super::vehicle::LampRect| {
        filtered_band(p.y.abs(), r.y0, r.y1, fu) * filtered_band(p.z, r.z0, r.z1, fw)
    };
    if rear {
        let tail = lamp_cover(m.tail);
        if tail > 0.0 {
            let on = if st.brake_lights && moving {
                Rgb::new(5.0, 0.18, 0.08)
            } else if l.night && moving {
                Rgb::new(1.3, 0.04, 0.02)
            } else {
                Rgb::BLACK
            };
            s.albedo = s.albedo.lerp(Rgb::new(0.28, 0.015, 0.01), tail);
            s.emissive += on * tail;
            s.gloss = s.gloss.max(0.6 * tail);
        }
    }
    if front && l.night && moving {
        let head = lamp_cover(m.head);
        s.albedo = s.albedo.lerp(Rgb::grey(0.5), head);
        s.emissive += Rgb::new(6.0, 5.7, 5.1) * head;
    } else if front {
        let head = lamp_cover(m.head);
        s.albedo = s.albedo.lerp(Rgb::grey(0.45), head);
    }
    match part.kind {
        PartKind::Body => {
            let clearance = m.parts[0].planes[5].d.abs();
            if rear || front {
                // Bumper and number plate.
                let bumper = filtered_band(p.z, 0.0, clearance + 0.17, fw);
                let plate_z = clearance + 0.2;
                let plate = filtered_band(p.y, -0.26, 0.26, fu)
                    * filtered_band(p.z, plate_z, plate_z + 0.12, fw);
                s.albedo = s.albedo.lerp(Rgb::grey(0.035), bumper * 0.85);
                s.albedo = s.albedo.lerp(Rgb::new(0.6, 0.6, 0.55), plate);
                if front {
                    let grille = filtered_band(p.y, -0.4, 0.4, fu)
                        * filtered_band(p.z, clearance + 0.22, clearance + 0.38, fw);
                    s.albedo = s.albedo.lerp(Rgb::grey(0.02), grille);
                }
            } else if n.y.abs() > 0.6 {
                // Wheel arches and a door seam.
                for w in &m.wheels {
                    let r = ((p.x - w.x) * (p.x - w.x) + (p.z - w.r) * (p.z - w.r)).sqrt();
                    let arch = filtered_band(r, 0.0, w.r + 0.08, fw);
                    s.albedo = s.albedo.lerp(Rgb::grey(0.01), arch);
                }
                let seam =
                    filtered_band(p.x, -0.05, -0.03, fu) + filtered_band(p.x, 0.95, 0.97, fu);
                s.albedo = s.albedo * (1.0 - 0.5 * seam.min(1.0));
            }
            if m.body == BodyType::Van && rear {
                let split = filtered_band(p.y, -0.015, 0.015, fu);
                s.albedo = s.albedo * (1.0 - 0.6 * split);
            }
        }
        PartKind::Cabin => {
            let belt = part.planes[5].d.abs();
            let roof = part.planes[4].d;
            if !top {
                let band = filtered_band(p.z, belt + 0.05, roof - 0.07, fw);
                let mut win = band;
                if n.y.abs() > 0.6 {
                    if m.body == BodyType::Van {
                        let front_base = part.planes[0].d;
                        win *= filtered_band(p.x, front_base - 1.3, front_base + 1.0, fu);
                    } else {
                        // B-pillar.
                        let pillar = filtered_band(p.x, -0.1, 0.02, fu);
                        win *= 1.0 - pillar;
                    }
                } else if m.body == BodyType::Van && rear {
                    win *= filtered_band(p.z, 1.2, roof - 0.15, fw)
                        * (1.0 - filtered_band(p.y, -0.04, 0.04, fu));
                } else {
                    let half = m.width * 0.5 - 0.2;
                    win *= filtered_band(p.y, -half, half, fu);
                }
                s.albedo = s.albedo.lerp(glass, win);
                s.gloss += 0.4 * win;
                if rear && st.brake_lights && moving && m.body != BodyType::Van {
                    // Third brake light at the top of the rear window.
                    let third = filtered_band(p.y, -0.25, 0.25, fu)
                        * filtered_band(p.z, roof - 0.13, roof - 0.07, fw);
                    s.emissive += Rgb::new(4.0, 0.1, 0.05) * third;
                }
            }
        }
        PartKind::Cab => {
            let hl = 0.5 * m.length;
            let upper = filtered_band(p.z, 1.85, 2.75, fw);
            let win = if front {
                upper * filtered_band(p.y, -1.05, 1.05, fu)
            } else if n.y.abs() > 0.6 {
                upper * filtered_band(p.x, hl - 1.3, hl - 0.15, fu)
            } else {
                0.0
            };
            s.albedo = Rgb::new(0.7, 0.7, 0.69).lerp(glass, win);
            if front {
                let grille = filtered_band(p.z, 0.8, 1.5, fw) * filtered_band(p.y, -0.8, 0.8, fu);
                s.albedo = s.albedo.lerp(Rgb::grey(0.03), grille);
            }
        }
        PartKind::Cargo => {
            let ribs = filtered_pulse(p.x + 20.0, 0.6, 0.06, fu);
            s.gloss = 0.15;
            if rear {
                let split = filtered_band(p.y, -0.02, 0.02, fu);
                let bars = filtered_pulse(p.y.abs() - 0.3, 10.0, 0.06, fu);
                let dirt = 1.0 - 0.3 * smoothstep(1.8, 1.05, p.z);
                s.albedo = s.albedo * ((1.0 - 0.6 * split) * (1.0 - 0.4 * bars) * dirt);
            } else if n.y.abs() > 0.6 {
                s.albedo = s.albedo * (1.0 - 0.25 * ribs);
            }
        }
        PartKind::Chassis => {
            s.gloss = 0.05;
            let mut a = Rgb::grey(0.03);
            if rear {
                let plate =
                    filtered_band(p.y, -0.26, 0.26, fu) * filtered_band(p.z, 0.54, 0.66, fw);
                a = a.lerp(Rgb::new(0.6, 0.6, 0.55), plate);
                let tail = lamp_cover(m.tail);
                a = a.lerp(Rgb::new(0.28, 0.015, 0.01), tail);
            }
            s.albedo = a;
        }
        PartKind::BusBody => {
            let h = m.height;
            let win = if n.y.abs() > 0.6 {
                filtered_band(p.z, 1.2, h - 0.45, fw)
                    * (1.0 - filtered_pulse(p.x + 30.0, 1.5, 0.14, fu))
            } else if front {
                filtered_band(p.z, 0.95, h - 0.35, fw) * filtered_band(p.y, -1.1, 1.1, fu)
            } else if rear {
                filtered_band(p.z, 2.0, h - 0.4, fw) * filtered_band(p.y, -1.0, 1.0, fu)
            } else {
                0.0
            };
            let skirt = filtered_band(p.z, 0.0, 0.6, fw);
            s.albedo = s.albedo.lerp(Rgb::grey(0.05), skirt).lerp(glass, win);
            s.gloss += 0.3 * win;
        }
    }
    s
}
