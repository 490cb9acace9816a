//! One frame end to end: ray casting every pixel into a geometry buffer (object key, depth,
//! surface point) and shaded radiance, then post-processing, ground-truth flow from the
//! previous frame's geometry buffer, boxes and the ACTION/ANOMALY records, assembled into a
//! `sequence::FrameRecord`.

use rayon::prelude::*;

use super::gbuffer::GBuffer;
use super::keys::{KEY_BACKDROP, KEY_GROUND, KEY_SKY, KEY_VEHICLE};
use super::light_bank::LightBank;
use super::math::{Rgb, V3};
use super::render::{FrameView, GroundHint, Hit, TILE};
use super::world::World;
use super::{flow, labels, post, shade};
use crate::sequence::{FrameId, FrameRecord};

/// Depth written for sky and backdrop pixels (CARLA's far plane).
pub const FAR_DEPTH_M: f32 = 1000.0;

/// Shaded output of a frame before post-processing.
pub struct Shading {
    /// Linear radiance.
    pub hdr: Vec<Rgb>,
    /// Semantic ids.
    pub semantic: Vec<u8>,
    /// Instance tags.
    pub tag: Vec<u8>,
    /// Instance ids.
    pub id: Vec<u16>,
}

/// One band of `TILE` image rows of every per-pixel output of [`cast`] (the shading slices
/// are empty without shading).
struct Band<'a> {
    key: &'a mut [u32],
    part: &'a mut [u8],
    depth: &'a mut [f32],
    point: &'a mut [V3],
    rgb: &'a mut [Rgb],
    semantic: &'a mut [u8],
    tag: &'a mut [u8],
    id: &'a mut [u16],
}

impl Band<'_> {
    /// Stores the shading of pixel `i` of the band.
    #[inline]
    fn put(&mut self, i: usize, s: shade::Shaded) {
        self.rgb[i] = s.rgb;
        self.semantic[i] = s.semantic;
        self.tag[i] = s.tag;
        self.id[i] = s.id;
    }
}

