//! `vadscope score` and `vadscope eval` through the binary, on a tiny generated data set (a
//! normal and a braking scenario at 96×64) and a tiny random checkpoint made here: caches
//! appear and are reused (also when two processes score the same scenarios at once), the
//! tables have the rows asked for, and bad inputs fail with a message that names the
//! culprit.

use std::path::{Path, PathBuf};

use burn::tensor::Device;
use serde_json::Value;
use vadscope::model::{
    CheckpointMeta, Hf2Vad, ModelConfig, NoiseRng, PixelStats, ScoreStats, TrainingStats,
    save_checkpoint,
};
use vadscope::score::ScoreCache;

use crate::support::cli::{succeed, text, vadscope};
use crate::support::model::tiny_config;

/// Frames per generated scenario: the generator's shortest braking scenario (the lead
/// vehicle brakes to a standstill inside it, so it has anomalous frames).
const FRAMES: usize = 80;

/// Runs vadscope and insists that it fails; returns standard error.
fn fail(args: &[&str]) -> String {
    let out = vadscope(args);
    assert!(
        !out.status.success(),
        "vadscope {args:?} should fail but printed:\n{}",
        text(&out.stdout)
    );
    text(&out.stderr)
}

fn pixel_stats(median: f64, q25: f64, q75: f64) -> PixelStats {
    PixelStats {
        median,
        q25,
        q75,
        iqr: q75 - q25,
        sampled: 1000,
        total: 1000,
    }
}

/// A random-init checkpoint of a tiny model (16×16 cubes) with plausible statistics.
fn tiny_checkpoint(dir: &Path) -> PathBuf {
    let config = tiny_config(ModelConfig::paper());
    let model = Hf2Vad::new(&config, &Device::flex(), &mut NoiseRng::new(7)).expect("model");
    let meta = CheckpointMeta {
        config,
        stats: Some(TrainingStats {
            cubes: 1000,
            flow_score: ScoreStats {
                mean: 400.0,
                std: 150.0,
            },
            frame_score: ScoreStats {
                mean: 20.0,
                std: 8.0,
            },
            flow_pixel: pixel_stats(0.1, 0.02, 0.5),
            frame_pixel: pixel_stats(0.01, 0.002, 0.04),
            bands: Vec::new(),
            tails: None,
        }),
        note: Some("random init for the CLI tests".into()),
    };
    let path = dir.join("tiny.safetensors");
    save_checkpoint(&path, &model, &meta).expect("save checkpoint");
    path
}

/// Two scenarios under `dir/data`: normal city-sun and braking highway-rain.
fn dataset(dir: &Path) -> PathBuf {
    let data = dir.join("data");
    let frames = FRAMES.to_string();
    for (kind, domain, weather, seed) in [
        ("normal", "city", "sun", "1"),
        ("braking", "highway", "rain", "2"),
    ] {
        succeed(&[
            "generate",
            "--out",
            data.to_str().unwrap(),
            "--kind",
            kind,
            "--domain",
            domain,
            "--weather",
            weather,
            "--frames",
            &frames,
            "--size",
            "96x64",
            "--seed",
            seed,
            "--omit",
            "depth,instance,action,anomaly",
        ]);
    }
    data
}

/// The score cache files of every scenario under `data`.
fn cache_files(data: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for scenario in std::fs::read_dir(data).unwrap() {
        let scores = scenario.unwrap().path().join(".vadscope/scores");
        if let Ok(entries) = std::fs::read_dir(&scores) {
            files.extend(
                entries
                    .map(|e| e.unwrap().path())
                    .filter(|p| p.extension().is_some_and(|x| x == "vsc")),
            );
        }
    }
    files.sort();
    files
}

fn rows<'a>(report: &'a Value, table: &str) -> &'a [Value] {
    report[table].as_array().expect("a table of rows")
}

