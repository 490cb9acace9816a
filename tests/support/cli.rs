//! Shared by the end-to-end tests of the `vadscope` binary: running it and generating small
//! scenarios to run it on.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `vadscope` binary built for these tests with `args` (a `$VADSCOPE_MODEL` of the
/// environment is removed, so the default model is always the bundled one).
pub fn vadscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vadscope"))
        .args(args)
        .env_remove("VADSCOPE_MODEL")
        .output()
        .expect("the vadscope binary runs")
}

/// The arguments of `vadscope generate` for one 12-frame 96×64 normal city scenario in sun
/// with `seed`, written under `out`.
pub fn tiny_generate_args<'a>(out: &'a str, seed: &'a str) -> [&'a str; 15] {
    [
        "generate",
        "--out",
        out,
        "--kind",
        "normal",
        "--domain",
        "city",
        "--weather",
        "sun",
        "--frames",
        "12",
        "--size",
        "96x64",
        "--seed",
        seed,
    ]
}

/// Runs the binary like [`vadscope`] and insists that it succeeds; returns standard output.
pub fn succeed(args: &[&str]) -> String {
    let out = vadscope(args);
    assert!(
        out.status.success(),
        "vadscope {args:?} failed:\n{}",
        text(&out.stderr)
    );
    text(&out.stdout)
}

/// A temp path as the `&str` a command line takes.
pub fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

/// Every file under `root` (hidden ones included) by its path relative to `root`, with its
/// bytes; nothing for a folder that does not exist.
pub fn files_under(root: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut folders = vec![root.to_path_buf()];
    while let Some(folder) = folders.pop() {
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        for entry in entries {
            let path = entry.expect("folder entry").path();
            if path.is_dir() {
                folders.push(path);
            } else if let Ok(bytes) = std::fs::read(&path) {
                files.insert(path.strip_prefix(root).unwrap().to_path_buf(), bytes);
            }
        }
    }
    files
}

/// Process output as text, for messages and `contains` checks.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The `Scenario_*` folders directly under `root`, sorted.
pub fn scenario_folders(root: &Path) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(root)
        .expect("readable folder")
        .map(|e| e.expect("entry").path())
        .filter(|p| {
            p.is_dir()
                && p.file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with("Scenario_"))
        })
        .collect();
    found.sort();
    found
}
