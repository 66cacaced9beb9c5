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

use super::elementwise;
use super::gemm::{Epilogue, Mat, add_column_sums, dots, gemm, gemm_then};
use crate::model::siren::W0;

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
        assert!(
            widths.len() >= 2 && widths[0] == 3 && widths[widths.len() - 1] == 1,
            "a SIREN maps 3 inputs to 1 output"
        );
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

    pub fn of(config: &crate::model::siren::SirenConfig) -> SirenShape {
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
    fn adjoint(
        &self,
        group: usize,
        first: usize,
        f: &[f32],
        g: &[f32],
        d_f: &mut [f32],
        d_g: &mut [f32],
    ) -> LossTerms;
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
        }
    }
}

/// Each layer's weights transposed ([out, in]) into `wt`: products with W^T then read both
/// operands row-major (the fast kernel of `gemm`). Once per SIREN and step, shared by its
/// blocks.
pub fn transpose_weights(shape: &SirenShape, params: &[f32], wt: &mut Vec<Vec<f32>>) {
    wt.resize_with(shape.layers(), Vec::new);
    for (k, dst) in wt.iter_mut().enumerate() {
        let (fan_in, fan_out) = shape.dims(k);
        let src = &params[shape.w_range(k)];
        dst.resize(fan_in * fan_out, 0.0);
        for i in 0..fan_in {
            for j in 0..fan_out {
                dst[j * fan_in + i] = src[i * fan_out + j];
            }
        }
    }
}

