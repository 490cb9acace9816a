//! The bytes of a score cache file (see the layout in the module docs of `score::cache`):
//! the f16 codec of the reconstructed flow, the per-object map blocks and the tables.

use std::path::Path;

use crate::eval::RobustStats;
use crate::model::{BandStats, PixelStats, ScoreStats, ScoreTails, TailTable, TrainingStats};
use crate::sequence::FrameId;

use super::super::ScoreError;
use super::key::{CacheKey, ModelKey};
use super::table::{
    FrameEntry, FrameState, ObjectMaps, ObjectScore, PixelReference, ScoreMeta, ScoreTable,
};

/// File magic.
pub const MAGIC: &[u8; 8] = b"VADSCORE";
/// Format version written and read by this vadscope (2: training statistics carry the
/// per-band score moments; 3: and the tail tables of models that score by tail surprisal).
pub const VERSION: u32 = 3;

/// Bytes of the preamble.
pub(super) const PREAMBLE_LEN: u64 = 64;
pub(super) const FRAME_RECORD_LEN: usize = 16;
pub(super) const OBJECT_RECORD_LEN: usize = 48;
pub(super) const BATCH_RECORD_LEN: usize = 48;
/// Bytes of one score band: cubes (u64) and two (mean, std) pairs of f64.
const BAND_RECORD_LEN: usize = 40;

