//! MetaAvatar's hypernetwork: a pose condition (the bone encoder) goes through one head per
//! SDF layer; each head predicts a residual that is added to the meta-learned SDF's weights of
//! its layer. The heads' last linear layer starts at zero, so at initialisation every pose
//! gets exactly the meta-SDF.
//!
//! Two presets behind one config: `paper` (heads 144 -> 256 -> 256 -> in*out+out over a 5 x 256
//! SIREN, 85.6 M parameters) and `compact` (a 4 x 128 SIREN, heads 144 -> 128 -> 128 and a
//! low-rank residual U_l C(pose) per layer, about 1 M parameters) that a laptop CPU
//! fine-tunes in minutes.

use crate::data::off_surface::gauss;
use crate::model::encoder::{BoneEncoder, PoseEncoding, default_linear};
use crate::model::siren::{Siren, SirenConfig};
use burn::module::{Module, Param};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HyperConfig {
    pub siren: SirenConfig,
    /// Width of the heads' two hidden layers.
    pub head_hidden: usize,
    /// Rank of the weight residuals (None: a full in*out residual, as in the paper).
    pub rank: Option<usize>,
    pub encoding: PoseEncoding,
}

impl HyperConfig {
    /// The published sizes (MetaAvatar): 85.6 M parameters in the heads and the encoder.
    pub fn paper() -> Self {
        HyperConfig {
            siren: SirenConfig::paper(),
            head_hidden: 256,
            rank: None,
            encoding: PoseEncoding::Hierarchical,
        }
    }

    /// The compact default: fine-tunes on two CPU cores in minutes, ships in a few MB.
    pub fn compact() -> Self {
        HyperConfig {
            siren: SirenConfig::compact(),
            head_hidden: 128,
            rank: Some(8),
            encoding: PoseEncoding::Hierarchical,
        }
    }

    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(Self::paper()),
            "compact" => Some(Self::compact()),
            _ => None,
        }
    }

    /// (in, out) of every SDF layer.
    pub fn layer_shapes(&self) -> Vec<(usize, usize)> {
        self.siren.widths().windows(2).map(|p| (p[0], p[1])).collect()
    }

    /// Rank of layer `(fan_in, fan_out)`'s residual, None for a full residual.
    fn layer_rank(&self, fan_in: usize) -> Option<usize> {
        self.rank.map(|r| r.min(fan_in))
    }

    /// Outputs of the head of a layer.
    fn head_outputs(&self, fan_in: usize, fan_out: usize) -> usize {
        match self.layer_rank(fan_in) {
            Some(r) => r * fan_out + fan_out,
            None => fan_in * fan_out + fan_out,
        }
    }

    /// Refuse sizes no network of this build has (a corrupt or hostile file header): checked
    /// before any size arithmetic, which then cannot overflow.
    pub fn check(&self) -> crate::error::Result<()> {
        self.siren.check()?;
        crate::config::within("head_hidden", self.head_hidden, 1, 4096)?;
        match self.rank {
            Some(r) => crate::config::within("rank", r, 1, 4096),
            None => Ok(()),
        }
    }

    /// Parameters of the whole hypernetwork: encoder, heads, low-rank bases and base SDF.
    pub fn num_params(&self) -> usize {
        self.encoder_params() + self.head_params() + self.siren.num_params()
    }

    pub fn encoder_params(&self) -> usize {
        use crate::model::encoder::{BONE_FEATURES as F, BONE_INPUTS as I};
        match self.encoding {
            PoseEncoding::Hierarchical => {
                24 * 12 * F + F + 24 * ((I + F) * (I + F) + (I + F) + (I + F) * F + F)
            }
            PoseEncoding::Quaternion => 0,
        }
    }

    /// Heads and low-rank bases.
    pub fn head_params(&self) -> usize {
        let (c, h) = (self.encoding.output_len(), self.head_hidden);
        self.layer_shapes()
            .into_iter()
            .map(|(fan_in, fan_out)| {
                let out = self.head_outputs(fan_in, fan_out);
                c * h
                    + h
                    + 2 * h
                    + h * h
                    + h
                    + 2 * h
                    + h * out
                    + out
                    + self.layer_rank(fan_in).map_or(0, |r| fan_in * r)
            })
            .sum()
    }

    pub fn init(&self, meta_sdf: Siren, seed: u64, device: &Device) -> HyperNet {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x4E7E);
        let encoder = BoneEncoder::init(self.encoding, seed, device);
        let cond = self.encoding.output_len();
        let mut heads = Vec::new();
        let mut bases = Vec::new();
        for (fan_in, fan_out) in self.layer_shapes() {
            heads.push(Head::init(
                &mut rng,
                cond,
                self.head_hidden,
                self.head_outputs(fan_in, fan_out),
                device,
            ));
            if let Some(r) = self.layer_rank(fan_in) {
                let bound = 1.0 / (fan_in as f32).sqrt();
                let u: Vec<f32> =
                    (0..fan_in * r).map(|_| rng.random_range(-bound..bound)).collect();
                bases.push(Param::from_tensor(Tensor::from_data(
                    TensorData::new(u, [fan_in, r]),
                    device,
                )));
            }
        }
        HyperNet { encoder, heads, bases, sdf: meta_sdf }
    }
}

