//! `kill -9` at random moments of the commands that write files an analyst would miss:
//! `generate`, `flow`, `score`, `train --resume`, `export` and `labels --import`.
//!
//! Each test first runs the command uninterrupted into a reference folder and times it. Then,
//! from a fresh folder, it starts the same command again and again, each time killed
//! (SIGKILL) after a seeded random delay shorter than the reference run, until a run ends by
//! itself (after [`KILLS_PER_FOLDER`] kills the next run is let finish). After every kill no file under its final name may differ from the reference's (a
//! half-written file taken as complete would); after the run that ends by itself the folder
//! must hold exactly the reference's files. Fresh folders are started until at least
//! [`KILLS`] kills have landed on a running process; the count is printed.

use std::collections::BTreeMap;
use std::fs::File;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use vadscope::annotate::{Editor, LabelFormat, LabelSet, export_labels};
use vadscope::sequence::Scenario;

use crate::support::annotate::{add_interval, write_scenario};
use crate::support::app::tiny_checkpoint;
use crate::support::cli::{files_under, path, text, vadscope};

/// Kills that must land on a running process in each test.
const KILLS: usize = 20;

/// Most kills in one fresh folder before its run is let finish.
const KILLS_PER_FOLDER: usize = 6;

/// SIGKILL.
const SIGKILL: i32 = 9;

/// The delays between starting a run and killing it: SplitMix64, so a failing test can be
/// replayed from its seed.
struct Delays(u64);