/// Ray-casts every pixel of `view`; shades them too when `with_shading`.
pub fn cast(view: &FrameView, with_shading: bool) -> (GBuffer, Option<Shading>) {
    let w = view.cam.width as usize;
    let h = view.cam.height_px as usize;
    let n = w * h;
    let shaded = if with_shading { n } else { 0 };
    let mut key = vec![0u32; n];
    let mut part = vec![0u8; n];
    let mut depth = vec![0.0f32; n];
    let mut point = vec![V3::default(); n];
    let mut hdr = vec![Rgb::BLACK; shaded];
    let mut semantic = vec![0u8; shaded];
    let mut tag = vec![0u8; shaded];
    let mut id = vec![0u16; shaded];
    // Each output is written in place, band by band, rather than gathered from a buffer of
    // whole pixel records afterwards.
    let rows = w * TILE;
    let (mut rgb_bands, mut semantic_bands) = (hdr.chunks_mut(rows), semantic.chunks_mut(rows));
    let (mut tag_bands, mut id_bands) = (tag.chunks_mut(rows), id.chunks_mut(rows));
    let bands: Vec<Band> = key
        .chunks_mut(rows)
        .zip(part.chunks_mut(rows))
        .zip(depth.chunks_mut(rows))
        .zip(point.chunks_mut(rows))
        .map(|(((key, part), depth), point)| Band {
            key,
            part,
            depth,
            point,
            rgb: rgb_bands.next().unwrap_or_default(),
            semantic: semantic_bands.next().unwrap_or_default(),
            tag: tag_bands.next().unwrap_or_default(),
            id: id_bands.next().unwrap_or_default(),
        })
        .collect();
    let cam = &view.cam;
    let tiles_x = w.div_ceil(TILE);
    // A pixel's ray shares its horizontal components with its column and the rest with its
    // row: computed once each instead of per pixel.
    let columns: Vec<(f32, f32)> = (0..w).map(|x| cam.ray_xy(x as f32 + 0.5)).collect();
    // At night a tile is traced before it is shaded: the box around its surface points
    // tells which of its lights can reach any of them. By day each pixel is shaded as soon
    // as it is traced.
    let deferred = with_shading && view.world.lighting.night;
    bands
        .into_par_iter()
        .enumerate()
        .for_each(|(band, mut out)| {
            let band_rows = out.key.len() / w;
            let mut hits: Vec<(usize, Hit, V3)> = Vec::new();
            let mut reaching = Vec::new();
            let mut bank = LightBank::default();
            // Tile by tile, so that each tile's primitive list is fetched once and the previous
            // pixels' ground points seed the Frenet inversion of the next.
            for tx in 0..tiles_x {
                let tile = band * tiles_x + tx;
                let x_end = ((tx + 1) * TILE).min(w);
                let mut lo = V3::new(f32::INFINITY, f32::INFINITY, f32::INFINITY);
                let mut hi = V3::new(f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY);
                for r in 0..band_rows {
                    let y = band * TILE + r;
                    let v = y as f32 + 0.5;
                    let dir_z = cam.ray_z(v);
                    let planes = view.plane_hits(dir_z);
                    let mut hint = None;
                    let mut last_ground: Option<GroundHint> = None;
                    for (x, &(dir_x, dir_y)) in
                        columns.iter().enumerate().take(x_end).skip(tx * TILE)
                    {
                        let i = r * w + x;
                        let u = x as f32 + 0.5;
                        let dir = V3::new(dir_x, dir_y, dir_z);
                        let hit = view.trace_planes(dir, planes, u, v, tile, hint);
                        (hint, last_ground) = next_ground_hint(&hit, last_ground);
                        out.key[i] = hit.key;
                        out.part[i] = hit.part;
                        out.depth[i] = hit.t;
                        out.point[i] = match hit.key {
                            KEY_SKY | KEY_BACKDROP => dir,
                            k if k & KEY_VEHICLE != 0 => hit.local,
                            _ => {
                                let p = cam.origin() + dir * hit.t;
                                V3::new(cam.x + p.x, cam.y + p.y, p.z)
                            }
                        };
                        if deferred {
                            if !matches!(hit.key, KEY_SKY | KEY_BACKDROP) {
                                // The camera-relative point that shading lights.
                                let p = cam.origin() + dir * hit.t;
                                lo = lo.min(p);
                                hi = hi.max(p);
                            }
                            hits.push((i, hit, dir));
                        } else if with_shading {
                            out.put(i, shade::shade(view, &hit, dir, tile, &bank));
                        }
                    }
                }
                if deferred {
                    bank.fill(view, view.lights_reaching(tile, lo, hi, &mut reaching));
                    for (i, hit, dir) in hits.drain(..) {
                        out.put(i, shade::shade(view, &hit, dir, tile, &bank));
                    }
                }
            }
        });
    if with_shading {
        antialias_edges(view, &key, &part, &mut hdr);
    }
    let gbuf = GBuffer {
        width: w,
        height: h,
        key,
        depth,
        point,
    };
    let shading = with_shading.then_some(Shading {
        hdr,
        semantic,
        tag,
        id,
    });
    (gbuf, shading)
}

/// The hint for the next pixel of a row from this pixel's hit and the previous pixel's
/// ground point, and this pixel's ground point. The ground points of a row lie on a
/// straight line in the world (one line per level), so two neighbours on one level predict
/// the next one's arc length almost exactly.
#[inline]
fn next_ground_hint(
    hit: &Hit,
    last: Option<GroundHint>,
) -> (Option<GroundHint>, Option<GroundHint>) {
    if hit.key != KEY_GROUND {
        return (None, None);
    }
    let here = GroundHint {
        s: hit.local.x,
        raised: hit.local.z > 0.0,
    };
    let next = match last {
        Some(prev) if prev.raised == here.raised => GroundHint {
            s: 2.0 * here.s - prev.s,
            ..here
        },
        _ => here,
    };
    (Some(next), Some(here))
}