/// One head: Linear -> LayerNorm -> ReLU, twice, then a zero-initialised linear layer.
#[derive(Module, Debug)]
pub struct Head {
    pub w: Vec<Param<Tensor<2>>>,
    pub b: Vec<Param<Tensor<1>>>,
    /// LayerNorm scale and shift of the two hidden layers.
    pub gamma: Vec<Param<Tensor<1>>>,
    pub beta: Vec<Param<Tensor<1>>>,
}

impl Head {
    fn init(
        rng: &mut ChaCha8Rng,
        inputs: usize,
        hidden: usize,
        outputs: usize,
        device: &Device,
    ) -> Head {
        let mut head = Head { w: vec![], b: vec![], gamma: vec![], beta: vec![] };
        for fan_in in [inputs, hidden] {
            // Kaiming normal (fan_in, ReLU) as in the reference; biases PyTorch's default.
            let std = (2.0 / fan_in as f32).sqrt();
            let w: Vec<f32> = (0..fan_in * hidden).map(|_| gauss(rng) * std).collect();
            head.w.push(Param::from_tensor(Tensor::from_data(
                TensorData::new(w, [fan_in, hidden]),
                device,
            )));
            let (_, b) = default_linear(rng, fan_in, hidden, device);
            head.b.push(b);
            head.gamma.push(Param::from_tensor(Tensor::ones([hidden], device)));
            head.beta.push(Param::from_tensor(Tensor::zeros([hidden], device)));
        }
        head.w.push(Param::from_tensor(Tensor::zeros([hidden, outputs], device)));
        head.b.push(Param::from_tensor(Tensor::zeros([outputs], device)));
        head
    }

    fn forward(&self, cond: Tensor<2>) -> Tensor<2> {
        let mut h = cond;
        for l in 0..2 {
            let z = h.matmul(self.w[l].val()) + self.b[l].val().unsqueeze_dim::<2>(0);
            h = relu(layer_norm(z, self.gamma[l].val(), self.beta[l].val()));
        }
        h.matmul(self.w[2].val()) + self.b[2].val().unsqueeze_dim::<2>(0)
    }
}

fn layer_norm(x: Tensor<2>, gamma: Tensor<1>, beta: Tensor<1>) -> Tensor<2> {
    let mean = x.clone().mean_dim(1);
    let centred = x - mean;
    let var = (centred.clone() * centred.clone()).mean_dim(1);
    centred / (var + 1e-5).sqrt() * gamma.unsqueeze_dim::<2>(0) + beta.unsqueeze_dim::<2>(0)
}

