//! One SIREN's loss gradient with respect to its weights when the loss reads both the SDF
//! values and their spatial gradients (the IGR loss): a forward pass, the spatial gradient in
//! reverse mode, then the reverse pass over both (reverse over reverse). Per sine layer that
//! is six matrix products of the layer's size, against twelve for the three forward-mode
//! tangents the burn reference pushes; every product is one SGEMM over a block of points that
//! stays in cache, and every buffer is reused from step to step.
//!
//! Notation (layer k maps width w_k to w_{k+1}; the last layer is linear to one output):
//!   z_k = h_{k-1} W_k + b_k,  h_k = sin(W0 z_k),  c_k = W0 cos(W0 z_k),  f = z_last
//!   spatial gradient: v_last-1 = W_last (a column), q_k = v_k * c_k, v_{k-1} = q_k W_k^T,
//!   grad f = v_{-1}.
//! The adjoints follow the two chains backwards; the sine's second derivative enters through
//! c_k: d c_k / d z_k = -W0^2 h_k.

use super::gemm::{add_column_sums, gemm, Mat};
use crate::siren::W0;
use crate::siren_eval::sin_cos;

/// Where each layer's weights and biases sit in a SIREN's flat parameter vector (the burn
/// module's visit order: every weight matrix [in, out], then every bias).
#[derive(Debug, Clone, PartialEq)]
pub struct SirenShape {
    widths: Vec<usize>,
    w_off: Vec<usize>,
    b_off: Vec<usize>,
    len: usize,
}

impl SirenShape {
    /// From layer widths 3 -> ... -> 1.
    pub fn new(widths: &[usize]) -> SirenShape {
        assert!(widths.len() >= 2 && widths[0] == 3 && widths[widths.len() - 1] == 1, "a SIREN maps 3 inputs to 1 output");
        let mut off = 0;
        let mut w_off = Vec::new();
        for p in widths.windows(2) {
            w_off.push(off);
            off += p[0] * p[1];
        }
        let mut b_off = Vec::new();
        for &out in &widths[1..] {
            b_off.push(off);
            off += out;
        }
        SirenShape { widths: widths.to_vec(), w_off, b_off, len: off }
    }

    pub fn of(config: &crate::siren::SirenConfig) -> SirenShape {
        SirenShape::new(&config.widths())
    }

    pub fn layers(&self) -> usize {
        self.widths.len() - 1
    }

    /// Parameters in all.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// (fan_in, fan_out) of layer `k`.
    pub fn dims(&self, k: usize) -> (usize, usize) {
        (self.widths[k], self.widths[k + 1])
    }

    pub fn w_range(&self, k: usize) -> std::ops::Range<usize> {
        let (i, o) = self.dims(k);
        self.w_off[k]..self.w_off[k] + i * o
    }

    pub fn b_range(&self, k: usize) -> std::ops::Range<usize> {
        self.b_off[k]..self.b_off[k] + self.widths[k + 1]
    }

    fn widest(&self) -> usize {
        self.widths.iter().copied().max().unwrap_or(1)
    }
}

/// The loss of a block of points and its adjoints: given the SDF values `f` [n] and spatial
/// gradients `g` [n, 3] of rows `first..first + n` of a step's points, write dL/df and dL/dg
/// and return the block's share of the loss terms.
pub trait PointLoss: Sync {
    fn adjoint(&self, group: usize, first: usize, f: &[f32], g: &[f32], d_f: &mut [f32], d_g: &mut [f32]) -> LossTerms;
}

/// Shares of the loss (already weighted): on-surface, normal, off-surface, eikonal, sign prior.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LossTerms {
    pub terms: [f64; 5],
}

impl LossTerms {
    pub fn add(&mut self, other: &LossTerms) {
        for (a, b) in self.terms.iter_mut().zip(other.terms) {
            *a += b;
        }
    }

    pub fn total(&self) -> f64 {
        self.terms.iter().sum()
    }
}

