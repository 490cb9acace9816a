//! Where the bundled model lives: the checkpoint shipped in `assets/model/`, trained by
//! `vadscope train` on generated normal driving (see `assets/model/MODEL.md`). Every command
//! and the viewer use it when no `--model` is given.

use std::path::{Path, PathBuf};

use super::error::ModelError;

/// File name of the bundled checkpoint inside `assets/model/`.
pub const BUNDLED_MODEL_FILE: &str = "hf2vad_ad_compact.safetensors";

/// Environment variable that points vadscope at another default checkpoint.
pub const MODEL_ENV: &str = "VADSCOPE_MODEL";

/// The default checkpoint: `$VADSCOPE_MODEL` if set, else the bundled file next to the
/// binary's source tree (`assets/model/`), else `assets/model/` beside the executable.
///
/// Returns an error that names the places searched when none holds a checkpoint.
pub fn bundled_model() -> Result<PathBuf, ModelError> {
    if let Some(path) = std::env::var_os(MODEL_ENV) {
        let path = PathBuf::from(path);
        return if path.is_file() {
            Ok(path)
        } else {
            Err(ModelError::load(
                path,
                format!("{MODEL_ENV} names a file that does not exist"),
            ))
        };
    }
    let candidates = candidate_paths();
    candidates
        .iter()
        .find(|p| p.is_file())
        .cloned()
        .ok_or_else(|| {
            let searched: Vec<String> =
                candidates.iter().map(|p| p.display().to_string()).collect();
            ModelError::load(
                &candidates[0],
                format!(
                    "no bundled model found (looked in {}); pass --model or set {MODEL_ENV}",
                    searched.join(", ")
                ),
            )
        })
}

fn candidate_paths() -> Vec<PathBuf> {
    let mut out = vec![
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("assets/model")
            .join(BUNDLED_MODEL_FILE),
    ];
    if let Some(dir) = std::env::current_exe()
        .ok()
        .and_then(|exe| exe.parent().map(Path::to_path_buf))
    {
        out.push(dir.join("assets/model").join(BUNDLED_MODEL_FILE));
    }
    out
}
