//! The persistent score cache: everything the model said about the objects of one scenario,
//! so that fusion for any weights never needs the model again.
//!
//! One file per scenario × model × box source × flow source, at
//! `<scenario cache dir>/scores/<model>_<boxes>_<flow>.vsc` ([`CacheKey::path_in`]); the key
//! is repeated inside the file and checked on opening, with the scenario's frame count and
//! a hash of its frame ids, so a cache of another scenario or an older frame set is
//! rejected rather than misread.
//!
//! # Layout (version 1, little-endian)
//!
//! ```text
//! preamble, 64 bytes
//!   0  magic "VADSCORE"          8  version u32 (1)        12 patch P u32
//!   16 object count u64          24 maps offset u64 (64)   32 tables offset u64
//!   40 tables length u64         48 tables checksum u64    56 preamble checksum u64
//! maps: per object, 15·P² bytes (15,360 at P = 32)
//!   flow error   f32 [P²]   squared flow-reconstruction error, mean over the 2t channels
//!   frame error  f32 [P²]   squared frame-prediction error, mean over R, G, B
//!   predicted    u8  [3P²]  predicted patch, planar RGB (display only)
//!   recon flow   f16 [2P²]  reconstructed last flow, planar u, v, native pixels (display only)
//! tables
//!   meta      scenario name, model key, box key, flow key, frame count and size, clip_hist,
//!             frame-id hash, the model's training statistics, this scenario's pixel
//!             statistics, reference batch size and count
//!   frames    per frame: frame id u64, object count u32, state u8, 3 bytes padding
//!   objects   per object, 48 bytes: frame u32, class u16, pad u16, track u64, x1 y1 x2 y2
//!             f32, confidence f32, S_r f32, S_p f32, maps checksum u32
//!   batches   per reference batch: flow and frame median, q25, q75 as f64
//! ```
//!
//! Checksums are FNV-1a (64 bit; the low 32 bits per object map block). Opening reads only
//! the preamble and the tables (about 64 bytes per object), so it is fast whatever the size
//! of the maps; maps are read per frame on demand and their checksum verified then.
//!
//! **Why f32 error maps:** in the reference's units a flow error of 256 px squares to 65,536,
//! past f16's largest value (65,504), and robust scaling divides small differences from
//! the median by a small IQR, where f16's 11-bit mantissa would quantise pixel scores
//! visibly and change pixel AUROC ties. At 8 KiB per object the maps stay small next to
//! the frames they describe. The display-only reconstructed flow is f16 (native pixels,
//! far below the f16 range) and the predicted patch 8-bit, as it would be shown.
//!
//! Files are written atomically ([`crate::atomic_file`]), so a crash never leaves a
//! half-written cache under the real name.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::Serialize;

use crate::atomic_file::AtomicFile;
use crate::eval::RobustStats;
use crate::fnv::{Fnv64, fnv1a64};
use crate::model::{PixelStats, ScoreStats, TrainingStats};
use crate::sequence::{FrameId, Scenario};

use super::ScoreError;

/// File magic.
pub const MAGIC: &[u8; 8] = b"VADSCORE";
/// Format version written and read by this vadscope.
pub const VERSION: u32 = 1;
/// Extension of score cache files.
pub const EXTENSION: &str = "vsc";
/// Sub-folder of the scenario's cache folder that holds score caches.
pub const SCORES_FOLDER: &str = "scores";
/// Cubes per batch of the reference's pixel-level robust scaling (spec §7.2).
pub const REFERENCE_BATCH: usize = 128;

const PREAMBLE_LEN: u64 = 64;
const FRAME_RECORD_LEN: usize = 16;
const OBJECT_RECORD_LEN: usize = 48;
const BATCH_RECORD_LEN: usize = 48;

/// The identity of a model's weights (a hash of its checkpoint file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub struct ModelKey(pub u64);

