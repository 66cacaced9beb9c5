//! Forward and reverse passes of the hypernetwork's small layers on flat parameters: the bone
//! encoder (pose -> condition) and the heads (condition -> per-layer residuals), for a batch
//! of poses. Shapes are tiny next to the SIREN's (a few poses), so plain products suffice.

use super::gemm::{Mat, add_column_sums, gemm};
use super::layout::{Block, EncoderLayout, HeadLayout};
use crate::model::encoder::{BONE_FEATURES, BONE_INPUTS};
use avatar_core::body::skeleton::{NUM_JOINTS, SMPL_PARENTS};

/// LayerNorm's epsilon in the burn reference (`hyper::layer_norm`).
const LN_EPS: f32 = 1e-5;

fn slice<'a>(p: &'a [f32], b: &Block) -> &'a [f32] {
    &p[b.range()]
}

/// out [rows, b.cols] = x [rows, b.rows] W + bias.
fn linear(x: &[f32], rows: usize, p: &[f32], w: &Block, bias: &Block, out: &mut [f32]) {
    let cols = w.cols;
    for row in out[..rows * cols].chunks_exact_mut(cols) {
        row.copy_from_slice(slice(p, bias));
    }
    gemm(
        Mat::new(x, rows, w.rows),
        Mat::new(slice(p, w), w.rows, w.cols),
        1.0,
        &mut out[..rows * cols],
    );
}

/// Reverse of [`linear`]: gW += x^T d_out, gb += column sums of d_out, and (if asked)
/// d_x = d_out W^T.
#[allow(clippy::too_many_arguments)]
fn linear_back(
    x: &[f32],
    rows: usize,
    p: &[f32],
    w: &Block,
    bias: &Block,
    d_out: &[f32],
    grad: &mut [f32],
    d_x: Option<&mut [f32]>,
) {
    let cols = w.cols;
    gemm(Mat::new(x, rows, w.rows).t(), Mat::new(d_out, rows, cols), 1.0, &mut grad[w.range()]);
    add_column_sums(&d_out[..rows * cols], &mut grad[bias.range()]);
    if let Some(d_x) = d_x {
        gemm(
            Mat::new(d_out, rows, cols),
            Mat::new(slice(p, w), w.rows, cols).t(),
            0.0,
            &mut d_x[..rows * w.rows],
        );
    }
}

/// Activations of the bone encoder for a batch, kept for its reverse pass.
#[derive(Default)]
pub struct EncoderPass {
    rows: usize,
    prior_in: Vec<f32>,
    /// Per joint: input [rows, 19], pre-activation of the hidden layer, hidden activation.
    x: Vec<Vec<f32>>,
    pre: Vec<Vec<f32>>,
    act: Vec<Vec<f32>>,
}

/// Inputs [rows, 24 x 13] -> condition [rows, 24 x 6].
pub fn encoder_forward(
    e: &EncoderLayout,
    p: &[f32],
    input: &[f32],
    rows: usize,
    pass: &mut EncoderPass,
    cond: &mut [f32],
) {
    let n = BONE_INPUTS + BONE_FEATURES;
    let cond_len = NUM_JOINTS * BONE_FEATURES;
    pass.rows = rows;
    pass.prior_in = vec![0f32; rows * NUM_JOINTS * 12];
    for r in 0..rows {
        for j in 0..NUM_JOINTS {
            let src = &input[r * NUM_JOINTS * BONE_INPUTS + j * BONE_INPUTS..][..12];
            pass.prior_in[r * NUM_JOINTS * 12 + j * 12..][..12].copy_from_slice(src);
        }
    }
    let mut prior = vec![0f32; rows * BONE_FEATURES];
    linear(&pass.prior_in, rows, p, &e.prior_w, &e.prior_b, &mut prior);
    pass.x = vec![vec![0f32; rows * n]; NUM_JOINTS];
    pass.pre = vec![vec![0f32; rows * n]; NUM_JOINTS];
    pass.act = vec![vec![0f32; rows * n]; NUM_JOINTS];
    let mut feature = vec![0f32; rows * BONE_FEATURES];
    for j in 0..NUM_JOINTS {
        for r in 0..rows {
            let x = &mut pass.x[j][r * n..(r + 1) * n];
            x[..BONE_INPUTS].copy_from_slice(
                &input[r * NUM_JOINTS * BONE_INPUTS + j * BONE_INPUTS..][..BONE_INPUTS],
            );
            let parent = SMPL_PARENTS[j];
            let pf = if parent < 0 {
                &prior[r * BONE_FEATURES..][..BONE_FEATURES]
            } else {
                &cond[r * cond_len + parent as usize * BONE_FEATURES..][..BONE_FEATURES]
            };
            x[BONE_INPUTS..].copy_from_slice(pf);
        }
        linear(&pass.x[j], rows, p, &e.w1[j], &e.b1[j], &mut pass.pre[j]);
        for (a, z) in pass.act[j].iter_mut().zip(&pass.pre[j]) {
            *a = z.max(0.0);
        }
        linear(&pass.act[j], rows, p, &e.w2[j], &e.b2[j], &mut feature);
        for r in 0..rows {
            cond[r * cond_len + j * BONE_FEATURES..][..BONE_FEATURES]
                .copy_from_slice(&feature[r * BONE_FEATURES..][..BONE_FEATURES]);
        }
    }
}

