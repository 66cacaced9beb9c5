//! Inverse skinning by root finding (SNARF / PINA): find canonical x with
//! sum_i w_i(x) B_i x = x_posed, where w is the diffused skinning field. Broyden's method from
//! several starts (the inverse transform of bones near the point), keeping converged roots.

use super::field::SkinningField;
use crate::body::{NUM_JOINTS, SMPL_PARENTS, blend_transform};
use glam::{Mat3, Mat4, Vec3};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RootOptions {
    pub max_steps: usize,
    /// Converged when the posed residual is below this (metres).
    pub tolerance: f32,
    /// A start whose residual grows beyond this (metres) has diverged.
    pub divergence: f32,
    pub max_starts: usize,
}

impl Default for RootOptions {
    fn default() -> Self {
        RootOptions { max_steps: 50, tolerance: 1e-5, divergence: 1.0, max_starts: 9 }
    }
}

/// One converged canonical root.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Root {
    pub canonical: Vec3,
    pub start_bone: usize,
    /// The field's weight of the start bone at the root (how much the root "belongs" to it).
    pub agreement: f32,
    pub residual: f32,
    pub steps: usize,
}

/// Forward skinning of a canonical point with the field.
pub fn forward_point(field: &SkinningField, bones: &[Mat4; NUM_JOINTS], x: Vec3) -> Vec3 {
    blend_transform(bones, &field.weights_at(x)).transform_point3(x)
}

/// Start bones for a posed point: the bones that most influence it (by the weights of the
/// nearest posed body vertex), their parents and children, at most `max` of them.
pub fn start_bones(near_weights: &[f32; NUM_JOINTS], max: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..NUM_JOINTS).collect();
    order.sort_by(|&a, &b| near_weights[b].total_cmp(&near_weights[a]));
    let mut out = Vec::with_capacity(max);
    let push = |j: usize, out: &mut Vec<usize>| {
        if out.len() < max && !out.contains(&j) {
            out.push(j);
        }
    };
    for &j in order.iter().take(3) {
        push(j, &mut out);
    }
    for &j in order.iter().take(3) {
        if SMPL_PARENTS[j] >= 0 {
            push(SMPL_PARENTS[j] as usize, &mut out);
        }
        if let Some(c) = (0..NUM_JOINTS).find(|&c| SMPL_PARENTS[c] == j as i32) {
            push(c, &mut out);
        }
    }
    // The SNARF default starts fill the rest (pelvis, hips, knees, shoulders, elbows).
    for j in [0, 1, 2, 4, 5, 16, 17, 18, 19] {
        push(j, &mut out);
    }
    out
}

/// All converged roots from the given start bones.
pub fn find_roots(
    field: &SkinningField,
    bones: &[Mat4; NUM_JOINTS],
    posed: Vec3,
    starts: &[usize],
    options: &RootOptions,
) -> Vec<Root> {
    let mut roots: Vec<Root> = Vec::new();
    for &b in starts {
        if let Some(r) = broyden(field, bones, posed, b, options) {
            // Several starts often reach the same root: keep one.
            if !roots.iter().any(|q| (q.canonical - r.canonical).length() < 1e-3) {
                roots.push(r);
            }
        }
    }
    roots
}

/// The root Broyden's method reaches from the canonical point `x0` (a root for a nearby pose:
/// pose refinement's warm start); its `start_bone` is the bone of largest weight at `x0`.
pub fn find_root_from(
    field: &SkinningField,
    bones: &[Mat4; NUM_JOINTS],
    posed: Vec3,
    x0: Vec3,
    options: &RootOptions,
) -> Option<Root> {
    if !x0.is_finite() {
        return None;
    }
    let w = field.weights_at(x0);
    let start = (0..NUM_JOINTS).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
    broyden_from(field, bones, posed, x0, start, options)
}

fn broyden(
    field: &SkinningField,
    bones: &[Mat4; NUM_JOINTS],
    posed: Vec3,
    start: usize,
    options: &RootOptions,
) -> Option<Root> {
    broyden_from(
        field,
        bones,
        posed,
        bones[start].inverse().transform_point3(posed),
        start,
        options,
    )
}

fn broyden_from(
    field: &SkinningField,
    bones: &[Mat4; NUM_JOINTS],
    posed: Vec3,
    x0: Vec3,
    start: usize,
    options: &RootOptions,
) -> Option<Root> {
    let mut x = x0;
    // The field's weights at a point, their blend and the residual there (each point's
    // weights are looked up once: the lookup is most of a step).
    let eval = |x: Vec3| {
        let w = field.weights_at(x);
        let blend = blend_transform(bones, &w);
        (w, blend, blend.transform_point3(x) - posed)
    };
    let (mut w, blend, mut g) = eval(x);
    // Initial inverse Jacobian: the inverse of the blended linear part at the start point
    // (the derivative of the weights is neglected, as in SNARF's initialisation).
    let a = Mat3::from_mat4(blend);
    if a.determinant().abs() < 1e-8 {
        return None;
    }
    let mut j_inv = a.inverse();
    for step in 0..options.max_steps {
        let r = g.length();
        if !r.is_finite() || r > options.divergence {
            return None;
        }
        if r < options.tolerance {
            return field.contains(x).then(|| Root {
                canonical: x,
                start_bone: start,
                agreement: w[start],
                residual: r,
                steps: step,
            });
        }
        let dx = -(j_inv * g);
        let x_new = x + dx;
        let (w_new, _, g_new) = eval(x_new);
        let dg = g_new - g;
        // "Good" Broyden update of the inverse Jacobian.
        let denom = dx.dot(j_inv * dg);
        if denom.abs() > 1e-20 {
            let u = (dx - j_inv * dg) / denom;
            let v = j_inv.transpose() * dx;
            j_inv += Mat3::from_cols(u * v.x, u * v.y, u * v.z);
        }
        x = x_new;
        g = g_new;
        w = w_new;
    }
    let r = g.length();
    (r < options.tolerance && field.contains(x)).then(|| Root {
        canonical: x,
        start_bone: start,
        agreement: w[start],
        residual: r,
        steps: options.max_steps,
    })
}
