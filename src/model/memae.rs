//! ML-MemAE-SC (spec §3): a U-Net-like flow autoencoder with memory modules on the decoder
//! features at 4×4, 8×8 and 16×16 (for a 32×32 patch) and concatenating skip connections.

use burn::module::{Module, Param};
use burn::nn::conv::{Conv2d, ConvTranspose2d};
use burn::tensor::activation::{relu, softmax};
use burn::tensor::{Device, Tensor};

use super::config::{ModelConfig, SkipOp};
use super::gemm_conv::{
    Activation, ConvGeometry, GemmConv2d, GemmConvTranspose2d, memory_scores, training,
};
use super::layers::{BatchNorm2d, kaiming_conv, param, upsampling_conv};
use super::rng::NoiseRng;

/// `[Conv3×3 → BatchNorm → ReLU] × 2`.
#[derive(Module, Debug)]
pub struct DoubleConv {
    /// First convolution.
    pub conv1: Conv2d,
    /// First BatchNorm.
    pub bn1: BatchNorm2d,
    /// Second convolution.
    pub conv2: Conv2d,
    /// Second BatchNorm.
    pub bn2: BatchNorm2d,
    /// Both stages with BatchNorm's running statistics folded in and ReLU fused, set by
    /// [`MlMemAeSc::lowered`] for inference on non-autodiff devices.
    #[module(skip)]
    pub lowered: Option<[GemmConv2d; 2]>,
}

impl DoubleConv {
    fn new(cin: usize, cout: usize, device: &Device, rng: &mut NoiseRng) -> Self {
        Self {
            conv1: kaiming_conv([cin, cout], 3, 1, 1, device, rng),
            bn1: BatchNorm2d::new(cout, device, rng),
            conv2: kaiming_conv([cout, cout], 3, 1, 1, device, rng),
            bn2: BatchNorm2d::new(cout, device, rng),
            lowered: None,
        }
    }

    fn lowered(self) -> Self {
        let lowered = Some([
            lower_conv(&self.conv1, Some(&self.bn1), Activation::Relu),
            lower_conv(&self.conv2, Some(&self.bn2), Activation::Relu),
        ]);
        Self { lowered, ..self }
    }

    /// Applies both conv–BN–ReLU stages.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        if let Some([first, second]) = &self.lowered
            && !x.device().is_autodiff()
        {
            return second.forward(first.forward(x));
        }
        let x = self.bn1.forward_relu(conv_forward(&self.conv1, x));
        self.bn2.forward_relu(conv_forward(&self.conv2, x))
    }
}

/// Encoder level: strided 3×3 conv (×½ resolution, ×2 channels), then a [`DoubleConv`].
#[derive(Module, Debug)]
pub struct Down {
    /// The stride-2 convolution.
    pub conv: Conv2d,
    /// The double convolution after it.
    pub double: DoubleConv,
    /// `conv` lowered for inference (see [`MlMemAeSc::lowered`]).
    #[module(skip)]
    pub lowered: Option<GemmConv2d>,
}

impl Down {
    fn new(cin: usize, cout: usize, device: &Device, rng: &mut NoiseRng) -> Self {
        Self {
            conv: kaiming_conv([cin, cout], 3, 2, 1, device, rng),
            double: DoubleConv::new(cout, cout, device, rng),
            lowered: None,
        }
    }

    fn lowered(self) -> Self {
        Self {
            lowered: Some(lower_conv(&self.conv, None, Activation::Identity)),
            double: self.double.lowered(),
            ..self
        }
    }

    /// Halves the resolution of `x` and doubles its channels.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let x = match &self.lowered {
            Some(conv) if !x.device().is_autodiff() => conv.forward(x),
            _ => conv_forward(&self.conv, x),
        };
        self.double.forward(x)
    }
}

/// Decoder level: ConvTranspose ×2 (C → C/2), optional concat with the encoder feature
/// `[skip, up]`, then a [`DoubleConv`] to C/2.
#[derive(Module, Debug)]
pub struct Up {
    /// The transposed convolution.
    pub up: ConvTranspose2d,
    /// The double convolution on the (fused) upsampled map.
    pub double: DoubleConv,
    /// Whether the encoder feature is concatenated.
    pub concat: bool,
    /// `up` lowered for inference (see [`MlMemAeSc::lowered`]).
    #[module(skip)]
    pub lowered: Option<GemmConvTranspose2d>,
}

