//! Score cache files (`.vadscope/scores/*.vsc`): the header and tables on opening, then
//! every object's maps.
//!
//! The header and the tables carry FNV checksums, which random mutations almost never
//! match: the input's checksums are set right before it is written, so the fuzzer reaches
//! the size checks and the table decoding behind them (the checksum checks themselves are
//! covered by the normal tests).
#![no_main]
use libfuzzer_sys::fuzz_target;
use vadscope::fnv::fnv1a64;
use vadscope::score::ScoreCache;
use vadscope_fuzz::scratch_file;

/// Bytes of the header (`score::cache` codec): the table checksum at 48, its own at 56.
const PREAMBLE: usize = 64;

fuzz_target!(|bytes: &[u8]| {
    let mut bytes = bytes.to_vec();
    if bytes.len() >= PREAMBLE {
        let u64_at = |b: &[u8], o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap());
        let (offset, len) = (u64_at(&bytes, 32), u64_at(&bytes, 40));
        let tables = usize::try_from(offset)
            .ok()
            .zip(usize::try_from(len).ok())
            .and_then(|(o, l)| bytes.get(o..o.checked_add(l)?));
        if let Some(tables) = tables {
            let sum = fnv1a64(tables);
            bytes[48..56].copy_from_slice(&sum.to_le_bytes());
        }
        let sum = fnv1a64(&bytes[..56]);
        bytes[56..64].copy_from_slice(&sum.to_le_bytes());
    }
    let path = scratch_file("cache.vsc", &bytes);
    if let Ok(cache) = ScoreCache::open(&path) {
        let objects = cache.table().objects.len();
        let _ = cache.read_maps(0, objects);
    }
});
