//! `vadscope train` end to end on tiny generated scenarios: the validation loss falls, the
//! final checkpoint loads with its training statistics, an interrupted run resumes, a single
//! stage continues from an earlier run's checkpoint (`--init`), `--select-on` keeps the epoch
//! rated best on validation scenarios with anomalies, and bad
//! input (no scenarios, an unwritable output folder, a corrupt checkpoint, a second run in a
//! used folder) fails with a message that names the problem.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use burn::tensor::Device;
use vadscope::model::{Detector, FlowUnits, ModelConfig, ScoreScale, load_checkpoint};
use vadscope::train::CubeSet;

use crate::support::app::generate_dataset;
use crate::support::cli::{path, text, vadscope};
use crate::support::model::tiny_config;

/// Two 10-frame 96×64 normal-driving scenarios in `dir`, with `extra` generator options.
pub(crate) fn generate(dir: &Path, extra: &[&str]) {
    let mut args = vec![
        "generate",
        "--out",
        path(dir),
        "--count",
        "2",
        "--kind",
        "normal",
        "--frames",
        "10",
        "--size",
        "96x64",
        "--seed",
        "5",
    ];
    args.extend_from_slice(extra);
    let out = vadscope(&args);
    assert!(out.status.success(), "generate: {}", text(&out.stderr));
}

/// Writes a tiny model config (16×16 cubes, 4 base features, 8 memory slots) beside `dir`'s
/// other files and returns its path.
pub(crate) fn tiny_model(dir: &Path) -> PathBuf {
    let config = tiny_config(ModelConfig::compact());
    let file = dir.join("tiny_model.json");
    std::fs::write(&file, serde_json::to_string(&config).unwrap()).unwrap();
    file
}

/// A fast training run: the model of `model` (a config file, or a checkpoint when `extra`
/// holds `--init`), a few steps of 8 cubes per epoch, learning rates high enough to move in
/// a few steps.
pub(crate) fn tiny(data: &Path, out: &Path, model: Option<&Path>, extra: &[&str]) -> Vec<String> {
    let mut args: Vec<String> = [
        "train",
        "--data",
        path(data),
        "--out",
        path(out),
        "--batch",
        "8",
        "--max-steps",
        "3",
        "--eval-batch",
        "16",
        "--memae-lr",
        "2e-3",
        "--cvae-lr",
        "1e-3",
        "--finetune-lr",
        "1e-3",
        "--seed",
        "1",
        "--val-fraction",
        "0.5",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    if let Some(model) = model {
        args.extend(["--model-config".to_string(), path(model).to_string()]);
    }
    args.extend(extra.iter().map(|s| s.to_string()));
    args
}

/// Runs `vadscope train` with `args` (stage 1 first) and kills it as soon as its first
/// epoch is checkpointed.
pub(crate) fn stop_after_first_epoch(args: &[String]) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_vadscope"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("train starts");
    let stdout = child.stdout.take().expect("piped stdout");
    let first_epoch = BufReader::new(stdout)
        .lines()
        .map_while(Result::ok)
        .any(|l| l.starts_with("stage 1 memae epoch 1/"));
    child.kill().expect("kill the run");
    child.wait().expect("reap the run");
    assert!(first_epoch, "the run never finished an epoch");
}

fn run(args: &[String]) -> Output {
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    vadscope(&args)
}

/// Validation losses of `stage` in epoch order, from the per-epoch lines.
fn validation_losses(stdout: &str, stage: usize) -> Vec<f64> {
    stdout
        .lines()
        .filter(|l| l.starts_with(&format!("stage {stage} ")) && l.contains(" epoch "))
        .filter_map(|l| {
            l.split("validation loss ")
                .nth(1)?
                .split(',')
                .next()?
                .parse()
                .ok()
        })
        .collect()
}