/// Reverse of [`encoder_forward`]: adds the encoder's gradient given d(loss)/d(condition).
pub fn encoder_backward(
    e: &EncoderLayout,
    p: &[f32],
    pass: &EncoderPass,
    d_cond: &[f32],
    grad: &mut [f32],
) {
    let rows = pass.rows;
    let n = BONE_INPUTS + BONE_FEATURES;
    let cond_len = NUM_JOINTS * BONE_FEATURES;
    // Adjoints of every joint's feature; children (higher indices) add into their parents.
    let mut d_feat = d_cond[..rows * cond_len].to_vec();
    let mut d_prior = vec![0f32; rows * BONE_FEATURES];
    let mut d_f = vec![0f32; rows * BONE_FEATURES];
    let mut d_act = vec![0f32; rows * n];
    let mut d_x = vec![0f32; rows * n];
    for j in (0..NUM_JOINTS).rev() {
        for r in 0..rows {
            d_f[r * BONE_FEATURES..][..BONE_FEATURES]
                .copy_from_slice(&d_feat[r * cond_len + j * BONE_FEATURES..][..BONE_FEATURES]);
        }
        linear_back(&pass.act[j], rows, p, &e.w2[j], &e.b2[j], &d_f, grad, Some(&mut d_act));
        for (d, z) in d_act.iter_mut().zip(&pass.pre[j]) {
            if *z <= 0.0 {
                *d = 0.0;
            }
        }
        linear_back(&pass.x[j], rows, p, &e.w1[j], &e.b1[j], &d_act, grad, Some(&mut d_x));
        let parent = SMPL_PARENTS[j];
        for r in 0..rows {
            let src = &d_x[r * n + BONE_INPUTS..(r + 1) * n];
            let dst = if parent < 0 {
                &mut d_prior[r * BONE_FEATURES..][..BONE_FEATURES]
            } else {
                &mut d_feat[r * cond_len + parent as usize * BONE_FEATURES..][..BONE_FEATURES]
            };
            for (d, s) in dst.iter_mut().zip(src) {
                *d += s;
            }
        }
    }
    linear_back(&pass.prior_in, rows, p, &e.prior_w, &e.prior_b, &d_prior, grad, None);
}

/// Activations of one head for a batch, kept for its reverse pass.
#[derive(Default)]
pub struct HeadPass {
    rows: usize,
    /// Per hidden layer: normalised y, LayerNorm output (before ReLU), activation, 1/sigma.
    y: [Vec<f32>; 2],
    n: [Vec<f32>; 2],
    a: [Vec<f32>; 2],
    rstd: [Vec<f32>; 2],
    /// The head's output [rows, outputs].
    pub out: Vec<f32>,
}

/// condition [rows, C] -> out [rows, outputs] (kept in `pass.out`).
pub fn head_forward(h: &HeadLayout, p: &[f32], cond: &[f32], rows: usize, pass: &mut HeadPass) {
    pass.rows = rows;
    let width = h.w[0].cols;
    for l in 0..2 {
        let mut z = vec![0f32; rows * width];
        let input: &[f32] = if l == 0 { cond } else { &pass.a[0] };
        linear(input, rows, p, &h.w[l], &h.b[l], &mut z);
        let (gamma, beta) = (slice(p, &h.gamma[l]), slice(p, &h.beta[l]));
        let (mut y, mut nn, mut a, mut rstd) = (
            vec![0f32; rows * width],
            vec![0f32; rows * width],
            vec![0f32; rows * width],
            vec![0f32; rows],
        );
        for r in 0..rows {
            let zr = &z[r * width..(r + 1) * width];
            let mean = zr.iter().sum::<f32>() / width as f32;
            let var = zr.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / width as f32;
            let inv = 1.0 / (var + LN_EPS).sqrt();
            rstd[r] = inv;
            for c in 0..width {
                let yv = (zr[c] - mean) * inv;
                let nv = yv * gamma[c] + beta[c];
                y[r * width + c] = yv;
                nn[r * width + c] = nv;
                a[r * width + c] = nv.max(0.0);
            }
        }
        pass.y[l] = y;
        pass.n[l] = nn;
        pass.a[l] = a;
        pass.rstd[l] = rstd;
    }
    // Kept across steps (2 MB a pose-batch for the paper's heads: a fresh one faulted its
    // pages in every step).
    let outputs = h.w[2].cols;
    pass.out.resize(rows * outputs, 0.0);
    linear(&pass.a[1], rows, p, &h.w[2], &h.b[2], &mut pass.out);
}

