//! Full disks and read-only data: `score`, `export`, `labels --import` and `train --resume`
//! onto a filesystem with no space left fail with a message that names the file and the
//! cause, and leave every earlier file as it was; `score` on a read-only data set keeps its
//! caches in the per-user cache folder.
//!
//! The filesystem is a small tmpfs, mounted in a user and mount namespace of its own
//! (`unshare --user --map-root-user --mount`, which needs no privileges where the kernel
//! allows unprivileged namespaces). Where it does not, every write is made to fail instead
//! (`ulimit -f 0`: the process may create files but not put a byte in them), and the
//! read-only test is skipped; the tests print which one ran.

use std::path::{Path, PathBuf};
use std::process::Command;

use vadscope::annotate::{Editor, LabelFormat, LabelSet, export_labels};
use vadscope::sequence::Scenario;

use crate::support::annotate::{add_interval, write_scenario};
use crate::support::app::tiny_checkpoint;
use crate::support::cli::{files_under, path, scenario_folders, succeed};

/// Runs the command given to it on the prepared folder, as `run_on` describes.
const SCRIPT: &str = r#"
set -u
mode=$1 src=$2 root=$3 snapshot=$4 logs=$5
shift 5
if [ "$mode" != fsize ]; then
  mount -t tmpfs -o size=64m tmpfs "$root" || exit 90
fi
cp -a "$src/." "$root/" || exit 91
case "$mode" in
  tmpfs) head -c 100m /dev/zero > "$root/.filler" 2>/dev/null ;;
  readonly) mount -o remount,ro "$root" || exit 92 ;;
esac
(
  if [ "$mode" = fsize ]; then trap '' XFSZ; ulimit -f 0; fi
  exec "$@"
) 2>&1 >/dev/null | cat > "$logs/stderr.txt"
echo "${PIPESTATUS[0]}" > "$logs/status.txt"
rm -f "$root/.filler"
cp -a "$root/." "$snapshot/"
"#;

/// How the tests make writes fail.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// A full tmpfs in namespaces of its own.
    Tmpfs,
    /// A tmpfs remounted read-only after the data was copied in.
    ReadOnly,
    /// A file size limit of zero bytes.
    FileSize,
}

