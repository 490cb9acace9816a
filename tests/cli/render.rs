//! `vadscope render` and `vadscope export` end to end: a tiny generated scenario and a tiny
//! random checkpoint made here; the commands score it (no cache yet), write every view, a
//! GIF, annotated frames and a `scores.csv` that parses; bad input fails with a message.

use std::path::{Path, PathBuf};
use std::process::Output;

use burn::tensor::Device;
use vadscope::eval::MeanStd;
use vadscope::model::{
    CheckpointMeta, Hf2Vad, ModelConfig, NoiseRng, PixelStats, TrainingStats, save_checkpoint,
};

use crate::support::cli::{scenario_folders, text, tiny_generate_args, vadscope};

/// Runs `vadscope COMMAND SCENARIO --out OUT [--model MODEL] EXTRA...`.
fn on_scenario(
    command: &str,
    scenario: &Path,
    model: Option<&Path>,
    out: &Path,
    extra: &[&str],
) -> Output {
    let mut args = vec![
        command,
        scenario.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    if let Some(model) = model {
        args.extend(["--model", model.to_str().unwrap()]);
    }
    args.extend_from_slice(extra);
    vadscope(&args)
}

/// Like [`on_scenario`], asserting that the command succeeds.
fn succeed(command: &str, scenario: &Path, model: &Path, out: &Path, extra: &[&str]) {
    let run = on_scenario(command, scenario, Some(model), out, extra);
    assert!(
        run.status.success(),
        "{command} {extra:?} failed: {}",
        text(&run.stderr)
    );
}

/// Like [`on_scenario`], asserting that the command fails; returns its stderr.
fn fail(
    command: &str,
    scenario: &Path,
    model: Option<&Path>,
    out: &Path,
    extra: &[&str],
) -> String {
    let run = on_scenario(command, scenario, model, out, extra);
    assert!(!run.status.success(), "{command} {extra:?} succeeded");
    text(&run.stderr)
}

fn pixel_stats(median: f64, iqr: f64) -> PixelStats {
    PixelStats {
        median,
        q25: median - iqr / 2.0,
        q75: median + iqr / 2.0,
        iqr,
        sampled: 1000,
        total: 1000,
    }
}

/// A random tiny model with plausible training statistics.
fn tiny_checkpoint(dir: &Path) -> PathBuf {
    let config = ModelConfig::parity();
    let model = Hf2Vad::new(&config, &Device::flex(), &mut NoiseRng::new(5)).expect("model");
    let meta = CheckpointMeta {
        config,
        stats: Some(TrainingStats {
            cubes: 1000,
            flow_score: MeanStd {
                mean: 50.0,
                std: 20.0,
            },
            frame_score: MeanStd {
                mean: 30.0,
                std: 10.0,
            },
            flow_pixel: pixel_stats(0.02, 0.05),
            frame_pixel: pixel_stats(0.01, 0.02),
            bands: Vec::new(),
            tails: None,
        }),
        note: Some("render test: random weights".into()),
    };
    let path = dir.join("tiny.safetensors");
    save_checkpoint(&path, &model, &meta).expect("save checkpoint");
    path
}

/// Generates one 12-frame 96×64 scenario under `dir` and returns its folder.
fn tiny_scenario(dir: &Path) -> PathBuf {
    let out = vadscope(&tiny_generate_args(dir.to_str().unwrap(), "4"));
    assert!(
        out.status.success(),
        "generate failed: {}",
        text(&out.stderr)
    );
    scenario_folders(dir).pop().expect("a scenario folder")
}

#[test]
fn render_scores_then_writes_every_view_and_a_gif() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = tiny_scenario(dir.path());
    let model = tiny_checkpoint(dir.path());
    let out = dir.path().join("views");
    succeed(
        "render",
        &scenario,
        &model,
        &out,
        &[
            "--frames",
            "5..8",
            "--view",
            "dashboard,frame,pred,flow,timeline,roc",
            "--size",
            "320x200",
            "--gif",
            "--colormap",
            "viridis",
        ],
    );
    for view in ["dashboard", "frame", "pred", "flow"] {
        for index in 5..8 {
            let path = out.join(format!("{view}_{index:05}.png"));
            let image = image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert_eq!(
                (image.width(), image.height()),
                (320, 200),
                "{}",
                path.display()
            );
        }
        // A whole GIF: every frame decodes, at the size asked for.
        let gif = std::fs::File::open(out.join(format!("{view}.gif"))).expect("{view}.gif");
        let frames = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(gif))
            .and_then(|d| image::AnimationDecoder::into_frames(d).collect_frames())
            .unwrap_or_else(|e| panic!("{view}.gif: {e}"));
        assert_eq!(frames.len(), 3, "{view}.gif");
        assert_eq!(frames[0].buffer().dimensions(), (320, 200), "{view}.gif");
    }
    let leftovers: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    for name in ["timeline.png", "roc.png", "histogram.png"] {
        assert!(out.join(name).is_file(), "{name}");
    }
    assert!(
        !out.join("dashboard_00004.png").exists(),
        "only the asked frames"
    );
    let caches: Vec<_> = std::fs::read_dir(scenario.join(".vadscope/scores"))
        .expect("score cache folder")
        .collect();
    assert_eq!(caches.len(), 1, "the scoring run left one cache");

    // A second run finds the cache and gives the same pixels.
    let again = dir.path().join("again");
    succeed(
        "render",
        &scenario,
        &model,
        &again,
        &[
            "--frames",
            "6",
            "--view",
            "frame",
            "--size",
            "320x200",
            "--colormap",
            "viridis",
        ],
    );
    let a = std::fs::read(out.join("frame_00006.png")).unwrap();
    let b = std::fs::read(again.join("frame_00006.png")).unwrap();
    assert!(a == b, "the same frame rendered twice differs");
}