#[test]
fn training_lowers_the_loss_and_writes_a_checkpoint_with_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let out = dir.path().join("run");
    generate(&data, &[]);
    let model = tiny_model(dir.path());

    let trained = run(&tiny(&data, &out, Some(&model), &["--epochs", "3"]));
    let stdout = text(&trained.stdout);
    assert!(
        trained.status.success(),
        "train failed: {}\n{stdout}",
        text(&trained.stderr)
    );
    for stage in 1..=3 {
        let losses = validation_losses(&stdout, stage);
        assert_eq!(losses.len(), 3, "stage {stage} epoch lines:\n{stdout}");
        assert!(losses.iter().all(|l| l.is_finite() && *l > 0.0));
        if stage == 1 {
            assert!(
                losses[2] < losses[0],
                "stage 1 validation loss should fall: {losses:?}"
            );
        }
    }

    let trained_model = out.join("model.safetensors");
    assert!(stdout.contains(path(&trained_model)), "{stdout}");
    let checkpoint = load_checkpoint(&trained_model, &Device::flex()).expect("checkpoint loads");
    assert_eq!(checkpoint.meta.config.preset, "test-tiny");
    let stats = checkpoint.meta.stats.expect("training statistics stored");
    assert!(stats.cubes > 0);
    assert!(stats.flow_score.mean > 0.0 && stats.frame_score.std > 0.0);
    assert!(stats.frame_pixel.iqr >= 0.0 && stats.flow_pixel.total > 0);

    // Score bands and tail tables re-derived for the trained model: same weights,
    // statistics per band.
    let banded = dir.path().join("banded");
    let init = path(&trained_model).to_string();
    let rederived = run(&tiny(
        &data,
        &banded,
        None,
        &[
            "--init",
            &init,
            "--epochs",
            "0",
            "--score-bands",
            "3",
            "--score-scale",
            "tail",
        ],
    ));
    assert!(rederived.status.success(), "{}", text(&rederived.stderr));
    let again_stdout = text(&rederived.stdout);
    assert!(again_stdout.contains("band 3/3"), "{again_stdout}");
    let banded = load_checkpoint(&banded.join("model.safetensors"), &Device::flex())
        .expect("banded checkpoint loads");
    assert_eq!(banded.meta.config.score_bands, 3);
    assert_eq!(banded.meta.config.score_scale, ScoreScale::TailSurprisal);
    let banded_stats = banded.meta.stats.expect("statistics");
    assert_eq!(banded_stats.bands.len(), 3);
    let tails = banded_stats.tails.as_ref().expect("tail tables");
    assert!(tails.flow.surprisal(0.0) == 0.0 && tails.flow.surprisal(1e30) > 1.0);
    for band in &banded_stats.bands {
        assert_eq!(
            band.tails.is_some(),
            band.cubes > 0,
            "tables where there are cubes"
        );
    }
    assert!(stats.tails.is_none(), "the reference z-scores");
    assert_eq!(
        banded_stats.bands.iter().map(|b| b.cubes).sum::<u64>(),
        banded_stats.cubes,
        "every training cube lies in one band"
    );
    assert_eq!(
        banded_stats.flow_score, stats.flow_score,
        "same model, same cubes"
    );

    // Frame-width flow units named for the native-pixel model: the data's width recorded,
    // and at that width the cubes, so the statistics, are the same.
    let widths = dir.path().join("frame-width");
    let relabelled = run(&tiny(
        &data,
        &widths,
        None,
        &[
            "--init",
            &init,
            "--epochs",
            "0",
            "--flow-units",
            "frame-width",
        ],
    ));
    assert!(relabelled.status.success(), "{}", text(&relabelled.stderr));
    let relabelled = load_checkpoint(&widths.join("model.safetensors"), &Device::flex())
        .expect("relabelled checkpoint loads");
    assert_eq!(
        relabelled.meta.config.conventions.flow_units,
        FlowUnits::FrameWidth { width: 96 }
    );
    assert_eq!(
        relabelled.meta.stats.expect("statistics").flow_score,
        stats.flow_score,
        "same cubes at the training width"
    );
    // Other units cannot be given to a trained model.
    let refused = run(&tiny(
        &data,
        &dir.path().join("patch"),
        None,
        &["--init", &init, "--epochs", "0", "--flow-units", "patch"],
    ));
    assert!(!refused.status.success());
    assert!(
        text(&refused.stderr).contains("train a new model to change units"),
        "{}",
        text(&refused.stderr)
    );

    let again = run(&tiny(&data, &out, Some(&model), &["--epochs", "3"]));
    assert!(!again.status.success());
    assert!(
        text(&again.stderr).contains("already holds a training run"),
        "{}",
        text(&again.stderr)
    );
}

