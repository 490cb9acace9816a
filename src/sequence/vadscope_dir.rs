//! Where vadscope keeps its own files for a scenario (flow cache, score caches, the
//! analyst's labels): `<scenario>/.vadscope/`, or, when the scenario folder cannot be
//! written, a per-user cache folder keyed by the scenario's path. Source data is never
//! rewritten.

use std::path::{Path, PathBuf};

use super::SequenceError;
use super::layout::VADSCOPE_FOLDER;

/// The per-user cache base: `$XDG_CACHE_HOME/vadscope`, else `$HOME/.cache/vadscope`, else
/// the system temp folder's `vadscope`.
pub fn user_cache_base() -> PathBuf {
    let from_env = |key: &str| {
        std::env::var_os(key)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    from_env("XDG_CACHE_HOME")
        .or_else(|| from_env("HOME").map(|home| home.join(".cache")))
        .unwrap_or_else(std::env::temp_dir)
        .join("vadscope")
}

/// `<scenario>/.vadscope/` when it can be created and written, else
/// `<user_cache_base>/scenarios/<name>-<hash of the absolute scenario path>/`.
pub fn resolve_cache_dir(
    scenario: &Path,
    user_cache_base: &Path,
) -> Result<PathBuf, SequenceError> {
    let inside = scenario.join(VADSCOPE_FOLDER);
    if is_writable_dir(&inside) {
        return Ok(inside);
    }
    let absolute = std::path::absolute(scenario).unwrap_or_else(|_| scenario.to_path_buf());
    let name = absolute.file_name().map_or_else(
        || "scenario".to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let key = format!(
        "{name}-{:016x}",
        // FNV is stable across runs and Rust versions, so the folder does not move.
        crate::fnv::fnv1a64(absolute.to_string_lossy().as_bytes())
    );
    let fallback = user_cache_base.join("scenarios").join(key);
    std::fs::create_dir_all(&fallback).map_err(|e| SequenceError::io(&fallback, e))?;
    Ok(fallback)
}

/// Creates `dir` if needed and checks that a file can be created in it.
fn is_writable_dir(dir: &Path) -> bool {
    if std::fs::create_dir_all(dir).is_err() {
        return false;
    }
    // The probe carries a temporary file's name, so one stranded by a kill between its
    // creation and removal is cleared here by the next run.
    crate::atomic_file::remove_stale_temporaries(dir);
    let probe = crate::atomic_file::temporary_path(&dir.join("write-probe"));
    let writable = std::fs::write(&probe, b"").is_ok();
    // The probe is only a test; failing to remove it leaves an empty hidden file behind.
    let _ = std::fs::remove_file(&probe);
    writable
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_probe_stranded_by_a_killed_process_is_cleared_and_none_is_left() {
        let scenario = tempfile::tempdir().unwrap();
        let inside = scenario.path().join(VADSCOPE_FOLDER);
        std::fs::create_dir_all(&inside).unwrap();
        // No process has this id (above Linux's largest pid), as after a kill.
        let stranded = inside.join(".write-probe.4294967.tmp");
        std::fs::write(&stranded, b"").unwrap();
        let base = tempfile::tempdir().unwrap();
        let resolved = resolve_cache_dir(scenario.path(), base.path()).unwrap();
        assert_eq!(resolved, inside);
        let left: Vec<_> = std::fs::read_dir(&inside).unwrap().collect();
        assert!(left.is_empty(), "files left in .vadscope: {left:?}");
    }
}
