//! Replacing a file so that a crash leaves either the old file or the new one, never half
//! of one: the bytes go to a temporary file beside the target (`.<name>.<pid>.tmp`, so
//! that leftovers name the process that wrote them), which is flushed to disk and renamed
//! over the target; the folder is then flushed so that the rename itself survives. This is
//! how vadscope writes every file its user would miss: labels, failure tags, checkpoints,
//! training state, flow and score caches, exported frames.

use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Suffix of the temporary files.
const TEMPORARY_SUFFIX: &str = ".tmp";

/// A file that could not be written, and why.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct WriteError {
    /// The file (the target, or its temporary file).
    pub path: PathBuf,
    /// What went wrong.
    #[source]
    pub source: io::Error,
}

impl WriteError {
    fn new(path: &Path, source: io::Error) -> Self {
        Self {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Writes `bytes` to `target` atomically (see the module docs).
pub fn write_atomically(target: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let mut file = AtomicFile::create(target)?;
    file.write_all(bytes)
        .map_err(|e| WriteError::new(&file.temporary, e))?;
    file.commit()
}

/// Writes `target` atomically through `write`, which writes the whole file at the path it
/// is given (for writers that only take a path). Whatever `write` fails with is returned
/// as is; the temporary file is then removed.
pub fn write_atomically_with<E: From<WriteError>>(
    target: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    let temporary = temporary_path(target);
    let written = write(&temporary).and_then(|()| {
        // The writer closed its file; a handle opened for writing can flush it on every
        // platform (and leaves its contents alone).
        OpenOptions::new()
            .write(true)
            .open(&temporary)
            .and_then(|f| f.sync_all())
            .map_err(|e| WriteError::new(&temporary, e))?;
        Ok(rename_into_place(&temporary, target)?)
    });
    if written.is_err() {
        // The temporary file is useless without the rename; removing it is best effort.
        let _ = std::fs::remove_file(&temporary);
    }
    written
}

/// A file being written in pieces (and possibly rewritten in place through [`Seek`]) that
/// replaces its target only on [`AtomicFile::commit`]; dropped uncommitted, it removes its
/// temporary file.
pub struct AtomicFile {
    target: PathBuf,
    temporary: PathBuf,
    file: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Starts the file that will replace `target` (whose folder must exist).
    pub fn create(target: &Path) -> Result<Self, WriteError> {
        Self::with_capacity(target, 8 * 1024)
    }

    /// The same, buffering `capacity` bytes between writes to the operating system.
    pub fn with_capacity(target: &Path, capacity: usize) -> Result<Self, WriteError> {
        let temporary = temporary_path(target);
        let file = File::create(&temporary).map_err(|e| WriteError::new(&temporary, e))?;
        Ok(Self {
            target: target.to_path_buf(),
            temporary,
            file: Some(BufWriter::with_capacity(capacity, file)),
        })
    }

    /// The temporary file being written, for errors that name it.
    pub fn temporary_path(&self) -> &Path {
        &self.temporary
    }

    /// Flushes the file to disk and renames it over the target.
    pub fn commit(mut self) -> Result<(), WriteError> {
        let Some(writer) = self.file.take() else {
            return Ok(());
        };
        let temporary = self.temporary.clone();
        let synced = writer
            .into_inner()
            .map_err(|e| e.into_error())
            .and_then(|file| file.sync_all())
            .map_err(|e| WriteError::new(&temporary, e))
            .and_then(|()| rename_into_place(&temporary, &self.target));
        if synced.is_err() {
            let _ = std::fs::remove_file(&temporary);
        }
        synced
    }

    fn writer(&mut self) -> io::Result<&mut BufWriter<File>> {
        self.file
            .as_mut()
            .ok_or_else(|| io::Error::other("the file was already committed"))
    }
}

impl Write for AtomicFile {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        self.writer()?.write(bytes)
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.writer()?.write_all(bytes)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.writer()?.flush()
    }
}

impl Seek for AtomicFile {
    fn seek(&mut self, position: SeekFrom) -> io::Result<u64> {
        self.writer()?.seek(position)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            // Unfinished (an error or a cancel): failing to delete the temporary file
            // leaves a hidden file that `remove_stale_temporaries` or the next write of the
            // same process id replaces.
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

/// Removes temporary files left in `folder` by processes that were killed. Those of live
/// processes are left alone (on systems without `/proc`, nothing is removed).
pub fn remove_stale_temporaries(folder: &Path) {
    let Ok(entries) = std::fs::read_dir(folder) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = temporary_owner(&name) else {
            continue;
        };
        let owner_alive = Path::new("/proc").join(pid.to_string()).exists();
        if Path::new("/proc/self").exists() && !owner_alive {
            // A leftover that cannot be removed is harmless: it is ignored and overwritten
            // by nobody.
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// `.<name>.<pid>.tmp` beside `target`: the name [`remove_stale_temporaries`] clears once
/// the process that made it has died.
pub fn temporary_path(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    target.with_file_name(format!(".{name}.{}{TEMPORARY_SUFFIX}", std::process::id()))
}

/// The process id in a temporary file name: ours, `.<name>.<pid>.tmp`, or the scratch file
/// a burn store writes beside the path it is given, `<path>.<pid>-<n>.tmp` (with our
/// temporary path, `.<name>.<pid>.tmp.<pid>-<n>.tmp`), which a kill mid-save strands too.
fn temporary_owner(name: &str) -> Option<u32> {
    let stem = name.strip_prefix('.')?.strip_suffix(TEMPORARY_SUFFIX)?;
    let owner = stem.rsplit('.').next()?;
    owner
        .split_once('-')
        .map_or(owner, |(pid, _)| pid)
        .parse()
        .ok()
}

/// Renames `temporary` over `target` and flushes their folder.
fn rename_into_place(temporary: &Path, target: &Path) -> Result<(), WriteError> {
    std::fs::rename(temporary, target).map_err(|e| WriteError::new(target, e))?;
    // Persist the rename itself; not every platform can open a folder, which only weakens
    // durability, never correctness.
    let folder = target
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if let Ok(dir) = File::open(folder) {
        let _ = dir.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporary_names_carry_their_owner() {
        let path = temporary_path(Path::new("/a/OPTICAL_FLOW_7.png"));
        let name = path.file_name().unwrap().to_string_lossy();
        assert_eq!(temporary_owner(&name), Some(std::process::id()));
        assert_eq!(temporary_owner(".OPTICAL_FLOW_7.png.4242.tmp"), Some(4242));
        assert_eq!(temporary_owner("OPTICAL_FLOW_7.png"), None);
        assert_eq!(temporary_owner(".OPTICAL_FLOW_7.png.tmp"), None);
        assert_eq!(
            temporary_owner(".last_model.bpk.31425.tmp.31425-4.tmp"),
            Some(31425)
        );
        assert_eq!(temporary_owner(".notes.txt.draft-2.tmp"), None);
    }

    #[test]
    fn a_file_replaces_its_target_only_when_committed() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("labels.json");
        std::fs::write(&target, b"old").unwrap();
        let mut file = AtomicFile::create(&target).unwrap();
        file.write_all(b"new!").unwrap();
        file.seek(SeekFrom::Start(0)).unwrap();
        file.write_all(b"N").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        file.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"New!");
        drop(AtomicFile::create(&target).unwrap());
        write_atomically_with(&target, |path| {
            std::fs::write(path, b"half").map_err(|e| WriteError::new(path, e))?;
            Err(WriteError::new(path, io::Error::other("stopped")))
        })
        .unwrap_err();
        assert_eq!(std::fs::read(&target).unwrap(), b"New!");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "temporary files left behind");
    }
}
