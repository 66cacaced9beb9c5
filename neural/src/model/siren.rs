//! The SIREN signed distance network on [-1, 1]^3 with its spatial gradient carried by
//! forward-mode tangents: burn 0.22 has no double backward, so each layer pushes the three
//! tangent directions as one extra [3N, H] block through the same matrix multiply (a sine
//! layer scales the tangent by w0 cos(w0 z)). Reverse mode then differentiates the loss,
//! gradient terms included, with respect to the weights.

use burn::module::{Module, Param};
use burn::tensor::{Device, Tensor, TensorData};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// SIREN frequency of the sine layers.
pub const W0: f32 = 30.0;

#[derive(Module, Debug)]
pub struct Siren {
    /// Layer weights, [inputs, outputs].
    pub weights: Vec<Param<Tensor<2>>>,
    pub biases: Vec<Param<Tensor<1>>>,
}

/// Layer widths: 3 -> hidden x layers -> 1.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SirenConfig {
    pub hidden: usize,
    pub layers: usize,
}

impl SirenConfig {
    /// The paper's SDF: 3 -> 256, 5 x (256 -> 256), 256 -> 1 (the reference's
    /// `num_hidden_layers = 5` counts the hidden-to-hidden layers): 330,241 parameters.
    pub fn paper() -> Self {
        SirenConfig { hidden: 256, layers: 6 }
    }

    /// The compact default a laptop without a GPU can fine-tune.
    pub fn compact() -> Self {
        SirenConfig { hidden: 128, layers: 4 }
    }

    pub fn widths(&self) -> Vec<usize> {
        let mut w = vec![3];
        w.extend(std::iter::repeat_n(self.hidden, self.layers));
        w.push(1);
        w
    }

    /// Refuse sizes no network of this build has (checked before any size arithmetic): 1 to
    /// 64 layers of 1 to 4,096 (also `config::Check`).
    pub fn check(&self) -> crate::error::Result<()> {
        crate::config::within("siren.hidden", self.hidden, 1, 4096)?;
        crate::config::within("siren.layers", self.layers, 1, 64)
    }

    pub fn num_params(&self) -> usize {
        self.widths().windows(2).map(|p| p[0] * p[1] + p[1]).sum()
    }

    /// SIREN's initialisation (Sitzmann et al.): first layer U(-1/in, 1/in), the others
    /// U(-sqrt(6/in)/w0, sqrt(6/in)/w0); biases likewise. Seeded, deterministic.
    pub fn init(&self, seed: u64, device: &Device) -> Siren {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let widths = self.widths();
        let mut weights = Vec::new();
        let mut biases = Vec::new();
        for (l, p) in widths.windows(2).enumerate() {
            let (fan_in, fan_out) = (p[0], p[1]);
            let bound =
                if l == 0 { 1.0 / fan_in as f32 } else { (6.0 / fan_in as f32).sqrt() / W0 };
            let w: Vec<f32> =
                (0..fan_in * fan_out).map(|_| rng.random_range(-bound..bound)).collect();
            let b: Vec<f32> = (0..fan_out).map(|_| rng.random_range(-bound..bound)).collect();
            weights.push(Param::from_tensor(Tensor::from_data(
                TensorData::new(w, [fan_in, fan_out]),
                device,
            )));
            biases
                .push(Param::from_tensor(Tensor::from_data(TensorData::new(b, [fan_out]), device)));
        }
        Siren { weights, biases }
    }
}

/// Evaluate a SIREN given explicit layer parameters: SDF values [N, 1] and spatial gradients
/// [N, 3].
pub fn sdf_and_gradient(
    weights: &[Tensor<2>],
    biases: &[Tensor<1>],
    x: Tensor<2>,
) -> (Tensor<2>, Tensor<2>) {
    let w: Vec<Tensor<3>> = weights.iter().map(|w| w.clone().unsqueeze_dim::<3>(0)).collect();
    let b: Vec<Tensor<2>> = biases.iter().map(|b| b.clone().unsqueeze_dim::<2>(0)).collect();
    let (f, g) = batched_sdf_and_gradient(&w, &b, x.unsqueeze_dim::<3>(0));
    (f.squeeze_dim::<2>(0), g.squeeze_dim::<2>(0))
}

/// A batch of SIRENs, one per pose (the hypernetwork predicts a weight set per pose):
/// weights [B, in, out], biases [B, out], points [B, N, 3] -> SDF [B, N, 1] and spatial
/// gradients [B, N, 3].
pub fn batched_sdf_and_gradient(
    weights: &[Tensor<3>],
    biases: &[Tensor<2>],
    x: Tensor<3>,
) -> (Tensor<3>, Tensor<3>) {
    let [batch, n, _] = x.dims();
    let device = x.device();
    // Tangent block: rows [a * N + i] carry d/dx_a at point i; it starts as the identity.
    let mut eye = vec![0f32; batch * 3 * n * 3];
    for s in 0..batch {
        for a in 0..3 {
            for i in 0..n {
                eye[((s * 3 + a) * n + i) * 3 + a] = 1.0;
            }
        }
    }
    let mut t: Tensor<3> = Tensor::from_data(TensorData::new(eye, [batch, 3 * n, 3]), &device);
    let mut h = x;
    let last = weights.len() - 1;
    for (l, (w, b)) in weights.iter().zip(biases).enumerate() {
        let z = h.matmul(w.clone()) + b.clone().unsqueeze_dim::<3>(1);
        let tz = t.matmul(w.clone());
        if l == last {
            h = z;
            t = tz;
            break;
        }
        let s = z * W0;
        let c = s.clone().cos() * W0;
        h = s.sin();
        t = tz * Tensor::cat(vec![c.clone(), c.clone(), c], 1);
    }
    // [B, 3N, 1] -> [B, 3, N] -> [B, N, 3].
    let grad = t.reshape([batch, 3, n]).swap_dims(1, 2);
    (h, grad)
}

/// SDF values only (no tangents), for meshing: weights [in, out], biases [out], x [N, 3].
pub fn sdf_only(weights: &[Tensor<2>], biases: &[Tensor<1>], x: Tensor<2>) -> Tensor<2> {
    let last = weights.len() - 1;
    let mut h = x;
    for (l, (w, b)) in weights.iter().zip(biases).enumerate() {
        let z = h.matmul(w.clone()) + b.clone().unsqueeze_dim::<2>(0);
        h = if l == last { z } else { (z * W0).sin() };
    }
    h
}

impl Siren {
    /// The sizes this network was built with.
    pub fn config(&self) -> SirenConfig {
        let widths: Vec<usize> = self.weights.iter().map(|w| w.val().dims()[1]).collect();
        SirenConfig { hidden: widths[0], layers: widths.len() - 1 }
    }

    pub fn params(&self) -> (Vec<Tensor<2>>, Vec<Tensor<1>>) {
        (
            self.weights.iter().map(|w| w.val()).collect(),
            self.biases.iter().map(|b| b.val()).collect(),
        )
    }

    pub fn sdf_and_gradient(&self, x: Tensor<2>) -> (Tensor<2>, Tensor<2>) {
        let (w, b) = self.params();
        sdf_and_gradient(&w, &b, x)
    }

    /// SDF values only (no tangents), for meshing.
    pub fn sdf(&self, x: Tensor<2>) -> Tensor<2> {
        let (w, b) = self.params();
        sdf_only(&w, &b, x)
    }
}
