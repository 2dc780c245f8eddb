//! The network: a plain convolutional encoder down to 1/32 of the image, a two-level feature
//! pyramid back up to 1/8, and CenterNet's heads there (a heat map per class, and per cell the
//! centre's offset and the box's log size).
//!
//! Why this shape: the evaluator's frames are small (320 px wide), so a stride-8 output (40 x
//! 30 cells) still separates neighbouring objects, and five stride-2 stages give a receptive
//! field wide enough for a bed that fills the frame. Plain 3 x 3 convolutions and ReLU, no
//! normalisation layers: every operation has a fast CPU kernel in candle, training and
//! inference run the same graph, and the output depends on one image only. Training normalises
//! each hidden layer over the batch (batch normalisation, which lets a network trained from
//! scratch converge in a few epochs); the saved weights fold the normalisation's running
//! statistics into the convolutions, so inference is plain convolutions.

use std::collections::HashMap;

use candle_core::{DType, Device, Tensor, Var};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Input pixels per output cell.
pub const STRIDE_PX: usize = 8;
/// Input sides are padded up to a multiple of this: five stride-2 stages.
pub const PAD_TO_PX: usize = 32;
/// Classes of the heat map: scene-gen's COCO categories 1..=11 in order.
pub const NUM_CLASSES: usize = 11;
/// Channels of the box map: offset x, offset y (cells), ln width, ln height (ln cells).
pub const BOX_CHANNELS: usize = 4;

/// One convolution: name, input channels, output channels, kernel side, stride.
type LayerSpec = (&'static str, usize, usize, usize, usize);

/// Every layer, in the order [`Network::forward`] runs them. All but the last two (the heads)
/// are batch-normalised in training. `scripts/train_detector.py` holds the same table: change
/// both together.
const LAYERS: [LayerSpec; 14] = [
    ("stem", 3, 12, 3, 2),
    ("s4a", 12, 24, 3, 2),
    ("s4b", 24, 24, 3, 1),
    ("s8a", 24, 48, 3, 2),
    ("s8b", 48, 48, 3, 1),
    ("s16a", 48, 96, 3, 2),
    ("s16b", 96, 96, 3, 1),
    ("s32a", 96, 128, 3, 2),
    ("s32b", 128, 128, 3, 1),
    ("up16", 128 + 96, 96, 3, 1),
    ("up8", 96 + 48, 48, 3, 1),
    ("head", 48, 48, 3, 1),
    ("heat", 48, NUM_CLASSES, 1, 1),
    ("box", 48, BOX_CHANNELS, 1, 1),
];

/// The heat map's initial bias: sigmoid(-2.19) = 0.1, CenterNet's prior, so the first steps
/// are not swamped by the loss of millions of confident background cells.
const HEAT_PRIOR_BIAS: f32 = -2.19;

/// Layers normalised in training: every one but the two heads.
pub const NORMALISED_LAYERS: usize = LAYERS.len() - 2;

/// Added to a variance before its square root.
const NORM_EPSILON: f64 = 1e-5;

/// Mean and spread the input bytes are normalised by (value / 255 - mean) / spread.
pub const INPUT_MEAN: f32 = 0.45;
pub const INPUT_SPREAD: f32 = 0.25;

struct Conv {
    weight: Tensor,
    bias: Tensor,
    stride: usize,
    padding: usize,
}

impl Conv {
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let out_channels = self.bias.dim(0)?;
        x.conv2d(&self.weight, self.padding, self.stride, 1, 1)?.broadcast_add(&self.bias.reshape((
            1,
            out_channels,
            1,
            1,
        ))?)
    }
}

/// What the network says about a batch: heat-map logits `[B, 11, H/8, W/8]` and the box map
/// `[B, 4, H/8, W/8]`.
#[derive(Debug)]
pub struct Output {
    pub heat_logits: Tensor,
    pub boxes: Tensor,
}

/// The detector's network, over weights from a safetensors file or fresh ones to train.
pub struct Network {
    layers: Vec<Conv>,
}

