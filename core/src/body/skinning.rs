//! Linear blend skinning of points and normals, and its exact inverse for given weights.

use super::skeleton::NUM_JOINTS;
use glam::{Mat3, Mat4, Vec3};

/// Skinning weights of one point: one per joint, summing to 1.
pub type Weights = [f32; NUM_JOINTS];

/// sum_i w_i B_i
pub fn blend_transform(bones: &[Mat4; NUM_JOINTS], w: &Weights) -> Mat4 {
    let mut m = Mat4::ZERO;
    for (b, &wi) in bones.iter().zip(w) {
        if wi != 0.0 {
            m += *b * wi;
        }
    }
    m
}

/// The weights at a point of a triangle: its three vertices' `weights` (`face`: their indices)
/// blended by the point's barycentric coordinates `b`.
pub fn interpolate_weights(weights: &[Weights], face: [usize; 3], b: Vec3) -> Weights {
    std::array::from_fn(|j| {
        b.x * weights[face[0]][j] + b.y * weights[face[1]][j] + b.z * weights[face[2]][j]
    })
}

pub fn skin_point(bones: &[Mat4; NUM_JOINTS], w: &Weights, p: Vec3) -> Vec3 {
    blend_transform(bones, w).transform_point3(p)
}

/// Normals transform by the inverse transpose of the blended linear part.
pub fn skin_normal(bones: &[Mat4; NUM_JOINTS], w: &Weights, n: Vec3) -> Vec3 {
    let m = Mat3::from_mat4(blend_transform(bones, w));
    (m.inverse().transpose() * n).normalize_or_zero()
}

/// Inverse LBS when the weights are known (ground truth): x = (sum w_i B_i)^-1 x_posed.
pub fn unskin_point(bones: &[Mat4; NUM_JOINTS], w: &Weights, p: Vec3) -> Vec3 {
    blend_transform(bones, w).inverse().transform_point3(p)
}

/// Normalise a weight row so it sums to 1 (uniform root weight if all zero).
pub fn normalized(mut w: Weights) -> Weights {
    for x in w.iter_mut() {
        *x = x.max(0.0);
    }
    let s: f32 = w.iter().sum();
    if s > 0.0 {
        w.iter_mut().for_each(|x| *x /= s);
    } else {
        w[0] = 1.0;
    }
    w
}

/// Index of the largest weight.
pub fn dominant_joint(w: &Weights) -> usize {
    let mut best = 0;
    for j in 1..NUM_JOINTS {
        if w[j] > w[best] {
            best = j;
        }
    }
    best
}