/// Buffers of one block of at most `rows` points, reused across steps.
pub struct SirenScratch {
    rows: usize,
    x: Vec<f32>,
    /// Per sine layer: activation h, derivative c, spatial-gradient factor v, product q.
    h: Vec<Vec<f32>>,
    c: Vec<Vec<f32>>,
    v: Vec<Vec<f32>>,
    q: Vec<Vec<f32>>,
    f: Vec<f32>,
    g: Vec<f32>,
    d_f: Vec<f32>,
    d_g: Vec<f32>,
    t1: Vec<f32>,
    t2: Vec<f32>,
    /// Each layer's weights transposed ([out, in]): products with W^T then read both operands
    /// row-major (the fast kernel of `gemm`).
    wt: Vec<Vec<f32>>,
}

impl SirenScratch {
    pub fn new(shape: &SirenShape, rows: usize) -> SirenScratch {
        let hidden = shape.layers() - 1;
        let layer = |k: usize| vec![0f32; rows * shape.widths[k + 1]];
        let wide = rows * shape.widest();
        SirenScratch {
            rows,
            x: vec![0f32; rows * 3],
            h: (0..hidden).map(layer).collect(),
            c: (0..hidden).map(layer).collect(),
            v: (0..hidden).map(layer).collect(),
            q: (0..hidden).map(layer).collect(),
            f: vec![0f32; rows],
            g: vec![0f32; rows * 3],
            d_f: vec![0f32; rows],
            d_g: vec![0f32; rows * 3],
            t1: vec![0f32; wide],
            t2: vec![0f32; wide],
            wt: (0..shape.layers()).map(|k| vec![0f32; shape.widths[k] * shape.widths[k + 1]]).collect(),
        }
    }
}