/// Whether this machine lets the tests mount a tmpfs in namespaces of their own.
fn namespaces_allowed() -> bool {
    Command::new("unshare")
        .args(["--user", "--map-root-user", "--mount", "true"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// What a command left.
struct Outcome {
    /// Whether it succeeded.
    success: bool,
    /// Its standard error.
    stderr: String,
    /// A copy of the folder it worked in, taken after it ended.
    snapshot: PathBuf,
    /// The folder it worked in (gone with the tmpfs).
    root: PathBuf,
}

/// Copies `src` into a fresh folder whose writes fail as `mode` says, runs `vadscope`
/// with `args` there (`{root}` in an argument stands for that folder) and `env`, and returns
/// what happened with a copy of the folder afterwards.
fn run_on(mode: Mode, src: &Path, work: &Path, args: &[&str], env: &[(&str, &Path)]) -> Outcome {
    let [root, snapshot, logs] = ["root", "snapshot", "logs"].map(|n| work.join(n));
    for dir in [&root, &snapshot, &logs] {
        std::fs::create_dir_all(dir).unwrap();
    }
    let mode_name = match mode {
        Mode::Tmpfs => "tmpfs",
        Mode::ReadOnly => "readonly",
        Mode::FileSize => "fsize",
    };
    let mut command = if mode == Mode::FileSize {
        Command::new("bash")
    } else {
        let mut unshare = Command::new("unshare");
        unshare.args(["--user", "--map-root-user", "--mount", "bash"]);
        unshare
    };
    command
        .args(["-c", SCRIPT, "full-disk"])
        .args([
            mode_name,
            path(src),
            path(&root),
            path(&snapshot),
            path(&logs),
        ])
        .arg(env!("CARGO_BIN_EXE_vadscope"))
        .args(args.iter().map(|a| a.replace("{root}", path(&root))))
        .env_remove("VADSCOPE_MODEL");
    for (key, value) in env {
        command.env(key, value);
    }
    let ran = command.output().expect("bash runs");
    assert!(ran.status.success(), "the script failed: {ran:?}");
    let status = std::fs::read_to_string(logs.join("status.txt")).unwrap();
    Outcome {
        success: status.trim() == "0",
        stderr: std::fs::read_to_string(logs.join("stderr.txt")).unwrap(),
        snapshot,
        root,
    }
}

/// The mode the full-disk tests run in here, said once per test.
fn full_disk_mode() -> Mode {
    let mode = if namespaces_allowed() {
        Mode::Tmpfs
    } else {
        Mode::FileSize
    };
    println!("writes fail through: {mode:?}");
    mode
}

/// Asserts that `outcome` failed with a message naming a file under its folder and the
/// cause, without a panic.
fn assert_failed_clearly(outcome: &Outcome, mode: Mode) {
    assert!(!outcome.success, "succeeded on a full disk");
    let message = &outcome.stderr;
    println!("on a full disk: {}", message.trim());
    assert!(!message.contains("panicked"), "{message}");
    let cause = match mode {
        Mode::FileSize => "File too large",
        _ => "No space left on device",
    };
    assert_eq!(
        message.matches(cause).count(),
        1,
        "the cause once in: {message}"
    );
    assert!(
        message.contains(path(&outcome.root)),
        "no path in: {message}"
    );
}

/// Asserts that the folder after the run holds exactly the files before it, byte for byte:
/// nothing earlier damaged, no temporary file left behind.
fn assert_unchanged(before: &Path, outcome: &Outcome) {
    let (before, after) = (files_under(before), files_under(&outcome.snapshot));
    assert!(
        after.keys().eq(before.keys()),
        "files appeared or vanished: {:?} against {:?}",
        after.keys().collect::<Vec<_>>(),
        before.keys().collect::<Vec<_>>()
    );
    for ((name, was), is) in before.iter().zip(after.values()) {
        assert!(was == is, "{} changed", name.display());
    }
}

/// Two scored 12-frame 96×64 scenarios and the tiny model, under `dir/src`.
fn scored_data(dir: &Path) -> PathBuf {
    let src = dir.join("src");
    let data = src.join("data");
    std::fs::create_dir_all(&src).unwrap();
    let model = tiny_checkpoint(&src);
    succeed(&[
        "generate",
        "--out",
        path(&data),
        "--count",
        "2",
        "--kind",
        "normal",
        "--frames",
        "12",
        "--size",
        "96x64",
        "--seed",
        "4",
        "--omit",
        "depth,instance",
    ]);
    succeed(&[
        "score",
        path(&data),
        "--model",
        path(&model),
        "--boxes",
        "gt",
    ]);
    src
}

#[test]
fn score_and_export_on_a_full_disk_fail_clearly_and_keep_the_earlier_files() {
    let mode = full_disk_mode();
    let dir = tempfile::tempdir().unwrap();
    let src = scored_data(dir.path());
    let scenario = scenario_folders(&src.join("data")).remove(0);
    let name = scenario.file_name().unwrap().to_str().unwrap().to_string();
    let model = "{root}/tiny.safetensors";
    succeed(&[
        "export",
        path(&scenario),
        "--out",
        path(&src.join("export")),
        "--model",
        path(&src.join("tiny.safetensors")),
    ]);

    let scored = run_on(
        mode,
        &src,
        &dir.path().join("score"),
        &[
            "score",
            "{root}/data",
            "--model",
            model,
            "--boxes",
            "gt",
            "--force",
        ],
        &[],
    );
    assert_failed_clearly(&scored, mode);
    assert_unchanged(&src, &scored);

    let scenario_in_root = format!("{{root}}/data/{name}");
    let exported = run_on(
        mode,
        &src,
        &dir.path().join("export"),
        &[
            "export",
            &scenario_in_root,
            "--out",
            "{root}/export",
            "--model",
            model,
        ],
        &[],
    );
    assert_failed_clearly(&exported, mode);
    assert_unchanged(&src, &exported);
}

#[test]
fn labels_and_training_on_a_full_disk_fail_clearly_and_lose_nothing() {
    use crate::train::{generate, stop_after_first_epoch, tiny, tiny_model};

    let mode = full_disk_mode();
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src");
    std::fs::create_dir_all(&src).unwrap();

    // Labels: an import onto a full disk leaves the labels as they were.
    let labelled = write_scenario(&src);
    let before = Editor::open(&Scenario::open(&labelled).unwrap())
        .unwrap()
        .labels()
        .clone();
    let mut imported: LabelSet = before.clone();
    add_interval(900, 1, 4).apply(&mut imported).unwrap();
    let csv = dir.path().join("intervals.csv");
    export_labels(
        &Scenario::open(&labelled).unwrap(),
        &imported,
        LabelFormat::IntervalsCsv,
        &csv,
    )
    .unwrap();
    let relabelled = run_on(
        mode,
        &src,
        &dir.path().join("labels"),
        &[
            "labels",
            "{root}/s",
            "--import",
            path(&csv),
            "--format",
            "intervals-csv",
        ],
        &[],
    );
    assert_failed_clearly(&relabelled, mode);
    let kept = Editor::open(&Scenario::open(&relabelled.snapshot.join("s")).unwrap())
        .unwrap()
        .labels()
        .clone();
    assert_eq!(kept, before, "the labels changed");

    // Training: a run stopped after its first epoch, resumed onto a full disk, keeps that
    // epoch's files as they were.
    let data = src.join("data");
    generate(&data, &[]);
    let model = tiny_model(&src);
    let args = |out: &str, data: &str, model: &str| {
        tiny(
            Path::new(data),
            Path::new(out),
            Some(Path::new(model)),
            &["--stage", "memae", "--epochs", "3"],
        )
    };
    stop_after_first_epoch(&args(path(&src.join("run")), path(&data), path(&model)));
    let mut resumed = args("{root}/run", "{root}/data", "{root}/tiny_model.json");
    resumed.push("--resume".into());
    let resumed: Vec<&str> = resumed.iter().map(String::as_str).collect();
    let trained = run_on(mode, &src, &dir.path().join("train"), &resumed, &[]);
    assert_failed_clearly(&trained, mode);
    assert_unchanged(&src, &trained);
}

#[test]
fn score_on_a_read_only_data_set_keeps_its_caches_in_the_user_cache_folder() {
    if !namespaces_allowed() {
        println!("skipped: no namespaces to mount a read-only filesystem in");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let src = scored_data(dir.path());
    for scenario in scenario_folders(&src.join("data")) {
        std::fs::remove_dir_all(scenario.join(".vadscope")).unwrap();
    }
    let user_cache = dir.path().join("user-cache");
    let scored = run_on(
        Mode::ReadOnly,
        &src,
        &dir.path().join("score"),
        &[
            "score",
            "{root}/data",
            "--model",
            "{root}/tiny.safetensors",
            "--boxes",
            "gt",
        ],
        &[("XDG_CACHE_HOME", &user_cache)],
    );
    assert!(scored.success, "{}", scored.stderr);
    assert_unchanged(&src, &scored);
    let caches: Vec<_> = files_under(&user_cache)
        .into_iter()
        .filter(|(p, _)| p.extension().is_some_and(|x| x == "vsc"))
        .collect();
    assert_eq!(
        caches.len(),
        2,
        "one score cache per scenario in the user cache folder"
    );
}