/// f32 → IEEE binary16, rounding to nearest even; overflow becomes infinity.
fn f32_to_f16(value: f32) -> u16 {
    let x = value.to_bits();
    let sign = ((x >> 16) & 0x8000) as u16;
    let exp = ((x >> 23) & 0xff) as i32;
    let man = x & 0x007f_ffff;
    if exp == 0xff {
        return sign | 0x7c00 | if man != 0 { 0x0200 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 0x1f {
        return sign | 0x7c00;
    }
    let round = |kept: u32, rest: u32, half: u32| {
        if rest > half || (rest == half && kept & 1 == 1) {
            kept + 1
        } else {
            kept
        }
    };
    if e <= 0 {
        if e < -10 {
            return sign;
        }
        let full = man | 0x0080_0000;
        let shift = (14 - e) as u32;
        let kept = full >> shift;
        return sign | round(kept, full & ((1 << shift) - 1), 1 << (shift - 1)) as u16;
    }
    // A carry out of the mantissa correctly bumps the exponent (up to infinity).
    sign | round(((e as u32) << 10) | (man >> 13), man & 0x1fff, 0x1000) as u16
}

/// IEEE binary16 → f32 (exact).
fn f16_to_f32(half: u16) -> f32 {
    let negative = half & 0x8000 != 0;
    let exp = u32::from((half >> 10) & 0x1f);
    let man = u32::from(half & 0x03ff);
    let magnitude = match exp {
        0 => man as f32 * (-24f32).exp2(),
        0x1f => f32::from_bits(0x7f80_0000 | (man << 13)),
        _ => f32::from_bits(((exp + 112) << 23) | (man << 13)),
    };
    if negative { -magnitude } else { magnitude }
}

pub(super) fn encode_maps(maps: &ObjectMaps, out: &mut Vec<u8>) {
    out.clear();
    for v in maps.flow_error.iter().chain(&maps.frame_error) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&maps.predicted);
    for &v in &maps.recon_flow {
        out.extend_from_slice(&f32_to_f16(v).to_le_bytes());
    }
}

pub(super) fn decode_maps(bytes: &[u8], patch: usize) -> ObjectMaps {
    let area = patch * patch;
    let f32s = |b: &[u8]| -> Vec<f32> {
        b.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    };
    let (flow, rest) = bytes.split_at(4 * area);
    let (frame, rest) = rest.split_at(4 * area);
    let (predicted, recon) = rest.split_at(3 * area);
    ObjectMaps {
        flow_error: f32s(flow),
        frame_error: f32s(frame),
        predicted: predicted.to_vec(),
        recon_flow: recon
            .chunks_exact(2)
            .map(|c| f16_to_f32(u16::from_le_bytes([c[0], c[1]])))
            .collect(),
    }
}

/// Little-endian writer of the tables section.
#[derive(Default)]
struct TableBytes(Vec<u8>);

impl TableBytes {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u16(&mut self, v: u16) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn string(&mut self, s: &str) {
        self.u32(s.len() as u32);
        self.0.extend_from_slice(s.as_bytes());
    }
    fn robust(&mut self, r: &RobustStats) {
        self.f64(r.median);
        self.f64(r.q25);
        self.f64(r.q75);
    }
    fn score_stats(&mut self, s: &ScoreStats) {
        self.f64(s.mean);
        self.f64(s.std);
    }
    fn pixel_stats(&mut self, p: &PixelStats) {
        for v in [p.median, p.q25, p.q75, p.iqr] {
            self.f64(v);
        }
        self.u64(p.sampled);
        self.u64(p.total);
    }
    /// A presence byte, then S_r's and S_p's tables (level count, values, surprisals).
    fn tails(&mut self, tails: Option<&ScoreTails>) {
        self.u8(u8::from(tails.is_some()));
        for table in tails.iter().flat_map(|t| [&t.flow, &t.frame]) {
            self.u32(table.values.len() as u32);
            for &v in table.values.iter().chain(&table.surprisal) {
                self.f64(v);
            }
        }
    }
}

/// Bounds-checked little-endian reader of the tables section.
struct TableReader<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl<'a> TableReader<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], ScoreError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| {
                ScoreError::cache(
                    self.path,
                    format!("tables end early at byte {} while reading {what}", self.pos),
                )
            })?;
        let slice = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(slice)
    }
    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], ScoreError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N, what)?);
        Ok(a)
    }
    fn u8(&mut self, what: &str) -> Result<u8, ScoreError> {
        Ok(self.array::<1>(what)?[0])
    }
    fn u16(&mut self, what: &str) -> Result<u16, ScoreError> {
        Ok(u16::from_le_bytes(self.array(what)?))
    }
    fn u32(&mut self, what: &str) -> Result<u32, ScoreError> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }
    fn u64(&mut self, what: &str) -> Result<u64, ScoreError> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }
    fn f32(&mut self, what: &str) -> Result<f32, ScoreError> {
        Ok(f32::from_le_bytes(self.array(what)?))
    }
    fn f64(&mut self, what: &str) -> Result<f64, ScoreError> {
        Ok(f64::from_le_bytes(self.array(what)?))
    }
    fn string(&mut self, what: &str) -> Result<String, ScoreError> {
        let len = self.u32(what)? as usize;
        let bytes = self.take(len, what)?;
        String::from_utf8(bytes.to_vec())
            .map_err(|_| ScoreError::cache(self.path, format!("{what} is not UTF-8")))
    }
    fn robust(&mut self, what: &str) -> Result<RobustStats, ScoreError> {
        Ok(RobustStats {
            median: self.f64(what)?,
            q25: self.f64(what)?,
            q75: self.f64(what)?,
        })
    }
    fn score_stats(&mut self, what: &str) -> Result<ScoreStats, ScoreError> {
        Ok(ScoreStats {
            mean: self.f64(what)?,
            std: self.f64(what)?,
        })
    }
    fn pixel_stats(&mut self, what: &str) -> Result<PixelStats, ScoreError> {
        Ok(PixelStats {
            median: self.f64(what)?,
            q25: self.f64(what)?,
            q75: self.f64(what)?,
            iqr: self.f64(what)?,
            sampled: self.u64(what)?,
            total: self.u64(what)?,
        })
    }
    fn tail_table(&mut self, what: &str) -> Result<TailTable, ScoreError> {
        let n = self.count(16, what)?;
        let values = (0..n).map(|_| self.f64(what)).collect::<Result<_, _>>()?;
        let surprisal = (0..n).map(|_| self.f64(what)).collect::<Result<_, _>>()?;
        Ok(TailTable { values, surprisal })
    }
    fn tails(&mut self, what: &str) -> Result<Option<ScoreTails>, ScoreError> {
        Ok(match self.u8(what)? {
            0 => None,
            1 => Some(ScoreTails {
                flow: self.tail_table(what)?,
                frame: self.tail_table(what)?,
            }),
            other => {
                return Err(ScoreError::cache(
                    self.path,
                    format!("{what}: presence byte {other} is neither 0 nor 1"),
                ));
            }
        })
    }
    /// A count of records of `record_len` bytes that must still fit in the section.
    fn count(&mut self, record_len: usize, what: &str) -> Result<usize, ScoreError> {
        let n = self.u32(what)? as usize;
        if n.saturating_mul(record_len) > self.bytes.len() - self.pos {
            return Err(ScoreError::cache(
                self.path,
                format!(
                    "{n} {what} do not fit in the remaining {} bytes",
                    self.bytes.len() - self.pos
                ),
            ));
        }
        Ok(n)
    }
}

