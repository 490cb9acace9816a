//! Score cache files (`.vadscope/scores/*.vsc`): the header and tables on opening, then
//! every object's maps.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vadscope::score::ScoreCache;
use vadscope_fuzz::scratch_file;

fuzz_target!(|bytes: &[u8]| {
    let path = scratch_file("cache.vsc", bytes);
    if let Ok(cache) = ScoreCache::open(&path) {
        let objects = cache.table().objects.len();
        let _ = cache.read_maps(0, objects);
    }
});