impl ModelKey {
    /// Hashes the checkpoint file at `path` (streamed; a few hundred ms for the paper model).
    pub fn of_checkpoint(path: &Path) -> Result<Self, ScoreError> {
        let mut file = File::open(path).map_err(|e| ScoreError::io(path, e))?;
        let mut hash = Fnv64::new();
        let mut buffer = vec![0u8; 1 << 20];
        loop {
            let n = file
                .read(&mut buffer)
                .map_err(|e| ScoreError::io(path, e))?;
            if n == 0 {
                break;
            }
            hash.write(&buffer[..n]);
        }
        Ok(Self(hash.finish()))
    }
}

/// What a score cache was computed from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct CacheKey {
    /// The scenario folder's name.
    pub scenario: String,
    /// The model's weights.
    pub model: ModelKey,
    /// The box source ([`super::BoxSource::key`]).
    pub boxes: String,
    /// The flow source ([`super::FlowSource::key`]).
    pub flow: String,
}

impl CacheKey {
    /// The file name: `<model as 16 hex digits>_<boxes>_<flow>.vsc`, with characters other
    /// than letters, digits, `-` and `+` replaced by `-`.
    pub fn file_name(&self) -> String {
        let clean = |s: &str| {
            s.chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' || c == '+' {
                        c
                    } else {
                        '-'
                    }
                })
                .collect::<String>()
        };
        format!(
            "{:016x}_{}_{}.{EXTENSION}",
            self.model.0,
            clean(&self.boxes),
            clean(&self.flow)
        )
    }

    /// The cache file inside a scenario's cache folder (`<dir>/scores/<file name>`).
    pub fn path_in(&self, cache_dir: &Path) -> PathBuf {
        cache_dir.join(SCORES_FOLDER).join(self.file_name())
    }
}

/// Whether and why a frame has scored objects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum FrameState {
    /// At least one object was scored.
    Scored,
    /// The box source gave no box.
    NoBoxes,
    /// Boxes were given but none had a non-empty crop inside the image.
    NoCubes,
}

impl FrameState {
    fn code(self) -> u8 {
        match self {
            Self::Scored => 0,
            Self::NoBoxes => 1,
            Self::NoCubes => 2,
        }
    }

    fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Self::Scored),
            1 => Some(Self::NoBoxes),
            2 => Some(Self::NoCubes),
            _ => None,
        }
    }
}

/// One frame of a score table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrameEntry {
    /// AnoVox frame id.
    pub id: FrameId,
    /// Whether it has objects.
    pub state: FrameState,
    /// Index of its first object in [`ScoreTable::objects`].
    pub first_object: u32,
    /// Number of its objects (contiguous from `first_object`).
    pub objects: u32,
}

/// The scalar record of one scored object.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ObjectScore {
    /// Frame index.
    pub frame: u32,
    /// Track id of its box (0 when the source has none).
    pub track_id: u64,
    /// Class of its box.
    pub class: u16,
    /// The box, [x1, y1, x2, y2] in frame pixels (x2/y2 exclusive).
    pub bbox: [f32; 4],
    /// Confidence of its box (1 for ground truth).
    pub confidence: f32,
    /// S_r: summed squared flow-reconstruction error (model units).
    pub s_r: f32,
    /// S_p: summed squared frame-prediction error.
    pub s_p: f32,
}

/// The per-pixel data of one scored object, each plane P×P row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectMaps {
    /// Squared flow-reconstruction error, mean over the flow channels (P² values).
    pub flow_error: Vec<f32>,
    /// Squared frame-prediction error, mean over R, G, B (P² values).
    pub frame_error: Vec<f32>,
    /// Predicted patch, planar RGB bytes (3·P² values).
    pub predicted: Vec<u8>,
    /// Reconstructed last flow, planar u then v, native pixels (2·P² values).
    pub recon_flow: Vec<f32>,
}

impl ObjectMaps {
    /// All-zero maps for patches of `patch`×`patch`.
    pub fn zeros(patch: usize) -> Self {
        let area = patch * patch;
        Self {
            flow_error: vec![0.0; area],
            frame_error: vec![0.0; area],
            predicted: vec![0; 3 * area],
            recon_flow: vec![0.0; 2 * area],
        }
    }

