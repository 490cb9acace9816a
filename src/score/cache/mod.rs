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
//! The files: `key` (identity, file name), `table` (what a cache holds in memory), `codec`
//! (the bytes), `writer` ([`CacheWriter`]), `reader` ([`ScoreCache`]), each below the next.
//!
//! Files are written atomically ([`crate::atomic_file`]), so a crash never leaves a
//! half-written cache under the real name.

mod codec;
mod key;
mod reader;
mod table;
mod writer;

pub use codec::{MAGIC, VERSION};
pub use key::{CacheKey, EXTENSION, ModelKey, SCORES_FOLDER, frame_ids_hash};
pub use reader::{CacheLookup, ScoreCache};
pub use table::{
    FrameEntry, FrameState, ObjectMaps, ObjectScore, PixelReference, REFERENCE_BATCH, ScoreMeta,
    ScoreTable, map_stride,
};
pub use writer::{CacheWriter, write_cache};
