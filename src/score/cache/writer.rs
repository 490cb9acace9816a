//! Writing a score cache: [`CacheWriter`] streams the maps while scoring runs and the
//! tables at the end; [`write_cache`] writes a complete one at once.

use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::atomic_file::{AtomicFile, remove_stale_temporaries};
use crate::fnv::fnv1a64;

use super::super::ScoreError;
use super::codec::{MAGIC, PREAMBLE_LEN, VERSION, encode_maps, encode_tables};
use super::table::{ObjectMaps, ScoreTable, map_stride};

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
        // Caches half-written by a scorer that was killed.
        remove_stale_temporaries(dir);
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
