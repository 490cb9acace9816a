//! vadscope checkpoints: metadata round trip, identical outputs after save and load, and
//! clear errors for files that are not checkpoints.

use burn::tensor::{Device, Tensor, TensorData};

use vadscope::model::{
    CheckpointMeta, FlowUnits, Hf2Vad, InputConventions, Latents, ModelConfig, ModelError,
    NoiseRng, PixelStats, ScoreStats, TrainingStats, load_checkpoint, read_checkpoint_meta,
    save_checkpoint,
};

fn random(shape: [usize; 4], seed: u64, std: f64) -> Tensor<4> {
    let n = shape.iter().product();
    let values = NoiseRng::new(seed).normal_vec(n, 0.5, std);
    Tensor::from_data(TensorData::new(values, shape), &Device::flex())
}

fn stats() -> TrainingStats {
    let pixel = PixelStats {
        median: 0.5,
        q25: 0.1,
        q75: 1.5,
        iqr: 1.4,
        sampled: 10,
        total: 20,
    };
    TrainingStats {
        cubes: 20,
        flow_score: ScoreStats {
            mean: 2.0e4,
            std: 8.0e4,
        },
        frame_score: ScoreStats {
            mean: 14.1,
            std: 28.6,
        },
        flow_pixel: pixel,
        frame_pixel: PixelStats {
            median: 0.01,
            ..pixel
        },
        bands: Vec::new(),
        tails: None,
    }
}

#[test]
fn saved_checkpoint_reloads_with_metadata_and_identical_outputs() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("model.safetensors");
    let mut config = ModelConfig::parity();
    config.conventions = InputConventions::reference(FlowUnits::Scaled {
        x: 4.0 / 3.0,
        y: 1.25,
    });
    let device = Device::flex();
    let model = Hf2Vad::new(&config, &device, &mut NoiseRng::new(11)).expect("model");
    let meta = CheckpointMeta {
        config: config.clone(),
        stats: Some(stats()),
        note: Some("stage 3, epoch 2".into()),
    };
    save_checkpoint(&path, &model, &meta).expect("save");
    // Saving again replaces the file.
    save_checkpoint(&path, &model, &meta).expect("overwrite");

    assert_eq!(read_checkpoint_meta(&path).expect("meta"), meta);
    let loaded = load_checkpoint(&path, &device).expect("load");
    assert_eq!(loaded.meta, meta);

    let frames = random([2, 15, 32, 32], 1, 0.2);
    let flows = random([2, 8, 32, 32], 2, 2.0);
    let a = model.forward(frames.clone(), flows.clone(), &Latents::Mean, None);
    let b = loaded.model.forward(frames, flows, &Latents::Mean, None);
    let same = |x: Tensor<4>, y: Tensor<4>| x.into_data() == y.into_data();
    assert!(
        same(a.of_recon, b.of_recon),
        "flow reconstruction differs after reload"
    );
    assert!(
        same(a.cvae.frame_pred, b.cvae.frame_pred),
        "frame prediction differs after reload"
    );
}

#[test]
fn saving_the_same_model_twice_gives_identical_bytes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let config = ModelConfig::parity();
    let device = Device::flex();
    let model = Hf2Vad::new(&config, &device, &mut NoiseRng::new(5)).expect("model");
    let meta = CheckpointMeta {
        config,
        stats: Some(stats()),
        note: Some("reproducible".into()),
    };
    let files: Vec<Vec<u8>> = (0..3)
        .map(|i| {
            let path = dir.path().join(format!("model-{i}.safetensors"));
            save_checkpoint(&path, &model, &meta).expect("save");
            std::fs::read(&path).expect("read back")
        })
        .collect();
    assert!(
        files.windows(2).all(|w| w[0] == w[1]),
        "checkpoint bytes differ between saves of the same model"
    );
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name())
        .filter(|n| {
            let n = n.to_string_lossy();
            !(n.starts_with("model-") && n.ends_with(".safetensors"))
        })
        .collect();
    assert!(
        leftovers.is_empty(),
        "scratch files left behind: {leftovers:?}"
    );
    let loaded = load_checkpoint(&dir.path().join("model-0.safetensors"), &device).expect("load");
    assert_eq!(loaded.meta, meta);
}

#[test]
fn non_checkpoints_are_rejected_with_the_file_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let garbage = dir.path().join("garbage.safetensors");
    std::fs::write(&garbage, b"\xff\xff\xff\xff\xff\xff\xff\xffnot a header").expect("write");
    let err = read_checkpoint_meta(&garbage).expect_err("garbage");
    assert!(
        matches!(&err, ModelError::Load { path, .. } if path == &garbage),
        "{err}"
    );

    let truncated = dir.path().join("truncated.safetensors");
    std::fs::write(&truncated, [16u8, 0, 0, 0, 0, 0, 0, 0, b'{']).expect("write");
    assert!(read_checkpoint_meta(&truncated).is_err());

    // A valid safetensors file without vadscope metadata (e.g. reference weights).
    let foreign = dir.path().join("foreign.safetensors");
    let header = br#"{"__metadata__":{"format":"pt"}}"#;
    let mut bytes = (header.len() as u64).to_le_bytes().to_vec();
    bytes.extend_from_slice(header);
    std::fs::write(&foreign, bytes).expect("write");
    let err = load_checkpoint(&foreign, &Device::flex()).expect_err("foreign");
    assert!(
        err.to_string().contains("not a vadscope checkpoint"),
        "{err}"
    );

    let missing = dir.path().join("missing.safetensors");
    assert!(load_checkpoint(&missing, &Device::flex()).is_err());
}