impl Delays {
    /// A delay drawn uniformly from `[0, window)`.
    fn next(&mut self, window: Duration) -> Duration {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        window.mul_f64((z >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// How a run that was given a kill ended.
enum Ended {
    /// Killed while it ran.
    Killed,
    /// Finished successfully before the kill came.
    Finished,
}

/// Starts `command` with its output in files under `logs`, kills it after `delay` unless it
/// has finished (without a delay, lets it finish), and says which came first. A run that
/// fails on its own fails the test.
fn run_until(mut command: Command, delay: Option<Duration>, logs: &Path) -> Ended {
    let stderr_path = logs.join("stderr.txt");
    let mut child = command
        .env_remove("VADSCOPE_MODEL")
        .stdin(Stdio::null())
        .stdout(File::create(logs.join("stdout.txt")).expect("log file"))
        .stderr(File::create(&stderr_path).expect("log file"))
        .spawn()
        .expect("the vadscope binary starts");
    if let Some(delay) = delay {
        std::thread::sleep(delay);
        // Killing a process that has just exited but is not reaped yet does nothing; its
        // exit status tells the two apart.
        let _ = child.kill();
    }
    let status = child.wait().expect("reap the run");
    if status.signal() == Some(SIGKILL) {
        return Ended::Killed;
    }
    assert!(
        status.success(),
        "{command:?} failed on its own ({status}):\n{}",
        text(&std::fs::read(&stderr_path).unwrap_or_default())
    );
    Ended::Finished
}

/// One command under test: how to reset its folder, run it, and check what it left.
struct KillTest<'a> {
    /// Seed of the kill delays.
    seed: u64,
    /// Removes what earlier runs wrote, so the command starts from nothing.
    reset: &'a mut dyn FnMut(),
    /// The command to run again after a kill (it may depend on what is on disk).
    command: &'a mut dyn FnMut() -> Command,
    /// Checks what a killed run left; `finished` after the run that ended by itself.
    check: &'a mut dyn FnMut(bool),
}

impl KillTest<'_> {
    /// Kills runs of the command until [`KILLS`] kills have landed (see the module docs);
    /// `window` is the duration of an uninterrupted run. Returns the kills that landed.
    fn run(self, window: Duration, logs: &Path) -> usize {
        let mut delays = Delays(self.seed);
        let mut landed = 0;
        let mut folders = 0;
        while landed < KILLS {
            (self.reset)();
            folders += 1;
            assert!(folders <= 10 * KILLS, "kills keep missing the runs");
            let mut killed_here = 0;
            loop {
                // A run slower than the uninterrupted one (a loaded machine) could be killed
                // forever; after a few kills the folder's last run goes to the end.
                let delay = (killed_here < KILLS_PER_FOLDER).then(|| delays.next(window));
                match run_until((self.command)(), delay, logs) {
                    Ended::Killed => {
                        landed += 1;
                        killed_here += 1;
                        (self.check)(false);
                    }
                    Ended::Finished => {
                        (self.check)(true);
                        break;
                    }
                }
            }
        }
        println!(
            "survived {landed} kills in {folders} fresh folders (an uninterrupted run: {:.2} s)",
            window.as_secs_f64()
        );
        landed
    }
}

/// Runs `args` to the end and returns how long it took.
fn timed<S: AsRef<str>>(args: &[S]) -> Duration {
    let args: Vec<&str> = args.iter().map(AsRef::as_ref).collect();
    let start = Instant::now();
    let out = vadscope(&args);
    assert!(
        out.status.success(),
        "vadscope {args:?}: {}",
        text(&out.stderr)
    );
    start.elapsed()
}

/// A `vadscope` command with `args`.
fn vadscope_command<S: AsRef<str>>(args: &[S]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_vadscope"));
    command.args(args.iter().map(AsRef::as_ref));
    command
}

/// Whether `relative` is a temporary file of an atomic write (`.<name>.<pid>.tmp`) or lies
/// in a folder being generated (`.<scenario>.partial`): what a killed run may leave.
fn in_progress(relative: &Path) -> bool {
    relative.components().any(|c| {
        let name = c.as_os_str().to_string_lossy();
        name.starts_with('.') && (name.ends_with(".tmp") || name.ends_with(".partial"))
    })
}

/// Asserts that every file `found` holds under its final name has the reference's bytes
/// and, once the run `finished`, that `found` holds exactly the reference's files.
fn assert_matches(
    found: &BTreeMap<PathBuf, Vec<u8>>,
    reference: &BTreeMap<PathBuf, Vec<u8>>,
    finished: bool,
    what: &str,
) {
    for (path, bytes) in found.iter().filter(|(p, _)| !in_progress(p)) {
        match reference.get(path) {
            Some(expected) => assert!(
                expected == bytes,
                "{what}: {} differs from the uninterrupted run's ({} against {} bytes)",
                path.display(),
                bytes.len(),
                expected.len()
            ),
            None => panic!("{what}: {} is not in the uninterrupted run", path.display()),
        }
    }
    if finished {
        let names = |m: &BTreeMap<PathBuf, Vec<u8>>| m.keys().cloned().collect::<Vec<_>>();
        assert_eq!(
            names(found),
            names(reference),
            "{what}: the finished run left other files than the uninterrupted one"
        );
    }
}

/// The arguments of `generate`: three normal scenarios of `frames` frames of `size`, with
/// `extra`.
fn generate_args<'a>(
    out: &'a str,
    frames: &'a str,
    size: &'a str,
    extra: &[&'a str],
) -> Vec<&'a str> {
    let mut args = vec![
        "generate", "--out", out, "--count", "3", "--kind", "normal", "--frames", frames, "--size",
        size, "--seed", "3",
    ];
    args.extend_from_slice(extra);
    args
}

/// Removes `dir` and what is in it, if it exists.
fn remove(dir: &Path) {
    if dir.exists() {
        std::fs::remove_dir_all(dir).expect("remove a test folder");
    }
}

/// Copies the folder `from` to `to`, replacing `to`.
fn copy_folder(from: &Path, to: &Path) {
    remove(to);
    for (relative, bytes) in files_under(from) {
        let target = to.join(relative);
        std::fs::create_dir_all(target.parent().unwrap()).unwrap();
        std::fs::write(target, bytes).unwrap();
    }
}

/// Runs `command(folder)` to the end on a copy of `data`, then kills it at random moments
/// on fresh copies (see the module docs); returns the uninterrupted run's files.
fn kill_on_copies(
    dir: &Path,
    data: &Path,
    seed: u64,
    what: &str,
    command: &dyn Fn(&Path) -> Vec<String>,
) -> BTreeMap<PathBuf, Vec<u8>> {
    let reference = dir.join("reference");
    copy_folder(data, &reference);
    let window = timed(&command(&reference));
    let expected = files_under(&reference);
    let out = dir.join("out");
    let kills = KillTest {
        seed,
        reset: &mut || copy_folder(data, &out),
        command: &mut || vadscope_command(&command(&out)),
        check: &mut |finished| assert_matches(&files_under(&out), &expected, finished, what),
    }
    .run(window, dir);
    assert!(kills >= KILLS);
    expected
}

#[test]
fn generate_killed_at_random_moments_resumes_to_the_same_scenarios() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    let window = timed(&generate_args(path(&reference), "24", "192x128", &[]));
    let expected = files_under(&reference);
    let out = dir.path().join("out");
    let kills = KillTest {
        seed: 1,
        reset: &mut || remove(&out),
        command: &mut || {
            vadscope_command(&generate_args(path(&out), "24", "192x128", &["--resume"]))
        },
        check: &mut |finished| {
            assert_matches(&files_under(&out), &expected, finished, "generate");
        },
    }
    .run(window, dir.path());
    assert!(kills >= KILLS);
}

#[test]
fn flow_killed_at_random_moments_finishes_the_same_cache() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    timed(&generate_args(
        path(&data),
        "24",
        "192x128",
        &["--omit", "flow,depth,instance"],
    ));
    let frames = files_under(&data);
    let flow = |root: &Path| {
        vec![
            "flow".to_string(),
            path(root).into(),
            "--preset".into(),
            "fast".into(),
        ]
    };
    let expected = kill_on_copies(dir.path(), &data, 2, "flow", &flow);
    assert!(expected.len() > frames.len(), "the reference computed flow");
}

#[test]
fn score_killed_at_random_moments_finishes_the_same_caches() {
    let dir = tempfile::tempdir().unwrap();
    let model = tiny_checkpoint(dir.path());
    let data = dir.path().join("data");
    timed(&generate_args(
        path(&data),
        "10",
        "96x64",
        &["--omit", "depth,instance"],
    ));
    let score = |root: &Path| {
        vec![
            "score".to_string(),
            path(root).into(),
            "--model".into(),
            path(&model).into(),
            "--boxes".into(),
            "gt".into(),
        ]
    };
    kill_on_copies(dir.path(), &data, 3, "score", &score);
}