/// The pose-conditioned SDF: encoder, heads, low-rank bases and the meta-SDF whose weights the
/// residuals are added to.
#[derive(Module, Debug)]
pub struct HyperNet {
    pub encoder: BoneEncoder,
    pub heads: Vec<Head>,
    /// U_l [in, rank] of each layer (empty for full residuals).
    pub bases: Vec<Param<Tensor<2>>>,
    pub sdf: Siren,
}

/// SIREN layers predicted for a batch of poses.
pub struct PredictedLayers {
    /// [B, in, out] per layer.
    pub weights: Vec<Tensor<3>>,
    /// [B, out] per layer.
    pub biases: Vec<Tensor<2>>,
    /// Sum of squared residuals over all layers, mean over the batch (for the regulariser).
    pub residual_sq: Tensor<1>,
}

impl HyperNet {
    /// The sizes this network was built with.
    pub fn config(&self) -> HyperConfig {
        let widths: Vec<usize> = self.sdf.weights.iter().map(|w| w.val().dims()[1]).collect();
        let siren = SirenConfig { hidden: widths[0], layers: widths.len() - 1 };
        let head_hidden = self.heads[0].w[0].val().dims()[1];
        let rank = self.bases.iter().map(|u| u.val().dims()[1]).max();
        let encoding = if self.encoder.prior_w.is_empty() {
            crate::model::encoder::PoseEncoding::Quaternion
        } else {
            crate::model::encoder::PoseEncoding::Hierarchical
        };
        HyperConfig { siren, head_hidden, rank, encoding }
    }

    /// Pose inputs [B, input_len] -> one SIREN weight set per pose.
    pub fn predict(&self, pose_inputs: Tensor<2>) -> PredictedLayers {
        let batch = pose_inputs.dims()[0];
        let cond = self.encoder.forward(pose_inputs);
        let (base_w, base_b) = self.sdf.params();
        let mut weights = Vec::new();
        let mut biases = Vec::new();
        let mut residual_sq: Option<Tensor<1>> = None;
        for (l, head) in self.heads.iter().enumerate() {
            let [fan_in, fan_out] = base_w[l].dims();
            let out = head.forward(cond.clone());
            let width = out.dims()[1] - fan_out;
            let db = out.clone().slice([0..batch, width..width + fan_out]);
            let dw = match self.bases.get(l) {
                Some(u) => {
                    let r = width / fan_out;
                    let c = out.slice([0..batch, 0..width]).reshape([batch, r, fan_out]);
                    u.val().unsqueeze_dim::<3>(0).repeat_dim(0, batch).matmul(c)
                }
                None => out.slice([0..batch, 0..width]).reshape([batch, fan_in, fan_out]),
            };
            let sq = (dw.clone() * dw.clone()).sum() + (db.clone() * db.clone()).sum();
            residual_sq = Some(match residual_sq {
                Some(acc) => acc + sq,
                None => sq,
            });
            weights.push(base_w[l].clone().unsqueeze_dim::<3>(0) + dw);
            biases.push(base_b[l].clone().unsqueeze_dim::<2>(0) + db);
        }
        let residual_sq = residual_sq.expect("at least one layer") / batch as f32;
        PredictedLayers { weights, biases, residual_sq }
    }

    /// The SIREN of one pose (pose input of length input_len), for meshing.
    pub fn siren_for(
        &self,
        pose_input: &[f32],
        device: &Device,
    ) -> (Vec<Tensor<2>>, Vec<Tensor<1>>) {
        let x =
            Tensor::from_data(TensorData::new(pose_input.to_vec(), [1, pose_input.len()]), device);
        let p = self.predict(x);
        (
            p.weights.into_iter().map(|w| w.squeeze_dim::<2>(0)).collect(),
            p.biases.into_iter().map(|b| b.squeeze_dim::<1>(0)).collect(),
        )
    }
}