impl std::fmt::Debug for Network {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Network").field("layers", &self.layers.len()).finish()
    }
}

/// The names of a layer's batch-normalisation scale and shift (training only).
fn norm_names(layer: &str) -> (String, String) {
    (format!("{layer}.norm_scale"), format!("{layer}.norm_shift"))
}

/// The weight and bias names of a layer in the safetensors file.
fn names(layer: &str) -> (String, String) {
    (format!("{layer}.weight"), format!("{layer}.bias"))
}

impl Network {
    /// The network over `weights` (name to tensor, as [`BatchNorms::folded_weights`] names them).
    ///
    /// # Errors
    /// A missing tensor or one of the wrong shape, named.
    pub fn from_weights(weights: &HashMap<String, Tensor>) -> Result<Network, String> {
        let mut layers = Vec::with_capacity(LAYERS.len());
        for &(name, cin, cout, k, stride) in &LAYERS {
            let (wn, bn) = names(name);
            let get = |n: &str, dims: &[usize]| -> Result<Tensor, String> {
                let t = weights.get(n).ok_or_else(|| format!("weights lack tensor {n}"))?;
                if t.dims() != dims {
                    return Err(format!("tensor {n} has shape {:?}, the network needs {dims:?}", t.dims()));
                }
                t.to_dtype(DType::F32).map_err(|e| format!("tensor {n}: {e}"))
            };
            layers.push(Conv {
                weight: get(&wn, &[cout, cin, k, k])?,
                bias: get(&bn, &[cout])?,
                stride,
                padding: k / 2,
            });
        }
        Ok(Network { layers })
    }

    /// Fresh weights for training, drawn from `seed` (He-uniform, zero biases but the heat
    /// map's prior): the same seed gives the same network on any machine.
    ///
    /// # Errors
    /// Only candle's own errors.
    pub fn init_vars(seed: u64) -> candle_core::Result<Vec<(String, Var)>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut vars = Vec::new();
        for &(name, cin, cout, k, _) in &LAYERS {
            let fan_in = cin * k * k;
            let bound = (6.0 / fan_in as f64).sqrt() as f32;
            let w: Vec<f32> = (0..cout * fan_in).map(|_| rng.random_range(-bound..bound)).collect();
            let b = vec![if name == "heat" { HEAT_PRIOR_BIAS } else { 0.0 }; cout];
            let (wn, bn) = names(name);
            vars.push((wn, Var::from_tensor(&Tensor::from_vec(w, (cout, cin, k, k), &Device::Cpu)?)?));
            vars.push((bn, Var::from_tensor(&Tensor::from_vec(b, cout, &Device::Cpu)?)?));
        }
        for &(name, _, cout, _, _) in &LAYERS[..NORMALISED_LAYERS] {
            let (gamma, beta) = norm_names(name);
            vars.push((gamma, Var::from_tensor(&Tensor::ones(cout, DType::F32, &Device::Cpu)?)?));
            vars.push((beta, Var::from_tensor(&Tensor::zeros(cout, DType::F32, &Device::Cpu)?)?));
        }
        Ok(vars)
    }

    /// The network reading (and, in training, differentiating) `vars`.
    ///
    /// # Errors
    /// As [`Network::from_weights`].
    pub fn from_vars(vars: &[(String, Var)]) -> Result<Network, String> {
        let weights: HashMap<String, Tensor> = vars.iter().map(|(n, v)| (n.clone(), v.as_tensor().clone())).collect();
        Network::from_weights(&weights)
    }

    /// Runs the network on a normalised batch `[B, 3, H, W]`, H and W multiples of
    /// [`PAD_TO_PX`].
    ///
    /// # Errors
    /// Only candle's own errors (a side that is not a multiple of [`PAD_TO_PX`] among them).
    pub fn forward(&self, input: &Tensor) -> candle_core::Result<Output> {
        self.forward_with(input, &mut |_, z| Ok(z))
    }

    /// Runs the network, passing each hidden layer's pre-activation (and its index) through
    /// `norm` before the ReLU: the identity at inference, batch normalisation in training.
    ///
    /// # Errors
    /// Only candle's own errors.
    pub fn forward_with(
        &self,
        input: &Tensor,
        norm: &mut dyn FnMut(usize, Tensor) -> candle_core::Result<Tensor>,
    ) -> candle_core::Result<Output> {
        let l = &self.layers;
        let mut layer = |i: usize, x: &Tensor| norm(i, l[i].forward(x)?)?.relu();
        let mut x = layer(0, input)?;
        x = layer(1, &x)?;
        x = layer(2, &x)?;
        x = layer(3, &x)?;
        let f8 = layer(4, &x)?;
        x = layer(5, &f8)?;
        let f16 = layer(6, &x)?;
        x = layer(7, &f16)?;
        x = layer(8, &x)?;
        let (_, _, h16, w16) = f16.dims4()?;
        x = layer(9, &Tensor::cat(&[&x.upsample_nearest2d(h16, w16)?, &f16], 1)?)?;
        let (_, _, h8, w8) = f8.dims4()?;
        x = layer(10, &Tensor::cat(&[&x.upsample_nearest2d(h8, w8)?, &f8], 1)?)?;
        x = layer(11, &x)?;
        Ok(Output { heat_logits: l[12].forward(&x)?, boxes: l[13].forward(&x)? })
    }

    /// Parameters, for a size report.
    #[must_use]
    pub fn parameter_count() -> usize {
        LAYERS.iter().map(|&(_, cin, cout, k, _)| cout * cin * k * k + cout).sum()
    }
}