impl Up {
    fn new(cin: usize, op: SkipOp, device: &Device, rng: &mut NoiseRng) -> Self {
        let cout = cin / 2;
        let concat = op == SkipOp::Concat;
        let fused = if concat { cin } else { cout };
        Self {
            up: upsampling_conv([cin, cout], device, rng),
            double: DoubleConv::new(fused, cout, device, rng),
            concat,
            lowered: None,
        }
    }

    fn lowered(self) -> Self {
        let up = &self.up;
        let lowered = GemmConvTranspose2d::new(
            up.weight.val(),
            transposed_bias(up),
            transposed_geometry(up),
            up.padding_out[0],
        );
        Self {
            lowered: Some(lowered),
            double: self.double.lowered(),
            ..self
        }
    }

    /// Upsamples `x` and fuses it with the encoder feature `skip` (ignored without concat).
    pub fn forward(&self, x: Tensor<4>, skip: Tensor<4>) -> Tensor<4> {
        if let (Some(up), Some([first, second])) = (&self.lowered, &self.double.lowered)
            && !x.device().is_autodiff()
        {
            let up = up.forward(x);
            let parts = if self.concat {
                vec![skip, up]
            } else {
                vec![up]
            };
            return second.forward(first.forward_fused(parts, Activation::Identity, false));
        }
        let up = training::conv_transpose2d(
            x,
            self.up.weight.val(),
            transposed_bias(&self.up),
            transposed_geometry(&self.up),
            self.up.padding_out[0],
        );
        let fused = if self.concat {
            Tensor::cat(vec![skip, up], 1)
        } else {
            up
        };
        self.double.forward(fused)
    }
}

/// One memory read.
#[derive(Debug, Clone)]
pub struct MemoryRead {
    /// Retrieved features ŵ·M, [N, C].
    pub out: Tensor<2>,
    /// Attention after hard shrinkage and L1 renormalisation, [N, slots].
    pub attention: Tensor<2>,
    /// Attention softmax before shrinkage, [N, slots].
    pub softmax: Tensor<2>,
}

/// A memory module: `slots` learned items of the whole flattened feature map, read by
/// dot-product attention, softmax, hard shrinkage and L1 renormalisation.
#[derive(Module, Debug)]
pub struct Memory {
    /// The memory matrix M, [slots, C·H·W] (`memMatrix` in the reference).
    pub slots: Param<Tensor<2>>,
    /// Hard-shrinkage threshold λ.
    pub shrink_thres: f64,
}

impl Memory {
    fn new(
        slots: usize,
        dim: usize,
        shrink_thres: f64,
        device: &Device,
        rng: &mut NoiseRng,
    ) -> Self {
        let bound = 1.0 / (dim as f64).sqrt();
        Self {
            slots: param(
                rng.uniform_vec(slots * dim, -bound, bound),
                [slots, dim],
                device,
            ),
            shrink_thres,
        }
    }

    /// Reads the memory with `query` [N, C].
    pub fn forward(&self, query: Tensor<2>) -> MemoryRead {
        let m = self.slots.val();
        let scores = if query.device().is_autodiff() {
            query.matmul(m.clone().transpose())
        } else {
            memory_scores(query, m.clone())
        };
        let sm = softmax(scores, 1);
        let attention = if self.shrink_thres > 0.0 {
            // ReLU-based hard shrinkage ŵ = ReLU(w − λ)·w / (|w − λ| + 1e-12), then
            // ŵ / max(‖ŵ‖₁, 1e-12) (ŵ ≥ 0, so the L1 norm is the plain sum).
            let shifted = sm.clone().sub_scalar(self.shrink_thres);
            let shrunk = relu(shifted.clone()) * sm.clone() / shifted.abs().add_scalar(1e-12);
            let norm = shrunk.clone().sum_dim(1).clamp_min(1e-12);
            shrunk / norm
        } else {
            sm.clone()
        };
        MemoryRead {
            out: attention.clone().matmul(m),
            attention,
            softmax: sm,
        }
    }

    /// Reads the memory with a whole feature map `x` [B, C, H, W] as one query per sample.
    fn read_map(&self, x: Tensor<4>) -> (Tensor<4>, MemoryRead) {
        let [b, c, h, w] = x.dims();
        let read = self.forward(x.reshape([b, c * h * w]));
        (read.out.clone().reshape([b, c, h, w]), read)
    }
}

