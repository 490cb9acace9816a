//! Parity of the burn networks with the reference PyTorch implementation, on the fixtures
//! of `shared/parity/` (small configuration, see its README): forward outputs, losses and
//! gradients, through both weight-import paths (per-network safetensors and the official
//! `.pth` checkpoint layout).
//!
//! Tolerances: forward tensors and gradients within 1e-4 absolute *and* 1e-4 of the tensor's
//! largest magnitude (the second bound keeps tiny tensors honest, the README's §6 advice);
//! losses within 1e-5 relative; S_r (≈3e4, f32 noise ≈2e-3) relative only.

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::store::{ModuleStore, SafetensorsStore, bridge};
use burn::tensor::{Device, Tensor, TensorData};

use vadscope::model::losses::{LossWeights, per_sample_sse, stage1_loss, stage2_loss, stage3_loss};
use vadscope::model::weights::{
    import_reference_checkpoint, load_memae_safetensors, load_vunet_safetensors,
};
use vadscope::model::{
    Hf2Vad, Hf2VadOutput, InputConventions, Latents, MlMemAeSc, ModelConfig, NoiseRng,
};

fn parity_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/parity");
    if dir.join("hf2vad_io.safetensors").is_file() {
        Some(dir)
    } else {
        println!(
            "SKIPPED: parity fixtures not found at {} (CI places shared/ beside the clone)",
            dir.display()
        );
        None
    }
}

struct Fixtures {
    dir: PathBuf,
    io: SafetensorsStore,
    device: Device,
}

impl Fixtures {
    fn open(device: Device) -> Option<Self> {
        let dir = parity_dir()?;
        let io = SafetensorsStore::from_file(dir.join("hf2vad_io.safetensors"));
        Some(Self { dir, io, device })
    }

    fn data(&mut self, name: &str) -> TensorData {
        let t = self
            .io
            .get_tensor(name)
            .expect("readable fixture file")
            .unwrap_or_else(|| panic!("fixture tensor '{name}' missing"));
        bridge::to_data(t).expect("fixture tensor data")
    }

    fn tensor<const D: usize>(&mut self, name: &str) -> Tensor<D> {
        Tensor::from_data(self.data(name), &self.device)
    }

    fn scalar(&mut self, name: &str) -> f64 {
        self.data(name).try_to_vec::<f32>().expect("f32")[0] as f64
    }

    /// The network input frames: u8 / 255 with a correctly rounded f32 division.
    fn frames(&mut self) -> Tensor<4> {
        let data = self.data("input.frames_u8");
        let shape = data.shape().clone();
        let values: Vec<f32> = data
            .try_to_vec::<u8>()
            .expect("u8 frames")
            .into_iter()
            .map(|v| v as f32 / 255.0)
            .collect();
        Tensor::from_data(TensorData::new(values, shape), &self.device)
    }

    fn memae(&self) -> MlMemAeSc {
        let mut net = MlMemAeSc::new(&ModelConfig::parity(), &self.device, &mut NoiseRng::new(5));
        load_memae_safetensors(&mut net, &self.dir.join("memae.safetensors"))
            .expect("memae weights");
        net
    }

    fn hf2vad_from_safetensors(&self) -> Hf2Vad {
        let config = ModelConfig::parity();
        let mut model = Hf2Vad::new(&config, &self.device, &mut NoiseRng::new(6)).expect("model");
        load_memae_safetensors(&mut model.memae, &self.dir.join("memae.safetensors"))
            .expect("memae weights");
        load_vunet_safetensors(&mut model.vunet, &self.dir.join("vunet.safetensors"))
            .expect("vunet weights");
        model
    }
}

fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_to_vec::<f32>()
        .expect("f32")
}

/// Asserts `ours` ≈ `reference` (same shape, max abs ≤ 1e-4 and ≤ 1e-4·max|ref| + 1e-9) and
/// returns the max abs error.
fn assert_close<const D: usize>(name: &str, ours: Tensor<D>, reference: Tensor<D>) -> f32 {
    assert_eq!(ours.dims(), reference.dims(), "{name}: shape");
    let (a, b) = (values(ours), values(reference));
    let max_ref = b.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let err = a
        .iter()
        .zip(&b)
        .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
    println!("{name:<40} max abs err {err:.3e}  (max |ref| {max_ref:.3e})");
    assert!(err <= 1e-4, "{name}: max abs err {err} > 1e-4");
    assert!(
        err <= 1e-4 * max_ref + 1e-9,
        "{name}: max abs err {err} > 1e-4 of max |ref| {max_ref}"
    );
    err
}