/// Batch normalisation of the hidden layers in training: each layer's scale and shift, and the
/// running mean and variance of its pre-activations that inference folds in.
#[derive(Debug)]
pub struct BatchNorms {
    scale: Vec<Tensor>,
    shift: Vec<Tensor>,
    running: Vec<(Vec<f32>, Vec<f32>)>,
    /// Weight of a batch's statistics in the running ones.
    momentum: f32,
}

impl BatchNorms {
    /// Over the scale and shift variables of [`Network::init_vars`], running mean 0 and
    /// variance 1.
    ///
    /// # Errors
    /// A missing variable, named.
    pub fn from_vars(vars: &[(String, Var)]) -> Result<BatchNorms, String> {
        let find = |n: &str| {
            vars.iter()
                .find(|(name, _)| name == n)
                .map(|(_, v)| v.as_tensor().clone())
                .ok_or(format!("no variable {n}"))
        };
        let (mut scale, mut shift, mut running) = (Vec::new(), Vec::new(), Vec::new());
        for &(name, _, cout, _, _) in &LAYERS[..NORMALISED_LAYERS] {
            let (g, b) = norm_names(name);
            scale.push(find(&g)?);
            shift.push(find(&b)?);
            running.push((vec![0.0; cout], vec![1.0; cout]));
        }
        Ok(BatchNorms { scale, shift, running, momentum: 0.1 })
    }

    /// Normalises layer `i`'s pre-activation `z` `[B, C, H, W]` over the batch and the image,
    /// and moves the running statistics towards the batch's.
    ///
    /// # Errors
    /// Only candle's own errors.
    pub fn apply(&mut self, i: usize, z: Tensor) -> candle_core::Result<Tensor> {
        if i >= NORMALISED_LAYERS {
            return Ok(z);
        }
        let c = z.dim(1)?;
        let mean = z.mean_keepdim(0)?.mean_keepdim(2)?.mean_keepdim(3)?;
        let centred = z.broadcast_sub(&mean)?;
        let var = centred.sqr()?.mean_keepdim(0)?.mean_keepdim(2)?.mean_keepdim(3)?;
        let normed = centred.broadcast_div(&var.affine(1.0, NORM_EPSILON)?.sqrt()?)?;
        let out = normed
            .broadcast_mul(&self.scale[i].reshape((1, c, 1, 1))?)?
            .broadcast_add(&self.shift[i].reshape((1, c, 1, 1))?)?;
        let (batch_mean, batch_var) = (mean.flatten_all()?.to_vec1::<f32>()?, var.flatten_all()?.to_vec1::<f32>()?);
        let m = self.momentum;
        let (rm, rv) = &mut self.running[i];
        for (r, b) in rm.iter_mut().zip(batch_mean) {
            *r = (1.0 - m) * *r + m * b;
        }
        for (r, b) in rv.iter_mut().zip(batch_var) {
            *r = (1.0 - m) * *r + m * b;
        }
        Ok(out)
    }

