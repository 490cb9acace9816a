//! The inference entry point: conventions applied on the way in and undone on the way out,
//! batching that does not change results, and rejection of malformed inputs.

use std::path::Path;

use burn::store::{ModuleStore, SafetensorsStore, bridge};
use burn::tensor::{Device, Tensor, TensorData};

use vadscope::model::weights::import_reference_checkpoint;
use vadscope::model::{
    CheckpointMeta, Detector, FlowUnits, Hf2Vad, InputConventions, Latents, ModelConfig,
    ModelError, NoiseRng,
};

const AREA: usize = 32 * 32;

fn detector(config: &ModelConfig, seed: u64) -> Detector {
    let device = Device::flex();
    let model = Hf2Vad::new(config, &device, &mut NoiseRng::new(seed)).expect("model");
    let meta = CheckpointMeta {
        config: config.clone(),
        stats: None,
        note: None,
    };
    Detector::new(model, meta, &device).expect("detector")
}

fn cubes(n: usize, seed: u64) -> (Vec<f32>, Vec<f32>) {
    let mut rng = NoiseRng::new(seed);
    let frames = rng.uniform_vec(n * 15 * AREA, 0.0, 1.0);
    let flows = rng.normal_vec(n * 8 * AREA, 0.0, 2.0);
    (frames, flows)
}

/// Swaps the R and B planes of every 3-channel image.
fn swap_rb(values: &[f32]) -> Vec<f32> {
    values
        .chunks(3 * AREA)
        .flat_map(|img| [&img[2 * AREA..], &img[AREA..2 * AREA], &img[..AREA]].concat())
        .collect()
}

#[test]
fn batching_does_not_change_results_and_scores_sum_the_maps() {
    let config = ModelConfig::parity();
    let (frames, flows) = cubes(5, 1);
    let whole = detector(&config, 3).infer(&frames, &flows).expect("infer");
    let split = detector(&config, 3)
        .with_max_batch(2)
        .infer(&frames, &flows)
        .expect("infer");
    assert_eq!(whole.len(), 5);
    for (a, b) in whole.iter().zip(&split) {
        let max = a
            .flow_error
            .iter()
            .zip(&b.flow_error)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        assert!(max < 1e-4, "batch split changes flow errors by {max}");
        assert!((a.s_p - b.s_p).abs() < 1e-4 * a.s_p.max(1.0));
    }
    let c = &whole[0];
    assert_eq!(c.recon_flows.len(), 8 * AREA);
    assert_eq!(c.predicted_frame.len(), 3 * AREA);
    let s_r: f32 = c.flow_error.iter().sum();
    assert!(
        (s_r - c.s_r).abs() <= 1e-3 * c.s_r,
        "S_r {} vs map sum {s_r}",
        c.s_r
    );
    // Flow error is (recon − input)² element-wise.
    let e0 = (c.recon_flows[0] - flows[0]).powi(2);
    assert!((e0 - c.flow_error[0]).abs() <= 1e-5 * e0.max(1.0));
    assert!(c.predicted_frame.iter().all(|&v| v > 0.0 && v < 1.0));
}