/// Sub-pixel offsets of the extra samples at object boundaries (with the centre sample they
/// form a diagonal of three, enough to soften silhouettes at a third of the cost of 4×).
const EDGE_SAMPLES: [(f32, f32); 2] = [(-0.25, -0.25), (0.25, 0.25)];

/// Re-shades pixels on object boundaries with two extra samples and averages them with the
/// centre sample, so that silhouettes are anti-aliased. Labels, depth and geometry keep the
/// centre sample.
fn antialias_edges(view: &FrameView, key: &[u32], part: &[u8], hdr: &mut [Rgb]) {
    let w = view.cam.width as usize;
    let h = view.cam.height_px as usize;
    // Parts count as separate surfaces so that kerb faces and vehicle parts are smoothed too.
    let surfaces: Vec<u32> = key
        .par_iter()
        .zip(part)
        .map(|(&k, &p)| k ^ ((p as u32) << 24))
        .collect();
    let surface = |i: usize| surfaces[i];
    let lum: Vec<f32> = hdr.par_iter().map(|c| c.luminance()).collect();
    let cam = &view.cam;
    let night = view.world.lighting.night;
    hdr.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let mut bank = LightBank::default();
        let mut bank_tile = None;
        for (x, out) in row.iter_mut().enumerate() {
            let i = y * w + x;
            let (k, l) = (surface(i), lum[i]);
            // Only boundaries that show: another surface with a visibly different brightness.
            let visible =
                |j: usize| surface(j) != k && (lum[j] - l).abs() > 0.04 * (lum[j] + l) + 0.002;
            let edge = (x > 0 && visible(i - 1))
                || (x + 1 < w && visible(i + 1))
                || (y > 0 && visible(i - w))
                || (y + 1 < h && visible(i + w));
            if !edge {
                continue;
            }
            let mut sum = *out;
            for (dx, dy) in EDGE_SAMPLES {
                let (u, v) = (x as f32 + 0.5 + dx, y as f32 + 0.5 + dy);
                let dir = cam.ray(u, v);
                let tile = view.tile_of(u, v);
                // Sub-samples may leave the tile's box of surface points: all its lights.
                if night && bank_tile != Some(tile) {
                    bank.fill(view, view.tile_lights(tile));
                    bank_tile = Some(tile);
                }
                let hit = view.trace_in_tile(dir, u, v, tile, None);
                sum += shade::shade(view, &hit, dir, tile, &bank).rgb;
            }
            *out = sum * (1.0 / (1 + EDGE_SAMPLES.len()) as f32);
        }
    });
}

