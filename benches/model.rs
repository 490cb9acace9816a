//! Throughput of the HF²-VAD model on the CPU backend: inference through `Detector::infer`
//! (cubes/s at batch 1, 16, 64) and one optimiser step of each training stage, for the
//! `paper` and `compact` presets.
//!
//! Threads: burn's CPU backend uses the rayon pool, so run once per thread count:
//! `RAYON_NUM_THREADS=1 cargo bench --bench model` and `RAYON_NUM_THREADS=2 …`.
//! `VADSCOPE_BENCH=infer` or `=train` restricts the run to one part; `VADSCOPE_PRESETS=compact`
//! to one preset. Training steps run through the lowered convolutions and the fused
//! BatchNorm and, side by side, through burn's own layers (`stage1/burn_layers`);
//! `VADSCOPE_TRAIN_PATHS=lowered` keeps one. The
//! PyTorch reference figures to compare with are in `shared/design/pytorch-cpu-anchor.md`.

use std::time::Duration;

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Device, Tensor, TensorData};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};

use vadscope::model::gemm_conv::training::with_burn_layers;
use vadscope::model::losses::{LossWeights, stage1_loss, stage2_loss, stage3_loss};
use vadscope::model::{CheckpointMeta, Detector, Hf2Vad, Latents, ModelConfig, NoiseRng};

fn enabled(part: &str) -> bool {
    std::env::var("VADSCOPE_BENCH").map_or(true, |v| v == part)
}

fn presets() -> Vec<ModelConfig> {
    let wanted = std::env::var("VADSCOPE_PRESETS").unwrap_or_else(|_| "paper,compact".into());
    wanted
        .split(',')
        .filter_map(|name| ModelConfig::preset(name.trim()).ok())
        .collect()
}

/// The training paths to measure: the lowered convolutions and fused BatchNorm (`lowered`,
/// what training uses) and burn's own convolutions, BatchNorm and ReLU (`burn_layers`, the
/// reference they replace), side by side; `VADSCOPE_TRAIN_PATHS=lowered` restricts the run
/// to one.
fn training_paths() -> Vec<&'static str> {
    let wanted =
        std::env::var("VADSCOPE_TRAIN_PATHS").unwrap_or_else(|_| "lowered,burn_layers".into());
    ["lowered", "burn_layers"]
        .into_iter()
        .filter(|path| wanted.split(',').any(|w| w.trim() == *path))
        .collect()
}

fn cubes(config: &ModelConfig, n: usize, seed: u64) -> (Vec<f32>, Vec<f32>) {
    let area = config.patch_size * config.patch_size;
    let mut rng = NoiseRng::new(seed);
    (
        rng.uniform_vec(n * config.cube_frame_channels() * area, 0.0, 1.0),
        rng.normal_vec(n * config.cube_flow_channels() * area, 0.0, 2.0),
    )
}

fn tensor(values: Vec<f32>, shape: [usize; 4], device: &Device) -> Tensor<4> {
    Tensor::from_data(TensorData::new(values, shape), device)
}

fn inference(c: &mut Criterion) {
    if !enabled("infer") {
        return;
    }
    let threads = rayon::current_num_threads();
    for config in presets() {
        let device = Device::flex();
        let model = Hf2Vad::new(&config, &device, &mut NoiseRng::new(1)).expect("model");
        let meta = CheckpointMeta {
            config: config.clone(),
            stats: None,
            note: None,
        };
        let detector = Detector::new(model, meta, &device).expect("detector");
        let mut group = c.benchmark_group(format!("infer/{}/{threads}t", config.preset));
        group.sample_size(10).warm_up_time(Duration::from_secs(2));
        for batch in [1usize, 16, 64] {
            let (frames, flows) = cubes(&config, batch, batch as u64);
            group.throughput(Throughput::Elements(batch as u64));
            group.bench_with_input(BenchmarkId::from_parameter(batch), &batch, |b, _| {
                b.iter(|| detector.infer(&frames, &flows).expect("infer"))
            });
        }
        group.finish();
    }
}

fn training(c: &mut Criterion) {
    if !enabled("train") {
        return;
    }
    let threads = rayon::current_num_threads();
    let w = LossWeights::default();
    for config in presets() {
        let device = Device::flex().autodiff();
        let mut group = c.benchmark_group(format!("train_step/{}/{threads}t", config.preset));
        group.sample_size(10).warm_up_time(Duration::from_secs(1));
        let p = config.patch_size;
        for (stage, batch) in [(1usize, 256usize), (2, 128), (3, 128)] {
            let (frames, flows) = cubes(&config, batch, 9);
            let frames = tensor(frames, [batch, config.cube_frame_channels(), p, p], &device);
            let flows = tensor(flows, [batch, config.cube_flow_channels(), p, p], &device);
            group.throughput(Throughput::Elements(batch as u64));
            for path in training_paths() {
                let mut model =
                    Hf2Vad::new(&config, &device, &mut NoiseRng::new(2)).expect("model");
                if stage == 2 {
                    model.memae = model.memae.freeze();
                }
                let mut optim = AdamConfig::new().with_epsilon(1e-7).init();
                let mut rng = NoiseRng::new(3);
                let mut slot = Some(model);
                let mut step = || {
                    let mut model = slot.take().expect("model");
                    model = match stage {
                        1 => {
                            let last = flows.clone().narrow(1, 6, 2);
                            let out = model.memae.forward(last.clone());
                            let loss = stage1_loss(&out, last, &w).total;
                            let grads = GradientsParams::from_grads(loss.backward(), &model.memae);
                            model.memae = optim.step(1e-4, model.memae, grads);
                            model
                        }
                        _ => {
                            let latents = Latents::sampled(&config, batch, &device, &mut rng);
                            let target = frames.clone().narrow(1, 12, 3);
                            let out = model.forward(
                                frames.clone(),
                                flows.clone(),
                                &latents,
                                Some(&mut rng),
                            );
                            if stage == 2 {
                                let loss = stage2_loss(&out, target, &w).total;
                                let grads =
                                    GradientsParams::from_grads(loss.backward(), &model.vunet);
                                model.vunet = optim.step(1e-4, model.vunet, grads);
                                model
                            } else {
                                let loss = stage3_loss(&out, flows.clone(), target, &w).total;
                                let grads = GradientsParams::from_grads(loss.backward(), &model);
                                optim.step(8e-5, model, grads)
                            }
                        }
                    };
                    slot = Some(model);
                };
                let id = BenchmarkId::new(format!("stage{stage}/{path}"), batch);
                group.bench_function(id, |b| {
                    b.iter(|| match path {
                        "burn_layers" => with_burn_layers(&mut step),
                        _ => step(),
                    })
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, inference, training);
criterion_main!(benches);