/// Asserts a scalar within 1e-5 relative.
fn assert_rel(name: &str, ours: Tensor<1>, reference: f64) {
    let v = values(ours)[0] as f64;
    let rel = (v - reference).abs() / reference.abs().max(1e-30);
    println!("{name:<40} {v:.9e} vs {reference:.9e}  rel err {rel:.2e}");
    assert!(rel <= 1e-5, "{name}: {v} vs {reference} (rel {rel})");
}

/// [`assert_close`] for each `(name, ours)`, against the fixture tensor of the same name.
fn assert_outputs<const D: usize>(fx: &mut Fixtures, outputs: &[(&str, &Tensor<D>)]) {
    for &(name, ours) in outputs {
        assert_close(name, ours.clone(), fx.tensor(name));
    }
}

/// [`assert_rel`] for each `(name, loss)`, against the fixture scalar of the same name.
fn assert_losses(fx: &mut Fixtures, losses: &[(&str, &Tensor<1>)]) {
    for &(name, ours) in losses {
        assert_rel(name, ours.clone(), fx.scalar(name));
    }
}

/// Checks the outputs of one HF²-VAD test-mode pass against the fixtures.
fn check_hf2vad_outputs(fx: &mut Fixtures, out: &Hf2VadOutput) {
    let cvae = &out.cvae;
    assert_outputs(
        fx,
        &[
            ("hf2vad.of_recon", &out.of_recon),
            ("hf2vad.frame_pred", &cvae.frame_pred),
            ("hf2vad.q_mean_4x4", &cvae.q_means[0]),
            ("hf2vad.p_mean_4x4", &cvae.p_means[0]),
            ("hf2vad.q_mean_8x8", &cvae.q_means[1]),
            ("hf2vad.p_mean_8x8", &cvae.p_means[1]),
            ("vunet.f_phi.s4_2", &cvae.f_phi_last),
            ("vunet.e_theta.s4_2", &cvae.e_theta_last),
            ("vunet.bottleneck_out", &cvae.bottleneck_out),
        ],
    );
    for (i, ours) in out.attention.iter().enumerate() {
        let name = format!("hf2vad.att_weight{}", i + 1);
        let reference: Tensor<3> = fx.tensor(&name);
        assert_close(&name, ours.clone(), reference.reshape([16, 16]));
    }

    let flows: Tensor<4> = fx.tensor("input.flows");
    let target = fx.frames().narrow(1, 12, 3);
    let s_r = per_sample_sse(out.of_recon.clone(), flows);
    let s_p = per_sample_sse(out.cvae.frame_pred.clone(), target);
    let (s_r, s_p) = (values(s_r), values(s_p));
    let ref_r = [36309.98293, 31203.62283, 32353.19519, 31559.53975];
    let ref_p = [46.17539037, 53.10316302, 52.87623229, 47.65318940];
    for i in 0..4 {
        let rel_r = (s_r[i] as f64 - ref_r[i]).abs() / ref_r[i];
        let abs_p = (s_p[i] as f64 - ref_p[i]).abs();
        println!(
            "S_r[{i}] {} rel err {rel_r:.2e}; S_p[{i}] {} abs err {abs_p:.2e}",
            s_r[i], s_p[i]
        );
        assert!(rel_r <= 1e-5, "S_r[{i}]");
        assert!(abs_p <= 1e-4, "S_p[{i}]");
    }
}

fn check_stage2_and_3_losses(fx: &mut Fixtures, out: &Hf2VadOutput) {
    let w = LossWeights::default();
    let flows: Tensor<4> = fx.tensor("input.flows");
    let target = fx.frames().narrow(1, 12, 3);
    let s3 = stage3_loss(out, flows, target, &w);
    let s2 = &s3.cvae;
    assert_losses(
        fx,
        &[
            ("s2.loss_kl_4x4", &s2.kl_scales[0]),
            ("s2.loss_kl_8x8", &s2.kl_scales[1]),
            ("s2.loss_kl", &s2.kl),
            ("s2.loss_frame", &s2.frame),
            ("s2.loss_grad", &s2.grad),
            ("s2.loss_total", &s2.total),
            ("s3.loss_recon", &s3.recon),
            ("s3.loss_sparsity", &s3.sparsity),
        ],
    );
}