/// Add the gradient of the loss over one block of points to `grad` (same layout as `params`)
/// and return the block's loss terms. `group` and `first` tell `loss` which points these are.
#[allow(clippy::too_many_arguments)]
pub fn siren_backward(shape: &SirenShape, params: &[f32], points: &[[f32; 3]], loss: &dyn PointLoss, group: usize, first: usize, s: &mut SirenScratch, grad: &mut [f32]) -> LossTerms {
    let n = points.len();
    assert!(n <= s.rows, "block larger than its scratch");
    let last = shape.layers() - 1;
    let w = |k: usize| &params[shape.w_range(k)];
    let b = |k: usize| &params[shape.b_range(k)];
    for (row, p) in s.x.chunks_exact_mut(3).zip(points) {
        row.copy_from_slice(p);
    }
    for k in 0..=last {
        let (fan_in, fan_out) = shape.dims(k);
        let (src, dst) = (w(k), &mut s.wt[k]);
        for i in 0..fan_in {
            for j in 0..fan_out {
                dst[j * fan_in + i] = src[i * fan_out + j];
            }
        }
    }

    // Forward: z_k = h_{k-1} W_k + b_k; h_k = sin(W0 z_k), c_k = W0 cos(W0 z_k).
    for k in 0..=last {
        let (fan_in, fan_out) = shape.dims(k);
        let z: &mut [f32] = if k == last { &mut s.f[..n] } else { &mut s.t1[..n * fan_out] };
        for row in z.chunks_exact_mut(fan_out) {
            row.copy_from_slice(b(k));
        }
        let input = if k == 0 { &s.x[..n * 3] } else { &s.h[k - 1][..n * fan_in] };
        gemm(Mat::new(input, n, fan_in), Mat::new(w(k), fan_in, fan_out), 1.0, z);
        if k < last {
            let (h, c) = (&mut s.h[k][..n * fan_out], &mut s.c[k][..n * fan_out]);
            for ((z, h), c) in s.t1[..n * fan_out].iter().zip(h.iter_mut()).zip(c.iter_mut()) {
                let (sin, cos) = sin_cos(W0 * z);
                *h = sin;
                *c = W0 * cos;
            }
        }
    }

    // Spatial gradient: v_{last-1} = W_last (one column) for every point; q_k = v_k c_k;
    // v_{k-1} = q_k W_k^T; the input's gradient is the last v.
    let top = shape.widths[last];
    for row in s.v[last - 1][..n * top].chunks_exact_mut(top) {
        row.copy_from_slice(w(last));
    }
    for k in (0..last).rev() {
        let (fan_in, fan_out) = shape.dims(k);
        for ((q, v), c) in s.q[k][..n * fan_out].iter_mut().zip(&s.v[k][..n * fan_out]).zip(&s.c[k][..n * fan_out]) {
            *q = v * c;
        }
        let out: &mut [f32] = if k == 0 { &mut s.g[..n * 3] } else { &mut s.v[k - 1][..n * fan_in] };
        gemm(Mat::new(&s.q[k][..n * fan_out], n, fan_out), Mat::new(&s.wt[k], fan_out, fan_in), 0.0, out);
    }

    let terms = loss.adjoint(group, first, &s.f[..n], &s.g[..n * 3], &mut s.d_f[..n], &mut s.d_g[..n * 3]);

    // Reverse of the gradient chain, from the input up. t1 holds the adjoint of v_{k-1}
    // (the adjoint of the input's gradient first); per layer: adj q_k = adj v_{k-1} W_k,
    // dW_k += adj v_{k-1}^T q_k, adj v_k = adj q_k c_k, and adj z_k gets
    // adj q_k v_k (-W0^2 h_k), kept in v_k's buffer (v_k is not needed any more).
    s.t1[..n * 3].copy_from_slice(&s.d_g[..n * 3]);
    for k in 0..last {
        let (fan_in, fan_out) = shape.dims(k);
        gemm(Mat::new(&s.t1[..n * fan_in], n, fan_in), Mat::new(w(k), fan_in, fan_out), 0.0, &mut s.t2[..n * fan_out]);
        gemm(Mat::new(&s.t1[..n * fan_in], n, fan_in).t(), Mat::new(&s.q[k][..n * fan_out], n, fan_out), 1.0, &mut grad[shape.w_range(k)]);
        let second = -W0 * W0;
        for ((((aq, v), h), c), av) in s.t2[..n * fan_out].iter().zip(s.v[k][..n * fan_out].iter_mut()).zip(&s.h[k][..n * fan_out]).zip(&s.c[k][..n * fan_out]).zip(s.t1[..n * fan_out].iter_mut()) {
            *v = second * aq * *v * h;
            *av = aq * c;
        }
    }
    // v_{last-1} is W_last broadcast over the points: its adjoint sums into W_last.
    add_column_sums(&s.t1[..n * top], &mut grad[shape.w_range(last)]);

    // Reverse of the forward chain: adj z_last = dL/df; adj h_{last-1} = adj z_last W_last^T.
    gemm(Mat::new(&s.h[last - 1][..n * top], n, top).t(), Mat::new(&s.d_f[..n], n, 1), 1.0, &mut grad[shape.w_range(last)]);
    grad[shape.b_range(last)][0] += s.d_f[..n].iter().sum::<f32>();
    for (row, &a) in s.t1[..n * top].chunks_exact_mut(top).zip(&s.d_f[..n]) {
        for (r, wv) in row.iter_mut().zip(w(last)) {
            *r = a * wv;
        }
    }
    for k in (0..last).rev() {
        let (fan_in, fan_out) = shape.dims(k);
        // adj z_k = adj h_k c_k + (the gradient chain's share, in v_k's buffer).
        for ((az, ah), c) in s.v[k][..n * fan_out].iter_mut().zip(&s.t1[..n * fan_out]).zip(&s.c[k][..n * fan_out]) {
            *az += ah * c;
        }
        let input = if k == 0 { &s.x[..n * 3] } else { &s.h[k - 1][..n * fan_in] };
        gemm(Mat::new(input, n, fan_in).t(), Mat::new(&s.v[k][..n * fan_out], n, fan_out), 1.0, &mut grad[shape.w_range(k)]);
        add_column_sums(&s.v[k][..n * fan_out], &mut grad[shape.b_range(k)]);
        if k > 0 {
            gemm(Mat::new(&s.v[k][..n * fan_out], n, fan_out), Mat::new(&s.wt[k], fan_out, fan_in), 0.0, &mut s.t1[..n * fan_in]);
        }
    }
    terms
}
