//! Reading a score cache: [`ScoreCache`] holds the tables in memory and reads the maps
//! of a frame on demand, verifying their checksums; [`ScoreCache::find`] tells current,
//! missing and unusable caches apart ([`CacheLookup`]).

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::fnv::fnv1a64;
use crate::model::config::MAX_PATCH_SIZE;
use crate::sequence::Scenario;

use super::super::ScoreError;
use super::codec::{MAGIC, PREAMBLE_LEN, VERSION, decode_maps, decode_tables};
use super::key::{CacheKey, frame_ids_hash};
use super::table::{ObjectMaps, ScoreTable, map_stride};

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
        /// Why (names the file).
        error: ScoreError,
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
        if patch as usize > MAX_PATCH_SIZE {
            return Err(ScoreError::cache(
                path,
                format!("patch size {patch} exceeds the limit of {MAX_PATCH_SIZE} (corrupt file)"),
            ));
        }
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
            Err(error @ (ScoreError::Cache { .. } | ScoreError::Io { .. })) => {
                Ok(CacheLookup::Unusable { path, error })
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