#[test]
fn memae_alone_reproduces_reference_features_and_attention() {
    let Some(mut fx) = Fixtures::open(Device::flex()) else {
        return;
    };
    let net = fx.memae();
    let flows: Tensor<4> = fx.tensor("input.flows");
    let out = net.forward(flows.narrow(1, 6, 2));
    assert_outputs(
        &mut fx,
        &[("memae.x3", &out.x3), ("memae.up3_out", &out.up3_out)],
    );
    for i in 0..3 {
        let sm = format!("memae.att_softmax{}", i + 1);
        let aw = format!("memae.att_weight{}", i + 1);
        let softmax = out.softmax[i].clone().expect("all three memories enabled");
        assert_close(&sm, softmax, fx.tensor(&sm));
        assert_close(&aw, out.attention[i].clone(), fx.tensor(&aw));
    }
    let of_recon: Tensor<4> = fx.tensor("hf2vad.of_recon");
    assert_close(
        "memae.recon (last flow)",
        out.recon,
        of_recon.narrow(1, 6, 2),
    );
}

#[test]
fn hf2vad_from_safetensors_reproduces_reference_outputs_and_losses() {
    let Some(mut fx) = Fixtures::open(Device::flex()) else {
        return;
    };
    let model = fx.hf2vad_from_safetensors();
    let out = model.forward(fx.frames(), fx.tensor("input.flows"), &Latents::Mean, None);
    check_hf2vad_outputs(&mut fx, &out);
    check_stage2_and_3_losses(&mut fx, &out);
}

#[test]
fn lowered_inference_layers_reproduce_reference_outputs() {
    let Some(mut fx) = Fixtures::open(Device::flex()) else {
        return;
    };
    let mut model = fx.hf2vad_from_safetensors();
    model.memae = model.memae.lowered();
    model.vunet = model.vunet.lowered();
    let out = model.forward(fx.frames(), fx.tensor("input.flows"), &Latents::Mean, None);
    check_hf2vad_outputs(&mut fx, &out);
}

#[test]
fn hf2vad_from_pytorch_checkpoint_reproduces_reference_outputs() {
    let Some(mut fx) = Fixtures::open(Device::flex()) else {
        return;
    };
    let (model, config) = import_reference_checkpoint(
        &fx.dir.join("hf2vad_official_layout.pth"),
        InputConventions::reference(vadscope::model::FlowUnits::NativePixels),
        &fx.device,
    )
    .expect("import .pth");
    let mut expected = ModelConfig::parity();
    expected.preset = config.preset.clone();
    assert_eq!(
        config, expected,
        "config inferred from the checkpoint shapes"
    );
    let out = model.forward(fx.frames(), fx.tensor("input.flows"), &Latents::Mean, None);
    check_hf2vad_outputs(&mut fx, &out);
    check_stage2_and_3_losses(&mut fx, &out);
}

#[test]
fn injected_posterior_noise_reproduces_reference_train_mode() {
    let Some(mut fx) = Fixtures::open(Device::flex()) else {
        return;
    };
    let model = fx.hf2vad_from_safetensors();
    let latents = Latents::Sampled {
        eps_4: fx.tensor("s2_eps.eps_4x4"),
        eps_8: fx.tensor("s2_eps.eps_8x8"),
    };
    let out = model.forward(fx.frames(), fx.tensor("input.flows"), &latents, None);
    assert_outputs(
        &mut fx,
        &[
            ("s2_eps.frame_pred", &out.cvae.frame_pred),
            ("s2_eps.p_mean_4x4", &out.cvae.p_means[0]),
        ],
    );
    assert_close(
        "q_mean_4x4 unchanged by noise",
        out.cvae.q_means[0].clone(),
        fx.tensor("hf2vad.q_mean_4x4"),
    );
    let target = fx.frames().narrow(1, 12, 3);
    let s2 = stage2_loss(&out, target, &LossWeights::default());
    assert_losses(
        &mut fx,
        &[
            ("s2_eps.loss_kl", &s2.kl),
            ("s2_eps.loss_frame", &s2.frame),
            ("s2_eps.loss_grad", &s2.grad),
            ("s2_eps.loss_total", &s2.total),
        ],
    );
}