    fn check(&self, patch: usize) -> Result<(), String> {
        let area = patch * patch;
        let sizes = [
            ("flow error", self.flow_error.len(), area),
            ("frame error", self.frame_error.len(), area),
            ("predicted patch", self.predicted.len(), 3 * area),
            ("reconstructed flow", self.recon_flow.len(), 2 * area),
        ];
        match sizes.iter().find(|(_, len, want)| len != want) {
            Some((name, len, want)) => Err(format!("{name} has {len} values, expected {want}")),
            None => Ok(()),
        }
    }
}

/// Bytes of one object's map block for `patch`×`patch` patches.
pub fn map_stride(patch: usize) -> usize {
    15 * patch * patch
}

/// Robust statistics of the two per-pixel error kinds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PixelReference {
    /// Per-element squared flow errors.
    pub flow: RobustStats,
    /// Per-element squared frame errors.
    pub frame: RobustStats,
}

impl PixelReference {
    /// The pixel statistics stored with a model's training statistics.
    pub fn of_training(stats: &TrainingStats) -> Self {
        let robust = |p: &PixelStats| RobustStats {
            median: p.median,
            q25: p.q25,
            q75: p.q75,
        };
        Self {
            flow: robust(&stats.flow_pixel),
            frame: robust(&stats.frame_pixel),
        }
    }
}

/// Everything of a score cache except the maps.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScoreMeta {
    /// What the scores were computed from.
    pub key: CacheKey,
    /// Frame width in pixels.
    pub frame_width: u32,
    /// Frame height in pixels.
    pub frame_height: u32,
    /// Patch side P of the cubes.
    pub patch: u32,
    /// Past frames per cube; the first `clip_hist` frames are excluded from metrics.
    pub clip_hist: u32,
    /// Hash of the scenario's frame ids ([`frame_ids_hash`]).
    pub frame_ids_hash: u64,
    /// The model's training statistics (z-scores, default pixel reference).
    pub training: TrainingStats,
    /// Pixel statistics over this scenario's scored objects (the "scenario" reference).
    pub scenario_pixels: PixelReference,
    /// Objects per batch of the reference's per-batch pixel scaling.
    pub batch_size: u32,
}

/// The scalar part of a score cache: what frame fusion needs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScoreTable {
    /// Key, sizes and statistics.
    pub meta: ScoreMeta,
    /// One entry per frame index.
    pub frames: Vec<FrameEntry>,
    /// Every scored object, grouped by frame in frame order.
    pub objects: Vec<ObjectScore>,
    /// Pixel statistics per reference batch of `meta.batch_size` consecutive objects.
    pub batches: Vec<PixelReference>,
}

impl ScoreTable {
    /// The objects of frame `index` (empty outside the table).
    pub fn frame_objects(&self, index: usize) -> &[ObjectScore] {
        let Some(f) = self.frames.get(index) else {
            return &[];
        };
        let start = f.first_object as usize;
        self.objects
            .get(start..start + f.objects as usize)
            .unwrap_or(&[])
    }

    /// Frames with `frames` in order and objects grouped by them, checking that they fit
    /// together (contiguous, in frame order, batch statistics present).
    pub fn validate(&self) -> Result<(), String> {
        let mut next = 0u64;
        for (i, f) in self.frames.iter().enumerate() {
            if u64::from(f.first_object) != next {
                return Err(format!(
                    "frame {i} starts at object {} but object {next} is next",
                    f.first_object
                ));
            }
            if (f.objects > 0) != (f.state == FrameState::Scored) {
                return Err(format!(
                    "frame {i} has {} objects but state {:?}",
                    f.objects, f.state
                ));
            }
            next += u64::from(f.objects);
        }
        if next != self.objects.len() as u64 {
            return Err(format!(
                "frames hold {next} objects but the table has {}",
                self.objects.len()
            ));
        }
        if let Some((k, o)) = self
            .frames
            .iter()
            .enumerate()
            .flat_map(|(i, f)| {
                let start = f.first_object as usize;
                (start..start + f.objects as usize).map(move |k| (k, i))
            })
            .map(|(k, i)| (k, (self.objects[k].frame as usize, i)))
            .find(|(_, (stored, expected))| stored != expected)
        {
            return Err(format!(
                "object {k} names frame {} but lies in frame {}",
                o.0, o.1
            ));
        }
        let batch = self.meta.batch_size.max(1) as usize;
        if self.batches.len() != self.objects.len().div_ceil(batch) {
            return Err(format!(
                "{} reference batches for {} objects in batches of {batch}",
                self.batches.len(),
                self.objects.len()
            ));
        }
        Ok(())
    }
}

