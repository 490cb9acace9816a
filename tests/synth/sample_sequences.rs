//! The bundled sample scenarios are exactly what the generator makes from their recorded
//! spec: regenerating a few frames (first, anomaly onset, last) reproduces every stored
//! modality pixel for pixel, and the metadata, labels and boxes match.

use std::path::{Path, PathBuf};

use vadscope::sequence::{AnomalyType, Scenario as StoredScenario};
use vadscope::synth::{Scenario, ScenarioKind, ScenarioSpec};

fn samples_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("sample_sequences")
}

fn sample_dirs() -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(samples_root())
        .expect("sample_sequences/ is part of the repository")
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.is_dir()
                && p.file_name()
                    .unwrap()
                    .to_string_lossy()
                    .starts_with("Scenario_")
        })
        .collect();
    dirs.sort();
    dirs
}

/// The spec the generator was given, read back from what it recorded in `scenario.json`.
fn spec_of(dir: &Path, stored: &StoredScenario) -> ScenarioSpec {
    let meta = stored.meta();
    let camera = meta
        .camera
        .expect("generated scenarios record their camera");
    let kind = match meta
        .anomaly_type
        .expect("generated scenarios record their event")
    {
        AnomalyType::Normality => ScenarioKind::Normal,
        AnomalyType::SuddenBraking => ScenarioKind::Braking,
        AnomalyType::LeadTurning => ScenarioKind::Turning,
        AnomalyType::CutIn => ScenarioKind::CutIn,
        AnomalyType::Static => panic!("the generator makes no static anomalies"),
    };
    let name = dir.file_name().unwrap().to_string_lossy();
    ScenarioSpec {
        name: name.trim_start_matches("Scenario_").to_string(),
        kind,
        domain: meta.domain,
        weather: meta.weather,
        frames: stored.len() as u32,
        width: camera.width,
        height: camera.height,
        seed: meta.seed.expect("generated scenarios record their seed"),
        town: meta
            .town
            .clone()
            .expect("generated scenarios record their town"),
    }
}

#[test]
fn there_is_a_normal_and_a_braking_sample_within_the_size_budget() {
    let dirs = sample_dirs();
    let kinds: Vec<_> = dirs
        .iter()
        .map(|d| StoredScenario::open(d).unwrap().meta().anomaly_type)
        .collect();
    assert!(kinds.contains(&Some(AnomalyType::Normality)), "{kinds:?}");
    assert!(
        kinds.contains(&Some(AnomalyType::SuddenBraking)),
        "{kinds:?}"
    );
    // The bundle is what the repository ships: the caches vadscope writes beside the
    // scenarios when they are opened or scored (`.vadscope/`, ignored by git) are not part
    // of it.
    let bytes: u64 = walk(&samples_root())
        .iter()
        .filter(|p| !p.components().any(|c| c.as_os_str() == ".vadscope"))
        .map(|p| p.metadata().unwrap().len())
        .sum();
    assert!(
        bytes <= 25 * 1024 * 1024,
        "sample_sequences/ holds {bytes} bytes, over 25 MB"
    );
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut files = vec![];
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(walk(&path));
        } else {
            files.push(path);
        }
    }
    files
}

#[test]
fn regenerating_the_samples_gives_the_same_content() {
    for dir in sample_dirs() {
        let stored = StoredScenario::open(&dir).unwrap();
        let spec = spec_of(&dir, &stored);
        let generated = Scenario::build(&spec).unwrap();
        assert_eq!(
            generated.meta(),
            *stored.meta(),
            "{}: scenario.json",
            dir.display()
        );
        assert_eq!(generated.frame_count(), stored.len());

        let labels = stored.frame_labels();
        let mut frames = vec![0, stored.len() - 1];
        if let Some(window) = generated.anomaly_window() {
            frames.push(window.start as usize);
        }
        for k in frames {
            let record = generated.render_frame(k).unwrap();
            let at = format!("{} frame {k}", dir.display());
            // Images are compared with `==` and a short message: a failing `assert_eq!` would
            // print every pixel.
            let regenerate = "regenerate with `bash sample_sequences/regenerate.sh`";
            assert!(
                *stored.rgb(k).unwrap() == record.rgb,
                "{at}: RGB differs; {regenerate}"
            );
            let semantic = stored
                .semantic(k)
                .unwrap()
                .expect("samples store semantic ids");
            assert!(
                Some(&semantic.ids) == record.semantic.as_ref(),
                "{at}: semantic ids differ; {regenerate}"
            );
            let instance = stored
                .instance(k)
                .unwrap()
                .expect("samples store instance ids");
            assert!(
                Some(instance.to_rgb()) == record.instance,
                "{at}: instance ids differ; {regenerate}"
            );
            assert_eq!(stored.boxes(k).unwrap(), record.boxes, "{at}: boxes");
            assert_eq!(Some(labels.flags[k]), record.anomalous, "{at}: label");
            assert_eq!(stored.action(k).unwrap(), record.action, "{at}: ACTION");
        }
    }
}