#[test]
fn an_interrupted_run_resumes_and_a_corrupt_checkpoint_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let out = dir.path().join("run");
    generate(&data, &[]);
    let model = tiny_model(dir.path());
    let args = tiny(
        &data,
        &out,
        Some(&model),
        &["--stage", "memae", "--epochs", "3"],
    );

    stop_after_first_epoch(&args);
    assert!(!out.join("model.safetensors").exists());

    // A damaged checkpoint in a copy of the folder is named in the error.
    let damaged = dir.path().join("damaged");
    std::fs::create_dir(&damaged).unwrap();
    for entry in std::fs::read_dir(&out).unwrap() {
        let entry = entry.unwrap();
        std::fs::copy(entry.path(), damaged.join(entry.file_name())).unwrap();
    }
    std::fs::write(damaged.join("last_model.bpk"), b"not a checkpoint").unwrap();
    let failed = run(&tiny(
        &data,
        &damaged,
        Some(&model),
        &["--stage", "memae", "--epochs", "3", "--resume"],
    ));
    assert!(!failed.status.success());
    assert!(
        text(&failed.stderr).contains("last_model.bpk"),
        "{}",
        text(&failed.stderr)
    );

    let mut resume_args = args;
    resume_args.push("--resume".into());
    let resumed = run(&resume_args);
    let stdout = text(&resumed.stdout);
    assert!(
        resumed.status.success(),
        "resume failed: {}\n{stdout}",
        text(&resumed.stderr)
    );
    assert!(stdout.contains("stage 1: resuming at epoch"), "{stdout}");
    assert!(
        !stdout.contains("epoch 1/3"),
        "the finished epoch must not run again:\n{stdout}"
    );
    assert!(stdout.contains("epoch 3/3"), "{stdout}");
    let stage1 = out.join("model.safetensors");
    assert!(
        load_checkpoint(&stage1, &Device::flex())
            .unwrap()
            .meta
            .stats
            .is_some()
    );

    // Stage 2 alone, started from the stage-1 model: ML-MemAE-SC (hence S_r) is unchanged
    // while the CVAE (hence S_p) trains.
    let cvae = dir.path().join("cvae");
    let second = run(&tiny(
        &data,
        &cvae,
        None,
        &["--stage", "cvae", "--epochs", "1", "--init", path(&stage1)],
    ));
    assert!(second.status.success(), "{}", text(&second.stderr));
    let cubes = CubeSet::load(&out.join("cubes.safetensors")).unwrap();
    let (frames, flows) = cubes.gather(&[0, 1, 2]);
    let before = Detector::from_checkpoint(&stage1).unwrap();
    let after = Detector::from_checkpoint(&cvae.join("model.safetensors")).unwrap();
    let before = before.infer(&frames, &flows).unwrap();
    let after = after.infer(&frames, &flows).unwrap();
    for (b, a) in before.iter().zip(&after) {
        assert!(
            (b.s_r - a.s_r).abs() <= 1e-4 * b.s_r.abs().max(1.0),
            "S_r moved"
        );
    }
    assert!(
        before.iter().zip(&after).any(|(b, a)| b.s_p != a.s_p),
        "stage 2 should change the frame prediction"
    );
}

#[test]
fn bad_input_gives_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let out = dir.path().join("run");

    let no_data = run(&tiny(&empty, &out, None, &["--epochs", "1"]));
    assert!(!no_data.status.success());
    let message = text(&no_data.stderr);
    assert!(
        message.contains(path(&empty)) && message.contains("no Scenario_* folders"),
        "{message}"
    );

    let data = dir.path().join("data");
    generate(&data, &[]);
    let blocker = dir.path().join("a_file");
    std::fs::write(&blocker, b"x").unwrap();
    let unwritable = run(&tiny(&data, &blocker.join("run"), None, &["--epochs", "1"]));
    assert!(!unwritable.status.success());
    assert!(
        text(&unwritable.stderr).contains("cannot create the output folder"),
        "{}",
        text(&unwritable.stderr)
    );

    let nothing = run(&tiny(&data, &dir.path().join("fresh"), None, &["--resume"]));
    assert!(!nothing.status.success());
    assert!(
        text(&nothing.stderr).contains("no run to resume"),
        "{}",
        text(&nothing.stderr)
    );

    let help = vadscope(&["train", "--help"]);
    let help = text(&help.stdout);
    for option in [
        "--data",
        "--out",
        "--stage",
        "--preset",
        "--epochs",
        "--batch",
        "--seed",
        "--resume",
        "--frame-stride",
        "--val-fraction",
        "--config",
        "--model-config",
        "--init",
        "--select-on",
        "--select-every",
    ] {
        assert!(help.contains(option), "--help lacks {option}:\n{help}");
    }
}

