//! Row-major single-precision matrix products for the training path. A transposed operand is
//! the same buffer read with swapped strides, so no product copies its inputs.
//!
//! The training step's products are small and skinny (a block of 256 points times a 128-wide
//! layer), where a packing GEMM spends as long copying its operands into panels as
//! multiplying them (measured: 36 % packing, 27 % kernel). With AVX-512 (checked at run
//! time), products whose right operand is row-major with a width that is a multiple of 32 run
//! on `kernel`, which reads both operands in place and applies the product's [`Epilogue`] in
//! registers; with AVX2 + FMA instead, the same on `kernel::avx2` for widths that are a
//! multiple of 16. Everything else goes to matrixmultiply's SGEMM, then the epilogue in a loop.

use super::KernelPath;
use super::kernel::{self, Isa};

/// A row-major matrix view: `rows x cols` with an optional transpose.
#[derive(Clone, Copy)]
pub struct Mat<'a> {
    pub data: &'a [f32],
    pub rows: usize,
    pub cols: usize,
    /// Read as the transpose (the view is then `cols x rows`).
    pub t: bool,
}

impl<'a> Mat<'a> {
    pub fn new(data: &'a [f32], rows: usize, cols: usize) -> Mat<'a> {
        debug_assert!(data.len() >= rows * cols);
        Mat { data, rows, cols, t: false }
    }

    pub fn t(self) -> Mat<'a> {
        Mat { t: !self.t, ..self }
    }

    /// Shape as read (rows, cols).
    fn shape(&self) -> (usize, usize) {
        if self.t { (self.cols, self.rows) } else { (self.rows, self.cols) }
    }

    /// (row stride, column stride) as read.
    fn strides(&self) -> (isize, isize) {
        if self.t { (1, self.cols as isize) } else { (self.cols as isize, 1) }
    }
}

