//! The pose condition of the hypernetwork: a LEAP-style hierarchical bone encoder of the 24
//! bone transforms (MetaAvatar's variant: root rotation dropped, absolute normalised rest
//! joints, no final ReLU), or the plain quaternion encoding (23 joints x 4) as an option.

use avatar_core::body::BodyParams;
use avatar_core::body::skeleton::{NUM_JOINTS, SMPL_PARENTS as PARENTS};
use avatar_core::canonical::Normalisation;
use burn::module::{Module, Param};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use glam::{Mat3, Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Inputs per joint for the hierarchical encoder: rotation (9), rest joint (3), bone length (1).
pub const BONE_INPUTS: usize = 13;
/// Features per joint out of the hierarchical encoder.
pub const BONE_FEATURES: usize = 6;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseEncoding {
    /// LEAP-style hierarchical bone encoder: 24 x 6 = 144 features.
    Hierarchical,
    /// Unit quaternions of the 23 non-root joints: 92 features, no parameters.
    Quaternion,
}

impl PoseEncoding {
    /// Length of the CPU-side input vector of one pose.
    pub fn input_len(&self) -> usize {
        match self {
            PoseEncoding::Hierarchical => NUM_JOINTS * BONE_INPUTS,
            PoseEncoding::Quaternion => (NUM_JOINTS - 1) * 4,
        }
    }

    /// Length of the condition the hypernetwork heads receive.
    pub fn output_len(&self) -> usize {
        match self {
            PoseEncoding::Hierarchical => NUM_JOINTS * BONE_FEATURES,
            PoseEncoding::Quaternion => (NUM_JOINTS - 1) * 4,
        }
    }

    /// The input vector of one pose. `rest_joints`: the subject's rest joints in metres;
    /// `norm`: the subject's canonical normalisation. The global orientation (joint 0) is
    /// dropped: the avatar lives in the canonical frame.
    pub fn input(
        &self,
        params: &BodyParams,
        rest_joints: &[Vec3; NUM_JOINTS],
        norm: &Normalisation,
    ) -> Vec<f32> {
        let rotations = params.rotations();
        match self {
            PoseEncoding::Hierarchical => {
                let unit: Vec<Vec3> = rest_joints.iter().map(|j| norm.to_unit(*j)).collect();
                let mut out = Vec::with_capacity(self.input_len());
                for j in 0..NUM_JOINTS {
                    let r = if j == 0 { Mat3::IDENTITY } else { rotations[j] };
                    // Row-major rotation matrix.
                    out.extend_from_slice(&r.transpose().to_cols_array());
                    out.extend_from_slice(&unit[j].to_array());
                    let parent = PARENTS[j];
                    let length = if parent < 0 {
                        unit[j].length()
                    } else {
                        (unit[j] - unit[parent as usize]).length()
                    };
                    out.push(length);
                }
                out
            }
            PoseEncoding::Quaternion => {
                let mut out = Vec::with_capacity(self.input_len());
                for r in rotations.iter().skip(1) {
                    let q = Quat::from_mat3(r).normalize();
                    // One of the two signs, so equal rotations give equal features.
                    let q = if q.w < 0.0 { -q } else { q };
                    out.extend_from_slice(&q.to_array());
                }
                out
            }
        }
    }
}

/// The hierarchical encoder's parameters (empty for the quaternion encoding).
#[derive(Module, Debug)]
pub struct BoneEncoder {
    /// Global prior over all rotations and joints: [24 x 12, 6] (root's parent feature).
    pub prior_w: Vec<Param<Tensor<2>>>,
    pub prior_b: Vec<Param<Tensor<1>>>,
    /// Per joint: Linear(19, 19) -> ReLU -> Linear(19, 6).
    pub w1: Vec<Param<Tensor<2>>>,
    pub b1: Vec<Param<Tensor<1>>>,
    pub w2: Vec<Param<Tensor<2>>>,
    pub b2: Vec<Param<Tensor<1>>>,
}

/// PyTorch's default linear initialisation, U(+-1/sqrt(fan_in)) for weights and biases.
pub(crate) fn default_linear(
    rng: &mut ChaCha8Rng,
    fan_in: usize,
    fan_out: usize,
    device: &Device,
) -> (Param<Tensor<2>>, Param<Tensor<1>>) {
    let bound = 1.0 / (fan_in as f32).sqrt();
    let w: Vec<f32> = (0..fan_in * fan_out).map(|_| rng.random_range(-bound..bound)).collect();
    let b: Vec<f32> = (0..fan_out).map(|_| rng.random_range(-bound..bound)).collect();
    (
        Param::from_tensor(Tensor::from_data(TensorData::new(w, [fan_in, fan_out]), device)),
        Param::from_tensor(Tensor::from_data(TensorData::new(b, [fan_out]), device)),
    )
}

fn linear(x: Tensor<2>, w: &Param<Tensor<2>>, b: &Param<Tensor<1>>) -> Tensor<2> {
    x.matmul(w.val()) + b.val().unsqueeze_dim::<2>(0)
}

impl BoneEncoder {
    pub fn init(encoding: PoseEncoding, seed: u64, device: &Device) -> BoneEncoder {
        let mut e = BoneEncoder {
            prior_w: vec![],
            prior_b: vec![],
            w1: vec![],
            b1: vec![],
            w2: vec![],
            b2: vec![],
        };
        if encoding == PoseEncoding::Quaternion {
            return e;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xB0E5);
        let (w, b) = default_linear(&mut rng, NUM_JOINTS * 12, BONE_FEATURES, device);
        e.prior_w.push(w);
        e.prior_b.push(b);
        for _ in 0..NUM_JOINTS {
            let n = BONE_INPUTS + BONE_FEATURES;
            let (w, b) = default_linear(&mut rng, n, n, device);
            e.w1.push(w);
            e.b1.push(b);
            let (w, b) = default_linear(&mut rng, n, BONE_FEATURES, device);
            e.w2.push(w);
            e.b2.push(b);
        }
        e
    }

    /// Inputs [B, input_len] -> condition [B, output_len].
    pub fn forward(&self, input: Tensor<2>) -> Tensor<2> {
        if self.prior_w.is_empty() {
            return input;
        }
        let b = input.dims()[0];
        let bone = |j: usize| input.clone().slice([0..b, j * BONE_INPUTS..(j + 1) * BONE_INPUTS]);
        let rot_and_joint: Vec<Tensor<2>> =
            (0..NUM_JOINTS).map(|j| bone(j).slice([0..b, 0..12])).collect();
        let prior = linear(Tensor::cat(rot_and_joint, 1), &self.prior_w[0], &self.prior_b[0]);
        // Joints come in kinematic order: a parent's feature is ready before its children.
        let mut features: Vec<Tensor<2>> = Vec::with_capacity(NUM_JOINTS);
        for j in 0..NUM_JOINTS {
            let parent =
                if PARENTS[j] < 0 { prior.clone() } else { features[PARENTS[j] as usize].clone() };
            let x = Tensor::cat(vec![bone(j), parent], 1);
            let h = relu(linear(x, &self.w1[j], &self.b1[j]));
            features.push(linear(h, &self.w2[j], &self.b2[j]));
        }
        Tensor::cat(features, 1)
    }
}