#[test]
fn flow_units_and_colour_order_are_applied_for_the_model_and_undone_for_the_caller() {
    let mut config = ModelConfig::parity();
    config.conventions = InputConventions::reference(FlowUnits::Scaled { x: 2.0, y: 0.5 });
    let det = detector(&config, 4);
    let (frames, flows) = cubes(2, 2);
    let results = det.infer(&frames, &flows).expect("infer");

    // What the network itself sees: BGR frames and scaled flows.
    let device = Device::flex();
    let model_frames = swap_rb(&frames);
    let model_flows: Vec<f32> = flows
        .chunks(AREA)
        .enumerate()
        .flat_map(|(i, p)| {
            p.iter()
                .map(move |v| v * if i % 2 == 0 { 2.0 } else { 0.5 })
        })
        .collect();
    let t =
        |v: Vec<f32>, c: usize| Tensor::<4>::from_data(TensorData::new(v, [2, c, 32, 32]), &device);
    let out = det.model().forward(
        t(model_frames, 15),
        t(model_flows.clone(), 8),
        &Latents::Mean,
        None,
    );
    let recon = out.of_recon.into_data().try_to_vec::<f32>().expect("f32");
    let pred = out
        .cvae
        .frame_pred
        .into_data()
        .try_to_vec::<f32>()
        .expect("f32");

    let r = &results[1];
    // Reconstruction returned in native pixels: u divided by 2, v by 0.5.
    let i = 8 * AREA + 5; // cube 1, channel 0 (u of flow 0), pixel 5
    assert!((r.recon_flows[5] - recon[i] / 2.0).abs() < 1e-5);
    let j = 8 * AREA + AREA + 7; // cube 1, channel 1 (v of flow 0), pixel 7
    assert!((r.recon_flows[AREA + 7] - recon[j] / 0.5).abs() < 1e-5);
    // Error maps in model units.
    let e = (recon[i] - model_flows[i]).powi(2);
    assert!((r.flow_error[5] - e).abs() <= 1e-5 * e.max(1.0));
    // Predicted frame returned as RGB: our red plane is the network's channel 2.
    assert!((r.predicted_frame[3] - pred[3 * AREA + 2 * AREA + 3]).abs() < 1e-6);
}

#[test]
fn malformed_inputs_are_errors_not_panics() {
    let det = detector(&ModelConfig::parity(), 5);
    let (frames, flows) = cubes(2, 3);
    let short = &frames[..frames.len() - 1];
    assert!(matches!(
        det.infer(short, &flows),
        Err(ModelError::InvalidInput(_))
    ));
    assert!(matches!(
        det.infer(&frames, &flows[..8 * AREA]),
        Err(ModelError::InvalidInput(_))
    ));
    let mut bad = flows.clone();
    bad[17] = f32::NAN;
    assert!(matches!(
        det.infer(&frames, &bad),
        Err(ModelError::InvalidInput(_))
    ));
    assert!(det.infer(&[], &[]).expect("empty batch").is_empty());
}

#[test]
fn imported_reference_model_scores_rgb_cubes_as_the_reference_scores_bgr_ones() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/parity");
    if !dir.join("hf2vad_official_layout.pth").is_file() {
        println!("SKIPPED: parity fixtures not found at {}", dir.display());
        return;
    }
    let device = Device::flex();
    let (model, config) = import_reference_checkpoint(
        &dir.join("hf2vad_official_layout.pth"),
        InputConventions::reference(FlowUnits::NativePixels),
        &device,
    )
    .expect("import");
    let meta = CheckpointMeta {
        config,
        stats: None,
        note: None,
    };
    let det = Detector::new(model, meta, &device).expect("detector");
    let mut io = SafetensorsStore::from_file(dir.join("hf2vad_io.safetensors"));
    let mut read = |name: &str| {
        let t = io.get_tensor(name).expect("read").expect("tensor present");
        bridge::to_data(t).expect("data")
    };
    let bgr: Vec<f32> = read("input.frames_u8")
        .try_to_vec::<u8>()
        .expect("u8")
        .into_iter()
        .map(|v| v as f32 / 255.0)
        .collect();
    let flows = read("input.flows").try_to_vec::<f32>().expect("f32");
    let s_r = read("hf2vad.S_r").try_to_vec::<f32>().expect("f32");
    let s_p = read("hf2vad.S_p").try_to_vec::<f32>().expect("f32");
    let pred_bgr = read("hf2vad.frame_pred").try_to_vec::<f32>().expect("f32");

    let results = det.infer(&swap_rb(&bgr), &flows).expect("infer");
    let pred_rgb = swap_rb(&pred_bgr);
    for (i, r) in results.iter().enumerate() {
        assert!(
            (r.s_r - s_r[i]).abs() <= 1e-5 * s_r[i],
            "S_r[{i}] {} vs {}",
            r.s_r,
            s_r[i]
        );
        assert!(
            (r.s_p - s_p[i]).abs() <= 1e-4,
            "S_p[{i}] {} vs {}",
            r.s_p,
            s_p[i]
        );
        let expected = &pred_rgb[i * 3 * AREA..(i + 1) * 3 * AREA];
        let max = r
            .predicted_frame
            .iter()
            .zip(expected)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(max < 1e-5, "predicted frame {i} differs by {max}");
    }
}