pub(super) fn encode_tables(table: &ScoreTable, checksums: &[u32]) -> Vec<u8> {
    let m = &table.meta;
    let mut t = TableBytes::default();
    t.string(&m.key.scenario);
    t.u64(m.key.model.0);
    t.string(&m.key.boxes);
    t.string(&m.key.flow);
    t.u32(m.frame_width);
    t.u32(m.frame_height);
    t.u32(m.patch);
    t.u32(m.clip_hist);
    t.u64(m.frame_ids_hash);
    t.u64(m.training.cubes);
    t.score_stats(&m.training.flow_score);
    t.score_stats(&m.training.frame_score);
    t.pixel_stats(&m.training.flow_pixel);
    t.pixel_stats(&m.training.frame_pixel);
    t.u32(m.training.bands.len() as u32);
    for band in &m.training.bands {
        t.u64(band.cubes);
        t.score_stats(&band.flow_score);
        t.score_stats(&band.frame_score);
    }
    t.tails(m.training.tails.as_ref());
    for band in &m.training.bands {
        t.tails(band.tails.as_ref());
    }
    t.robust(&m.scenario_pixels.flow);
    t.robust(&m.scenario_pixels.frame);
    t.u32(m.batch_size);
    t.u32(table.frames.len() as u32);
    for f in &table.frames {
        t.u64(f.id.0);
        t.u32(f.objects);
        t.u8(f.state.code());
        t.0.extend_from_slice(&[0; 3]);
    }
    t.u32(table.objects.len() as u32);
    for (o, &checksum) in table.objects.iter().zip(checksums) {
        t.u32(o.frame);
        t.u16(o.class);
        t.u16(0);
        t.u64(o.track_id);
        for v in o.bbox {
            t.f32(v);
        }
        t.f32(o.confidence);
        t.f32(o.s_r);
        t.f32(o.s_p);
        t.u32(checksum);
    }
    t.u32(table.batches.len() as u32);
    for b in &table.batches {
        t.robust(&b.flow);
        t.robust(&b.frame);
    }
    t.0
}

