//! What the fuzz targets share: scratch files for the parsers that read from a path.
//!
//! Each fuzzing process writes its inputs into a folder of its own under the temp folder
//! (`TMPDIR`; a tmpfs such as `/dev/shm` keeps the runs fast), overwriting them on every
//! input, so nothing accumulates.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// This process's scratch folder, created on first use.
pub fn scratch_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("vadscope-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch folder");
        dir
    })
}

/// Writes `bytes` to the scratch file `relative` (its folders created) and returns its path.
pub fn scratch_file(relative: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch_dir().join(relative);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).expect("scratch folder");
    }
    std::fs::write(&path, bytes).expect("scratch file");
    path
}

/// The input as text, lossily: the text parsers take `&str` once the file has been read.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Splits `bytes` at the first `separator` into two inputs (the second empty without one),
/// for targets that read two files.
pub fn split_at_separator<'a>(bytes: &'a [u8], separator: &[u8]) -> (&'a [u8], &'a [u8]) {
    match bytes.windows(separator.len()).position(|w| w == separator) {
        Some(at) => (&bytes[..at], &bytes[at + separator.len()..]),
        None => (bytes, &[]),
    }
}