#[test]
fn score_writes_caches_and_a_second_run_reuses_them() {
    let dir = tempfile::tempdir().unwrap();
    let model = tiny_checkpoint(dir.path());
    let data = dataset(dir.path());
    let (data_s, model_s) = (data.to_str().unwrap(), model.to_str().unwrap());

    let first = succeed(&["score", data_s, "--model", model_s, "--boxes", "gt"]);
    assert_eq!(first.matches(": scored ").count(), 2, "{first}");
    assert!(first.contains("frames/s"), "{first}");
    let files = cache_files(&data);
    assert_eq!(files.len(), 2, "one cache per scenario: {files:?}");
    for file in &files {
        let cache = ScoreCache::open(file).expect("a complete cache");
        assert_eq!(cache.table().frames.len(), FRAMES);
        assert!(!cache.table().objects.is_empty(), "{}", file.display());
        assert!(first.contains(&file.display().to_string()), "{first}");
    }
    let stamp = |p: &PathBuf| std::fs::metadata(p).unwrap().modified().unwrap();
    let before: Vec<_> = files.iter().map(stamp).collect();

    let second = succeed(&["score", data_s, "--model", model_s, "--boxes", "gt"]);
    assert_eq!(second.matches("cache is current").count(), 2, "{second}");
    assert!(!second.contains(": scored "), "{second}");
    assert_eq!(files.iter().map(stamp).collect::<Vec<_>>(), before);

    // One scenario folder on its own, forced: scored again, the other cache untouched.
    let one = files[0]
        .parent()
        .unwrap()
        .parent()
        .unwrap()
        .parent()
        .unwrap();
    let forced = succeed(&[
        "score",
        one.to_str().unwrap(),
        "--model",
        model_s,
        "--force",
    ]);
    assert_eq!(forced.matches(": scored ").count(), 1, "{forced}");
    assert_eq!(stamp(&files[1]), before[1]);
    assert!(
        !std::fs::read_dir(files[0].parent().unwrap())
            .unwrap()
            .any(|e| e.unwrap().file_name().to_string_lossy().starts_with('.')),
        "no temporary file is left behind"
    );
}

#[test]
fn two_processes_scoring_the_same_scenarios_leave_complete_caches() {
    let dir = tempfile::tempdir().unwrap();
    let model = tiny_checkpoint(dir.path());
    let data = dataset(dir.path());
    let (data_s, model_s) = (data.to_str().unwrap(), model.to_str().unwrap());
    let args = [
        "score", data_s, "--model", model_s, "--boxes", "gt", "--force",
    ];
    // Both started before either can finish: each writes its own temporary files and
    // renames them over the same cache names.
    let spawn = || {
        std::process::Command::new(env!("CARGO_BIN_EXE_vadscope"))
            .args(args)
            .env_remove("VADSCOPE_MODEL")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("the vadscope binary runs")
    };
    let (first, second) = (spawn(), spawn());
    for process in [first, second] {
        let out = process.wait_with_output().expect("finishes");
        let stdout = text(&out.stdout);
        assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
        assert_eq!(stdout.matches(": scored ").count(), 2, "{stdout}");
    }
    let files = cache_files(&data);
    assert_eq!(files.len(), 2, "one cache per scenario: {files:?}");
    for file in &files {
        let cache = ScoreCache::open(file).expect("a complete cache");
        assert_eq!(cache.table().frames.len(), FRAMES);
        let leftovers: Vec<_> = std::fs::read_dir(file.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|name| name.starts_with('.'))
            .collect();
        assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    }
    let again = succeed(&["score", data_s, "--model", model_s, "--boxes", "gt"]);
    assert_eq!(again.matches("cache is current").count(), 2, "{again}");
}

#[test]
fn eval_prints_the_rows_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let model = tiny_checkpoint(dir.path());
    let data = dataset(dir.path());
    let (data_s, model_s) = (data.to_str().unwrap(), model.to_str().unwrap());

    let json = succeed(&[
        "eval",
        data_s,
        "--model",
        model_s,
        "--boxes",
        "gt,motion",
        "--by",
        "domain,weather",
        "--pixel",
        "--format",
        "json",
    ]);
    let report: Value = serde_json::from_str(&json).expect("eval --format json is JSON");
    let table = rows(&report, "table2");
    // Per box source: all scenarios, city × sun, highway × rain.
    assert_eq!(table.len(), 6, "{json}");
    let sources: Vec<&str> = table
        .iter()
        .map(|r| r["box_source"].as_str().unwrap())
        .collect();
    assert_eq!(
        sources,
        [
            "ground truth",
            "ground truth",
            "ground truth",
            "motion boxes",
            "motion boxes",
            "motion boxes"
        ]
    );
    let conditions: Vec<(Value, Value)> = table[..3]
        .iter()
        .map(|r| (r["domain"].clone(), r["weather"].clone()))
        .collect();
    assert_eq!(
        conditions,
        [
            (Value::Null, Value::Null),
            ("city".into(), "sun".into()),
            ("highway".into(), "rain".into())
        ]
    );
    let all = &table[0];
    assert_eq!(all["scenarios"], 2);
    assert_eq!(
        all["frames"],
        2 * (FRAMES - 4),
        "the first clip_hist frames are skipped"
    );
    assert!(all["anomalous_frames"].as_u64().unwrap() > 0, "{all}");
    assert!(all["metrics"]["auroc"].is_f64(), "{all}");
    assert!(
        all["pixel"]["auroc"].is_f64(),
        "pixel metrics were asked for: {all}"
    );
    let iou = all["mean_iou"].as_f64().unwrap();
    assert!(
        iou > 0.95,
        "ground-truth boxes match the ground truth: {iou}"
    );
    assert!(
        table[1]["metrics"].is_null(),
        "a normal scenario alone has one class: {}",
        table[1]
    );

    let md = succeed(&["eval", data_s, "--model", model_s, "--by", "none"]);
    let md_rows: Vec<&str> = md.lines().filter(|l| l.starts_with("| ")).collect();
    assert_eq!(md_rows.len(), 3, "header, rule and one row:\n{md}");
    assert!(
        md_rows[0].contains("AUROC") && md_rows[0].contains("mIoU"),
        "{md}"
    );
    assert!(md_rows[2].starts_with("| ground truth"), "{md}");
}