/// Everything one ML-MemAE-SC pass produces.
#[derive(Debug, Clone)]
pub struct MemAeOutput {
    /// Reconstructed flow, same shape as the input.
    pub recon: Tensor<4>,
    /// Attention of mem1 (16×16 level), mem2 (8×8), mem3 (4×4), each [B, slots]; zeros for a
    /// disabled memory, as the reference's dummies.
    pub attention: [Tensor<2>; 3],
    /// Pre-shrinkage softmax of the same memories (None where disabled).
    pub softmax: [Option<Tensor<2>>; 3],
    /// Output of the deepest encoder level (`down_3`), before mem3.
    pub x3: Tensor<4>,
    /// Output of the deepest decoder level (`up_3`), the query of mem2.
    pub up3_out: Tensor<4>,
}

/// ML-MemAE-SC.
#[derive(Module, Debug)]
pub struct MlMemAeSc {
    /// Input double conv, 2 → feature_root.
    pub in_conv: DoubleConv,
    /// Encoder level 1 (½ resolution).
    pub down_1: Down,
    /// Encoder level 2 (¼).
    pub down_2: Down,
    /// Encoder level 3 (⅛).
    pub down_3: Down,
    /// Memory on the level-1 decoder output (16×16 for a 32 patch).
    pub mem1: Option<Memory>,
    /// Memory on the level-2 decoder output (8×8).
    pub mem2: Option<Memory>,
    /// Memory on the deepest encoder output (4×4).
    pub mem3: Option<Memory>,
    /// Decoder level 3 → 2.
    pub up_3: Up,
    /// Decoder level 2 → 1.
    pub up_2: Up,
    /// Decoder level 1 → full resolution.
    pub up_1: Up,
    /// Linear 1×1 output conv to the flow channels of one pass (2, or 2·t when joint).
    pub out_conv: Conv2d,
    /// Slots per memory (for the dummy attention of disabled memories).
    pub num_slots: usize,
    /// `out_conv` lowered for inference (see [`MlMemAeSc::lowered`]).
    #[module(skip)]
    pub out_lowered: Option<GemmConv2d>,
}

impl MlMemAeSc {
    /// A freshly initialised network (reference init, seeded by `rng`).
    pub fn new(config: &ModelConfig, device: &Device, rng: &mut NoiseRng) -> Self {
        let fr = config.feature_root;
        let memory = |level: usize, rng: &mut NoiseRng| {
            config.mem_usage[level].then(|| {
                Memory::new(
                    config.num_slots,
                    config.slot_dim(level),
                    config.shrink_thres,
                    device,
                    rng,
                )
            })
        };
        Self {
            in_conv: DoubleConv::new(config.memae_channels(), fr, device, rng),
            down_1: Down::new(fr, 2 * fr, device, rng),
            down_2: Down::new(2 * fr, 4 * fr, device, rng),
            down_3: Down::new(4 * fr, 8 * fr, device, rng),
            mem1: memory(1, rng),
            mem2: memory(2, rng),
            mem3: memory(3, rng),
            up_3: Up::new(8 * fr, config.skip_ops[2], device, rng),
            up_2: Up::new(4 * fr, config.skip_ops[1], device, rng),
            up_1: Up::new(2 * fr, config.skip_ops[0], device, rng),
            out_conv: kaiming_conv([fr, config.memae_channels()], 1, 1, 0, device, rng),
            num_slots: config.num_slots,
            out_lowered: None,
        }
    }

    /// The network with every convolution lowered to batched GEMMs for inference, BatchNorm's
    /// running statistics folded into the weights (same outputs in eval mode). The lowered
    /// layers run only on non-autodiff devices and copy the weights: lower again after the
    /// weights change.
    pub fn lowered(self) -> Self {
        Self {
            in_conv: self.in_conv.lowered(),
            down_1: self.down_1.lowered(),
            down_2: self.down_2.lowered(),
            down_3: self.down_3.lowered(),
            up_3: self.up_3.lowered(),
            up_2: self.up_2.lowered(),
            up_1: self.up_1.lowered(),
            out_lowered: Some(lower_conv(&self.out_conv, None, Activation::Identity)),
            ..self
        }
    }