impl HeadPass {
    /// The output layer's input (the second hidden layer's activations) [rows, hidden].
    pub fn hidden(&self) -> &[f32] {
        &self.a[1]
    }
}

/// Reverse of [`head_forward`]: adds the head's gradient given d(loss)/d(out), but writes
/// (not adds) the output layer's weight gradient (`grad[h.w[2]]`: most of the network's
/// parameters, which the step therefore does not clear), or leaves it alone when not
/// `output_weights` (`HyperGradient::step` makes it inside Adam's update), and, if asked,
/// adds d(loss)/d(condition) into `d_cond`.
#[allow(clippy::too_many_arguments)]
pub fn head_backward(
    h: &HeadLayout,
    p: &[f32],
    cond: &[f32],
    pass: &HeadPass,
    d_out: &[f32],
    grad: &mut [f32],
    mut d_cond: Option<&mut [f32]>,
    output_weights: bool,
) {
    let rows = pass.rows;
    let width = h.w[0].cols;
    let mut d_a = vec![0f32; rows * width];
    // The output layer's two products (each a pass over its weights) on both cores; without
    // the weight gradient, d_out W^T's two halves of W (the same sums as one product).
    let (w, outputs) = (&h.w[2], h.w[2].cols);
    let (weights, d_out_m) = (slice(p, w), Mat::new(d_out, rows, outputs));
    if output_weights {
        let g_w = &mut grad[w.range()];
        rayon::join(
            || gemm(Mat::new(&pass.a[1], rows, w.rows).t(), d_out_m, 0.0, g_w),
            || gemm(d_out_m, Mat::new(weights, w.rows, outputs).t(), 0.0, &mut d_a),
        );
    } else {
        let half = w.rows / 2;
        let (top, bottom) = weights.split_at(half * outputs);
        let (mut d_top, mut d_bottom) =
            (vec![0f32; rows * half], vec![0f32; rows * (w.rows - half)]);
        rayon::join(
            || gemm(d_out_m, Mat::new(top, half, outputs).t(), 0.0, &mut d_top),
            || gemm(d_out_m, Mat::new(bottom, w.rows - half, outputs).t(), 0.0, &mut d_bottom),
        );
        for ((row, t), b) in d_a
            .chunks_exact_mut(width)
            .zip(d_top.chunks_exact(half))
            .zip(d_bottom.chunks_exact(w.rows - half))
        {
            row[..half].copy_from_slice(t);
            row[half..].copy_from_slice(b);
        }
    }
    add_column_sums(&d_out[..rows * outputs], &mut grad[h.b[2].range()]);
    let mut d_z = vec![0f32; rows * width];
    for l in (0..2).rev() {
        let gamma = slice(p, &h.gamma[l]);
        // ReLU, then the LayerNorm's affine part.
        let mut d_y = vec![0f32; rows * width];
        {
            let (g_gamma, g_beta) = (h.gamma[l].range(), h.beta[l].range());
            for r in 0..rows {
                for c in 0..width {
                    let i = r * width + c;
                    let dn = if pass.n[l][i] > 0.0 { d_a[i] } else { 0.0 };
                    grad[g_gamma.start + c] += dn * pass.y[l][i];
                    grad[g_beta.start + c] += dn;
                    d_y[i] = dn * gamma[c];
                }
            }
        }
        // LayerNorm: d_z = (d_y - mean(d_y) - y mean(d_y y)) / sigma.
        for r in 0..rows {
            let (dy, y) =
                (&d_y[r * width..(r + 1) * width], &pass.y[l][r * width..(r + 1) * width]);
            let m1 = dy.iter().sum::<f32>() / width as f32;
            let m2 = dy.iter().zip(y).map(|(a, b)| a * b).sum::<f32>() / width as f32;
            for c in 0..width {
                d_z[r * width + c] = (dy[c] - m1 - y[c] * m2) * pass.rstd[l][r];
            }
        }
        if l == 1 {
            linear_back(&pass.a[0], rows, p, &h.w[1], &h.b[1], &d_z, grad, Some(&mut d_a));
        } else {
            match d_cond.take() {
                Some(d_cond) => {
                    let mut d_c = vec![0f32; rows * h.w[0].rows];
                    linear_back(cond, rows, p, &h.w[0], &h.b[0], &d_z, grad, Some(&mut d_c));
                    for (a, b) in d_cond.iter_mut().zip(&d_c) {
                        *a += b;
                    }
                }
                None => linear_back(cond, rows, p, &h.w[0], &h.b[0], &d_z, grad, None),
            }
        }
    }
}