#[test]
fn baselines_are_scored_on_the_same_frames_beside_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let model = tiny_checkpoint(dir.path());
    let data = dataset(dir.path());
    let json = succeed(&[
        "eval",
        data.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--by",
        "none",
        "--baselines",
        "--format",
        "json",
    ]);
    let report: Value = serde_json::from_str(&json).expect("eval --format json is JSON");
    let model_row = &rows(&report, "table2")[0];
    let baselines = rows(&report, "baselines");
    // The scenarios were generated without ACTION files: no ego-deceleration row.
    let names: Vec<&str> = baselines
        .iter()
        .map(|r| r["box_source"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "baseline: flow energy (ground truth)",
            "baseline: looming (ground truth)",
            "baseline: frame difference (ground truth)"
        ]
    );
    for row in baselines {
        assert_eq!(
            row["frames"], model_row["frames"],
            "same frames as the model"
        );
        assert_eq!(row["anomalous_frames"], model_row["anomalous_frames"]);
        let auroc = row["metrics"]["auroc"].as_f64().expect("AUROC");
        assert!((0.0..=1.0).contains(&auroc), "{auroc}");
    }
    // The top-object count covers the braking scenario's anomaly frames with objects.
    let top = &report["top_object"][0];
    assert_eq!(top[0], "ground truth");
    let (hits, frames) = (top[1]["hits"].as_u64(), top[1]["frames"].as_u64());
    assert!(
        frames.unwrap() > 0 && hits.unwrap() <= frames.unwrap(),
        "{top}"
    );
}