    /// Reconstructs `flow` [B, 2, H, W].
    pub fn forward(&self, flow: Tensor<4>) -> MemAeOutput {
        let batch = flow.dims()[0];
        let device = flow.device();
        let x0 = self.in_conv.forward(flow);
        let x1 = self.down_1.forward(x0.clone());
        let x2 = self.down_2.forward(x1.clone());
        let x3 = self.down_3.forward(x2.clone());

        let mut attention: [Option<Tensor<2>>; 3] = [None, None, None];
        let mut softmax: [Option<Tensor<2>>; 3] = [None, None, None];
        let mut through = |memory: &Option<Memory>, x: Tensor<4>, slot: usize| match memory {
            Some(memory) => {
                let (out, read) = memory.read_map(x);
                attention[slot] = Some(read.attention);
                softmax[slot] = Some(read.softmax);
                out
            }
            None => x,
        };

        let h = through(&self.mem3, x3.clone(), 2);
        let up3_out = self.up_3.forward(h, x2);
        let h = through(&self.mem2, up3_out.clone(), 1);
        let h = self.up_2.forward(h, x1);
        let h = through(&self.mem1, h, 0);
        let h = self.up_1.forward(h, x0);
        let recon = match &self.out_lowered {
            Some(conv) if !h.device().is_autodiff() => conv.forward(h),
            _ => conv_forward(&self.out_conv, h),
        };

        let attention =
            attention.map(|a| a.unwrap_or_else(|| Tensor::zeros([batch, self.num_slots], &device)));
        MemAeOutput {
            recon,
            attention,
            softmax,
            x3,
            up3_out,
        }
    }

    /// Whether BatchNorm uses batch statistics for inputs on `device` (training behaviour).
    pub fn batch_statistics(&self, device: &Device) -> bool {
        device.is_autodiff() && self.in_conv.bn1.training.is_enabled()
    }
}

/// `conv`, followed by `bn` in eval mode (running statistics) when given, as one lowered
/// convolution: y = γ·(W*x + b − μ)/√(σ² + ε) + β folds into W' = W·s, b' = (b − μ)·s + β
/// with s = γ/√(σ² + ε).
fn lower_conv(conv: &Conv2d, bn: Option<&BatchNorm2d>, activation: Activation) -> GemmConv2d {
    let weight = conv.weight.val();
    let [cout, ..] = weight.dims();
    let bias = conv_bias(conv);
    let (weight, bias) = match bn {
        Some(bn) => {
            let device = weight.device();
            let var = bn.running_var.value_sync().to_device(&device);
            let mean = bn.running_mean.value_sync().to_device(&device);
            let scale = bn.weight.val() / var.add_scalar(bn.eps).sqrt();
            let bias = (bias - mean) * scale.clone() + bn.bias.val();
            (weight * scale.reshape([cout, 1, 1, 1]), bias)
        }
        None => (weight, bias),
    };
    GemmConv2d::new(weight, bias, conv_geometry(conv), activation)
}

/// `conv` applied to `x` through the lowering, differentiable when `x` is on the training
/// device (see [`training`]).
fn conv_forward(conv: &Conv2d, x: Tensor<4>) -> Tensor<4> {
    training::conv2d(x, conv.weight.val(), conv_bias(conv), conv_geometry(conv))
}

/// `conv`'s bias, zero where it has none.
fn conv_bias(conv: &Conv2d) -> Tensor<1> {
    let weight = conv.weight.val();
    conv.bias.as_ref().map_or_else(
        || Tensor::zeros([weight.dims()[0]], &weight.device()),
        |b| b.val(),
    )
}

fn conv_geometry(conv: &Conv2d) -> ConvGeometry {
    let [.., kernel] = conv.weight.dims();
    let padding = match conv.padding {
        burn::nn::PaddingConfig2d::Explicit(top, ..) => top,
        burn::nn::PaddingConfig2d::Valid => 0,
        burn::nn::PaddingConfig2d::Same => kernel / 2,
    };
    ConvGeometry {
        kernel,
        stride: conv.stride[0],
        padding,
    }
}

/// `up`'s bias, zero where it has none.
fn transposed_bias(up: &ConvTranspose2d) -> Tensor<1> {
    up.bias.as_ref().map_or_else(
        || Tensor::zeros([up.channels[1]], &up.weight.device()),
        |b| b.val(),
    )
}

fn transposed_geometry(up: &ConvTranspose2d) -> ConvGeometry {
    ConvGeometry {
        kernel: up.kernel_size[0],
        stride: up.stride[0],
        padding: up.padding[0],
    }
}