/// Renders frame `frame` completely. `prev` is the previous frame's geometry buffer (for the
/// flow); frame 0 gets zero flow.
pub fn render_record(
    world: &World,
    frame: usize,
    prev: Option<&GBuffer>,
) -> (FrameRecord, GBuffer) {
    let view = FrameView::new(world, frame);
    let (gbuf, shading) = cast(&view, true);
    let Some(shading) = shading else {
        unreachable!("cast with shading returns shading");
    };
    let w = gbuf.width as u32;
    let h = gbuf.height as u32;
    let rgb = post::finish(world, &view, &gbuf, shading.hdr);
    let semantic = image::GrayImage::from_raw(w, h, shading.semantic)
        .unwrap_or_else(|| image::GrayImage::new(w, h));
    let mut inst = vec![0u8; shading.tag.len() * 3];
    inst.par_chunks_mut(3 * w as usize)
        .zip(shading.tag.par_chunks(w as usize))
        .zip(shading.id.par_chunks(w as usize))
        .for_each(|((out, tags), ids)| {
            for ((px, &t), &id) in out.chunks_exact_mut(3).zip(tags).zip(ids) {
                px.copy_from_slice(&[t, (id & 0xff) as u8, (id >> 8) as u8]);
            }
        });
    let instance =
        image::RgbImage::from_raw(w, h, inst).unwrap_or_else(|| image::RgbImage::new(w, h));
    let depth_m: Vec<f32> = gbuf.depth.par_iter().map(|d| d.min(FAR_DEPTH_M)).collect();
    let flow = match prev {
        Some(p) => flow::exact_flow(world, p, &view, &gbuf),
        None => crate::sequence::FlowField::zeros(w, h),
    };
    let boxes = labels::boxes(world, frame, &gbuf.key, &shading.tag, w as usize);
    let anomalous = world
        .traffic
        .anomaly
        .is_some_and(|a| a.contains(frame as u32));
    let record = FrameRecord {
        id: FrameId(frame as u64),
        rgb,
        semantic: Some(semantic),
        instance: Some(instance),
        depth_m: Some(depth_m),
        flow: Some(flow),
        action: Some(labels::action(world, frame)),
        anomaly: labels::anomaly(world, frame),
        boxes,
        anomalous: Some(anomalous),
    };
    (record, gbuf)
}

/// The geometry buffer of a frame without shading (to seed the flow of the next frame).
pub fn geometry(world: &World, frame: usize) -> GBuffer {
    let view = FrameView::new(world, frame);
    cast(&view, false).0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::{Domain, Weather};
    use crate::synth::{Scenario, ScenarioKind, ScenarioSpec};

    /// The tile loop seeds each ground pixel with its row neighbours (`next_ground_hint`),
    /// and a pixel whose road point lies well inside the carriageway skips the raised level.
    /// Both are shortcuts: every pixel must meet the same surface as a ray traced on its own.
    #[test]
    fn hinted_rows_meet_the_ground_where_lone_rays_do() {
        let mut spec = ScenarioSpec::new(ScenarioKind::Normal, Domain::City, Weather::Sun, 11);
        (spec.width, spec.height, spec.frames) = (192, 128, 12);
        let scenario = Scenario::build(&spec).expect("build");
        let (mut road, mut raised, mut kerb) = (0, 0, 0);
        for frame in [0, 11] {
            let view = FrameView::new(scenario.world(), frame);
            let (w, h) = (view.cam.width as usize, view.cam.height_px as usize);
            for y in 0..h {
                let v = y as f32 + 0.5;
                let mut hint = None;
                let mut last = None;
                for x in 0..w {
                    let u = x as f32 + 0.5;
                    let dir = view.cam.ray(u, v);
                    let tile = view.tile_of(u, v);
                    let hinted = view.trace_in_tile(dir, u, v, tile, hint);
                    (hint, last) = next_ground_hint(&hinted, last);
                    let alone = view.trace_in_tile(dir, u, v, tile, None);
                    assert_eq!(
                        (hinted.key, hinted.part),
                        (alone.key, alone.part),
                        "frame {frame}, pixel ({x}, {y})"
                    );
                    if hinted.key != KEY_GROUND {
                        continue;
                    }
                    let off = hinted.local - alone.local;
                    assert!(
                        off.x.abs().max(off.y.abs()).max(off.z.abs()) < 1e-3
                            && (hinted.t - alone.t).abs() < 1e-3,
                        "frame {frame}, pixel ({x}, {y}): {hinted:?} against {alone:?}"
                    );
                    match (hinted.part, hinted.local.z > 0.0) {
                        (1, _) => kerb += 1,
                        (_, true) => raised += 1,
                        (_, false) => road += 1,
                    }
                }
            }
        }
        // The frames show the road, the sidewalks and the kerb faces between them.
        assert!(
            road > 5_000 && raised > 500 && kerb > 20,
            "{road} {raised} {kerb}"
        );
    }
}