    /// The inference weights: every normalised layer's convolution with the normalisation
    /// folded in (`w * s / sqrt(var + eps)`, `(b - mean) * s / sqrt(var + eps) + shift`), the
    /// heads as they are. Training-only tensors are left out.
    ///
    /// # Errors
    /// A missing variable, named; candle's errors.
    pub fn folded_weights(&self, vars: &[(String, Var)]) -> Result<HashMap<String, Tensor>, String> {
        let get = |n: &str| -> Result<Tensor, String> {
            vars.iter()
                .find(|(name, _)| name == n)
                .map(|(_, v)| v.as_tensor().detach())
                .ok_or(format!("no variable {n}"))
        };
        let mut out = HashMap::new();
        for (i, &(name, cin, cout, k, _)) in LAYERS.iter().enumerate() {
            let (wn, bn) = names(name);
            let (w, b) = (get(&wn)?, get(&bn)?);
            if i >= NORMALISED_LAYERS {
                out.insert(wn, w);
                out.insert(bn, b);
                continue;
            }
            let fold = || -> candle_core::Result<(Tensor, Tensor)> {
                let (mean, var) = &self.running[i];
                let scale = self.scale[i].detach().to_vec1::<f32>()?;
                let shift = self.shift[i].detach().to_vec1::<f32>()?;
                let factor: Vec<f32> =
                    scale.iter().zip(var).map(|(s, v)| s / (v + NORM_EPSILON as f32).sqrt()).collect();
                let bias: Vec<f32> = b.to_vec1::<f32>()?;
                let new_bias: Vec<f32> = (0..cout).map(|c| (bias[c] - mean[c]) * factor[c] + shift[c]).collect();
                let f = Tensor::from_vec(factor, (cout, 1, 1, 1), &Device::Cpu)?;
                Ok((w.broadcast_mul(&f)?.reshape((cout, cin, k, k))?, Tensor::from_vec(new_bias, cout, &Device::Cpu)?))
            };
            let (w, b) = fold().map_err(|e| format!("folding {name}: {e}"))?;
            out.insert(wn, w);
            out.insert(bn, b);
        }
        Ok(out)
    }
}

/// An 8-bit image as the network reads it: interleaved sRGB, or grey (one channel, repeated).
#[derive(Clone, Copy, Debug)]
pub struct ImageView<'a> {
    pub pixels: &'a [u8],
    pub width: usize,
    pub height: usize,
    /// 3 (RGB) or 1 (grey).
    pub channels: usize,
}

