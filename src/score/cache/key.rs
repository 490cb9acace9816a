//! A score cache's identity: which scenario, model, box source and flow source it holds
//! scores for, and where its file lives (`<scenario cache dir>/scores/<model>_<boxes>_<flow>.vsc`).

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::fnv::Fnv64;
use crate::sequence::FrameId;

use super::super::ScoreError;

/// Extension of score cache files.
pub const EXTENSION: &str = "vsc";
/// Sub-folder of the scenario's cache folder that holds score caches.
pub const SCORES_FOLDER: &str = "scores";

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
    /// The box source ([`crate::score::BoxSource::key`]).
    pub boxes: String,
    /// The flow source ([`crate::score::FlowSource::key`]).
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

/// Hash of a scenario's frame ids, to notice a cache of another frame set.
pub fn frame_ids_hash(ids: impl IntoIterator<Item = FrameId>) -> u64 {
    let mut h = Fnv64::new();
    for id in ids {
        h.write(&id.0.to_le_bytes());
    }
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

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