#[test]
fn objects_csv_lists_every_scored_object_with_its_frame_top_and_anomaly() {
    let dir = tempfile::tempdir().unwrap();
    let model = tiny_checkpoint(dir.path());
    let data = dataset(dir.path());
    let csv = dir.path().join("objects.csv");
    let json = succeed(&[
        "eval",
        data.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--by",
        "none",
        "--objects",
        csv.to_str().unwrap(),
        "--format",
        "json",
    ]);
    let report: Value = serde_json::from_str(&json).expect("JSON");
    let text = std::fs::read_to_string(&csv).expect("the objects file");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (scenario, frame, anomalous_frame, top, anomalous_object) = (
        column("scenario"),
        column("frame"),
        column("anomalous_frame"),
        column("top"),
        column("anomalous_object"),
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let cached: usize = cache_files(&data)
        .iter()
        .map(|f| ScoreCache::open(f).unwrap().table().objects.len())
        .sum();
    assert_eq!(rows.len(), cached, "one row per cached object");

    let mut tops = std::collections::BTreeMap::new();
    for row in &rows {
        assert_eq!(row.len(), header.len(), "{row:?}");
        *tops.entry((row[scenario], row[frame])).or_insert(0) += usize::from(row[top] == "1");
        if row[anomalous_object] == "1" {
            assert_eq!(
                row[anomalous_frame], "1",
                "an anomalous object in a normal frame"
            );
        }
    }
    assert!(
        tops.values().all(|&n| n == 1),
        "one top object per frame: {tops:?}"
    );
    // The rows agree with the top-object count (metric frames start at clip_hist = 4).
    let hits = rows
        .iter()
        .filter(|r| r[top] == "1" && r[anomalous_object] == "1")
        .filter(|r| r[frame].parse::<usize>().unwrap() >= 4)
        .count();
    assert_eq!(
        Some(hits as u64),
        report["top_object"][0][1]["hits"].as_u64(),
        "{report}"
    );
    assert!(
        rows.iter().any(|r| r[anomalous_object] == "1"),
        "the braking lead is among the scored objects"
    );
}

#[test]
fn sweep_gives_one_row_per_grid_point() {
    let dir = tempfile::tempdir().unwrap();
    let model = tiny_checkpoint(dir.path());
    let data = dataset(dir.path());
    let json = succeed(&[
        "eval",
        data.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--sweep",
        "--median",
        "5",
        "--format",
        "json",
    ]);
    let report: Value = serde_json::from_str(&json).expect("JSON");
    let sweep = rows(&report, "table3");
    assert_eq!(sweep.len(), 9, "{{0.1, 1, 10}}² for one box source");
    let mut points: Vec<(f64, f64)> = sweep
        .iter()
        .map(|r| {
            let w = &r["weights"];
            (w["w_r"].as_f64().unwrap(), w["w_p"].as_f64().unwrap())
        })
        .collect();
    points.dedup();
    assert_eq!(points.len(), 9, "every point once: {points:?}");
    let presets = sweep.iter().filter(|r| r["preset"].is_string()).count();
    assert_eq!(presets, 3, "the three presets lie on the grid");
    assert_eq!(report["median_kernel"], 5);

    let csv = succeed(&[
        "eval",
        data.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--sweep",
        "--format",
        "csv",
    ]);
    let tables: Vec<&str> = csv.split("\n\n").collect();
    assert_eq!(tables.len(), 2, "Table 2 and Table 3:\n{csv}");
    assert_eq!(tables[1].trim_end().lines().count(), 1 + 9, "{csv}");

    // Pixel metrics of the study (merged per box source as scenarios finish) agree with the
    // table's row over all scenarios at the same weights (the paper text's, on the grid).
    let json = succeed(&[
        "eval",
        data.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--boxes",
        "gt,motion",
        "--by",
        "none",
        "--pixel",
        "--sweep",
        "--format",
        "json",
    ]);
    let report: Value = serde_json::from_str(&json).expect("JSON");
    let table = rows(&report, "table2");
    let sweep = rows(&report, "table3");
    assert_eq!(sweep.len(), 2 * 9, "{json}");
    for row in table {
        let same = sweep
            .iter()
            .find(|r| {
                r["row"]["box_source"] == row["box_source"]
                    && r["preset"] == "HF²-VAD_AD paper text (10 / 0.1)"
            })
            .expect("the paper-text point of this box source");
        assert!(row["pixel"]["auroc"].is_f64(), "{row}");
        assert_eq!(same["row"]["pixel"], row["pixel"], "{}", row["box_source"]);
    }
}

#[test]
fn bad_inputs_fail_with_a_message_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let model = tiny_checkpoint(dir.path());
    let model_s = model.to_str().unwrap();
    let missing = dir.path().join("no-such-scenario");
    let err = fail(&["score", missing.to_str().unwrap(), "--model", model_s]);
    assert!(err.contains("no-such-scenario"), "{err}");

    let data = dataset(dir.path());
    let data_s = data.to_str().unwrap();
    let err = fail(&["eval", data_s, "--model", model_s, "--weights", "1,2,x"]);
    assert!(err.contains("1,2,x") && err.contains("--weights"), "{err}");
    let err = fail(&["eval", data_s, "--model", model_s, "--weights", "1,2,3"]);
    assert!(err.contains("four numbers"), "{err}");

    let garbage = dir.path().join("garbage.safetensors");
    std::fs::write(&garbage, b"this is not a checkpoint").unwrap();
    let err = fail(&["score", data_s, "--model", garbage.to_str().unwrap()]);
    assert!(err.contains("garbage.safetensors"), "{err}");
    let absent = dir.path().join("absent.safetensors");
    let err = fail(&["eval", data_s, "--model", absent.to_str().unwrap()]);
    assert!(err.contains("absent.safetensors"), "{err}");
    assert!(cache_files(&data).is_empty(), "nothing was scored");

    let err = fail(&["score", data_s, "--model", model_s, "--boxes", "nonsense"]);
    assert!(err.contains("nonsense"), "{err}");
    let err = fail(&["score", data_s, "--model", model_s, "--flow", "dis:warp"]);
    assert!(err.contains("dis:warp"), "{err}");
}