/// A batch of images as the network's input `[B, 3, ph, pw]`, each normalised and padded on
/// the right and bottom with the mean (zero after normalisation) to `padded = (pw, ph)`.
///
/// # Errors
/// Only candle's own errors.
pub fn input_tensor(images: &[ImageView<'_>], padded: (usize, usize)) -> candle_core::Result<Tensor> {
    let (pw, ph) = padded;
    let mut data = vec![0.0f32; images.len() * 3 * pw * ph];
    for (b, image) in images.iter().enumerate() {
        let base = b * 3 * pw * ph;
        let ch = image.channels.max(1);
        for y in 0..image.height.min(ph) {
            for x in 0..image.width.min(pw) {
                let p = (y * image.width + x) * ch;
                for c in 0..3 {
                    let v = f32::from(image.pixels[p + c.min(ch - 1)]);
                    data[base + (c * ph + y) * pw + x] = (v / 255.0 - INPUT_MEAN) / INPUT_SPREAD;
                }
            }
        }
    }
    Tensor::from_vec(data, (images.len(), 3, ph, pw), &Device::Cpu)
}

/// `side` rounded up to a multiple of [`PAD_TO_PX`].
#[must_use]
pub fn padded(side: usize) -> usize {
    side.div_ceil(PAD_TO_PX) * PAD_TO_PX
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_cover_the_padded_image_at_one_eighth() {
        let vars = Network::init_vars(1).unwrap();
        let net = Network::from_vars(&vars).unwrap();
        let pixels = vec![128u8; 70 * 50];
        let image = ImageView { pixels: &pixels, width: 70, height: 50, channels: 1 };
        let input = input_tensor(&[image], (padded(70), padded(50))).unwrap();
        assert_eq!(input.dims(), [1, 3, 64, 96]);
        let out = net.forward(&input).unwrap();
        assert_eq!(out.heat_logits.dims(), [1, NUM_CLASSES, 8, 12]);
        assert_eq!(out.boxes.dims(), [1, BOX_CHANNELS, 8, 12]);
    }

    #[test]
    fn initial_weights_follow_the_seed() {
        let a = Network::init_vars(7).unwrap();
        let b = Network::init_vars(7).unwrap();
        let c = Network::init_vars(8).unwrap();
        let flat = |v: &[(String, Var)]| v[0].1.as_tensor().flatten_all().unwrap().to_vec1::<f32>().unwrap();
        assert_eq!(flat(&a), flat(&b));
        assert_ne!(flat(&a), flat(&c));
        let total: usize =
            a.iter().filter(|(n, _)| !n.contains(".norm_")).map(|(_, v)| v.as_tensor().elem_count()).sum();
        assert_eq!(total, Network::parameter_count());
    }

    #[test]
    fn folding_the_normalisation_gives_the_normalised_network() {
        // After one training-mode pass has set the running statistics to this batch's
        // (momentum 1), the folded plain network must give what the normalised one gave.
        let vars = Network::init_vars(3).unwrap();
        let net = Network::from_vars(&vars).unwrap();
        let mut norms = BatchNorms::from_vars(&vars).unwrap();
        norms.momentum = 1.0;
        let pixels: Vec<u8> = (0..128 * 96 * 3).map(|i| ((i * 37) % 251) as u8).collect();
        let input =
            input_tensor(&[ImageView { pixels: &pixels, width: 128, height: 96, channels: 3 }], (128, 96)).unwrap();
        let trained = net.forward_with(&input, &mut |i, z| norms.apply(i, z)).unwrap();
        let folded = Network::from_weights(&norms.folded_weights(&vars).unwrap()).unwrap();
        let plain = folded.forward(&input).unwrap();
        let max_diff = |a: &Tensor, b: &Tensor| {
            a.sub(b).unwrap().abs().unwrap().flatten_all().unwrap().max(0).unwrap().to_scalar::<f32>().unwrap()
        };
        // Float rounding only: the deepest layers normalise over few cells, which amplifies it.
        let d = max_diff(&trained.heat_logits, &plain.heat_logits);
        assert!(d < 2e-3, "{d}");
        assert!(max_diff(&trained.boxes, &plain.boxes) < 2e-3);
    }

    #[test]
    fn missing_or_misshapen_weights_are_named() {
        let vars = Network::init_vars(1).unwrap();
        let mut weights: HashMap<String, Tensor> =
            vars.iter().map(|(n, v)| (n.clone(), v.as_tensor().clone())).collect();
        weights.remove("up8.bias");
        assert!(Network::from_weights(&weights).unwrap_err().contains("up8.bias"));
        weights.insert("up8.bias".into(), Tensor::zeros(3, DType::F32, &Device::Cpu).unwrap());
        assert!(Network::from_weights(&weights).unwrap_err().contains("shape"));
    }
}