pub(super) fn decode_tables(
    path: &Path,
    bytes: &[u8],
    patch: u32,
) -> Result<(ScoreTable, Vec<u32>), ScoreError> {
    let mut r = TableReader {
        bytes,
        pos: 0,
        path,
    };
    let key = CacheKey {
        scenario: r.string("scenario name")?,
        model: ModelKey(r.u64("model key")?),
        boxes: r.string("box source key")?,
        flow: r.string("flow source key")?,
    };
    let frame_width = r.u32("frame width")?;
    let frame_height = r.u32("frame height")?;
    let stored_patch = r.u32("patch size")?;
    if stored_patch != patch {
        return Err(ScoreError::cache(
            path,
            format!("tables say patch {stored_patch} but the preamble says {patch}"),
        ));
    }
    let clip_hist = r.u32("clip_hist")?;
    let frame_ids_hash = r.u64("frame id hash")?;
    let what = "training statistics";
    let (cubes, flow_score, frame_score) =
        (r.u64(what)?, r.score_stats(what)?, r.score_stats(what)?);
    let (flow_pixel, frame_pixel) = (r.pixel_stats(what)?, r.pixel_stats(what)?);
    let band_count = r.count(BAND_RECORD_LEN, "score bands")?;
    let mut bands = (0..band_count)
        .map(|_| {
            Ok(BandStats {
                cubes: r.u64("score bands")?,
                flow_score: r.score_stats("score bands")?,
                frame_score: r.score_stats("score bands")?,
                tails: None,
            })
        })
        .collect::<Result<Vec<_>, ScoreError>>()?;
    let tails = r.tails("tail tables")?;
    for band in &mut bands {
        band.tails = r.tails("tail tables of the score bands")?;
    }
    let training = TrainingStats {
        cubes,
        flow_score,
        frame_score,
        flow_pixel,
        frame_pixel,
        bands,
        tails,
    };
    let scenario_pixels = PixelReference {
        flow: r.robust("scenario pixel statistics")?,
        frame: r.robust("scenario pixel statistics")?,
    };
    let batch_size = r.u32("batch size")?;
    let frame_count = r.count(FRAME_RECORD_LEN, "frames")?;
    let mut frames = Vec::with_capacity(frame_count);
    let mut first = 0u64;
    for i in 0..frame_count {
        let id = FrameId(r.u64("frame record")?);
        let objects = r.u32("frame record")?;
        let code = r.u8("frame record")?;
        r.take(3, "frame record")?;
        let state = FrameState::from_code(code).ok_or_else(|| {
            ScoreError::cache(path, format!("frame {i} has unknown state {code}"))
        })?;
        let first_object =
            u32::try_from(first).map_err(|_| ScoreError::cache(path, "object offsets overflow"))?;
        frames.push(FrameEntry {
            id,
            state,
            first_object,
            objects,
        });
        first += u64::from(objects);
    }
    let object_count = r.count(OBJECT_RECORD_LEN, "objects")?;
    let mut objects = Vec::with_capacity(object_count);
    let mut checksums = Vec::with_capacity(object_count);
    for _ in 0..object_count {
        let frame = r.u32("object record")?;
        let class = r.u16("object record")?;
        r.u16("object record")?;
        let track_id = r.u64("object record")?;
        let mut bbox = [0f32; 4];
        for v in &mut bbox {
            *v = r.f32("object record")?;
        }
        objects.push(ObjectScore {
            frame,
            track_id,
            class,
            bbox,
            confidence: r.f32("object record")?,
            s_r: r.f32("object record")?,
            s_p: r.f32("object record")?,
        });
        checksums.push(r.u32("object record")?);
    }
    let batch_count = r.count(BATCH_RECORD_LEN, "reference batches")?;
    let mut batches = Vec::with_capacity(batch_count);
    for _ in 0..batch_count {
        batches.push(PixelReference {
            flow: r.robust("batch record")?,
            frame: r.robust("batch record")?,
        });
    }
    if r.pos != bytes.len() {
        return Err(ScoreError::cache(
            path,
            format!("{} unexpected bytes after the tables", bytes.len() - r.pos),
        ));
    }
    let table = ScoreTable {
        meta: ScoreMeta {
            key,
            frame_width,
            frame_height,
            patch,
            clip_hist,
            frame_ids_hash,
            training,
            scenario_pixels,
            batch_size,
        },
        frames,
        objects,
        batches,
    };
    table
        .validate()
        .map_err(|problem| ScoreError::cache(path, problem))?;
    Ok((table, checksums))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f16_round_trips_and_rounds_to_nearest_even() {
        for v in [
            0.0f32,
            -0.0,
            1.0,
            -2.5,
            0.333_251_95,
            65504.0,
            6.103_515_6e-5,
            5.960_464_5e-8,
        ] {
            assert_eq!(f16_to_f32(f32_to_f16(v)), v, "{v}");
        }
        assert_eq!(f32_to_f16(1.0), 0x3c00);
        assert_eq!(
            f32_to_f16(65520.0),
            0x7c00,
            "rounds past the largest half to infinity"
        );
        assert_eq!(f32_to_f16(1e-9), 0);
        // 1 + 2^-11 lies half-way between 1 and 1 + 2^-10: ties go to the even mantissa.
        assert_eq!(f32_to_f16(1.0 + (-11f32).exp2()), 0x3c00);
        assert_eq!(f32_to_f16(1.0 + 3.0 * (-11f32).exp2()), 0x3c02);
        assert!(f16_to_f32(f32_to_f16(f32::NAN)).is_nan());
        assert_eq!(f16_to_f32(f32_to_f16(f32::NEG_INFINITY)), f32::NEG_INFINITY);
        let rel = (f16_to_f32(f32_to_f16(2.71)) - 2.71f32).abs() / 2.71;
        assert!(rel < 5e-4);
    }
}