#[test]
fn export_killed_at_random_moments_leaves_whole_files_and_finishes_when_rerun() {
    let dir = tempfile::tempdir().unwrap();
    let model = tiny_checkpoint(dir.path());
    let data = dir.path().join("data");
    timed(&generate_args(
        path(&data),
        "16",
        "96x64",
        &["--omit", "depth,instance"],
    ));
    let scenario = crate::support::cli::scenario_folders(&data).remove(0);
    let export = |out: &Path| {
        vec![
            "export".to_string(),
            path(&scenario).into(),
            "--out".into(),
            path(out).into(),
            "--model".into(),
            path(&model).into(),
        ]
    };
    // The first export scores the scenario; time the one that only draws and writes.
    let reference = dir.path().join("reference");
    let args = export(&reference);
    timed(&args);
    remove(&reference);
    let window = timed(&args);
    let expected = files_under(&reference);
    let out = dir.path().join("out");
    let kills = KillTest {
        seed: 4,
        reset: &mut || remove(&out),
        command: &mut || vadscope_command(&export(&out)),
        check: &mut |finished| assert_matches(&files_under(&out), &expected, finished, "export"),
    }
    .run(window, dir.path());
    assert!(kills >= KILLS);
}

#[test]
fn train_killed_at_random_moments_resumes_to_the_uninterrupted_model() {
    use crate::train::{generate, tiny, tiny_model};

    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    generate(&data, &[]);
    let model = tiny_model(dir.path());
    let train = |out: &Path, resume: bool| {
        let mut extra = vec!["--epochs", "2", "--threads", "1"];
        if resume {
            extra.push("--resume");
        }
        tiny(&data, out, Some(&model), &extra)
    };
    let reference = dir.path().join("reference");
    let window = timed(&train(&reference, false));
    let weights = |run: &Path| std::fs::read(run.join("model.safetensors"));
    let expected = weights(&reference).expect("the reference model");
    let out = dir.path().join("out");
    let kills = KillTest {
        seed: 5,
        reset: &mut || remove(&out),
        // The same command, with `--resume` once the run has started (train refuses to
        // resume an empty folder, which catches a mistyped run folder).
        command: &mut || {
            vadscope_command(&train(
                &out,
                out.join("state.json").exists() || out.join("cubes.safetensors").exists(),
            ))
        },
        check: &mut |finished| {
            let final_model = out.join("model.safetensors");
            if finished {
                assert!(
                    weights(&out).ok() == Some(expected.clone()),
                    "the resumed run's model differs"
                );
                let leftovers: Vec<_> = files_under(&out)
                    .into_keys()
                    .filter(|p| in_progress(p))
                    .collect();
                assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
            } else if final_model.exists() {
                assert!(
                    weights(&out).ok() == Some(expected.clone()),
                    "a killed run left another model"
                );
            }
        },
    }
    .run(window, dir.path());
    assert!(kills >= KILLS);
}

#[test]
fn labels_import_killed_at_random_moments_leaves_the_old_or_the_new_labels() {
    let dir = tempfile::tempdir().unwrap();
    let original = write_scenario(dir.path());
    let scenario = Scenario::open(&original).expect("scenario");
    let labels_of = |root: &Path| -> LabelSet {
        let scenario = Scenario::open(root).expect("scenario");
        Editor::open(&scenario)
            .expect("labels open")
            .labels()
            .clone()
    };
    let before = labels_of(&original);
    // Many intervals, so that the import has something to write.
    let mut imported = before.clone();
    for k in 0..300 {
        add_interval(1_000 + k, k as usize % 6, k as usize % 6 + 2)
            .apply(&mut imported)
            .expect("interval");
    }
    let csv = dir.path().join("intervals.csv");
    export_labels(&scenario, &imported, LabelFormat::IntervalsCsv, &csv).expect("export");
    let import = |root: &Path| {
        vec![
            "labels".to_string(),
            path(root).into(),
            "--import".into(),
            path(&csv).into(),
            "--format".into(),
            "intervals-csv".into(),
        ]
    };
    let reference = dir.path().join("reference");
    copy_folder(&original, &reference);
    let window = timed(&import(&reference));
    let after = labels_of(&reference);
    assert_ne!(after, before, "the import changes the labels");
    let out = dir.path().join("out");
    let kills = KillTest {
        seed: 6,
        reset: &mut || copy_folder(&original, &out),
        command: &mut || vadscope_command(&import(&out)),
        check: &mut |finished| {
            let found = labels_of(&out);
            if finished {
                assert!(
                    found == after,
                    "the finished import differs from the uninterrupted one"
                );
            } else {
                assert!(
                    found == before || found == after,
                    "a killed import left labels in between"
                );
            }
        },
    }
    .run(window, dir.path());
    assert!(kills >= KILLS);
}