/// Hash of a scenario's frame ids, to notice a cache of another frame set.
pub fn frame_ids_hash(ids: impl IntoIterator<Item = FrameId>) -> u64 {
    let mut h = Fnv64::new();
    for id in ids {
        h.write(&id.0.to_le_bytes());
    }
    h.finish()
}

/// f32 → IEEE binary16, rounding to nearest even; overflow becomes infinity.
pub(crate) fn f32_to_f16(value: f32) -> u16 {
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
pub(crate) fn f16_to_f32(half: u16) -> f32 {
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

fn encode_maps(maps: &ObjectMaps, out: &mut Vec<u8>) {
    out.clear();
    for v in maps.flow_error.iter().chain(&maps.frame_error) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&maps.predicted);
    for &v in &maps.recon_flow {
        out.extend_from_slice(&f32_to_f16(v).to_le_bytes());
    }
}

fn decode_maps(bytes: &[u8], patch: usize) -> ObjectMaps {
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

fn encode_tables(table: &ScoreTable, checksums: &[u32]) -> Vec<u8> {
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

fn decode_tables(
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
    let training = TrainingStats {
        cubes: r.u64("training statistics")?,
        flow_score: r.score_stats("training statistics")?,
        frame_score: r.score_stats("training statistics")?,
        flow_pixel: r.pixel_stats("training statistics")?,
        frame_pixel: r.pixel_stats("training statistics")?,
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

/// Streams a score cache to disk: maps object by object while scoring runs, the tables at
/// the end, atomically ([`crate::atomic_file`]): the temporary file is removed if the
/// writer is dropped unfinished.
pub struct CacheWriter {
    path: PathBuf,
    file: Option<AtomicFile>,
    patch: usize,
    checksums: Vec<u32>,
    block: Vec<u8>,
}

impl CacheWriter {
    /// Starts writing the cache that will live at `path` (its folder is created).
    pub fn create(path: &Path, patch: usize) -> Result<Self, ScoreError> {
        if patch == 0 {
            return Err(ScoreError::Invalid("score cache: patch size 0".into()));
        }
        let dir = path.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir).map_err(|e| ScoreError::io(dir, e))?;
        let mut file = AtomicFile::with_capacity(path, 1 << 20)?;
        file.write_all(&[0u8; PREAMBLE_LEN as usize])
            .map_err(|e| ScoreError::io(file.temporary_path(), e))?;
        Ok(Self {
            path: path.to_path_buf(),
            file: Some(file),
            patch,
            checksums: Vec::new(),
            block: Vec::with_capacity(map_stride(patch)),
        })
    }

    /// Appends the maps of the next object.
    pub fn push_maps(&mut self, maps: &ObjectMaps) -> Result<(), ScoreError> {
        maps.check(self.patch).map_err(|p| {
            ScoreError::cache(&self.path, format!("object {}: {p}", self.checksums.len()))
        })?;
        encode_maps(maps, &mut self.block);
        self.checksums.push(fnv1a64(&self.block) as u32);
        let file = self
            .file
            .as_mut()
            .ok_or_else(|| ScoreError::cache(&self.path, "writer already finished"))?;
        file.write_all(&self.block)
            .map_err(|e| ScoreError::io(file.temporary_path(), e))
    }

    /// Objects whose maps were appended so far.
    pub fn objects_written(&self) -> usize {
        self.checksums.len()
    }

    /// Writes the tables (which must describe exactly the objects appended), syncs and
    /// renames the file into place.
    pub fn finish(mut self, table: &ScoreTable) -> Result<PathBuf, ScoreError> {
        if table.objects.len() != self.checksums.len() {
            return Err(ScoreError::cache(
                &self.path,
                format!(
                    "table has {} objects but {} map blocks were written",
                    table.objects.len(),
                    self.checksums.len()
                ),
            ));
        }
        if table.meta.patch as usize != self.patch {
            return Err(ScoreError::cache(
                &self.path,
                "table patch size differs from the maps'",
            ));
        }
        table
            .validate()
            .map_err(|p| ScoreError::cache(&self.path, p))?;
        let tables = encode_tables(table, &self.checksums);
        let mut file = self
            .file
            .take()
            .ok_or_else(|| ScoreError::cache(&self.path, "writer already finished"))?;
        let temp = file.temporary_path().to_path_buf();
        let io = |e| ScoreError::io(&temp, e);
        file.write_all(&tables).map_err(io)?;
        let maps_len = (self.checksums.len() * map_stride(self.patch)) as u64;
        let mut preamble = Vec::with_capacity(PREAMBLE_LEN as usize);
        preamble.extend_from_slice(MAGIC);
        preamble.extend_from_slice(&VERSION.to_le_bytes());
        preamble.extend_from_slice(&(self.patch as u32).to_le_bytes());
        preamble.extend_from_slice(&(self.checksums.len() as u64).to_le_bytes());
        preamble.extend_from_slice(&PREAMBLE_LEN.to_le_bytes());
        preamble.extend_from_slice(&(PREAMBLE_LEN + maps_len).to_le_bytes());
        preamble.extend_from_slice(&(tables.len() as u64).to_le_bytes());
        preamble.extend_from_slice(&fnv1a64(&tables).to_le_bytes());
        let checksum = fnv1a64(&preamble);
        preamble.extend_from_slice(&checksum.to_le_bytes());
        file.seek(SeekFrom::Start(0)).map_err(io)?;
        file.write_all(&preamble).map_err(io)?;
        file.commit()?;
        Ok(self.path.clone())
    }
}

/// Writes a complete cache at once (hand-built tables, tests, conversions).
pub fn write_cache(
    path: &Path,
    table: &ScoreTable,
    maps: &[ObjectMaps],
) -> Result<PathBuf, ScoreError> {
    let mut writer = CacheWriter::create(path, table.meta.patch as usize)?;
    for m in maps {
        writer.push_maps(m)?;
    }
    writer.finish(table)
}

/// What [`ScoreCache::find`] found for a key.
#[derive(Debug)]
pub enum CacheLookup {
    /// A cache computed for this key on the scenario as it is now.
    Current(Box<ScoreCache>),
    /// No cache exists; it would be written at this path.
    Missing(PathBuf),
    /// A file exists but cannot be used.
    Unusable {
        /// The file.
        path: PathBuf,
        /// Why, in words (names the file).
        reason: String,
    },
}

/// An opened score cache: the tables in memory, the maps read from disk on demand.
#[derive(Debug)]
pub struct ScoreCache {
    path: PathBuf,
    file: Mutex<File>,
    table: ScoreTable,
    checksums: Vec<u32>,
}

impl ScoreCache {
    /// Opens and checks a cache file: magic, version, checksums, sizes and table
    /// consistency. Reads only the preamble and tables.
    pub fn open(path: &Path) -> Result<Self, ScoreError> {
        let mut file = File::open(path).map_err(|e| ScoreError::io(path, e))?;
        let len = file.metadata().map_err(|e| ScoreError::io(path, e))?.len();
        if len < PREAMBLE_LEN {
            return Err(ScoreError::cache(
                path,
                format!("truncated: {len} bytes, shorter than the {PREAMBLE_LEN}-byte header"),
            ));
        }
        let mut pre = [0u8; PREAMBLE_LEN as usize];
        file.read_exact(&mut pre)
            .map_err(|e| ScoreError::io(path, e))?;
        if &pre[0..8] != MAGIC {
            return Err(ScoreError::cache(
                path,
                "not a vadscope score cache (wrong magic bytes)",
            ));
        }
        let u32_at = |o: usize| u32::from_le_bytes([pre[o], pre[o + 1], pre[o + 2], pre[o + 3]]);
        let u64_at = |o: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&pre[o..o + 8]);
            u64::from_le_bytes(b)
        };
        let version = u32_at(8);
        if version != VERSION {
            return Err(ScoreError::cache(
                path,
                format!(
                    "format version {version}, this vadscope reads version {VERSION}; score the scenario again"
                ),
            ));
        }
        if fnv1a64(&pre[..56]) != u64_at(56) {
            return Err(ScoreError::cache(
                path,
                "header checksum mismatch (corrupt file)",
            ));
        }
        let patch = u32_at(12);
        let objects = u64_at(16);
        let maps_offset = u64_at(24);
        let tables_offset = u64_at(32);
        let tables_len = u64_at(40);
        let stride = map_stride(patch as usize) as u64;
        let expected_tables = objects
            .checked_mul(stride)
            .and_then(|m| m.checked_add(maps_offset))
            .filter(|_| maps_offset == PREAMBLE_LEN && patch > 0);
        if expected_tables != Some(tables_offset) {
            return Err(ScoreError::cache(
                path,
                "header sizes are inconsistent (corrupt file)",
            ));
        }
        let expected_len = tables_offset.checked_add(tables_len);
        if expected_len != Some(len) {
            return Err(ScoreError::cache(
                path,
                format!(
                    "truncated or damaged: the header announces {} bytes but the file has {len}",
                    expected_len.map_or_else(|| "more than 2^64".into(), |l| l.to_string())
                ),
            ));
        }
        let mut tables = vec![0u8; tables_len as usize];
        file.seek(SeekFrom::Start(tables_offset))
            .and_then(|_| file.read_exact(&mut tables))
            .map_err(|e| ScoreError::io(path, e))?;
        if fnv1a64(&tables) != u64_at(48) {
            return Err(ScoreError::cache(
                path,
                "table checksum mismatch (corrupt file)",
            ));
        }
        let (table, checksums) = decode_tables(path, &tables, patch)?;
        if table.objects.len() as u64 != objects {
            return Err(ScoreError::cache(
                path,
                format!(
                    "header announces {objects} objects, tables hold {}",
                    table.objects.len()
                ),
            ));
        }
        Ok(Self {
            path: path.to_path_buf(),
            file: Mutex::new(file),
            table,
            checksums,
        })
    }

    /// Opens the cache of `key` for `scenario`; `Ok(None)` when there is none. A cache that
    /// belongs to another key, another frame count or other frame ids is an error (score
    /// again).
    pub fn lookup(scenario: &Scenario, key: &CacheKey) -> Result<Option<Self>, ScoreError> {
        let path = key.path_in(&scenario.cache_dir()?);
        if !path.is_file() {
            return Ok(None);
        }
        let cache = Self::open(&path)?;
        cache.check_fits(scenario, key)?;
        Ok(Some(cache))
    }

    /// Like [`ScoreCache::lookup`], but a cache that exists and cannot be used (stale,
    /// damaged, of another version) is reported as [`CacheLookup::Unusable`] with the reason
    /// instead of as an error, so that a caller can score the scenario again in its place.
    /// Errors are left for what stops scoring too (the cache folder cannot be made).
    pub fn find(scenario: &Scenario, key: &CacheKey) -> Result<CacheLookup, ScoreError> {
        let path = key.path_in(&scenario.cache_dir()?);
        if !path.is_file() {
            return Ok(CacheLookup::Missing(path));
        }
        let opened = Self::open(&path).and_then(|cache| {
            cache.check_fits(scenario, key)?;
            Ok(cache)
        });
        match opened {
            Ok(cache) => Ok(CacheLookup::Current(Box::new(cache))),
            Err(e @ (ScoreError::Cache { .. } | ScoreError::Io { .. })) => {
                Ok(CacheLookup::Unusable {
                    path,
                    reason: e.to_string(),
                })
            }
            Err(e) => Err(e),
        }
    }

    /// Checks that this cache was computed for `key` on `scenario` as it is now.
    pub fn check_fits(&self, scenario: &Scenario, key: &CacheKey) -> Result<(), ScoreError> {
        let m = &self.table.meta;
        let stale = |what: String| {
            ScoreError::cache(
                &self.path,
                format!("stale: {what}; score the scenario again"),
            )
        };
        if &m.key != key {
            return Err(stale(format!("computed for {:?}, wanted {key:?}", m.key)));
        }
        if self.table.frames.len() != scenario.len() {
            return Err(stale(format!(
                "{} frames scored, the scenario has {}",
                self.table.frames.len(),
                scenario.len()
            )));
        }
        let ids = (0..scenario.len()).filter_map(|i| scenario.frame_id(i));
        if frame_ids_hash(ids) != m.frame_ids_hash {
            return Err(stale("the scenario's frame ids changed".into()));
        }
        if scenario.resolution() != (m.frame_width, m.frame_height) {
            return Err(stale(format!(
                "scored at {}×{}, the frames are {}×{}",
                m.frame_width,
                m.frame_height,
                scenario.resolution().0,
                scenario.resolution().1
            )));
        }
        Ok(())
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The scalar tables (what frame fusion needs).
    pub fn table(&self) -> &ScoreTable {
        &self.table
    }

    /// Gives up the file and keeps the tables.
    pub fn into_table(self) -> ScoreTable {
        self.table
    }

    /// Reads the maps of objects `first..first + count`, verifying their checksums.
    pub fn read_maps(&self, first: usize, count: usize) -> Result<Vec<ObjectMaps>, ScoreError> {
        let total = self.table.objects.len();
        if first.checked_add(count).is_none_or(|end| end > total) {
            return Err(ScoreError::Invalid(format!(
                "{}: objects {first}..{} requested, the cache has {total}",
                self.path.display(),
                first.saturating_add(count)
            )));
        }
        let patch = self.table.meta.patch as usize;
        let stride = map_stride(patch);
        let mut bytes = vec![0u8; count * stride];
        {
            let mut file = self
                .file
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            file.seek(SeekFrom::Start(PREAMBLE_LEN + (first * stride) as u64))
                .and_then(|_| file.read_exact(&mut bytes))
                .map_err(|e| ScoreError::io(&self.path, e))?;
        }
        bytes
            .chunks_exact(stride)
            .enumerate()
            .map(|(k, block)| {
                if fnv1a64(block) as u32 != self.checksums[first + k] {
                    return Err(ScoreError::cache(
                        &self.path,
                        format!(
                            "maps of object {} fail their checksum (corrupt file)",
                            first + k
                        ),
                    ));
                }
                Ok(decode_maps(block, patch))
            })
            .collect()
    }

    /// The maps of the objects of frame `index`, in object order.
    pub fn frame_maps(&self, index: usize) -> Result<Vec<ObjectMaps>, ScoreError> {
        let f = self.table.frames.get(index).ok_or_else(|| {
            ScoreError::Invalid(format!(
                "{}: frame {index} requested, the cache has {}",
                self.path.display(),
                self.table.frames.len()
            ))
        })?;
        self.read_maps(f.first_object as usize, f.objects as usize)
    }
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

    #[test]
    fn file_names_are_clean() {
        let key = CacheKey {
            scenario: "s".into(),
            model: ModelKey(0xab),
            boxes: "mot-12ab/../x".into(),
            flow: "stored".into(),
        };
        assert_eq!(key.file_name(), "00000000000000ab_mot-12ab----x_stored.vsc");
    }
}