const GRAD_PARAMS: [&str; 6] = [
    "in_conv.conv.conv.0.weight",
    "in_conv.conv.conv.1.weight",
    "in_conv.conv.conv.1.bias",
    "up_1.up.weight",
    "out_conv.conv.weight",
    "out_conv.conv.bias",
];

/// The gradients of [`GRAD_PARAMS`] in `net` after `grads`, flattened.
fn param_grads(net: &MlMemAeSc, grads: &burn::tensor::Gradients) -> Vec<Vec<f32>> {
    let g4 = |t: Tensor<4>| values(t.grad(grads).expect("gradient"));
    let g1 = |t: Tensor<1>| values(t.grad(grads).expect("gradient"));
    let out_bias = net.out_conv.bias.as_ref().expect("out_conv bias").val();
    vec![
        g4(net.in_conv.conv1.weight.val()),
        g1(net.in_conv.bn1.weight.val()),
        g1(net.in_conv.bn1.bias.val()),
        g4(net.up_1.up.weight.val()),
        g4(net.out_conv.weight.val()),
        g1(out_bias),
    ]
}

fn check_param_grads(fx: &mut Fixtures, mode: &str, grads: Vec<Vec<f32>>) {
    for (name, ours) in GRAD_PARAMS.iter().zip(grads) {
        let key = format!("{mode}.grad.{name}");
        let reference = fx.data(&key).try_to_vec::<f32>().expect("f32");
        let n = reference.len();
        assert_eq!(ours.len(), n, "{key}: size");
        let flat = |v: Vec<f32>| Tensor::<1>::from_data(TensorData::new(v, [n]), &Device::flex());
        assert_close(&key, flat(ours), flat(reference));
    }
}

#[test]
fn stage1_train_mode_reproduces_losses_gradients_and_running_stats() {
    let Some(mut fx) = Fixtures::open(Device::flex().autodiff()) else {
        return;
    };
    let net = fx.memae();
    let flows: Tensor<4> = fx.tensor("input.flows");
    let input = flows.narrow(1, 6, 2).detach().require_grad();
    let out = net.forward(input.clone());
    assert_outputs(&mut fx, &[("s1_train.recon", &out.recon)]);
    for i in 0..3 {
        let name = format!("s1_train.att_weight{}", i + 1);
        assert_close(&name, out.attention[i].clone(), fx.tensor(&name));
    }
    let loss = stage1_loss(&out, input.clone().detach(), &LossWeights::default());
    assert_losses(
        &mut fx,
        &[
            ("s1_train.loss_recon", &loss.recon),
            ("s1_train.loss_entropy", &loss.entropy),
            ("s1_train.loss_total", &loss.total),
        ],
    );
    let grads = loss.total.backward();
    assert_close(
        "s1_train.grad.input",
        input.grad(&grads).expect("input gradient"),
        fx.tensor("s1_train.grad.input"),
    );
    check_param_grads(&mut fx, "s1_train", param_grads(&net, &grads));
    let bn = &net.in_conv.bn1;
    assert_close(
        "s1_train.bn_after running_mean",
        bn.running_mean.value_sync(),
        fx.tensor("s1_train.bn_after.in_conv.conv.conv.1.running_mean"),
    );
    assert_close(
        "s1_train.bn_after running_var",
        bn.running_var.value_sync(),
        fx.tensor("s1_train.bn_after.in_conv.conv.conv.1.running_var"),
    );
}

#[test]
fn stage1_eval_mode_reproduces_losses_and_gradients() {
    let Some(mut fx) = Fixtures::open(Device::flex().autodiff()) else {
        return;
    };
    // BatchNorm on running statistics, parameters still trainable.
    let net = fx.memae().freeze().set_require_grad(true);
    let flows: Tensor<4> = fx.tensor("input.flows");
    let input = flows.narrow(1, 6, 2);
    let out = net.forward(input.clone());
    let loss = stage1_loss(&out, input, &LossWeights::default());
    assert_losses(
        &mut fx,
        &[
            ("s1_eval.loss_recon", &loss.recon),
            ("s1_eval.loss_entropy", &loss.entropy),
            ("s1_eval.loss_total", &loss.total),
        ],
    );
    let grads = loss.total.backward();
    check_param_grads(&mut fx, "s1_eval", param_grads(&net, &grads));
}