/// What a product does with its result p = a b before it is stored. Every slice is laid out
/// like the result (`m x n` row-major), but `bias` (one row).
pub enum Epilogue<'a> {
    /// out = beta out + p (beta 0 or 1).
    Store { beta: f32 },
    /// A sine layer: z = w0 (p + bias); out = sin z, deriv = w0 cos z.
    Sine { w0: f32, bias: &'a [f32], deriv: &'a mut [f32] },
    /// out = p and times = p factor.
    AlsoTimes { factor: &'a [f32], times: &'a mut [f32] },
    /// v = scale p v h and out = p c (the reverse of a SIREN's spatial-gradient chain).
    GradChain { scale: f32, v: &'a mut [f32], h: &'a [f32], c: &'a [f32] },
    /// out += p factor.
    AddTimes { factor: &'a [f32] },
}

/// c = beta c + a b, with c row-major `m x n` (`m`, `n` from a and b); beta is 0 or 1.
pub fn gemm(a: Mat, b: Mat, beta: f32, c: &mut [f32]) {
    gemm_then(a, b, c, Epilogue::Store { beta });
}

/// out = the epilogue of a b, with out row-major `m x n`, on the process's kernels.
pub fn gemm_then(a: Mat, b: Mat, out: &mut [f32], ep: Epilogue) {
    gemm_then_on(kernel::current(), a, b, out, ep)
}

/// [`gemm_then`] on the kernels `path` runs on this CPU, whatever the process chose: how the
/// tests hold each path to a plain sum.
pub fn gemm_then_with(path: KernelPath, a: Mat, b: Mat, out: &mut [f32], ep: Epilogue) {
    gemm_then_on(kernel::resolve(path), a, b, out, ep)
}

fn gemm_then_on(isa: Option<Isa>, a: Mat, b: Mat, out: &mut [f32], ep: Epilogue) {
    let (m, k) = a.shape();
    let (k2, n) = b.shape();
    assert_eq!(k, k2, "inner dimensions of a matrix product");
    assert!(
        a.data.len() >= a.rows * a.cols && b.data.len() >= b.rows * b.cols,
        "operand views larger than their buffers"
    );
    let size = m * n;
    assert!(out.len() >= size, "product buffer too small");
    let sized = match &ep {
        Epilogue::Store { .. } => true,
        Epilogue::Sine { bias, deriv, .. } => bias.len() >= n && deriv.len() >= size,
        Epilogue::AlsoTimes { factor, times } => factor.len() >= size && times.len() >= size,
        Epilogue::GradChain { v, h, c, .. } => {
            v.len() >= size && h.len() >= size && c.len() >= size
        }
        Epilogue::AddTimes { factor } => factor.len() >= size,
    };
    assert!(sized, "epilogue buffers smaller than the product");
    if m == 0 || n == 0 {
        return;
    }
    let (rsa, csa) = a.strides();
    #[cfg(not(target_arch = "x86_64"))]
    let _ = isa;
    #[cfg(target_arch = "x86_64")]
    if let Some(isa) = isa
        && !b.t
        && n % kernel::tile_columns(isa) == 0
        && k > 0
    {
        use kernel::Raw;
        let raw = match ep {
            Epilogue::Store { beta } => Raw::Store { beta },
            Epilogue::Sine { w0, bias, deriv } => {
                Raw::Sine { w0, bias: bias.as_ptr(), deriv: deriv.as_mut_ptr() }
            }
            Epilogue::AlsoTimes { factor, times } => {
                Raw::AlsoTimes { factor: factor.as_ptr(), times: times.as_mut_ptr() }
            }
            Epilogue::GradChain { scale, v, h, c } => {
                Raw::GradChain { scale, v: v.as_mut_ptr(), h: h.as_ptr(), c: c.as_ptr() }
            }
            Epilogue::AddTimes { factor } => Raw::AddTimes { factor: factor.as_ptr() },
        };
        let (a, b, out) = (a.data.as_ptr(), b.data.as_ptr(), out.as_mut_ptr());
        // SAFETY: the CPU has `isa` (`kernel::resolve`); a's strides address its m x k view
        // inside its buffer, b is row-major k x n with n a multiple of the tile's columns, out
        // and the epilogue's buffers hold m x n (all checked above).
        unsafe { kernel::gemm(isa, m, k, n, a, rsa, csa, b, out, raw) };
        return;
    }
    // a b^T with b row-major: dot products of rows, in place (matrixmultiply would pack b,
    // and the heads' b is a whole weight matrix multiplied by a few rows).
    #[cfg(target_arch = "x86_64")]
    if let Some(isa) = isa
        && b.t
        && !a.t
        && k > 0
        && let Epilogue::Store { beta } = ep
    {
        let (a, b, out) = (a.data.as_ptr(), b.data.as_ptr(), out.as_mut_ptr());
        // SAFETY: the CPU has `isa` (`kernel::resolve`); a holds m x k, b's buffer n x k, out
        // m x n (checked above).
        unsafe { kernel::dots(isa, m, k, n, a, b, beta, out) };
        return;
    }
    let (rsb, csb) = b.strides();
    let plain = |beta: f32, c: &mut [f32]| {
        // SAFETY: the views hold rows*cols elements (checked above), and the strides address
        // exactly those elements; c holds m*n.
        unsafe {
            matrixmultiply::sgemm(
                m,
                k,
                n,
                1.0,
                a.data.as_ptr(),
                rsa,
                csa,
                b.data.as_ptr(),
                rsb,
                csb,
                beta,
                c.as_mut_ptr(),
                n as isize,
                1,
            )
        }
    };
    let out = &mut out[..size];
    match ep {
        Epilogue::Store { beta } => plain(beta, out),
        Epilogue::Sine { w0, bias, deriv } => {
            plain(0.0, out);
            for (row, d_row) in out.chunks_exact_mut(n).zip(deriv.chunks_exact_mut(n)) {
                for ((o, d), b) in row.iter_mut().zip(d_row.iter_mut()).zip(bias) {
                    let (s, c) = crate::model::sine::sin_cos(w0 * (*o + b));
                    (*o, *d) = (s, w0 * c);
                }
            }
        }
        Epilogue::AlsoTimes { factor, times } => {
            plain(0.0, out);
            for ((t, o), f) in times.iter_mut().zip(out.iter()).zip(factor) {
                *t = o * f;
            }
        }
        Epilogue::GradChain { scale, v, h, c } => {
            plain(0.0, out);
            for (((o, v), h), c) in out.iter_mut().zip(v.iter_mut()).zip(h).zip(c) {
                *v *= scale * *o * h;
                *o *= c;
            }
        }
        Epilogue::AddTimes { factor } => {
            let mut p = vec![0f32; size];
            plain(0.0, &mut p);
            for ((o, p), f) in out.iter_mut().zip(&p).zip(factor) {
                *o += p * f;
            }
        }
    }
}

/// out[i * r + j] = beta out[i * r + j] + a_i . rows_j, for a `m x k` and rows `r x k`, both
/// row-major (out `m x r`): the products with a layer of width 1 or 3.
pub fn dots(a: &[f32], rows: &[f32], k: usize, beta: f32, out: &mut [f32]) {
    dots_on(kernel::current(), a, rows, k, beta, out)
}

/// [`dots`] on the kernels `path` runs on this CPU (the tests' choice, as [`gemm_then_with`]).
pub fn dots_with(path: KernelPath, a: &[f32], rows: &[f32], k: usize, beta: f32, out: &mut [f32]) {
    dots_on(kernel::resolve(path), a, rows, k, beta, out)
}

fn dots_on(isa: Option<Isa>, a: &[f32], rows: &[f32], k: usize, beta: f32, out: &mut [f32]) {
    let (m, r) = (a.len() / k.max(1), rows.len() / k.max(1));
    assert!(out.len() >= m * r, "product buffer too small");
    #[cfg(target_arch = "x86_64")]
    if let Some(isa) = isa
        && k > 0
    {
        // SAFETY: the CPU has `isa`; a holds m x k, rows r x k, out m x r (checked above).
        unsafe { kernel::dots(isa, m, k, r, a.as_ptr(), rows.as_ptr(), beta, out.as_mut_ptr()) };
        return;
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = isa;
    for (ai, oi) in a.chunks_exact(k.max(1)).zip(out.chunks_exact_mut(r.max(1))) {
        for (bj, o) in rows.chunks_exact(k.max(1)).zip(oi.iter_mut()) {
            let s: f32 = ai.iter().zip(bj).map(|(x, y)| x * y).sum();
            *o = if beta == 0.0 { s } else { *o + s };
        }
    }
}

/// sums[j] += the sum over rows of m[row, j] (a bias's gradient), m row-major with
/// `sums.len()` columns.
pub fn add_column_sums(m: &[f32], sums: &mut [f32]) {
    for row in m.chunks_exact(sums.len()) {
        for (s, v) in sums.iter_mut().zip(row) {
            *s += v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Epilogue, KernelPath, Mat, dots_with, gemm_then_with};

    /// Every kernel path, each run explicitly (not through the process's choice, so the tests
    /// of one binary cannot change each other's kernels).
    const PATHS: [KernelPath; 3] = [KernelPath::Fastest, KernelPath::Avx2, KernelPath::Portable];

    /// The kernels a path must run here: a CPU with AVX2 and FMA runs the AVX2 kernel when
    /// asked (a silent fall-back to the plain loops would leave it untested).
    #[test]
    fn each_path_runs_its_kernel_on_this_cpu() {
        use crate::training::step::kernel_name_of;
        assert_eq!(kernel_name_of(KernelPath::Portable), "portable");
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 = std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma");
            let avx512 = std::arch::is_x86_feature_detected!("avx512f");
            assert_eq!(kernel_name_of(KernelPath::Avx2), if avx2 { "AVX2" } else { "portable" });
            let fastest = if avx512 {
                "AVX-512"
            } else if avx2 {
                "AVX2"
            } else {
                "portable"
            };
            assert_eq!(kernel_name_of(KernelPath::Fastest), fastest);
        }
    }

    fn gemm(path: KernelPath, a: Mat, b: Mat, beta: f32, c: &mut [f32]) {
        gemm_then_with(path, a, b, c, Epilogue::Store { beta });
    }

    fn naive(a: &[f32], b: &[f32], m: usize, k: usize, n: usize, at: bool, bt: bool) -> Vec<f32> {
        let mut c = vec![0f32; m * n];
        for i in 0..m {
            for j in 0..n {
                let mut s = 0f64;
                for p in 0..k {
                    let av = if at { a[p * m + i] } else { a[i * k + p] };
                    let bv = if bt { b[j * k + p] } else { b[p * n + j] };
                    s += av as f64 * bv as f64;
                }
                c[i * n + j] = s as f32;
            }
        }
        c
    }

    #[test]
    fn products_match_a_plain_sum_for_every_layout_and_edge() {
        for &(m, k, n) in &[
            (13, 128, 128),
            (256, 128, 128),
            (128, 37, 128),
            (9, 3, 64),
            (5, 128, 3),
            (33, 7, 1),
            (8, 256, 32),
            (7, 64, 48),
            (19, 256, 16),
            (6, 1, 80),
        ] {
            for (path, at) in PATHS.into_iter().flat_map(|p| [(p, false), (p, true)]) {
                for bt in [false, true] {
                    let a: Vec<f32> =
                        (0..m * k).map(|i| ((i * 37 % 101) as f32 - 50.0) * 0.01).collect();
                    let b: Vec<f32> =
                        (0..k * n).map(|i| ((i * 53 % 97) as f32 - 48.0) * 0.01).collect();
                    let am = if at { Mat::new(&a, k, m).t() } else { Mat::new(&a, m, k) };
                    let bm = if bt { Mat::new(&b, n, k).t() } else { Mat::new(&b, k, n) };
                    let expected = naive(&a, &b, m, k, n, at, bt);
                    let mut c = vec![1f32; m * n];
                    gemm(path, am, bm, 0.0, &mut c);
                    let mut acc = vec![1f32; m * n];
                    gemm(path, am, bm, 1.0, &mut acc);
                    for i in 0..m * n {
                        assert!(
                            (c[i] - expected[i]).abs() < 1e-4,
                            "{path:?} {m}x{k}x{n} at {at} bt {bt}: {} vs {}",
                            c[i],
                            expected[i]
                        );
                        assert!(
                            (acc[i] - 1.0 - expected[i]).abs() < 1e-4,
                            "{path:?} accumulate {m}x{k}x{n}"
                        );
                    }
                }
            }
        }
    }

    fn data(len: usize, seed: usize) -> Vec<f32> {
        (0..len).map(|i| (((i * 37 + seed * 11) % 101) as f32 - 50.0) * 0.01).collect()
    }

    #[test]
    fn every_epilogue_matches_its_formula_on_the_plain_product() {
        let w0 = 30.0;
        let shapes = [(128, 128, 128), (13, 3, 64), (25, 37, 32), (11, 256, 48), (7, 19, 16)];
        for (path, &(m, k, n)) in PATHS.iter().flat_map(|&p| shapes.iter().map(move |s| (p, s))) {
            let (a, b) = (data(m * k, 1), data(k * n, 2));
            // The plain product from the same kernel (the sine's argument is w0 times it: a
            // float-sum difference would show as 30 times larger).
            let mut p = vec![0f32; m * n];
            gemm(path, Mat::new(&a, m, k), Mat::new(&b, k, n), 0.0, &mut p);
            let reference = naive(&a, &b, m, k, n, false, false);
            assert!(
                p.iter().zip(&reference).all(|(x, y)| (x - y).abs() < 1e-4),
                "{path:?} plain product {m}x{k}x{n}"
            );
            let (f1, f2, f3) = (data(m * n, 3), data(m * n, 4), data(m * n, 5));
            let bias = data(n, 6);
            let close = |x: f32, y: f32, what: &str| {
                assert!(
                    (x - y).abs() <= 1e-4 * (1.0 + y.abs()),
                    "{path:?} {what} {m}x{k}x{n}: {x} vs {y}"
                )
            };
            let (am, bm) = (Mat::new(&a, m, k), Mat::new(&b, k, n));

            let (mut h, mut c) = (vec![0f32; m * n], vec![0f32; m * n]);
            gemm_then_with(path, am, bm, &mut h, Epilogue::Sine { w0, bias: &bias, deriv: &mut c });
            for i in 0..m * n {
                let z = w0 * (p[i] + bias[i % n]);
                // The same z on every path (no fused operation in w0 (p + bias)), so only the
                // sine's polynomial differs from the library's: a few ulps.
                let tight = |x: f32, y: f32, what: &str| {
                    assert!((x - y).abs() <= 2e-6, "{path:?} {what} {m}x{k}x{n}: {x} vs {y}")
                };
                tight(h[i], z.sin(), "sine");
                tight(c[i] / w0, z.cos(), "cosine");
            }
            let (mut out, mut times) = (vec![0f32; m * n], vec![0f32; m * n]);
            gemm_then_with(
                path,
                am,
                bm,
                &mut out,
                Epilogue::AlsoTimes { factor: &f1, times: &mut times },
            );
            for i in 0..m * n {
                close(out[i], p[i], "product");
                close(times[i], p[i] * f1[i], "times");
            }
            let mut v = f2.clone();
            gemm_then_with(
                path,
                am,
                bm,
                &mut out,
                Epilogue::GradChain { scale: -2.0, v: &mut v, h: &f1, c: &f3 },
            );
            for i in 0..m * n {
                close(v[i], -2.0 * p[i] * f2[i] * f1[i], "chain v");
                close(out[i], p[i] * f3[i], "chain out");
            }
            let mut acc = f2.clone();
            gemm_then_with(path, am, bm, &mut acc, Epilogue::AddTimes { factor: &f1 });
            for i in 0..m * n {
                close(acc[i], f2[i] + p[i] * f1[i], "add times");
            }
        }
    }

    #[test]
    fn dots_match_a_plain_sum() {
        let shapes = [
            (128, 128, 3),
            (7, 1152, 128),
            (5, 17, 1),
            (3, 8, 2),
            (8, 1031, 5),
            (9, 5003, 6),
            (5, 8200, 3),
            (2, 23, 3),
            (13, 256, 1),
            (21, 40, 3),
        ];
        for (path, &(m, k, r)) in PATHS.iter().flat_map(|&p| shapes.iter().map(move |s| (p, s))) {
            let (a, rows) = (data(m * k, 7), data(r * k, 8));
            let expected = naive(&a, &rows, m, k, r, false, true);
            let mut out = vec![1f32; m * r];
            dots_with(path, &a, &rows, k, 1.0, &mut out);
            // A float sum's rounding grows with its length.
            let tolerance = 1e-5 * (k as f32 / 1000.0).max(1.0);
            for i in 0..m * r {
                assert!(
                    (out[i] - 1.0 - expected[i]).abs() < tolerance * (1.0 + expected[i].abs()),
                    "{path:?} {m}x{k}x{r}: {} vs {}",
                    out[i] - 1.0,
                    expected[i]
                );
            }
        }
    }

    /// The kernels take several rows of a together; each row's sum must be the one it gets
    /// alone (the fit's results do not depend on how many rows a block has).
    #[test]
    fn dots_of_a_block_equal_each_row_alone_bit_for_bit() {
        for path in PATHS {
            for &(m, k, r) in &[(19, 256, 1), (11, 131, 3), (9, 1031, 2)] {
                let (a, rows) = (data(m * k, 3), data(r * k, 4));
                let mut block = vec![0f32; m * r];
                dots_with(path, &a, &rows, k, 0.0, &mut block);
                for i in 0..m {
                    let mut alone = vec![0f32; r];
                    dots_with(path, &a[i * k..(i + 1) * k], &rows, k, 0.0, &mut alone);
                    for j in 0..r {
                        assert_eq!(
                            block[i * r + j].to_bits(),
                            alone[j].to_bits(),
                            "{path:?} {m}x{k}x{r}, row {i}"
                        );
                    }
                }
            }
        }
    }
}