#[test]
fn export_writes_annotated_frames_and_a_scores_csv_with_provenance() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = tiny_scenario(dir.path());
    let model = tiny_checkpoint(dir.path());
    let out = dir.path().join("export");
    succeed(
        "export",
        &scenario,
        &model,
        &out,
        &[
            "--frames",
            "0..3",
            "--preset",
            "ad-code",
            "--threshold",
            "1.5",
        ],
    );
    for index in 0..3 {
        assert!(out.join(format!("frames/frame_{index:05}.png")).is_file());
    }
    assert!(!out.join("frames/frame_00003.png").exists());
    let csv = std::fs::read_to_string(out.join("scores.csv")).unwrap();
    let (header, body): (Vec<&str>, Vec<&str>) = csv.lines().partition(|l| l.starts_with('#'));
    let header = header.join("\n");
    for needle in [
        "# vadscope 0.1.0",
        "hash ",
        "# boxes: gt",
        "# flow: stored",
        "w_r=0.1 w_p=10",
        "# threshold: 1.5",
    ] {
        assert!(
            header.contains(needle),
            "provenance lacks {needle:?}:\n{header}"
        );
    }
    assert_eq!(
        body[0],
        "frame,anovox_id,s_r,s_p,fused,filtered,label,prediction"
    );
    let rows = &body[1..];
    assert_eq!(rows.len(), 12, "one row per frame");
    for (i, row) in rows.iter().enumerate() {
        let fields: Vec<&str> = row.split(',').collect();
        assert_eq!(fields.len(), 8, "row {i}: {row}");
        assert_eq!(fields[0].parse::<usize>().unwrap(), i);
        fields[1].parse::<u64>().expect("AnoVox id");
        fields[4].parse::<f64>().expect("fused score");
        assert!(matches!(fields[6], "0" | "1"), "label: {row}");
        if !fields[5].is_empty() {
            let filtered: f64 = fields[5].parse().unwrap();
            assert_eq!(
                fields[7],
                if filtered >= 1.5 { "1" } else { "0" },
                "prediction: {row}"
            );
        }
    }
    assert!(
        rows[0].split(',').nth(5) == Some(""),
        "the first frames are left out of the filtered score"
    );
}

#[test]
fn bad_input_fails_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let missing = fail(
        "render",
        Path::new("/nonexistent/scenario"),
        None,
        &out,
        &[],
    );
    assert!(missing.contains("/nonexistent/scenario"), "{missing}");

    let scenario = tiny_scenario(dir.path());
    let weights = fail("render", &scenario, None, &out, &["--weights", "1,2,3"]);
    assert!(weights.contains("four numbers"), "{weights}");

    let model = tiny_checkpoint(dir.path());
    let range = fail(
        "export",
        &scenario,
        Some(&model),
        &out,
        &["--frames", "50..60"],
    );
    assert!(
        range.contains("12 frames") && !range.contains("panicked"),
        "{range}"
    );

    let no_model = fail(
        "export",
        &scenario,
        Some(Path::new("/nonexistent.safetensors")),
        &out,
        &[],
    );
    assert!(no_model.contains("/nonexistent.safetensors"), "{no_model}");
}