#[test]
fn training_on_estimated_flow_needs_no_stored_flow_and_fills_the_flow_cache() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    generate(&data, &["--omit", "flow,depth"]);
    let model = tiny_model(dir.path());

    // Stored flow is the default, and these scenarios have none: the error says so.
    let stored = run(&tiny(
        &data,
        &dir.path().join("stored"),
        Some(&model),
        &["--epochs", "1"],
    ));
    assert!(!stored.status.success());
    let message = text(&stored.stderr);
    assert!(
        message.contains("flow") && message.contains(path(&data)),
        "{message}"
    );

    let estimated = run(&tiny(
        &data,
        &dir.path().join("dis"),
        Some(&model),
        &["--epochs", "1", "--flow", "dis:ultrafast"],
    ));
    assert!(
        estimated.status.success(),
        "{}\n{}",
        text(&estimated.stderr),
        text(&estimated.stdout)
    );
    let stdout = text(&estimated.stdout);
    assert_eq!(validation_losses(&stdout, 1).len(), 1, "{stdout}");
    // The estimates went to each scenario's flow cache, where scoring reads them.
    for scenario in std::fs::read_dir(&data).unwrap() {
        let cache = scenario.unwrap().path().join(".vadscope/flow/ultrafast");
        let cached = std::fs::read_dir(&cache).map_or(0, |d| d.count());
        assert!(cached > 0, "no cached flow in {}", cache.display());
    }
}

#[test]
fn select_on_keeps_the_epoch_with_the_best_validation_auroc() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    generate(&data, &[]);
    let validation = generate_dataset(&dir.path().join("validation"));
    let model = tiny_model(dir.path());
    let selected = |out: &str, extra: &[&str]| {
        let mut args = vec!["--stage", "memae", "--epochs", "3", "--select-on"];
        args.push(path(&validation));
        args.extend_from_slice(extra);
        run(&tiny(&data, &dir.path().join(out), Some(&model), &args))
    };

    let out = selected("every", &[]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}\n{}", stdout, text(&out.stderr));
    assert!(
        stdout.contains("model selection: frame AUROC on 2 validation scenarios"),
        "{stdout}"
    );
    let ratings: Vec<f64> = stdout
        .lines()
        .filter(|l| l.starts_with("stage 1 memae epoch"))
        .filter_map(|l| {
            l.split("validation frame AUROC ")
                .nth(1)?
                .split(' ')
                .next()?
                .parse()
                .ok()
        })
        .collect();
    assert_eq!(ratings.len(), 3, "every epoch judged:\n{stdout}");
    let best = ratings.iter().copied().fold(f64::MIN, f64::max);
    let first_best = ratings.iter().position(|&r| r == best).unwrap();
    assert!(
        stdout.contains(&format!(
            "kept epoch {} (validation frame AUROC {best:.2} %)",
            first_best + 1
        )),
        "{stdout}"
    );

    // Every second epoch and the last: epochs 2 and 3.
    let out = selected("sparse", &["--select-every", "2"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let judged: Vec<bool> = stdout
        .lines()
        .filter(|l| l.starts_with("stage 1 memae epoch"))
        .map(|l| l.contains("validation frame AUROC"))
        .collect();
    assert_eq!(judged, vec![false, true, true], "{stdout}");

    // Weight averaging from the second epoch: epochs 2 and 3 rate the running mean.
    let out = selected("averaged", &["--select-every", "2", "--average-from", "2"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let averaged: Vec<bool> = stdout
        .lines()
        .filter(|l| l.starts_with("stage 1 memae epoch"))
        .map(|l| l.contains("average of"))
        .collect();
    assert_eq!(averaged, vec![false, true, true], "{stdout}");
    assert!(stdout.contains("(average of 2 epochs)"), "{stdout}");
    assert!(
        stdout.contains("kept epoch 2 (") || stdout.contains("kept the average of epochs 2–3 ("),
        "{stdout}"
    );
    let zero = selected("zero-average", &["--average-from", "0"]);
    assert!(!zero.status.success());
    assert!(
        text(&zero.stderr).contains("--average-from"),
        "{}",
        text(&zero.stderr)
    );

    let zero = selected("zero", &["--select-every", "0"]);
    assert!(!zero.status.success());
    assert!(
        text(&zero.stderr).contains("--select-every"),
        "{}",
        text(&zero.stderr)
    );

    // Normal driving alone cannot rate a detector.
    let mut args = tiny(
        &data,
        &dir.path().join("normal"),
        Some(&model),
        &["--epochs", "1"],
    );
    args.extend(["--select-on".to_string(), path(&data).to_string()]);
    let normal = run(&args);
    assert!(!normal.status.success());
    let message = text(&normal.stderr);
    assert!(
        message.contains("--select-on") && message.contains("0 anomalous"),
        "{message}"
    );
}