/// The gradient of the loss over one block of points into `grad` (same layout as `params`;
/// added to it when `accumulate`, else overwritten) and the block's loss terms. `wt`: `transpose_weights` of `params`; `group` and
/// `first` tell `loss` which points these are.
#[allow(clippy::too_many_arguments)]
pub fn siren_backward(
    shape: &SirenShape,
    params: &[f32],
    wt: &[Vec<f32>],
    points: &[[f32; 3]],
    loss: &dyn PointLoss,
    group: usize,
    first: usize,
    s: &mut SirenScratch,
    grad: &mut [f32],
    accumulate: bool,
) -> LossTerms {
    let n = points.len();
    assert!(n <= s.rows, "block larger than its scratch");
    let last = shape.layers() - 1;
    let w = |k: usize| &params[shape.w_range(k)];
    let b = |k: usize| &params[shape.b_range(k)];
    for (row, p) in s.x.chunks_exact_mut(3).zip(points) {
        row.copy_from_slice(p);
    }
    let top = shape.widths[last];

    // Forward: h_k = sin(W0 z_k), c_k = W0 cos(W0 z_k) from z_k = h_{k-1} W_k + b_k in the
    // product's epilogue; f = h_{last-1} . W_last + b_last.
    for k in 0..last {
        let (fan_in, fan_out) = shape.dims(k);
        let (below, above) = s.h.split_at_mut(k);
        let input = if k == 0 { &s.x[..n * 3] } else { &below[k - 1][..n * fan_in] };
        let ep = Epilogue::Sine { w0: W0, bias: b(k), deriv: &mut s.c[k][..n * fan_out] };
        gemm_then(
            Mat::new(input, n, fan_in),
            Mat::new(w(k), fan_in, fan_out),
            &mut above[0][..n * fan_out],
            ep,
        );
    }
    dots(&s.h[last - 1][..n * top], w(last), top, 0.0, &mut s.f[..n]);
    let b_last = b(last)[0];
    s.f[..n].iter_mut().for_each(|f| *f += b_last);

    // Spatial gradient: v_{last-1} = W_last (one column) for every point; q_k = v_k c_k;
    // v_{k-1} = q_k W_k^T (q_{k-1} in the same product's epilogue); the input's gradient
    // is the last v.
    elementwise::broadcast_times(
        w(last),
        &s.c[last - 1][..n * top],
        &mut s.v[last - 1][..n * top],
        &mut s.q[last - 1][..n * top],
    );
    for k in (1..last).rev() {
        let (fan_in, fan_out) = shape.dims(k);
        let (q_below, q_above) = s.q.split_at_mut(k);
        let ep = Epilogue::AlsoTimes {
            factor: &s.c[k - 1][..n * fan_in],
            times: &mut q_below[k - 1][..n * fan_in],
        };
        gemm_then(
            Mat::new(&q_above[0][..n * fan_out], n, fan_out),
            Mat::new(&wt[k], fan_out, fan_in),
            &mut s.v[k - 1][..n * fan_in],
            ep,
        );
    }
    dots(&s.q[0][..n * shape.widths[1]], w(0), shape.widths[1], 0.0, &mut s.g[..n * 3]);

    let terms =
        loss.adjoint(group, first, &s.f[..n], &s.g[..n * 3], &mut s.d_f[..n], &mut s.d_g[..n * 3]);

    // Reverse of the gradient chain, from the input up. `adj` holds the adjoint of v_{k-1}
    // (the adjoint of the input's gradient first); per layer: dW_k += adj v_{k-1}^T q_k,
    // adj q_k = adj v_{k-1} W_k, and in that product's epilogue adj v_k = adj q_k c_k and
    // v_k's buffer takes adj z_k's share adj q_k v_k (-W0^2 h_k) (v_k is not needed any more).
    s.t1[..n * 3].copy_from_slice(&s.d_g[..n * 3]);
    let (mut adj, mut next) = (&mut s.t1, &mut s.t2);
    for k in 0..last {
        let (fan_in, fan_out) = shape.dims(k);
        // The first of dW_k's two products overwrites unless accumulating (no pass to zero it).
        let beta = if accumulate { 1.0 } else { 0.0 };
        gemm(
            Mat::new(&adj[..n * fan_in], n, fan_in).t(),
            Mat::new(&s.q[k][..n * fan_out], n, fan_out),
            beta,
            &mut grad[shape.w_range(k)],
        );
        let ep = Epilogue::GradChain {
            scale: -W0 * W0,
            v: &mut s.v[k][..n * fan_out],
            h: &s.h[k][..n * fan_out],
            c: &s.c[k][..n * fan_out],
        };
        gemm_then(
            Mat::new(&adj[..n * fan_in], n, fan_in),
            Mat::new(w(k), fan_in, fan_out),
            &mut next[..n * fan_out],
            ep,
        );
        std::mem::swap(&mut adj, &mut next);
    }

    // v_{last-1} is W_last broadcast over the points, f = h_{last-1} . W_last + b_last: both
    // chains' adjoints sum into W_last. adj h_{last-1} = dL/df W_last, and adj z_{last-1} =
    // adj h_{last-1} c_{last-1} + its share from the gradient chain (in v's buffer).
    if !accumulate {
        for k in 0..=last {
            grad[shape.b_range(k)].fill(0.0);
        }
        grad[shape.w_range(last)].fill(0.0);
    }
    elementwise::last_layer_grad(
        &adj[..n * top],
        &s.h[last - 1][..n * top],
        &s.d_f[..n],
        &mut grad[shape.w_range(last)],
    );
    grad[shape.b_range(last)][0] += s.d_f[..n].iter().sum::<f32>();
    elementwise::add_outer_times(
        &s.d_f[..n],
        w(last),
        &s.c[last - 1][..n * top],
        &mut s.v[last - 1][..n * top],
    );

    // Reverse of the forward chain: dW_k += h_{k-1}^T adj z_k, db_k += adj z_k, and adj
    // z_{k-1} = (adj z_k W_k^T) c_{k-1} + its gradient-chain share, in the product's epilogue.
    for k in (0..last).rev() {
        let (fan_in, fan_out) = shape.dims(k);
        let input = if k == 0 { &s.x[..n * 3] } else { &s.h[k - 1][..n * fan_in] };
        gemm(
            Mat::new(input, n, fan_in).t(),
            Mat::new(&s.v[k][..n * fan_out], n, fan_out),
            1.0,
            &mut grad[shape.w_range(k)],
        );
        add_column_sums(&s.v[k][..n * fan_out], &mut grad[shape.b_range(k)]);
        if k > 0 {
            let (below, above) = s.v.split_at_mut(k);
            let ep = Epilogue::AddTimes { factor: &s.c[k - 1][..n * fan_in] };
            gemm_then(
                Mat::new(&above[0][..n * fan_out], n, fan_out),
                Mat::new(&wt[k], fan_out, fan_in),
                &mut below[k - 1][..n * fan_in],
                ep,
            );
        }
    }
    terms
}
