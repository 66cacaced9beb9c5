//! Row-major single-precision matrix products for the training path. A transposed operand is
//! the same buffer read with swapped strides, so no product copies its inputs.
//!
//! The training step's products are small and skinny (a block of 256 points times a 128-wide
//! layer), where a packing GEMM spends as long copying its operands into panels as
//! multiplying them (measured: 36 % packing, 27 % kernel). With AVX-512 (checked at run
//! time), products whose right operand is row-major with a width that is a multiple of 32 run
//! on a kernel that reads both operands in place: 8 rows x 32 columns of the result in 16
//! registers, one broadcast of the left operand and two loads of the right one per 16 fused
//! multiply-adds. Everything else goes to matrixmultiply's SGEMM.

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

/// c = beta c + a b, with c row-major `m x n` (`m`, `n` from a and b); beta is 0 or 1.
pub fn gemm(a: Mat, b: Mat, beta: f32, c: &mut [f32]) {
    let (m, k) = a.shape();
    let (k2, n) = b.shape();
    assert_eq!(k, k2, "inner dimensions of a matrix product");
    assert!(a.data.len() >= a.rows * a.cols && b.data.len() >= b.rows * b.cols, "operand views larger than their buffers");
    assert!(c.len() >= m * n, "product buffer too small");
    if m == 0 || n == 0 {
        return;
    }
    let (rsa, csa) = a.strides();
    #[cfg(target_arch = "x86_64")]
    if !b.t && n % 32 == 0 && k > 0 && avx512::available() {
        // SAFETY: the CPU has AVX-512F (checked); a's strides address its m x k view inside its
        // buffer, b is row-major k x n, c holds m x n (all checked above).
        unsafe { avx512::gemm(m, k, n, a.data.as_ptr(), rsa, csa, b.data.as_ptr(), beta, c.as_mut_ptr()) };
        return;
    }
    let (rsb, csb) = b.strides();
    // SAFETY: the views hold rows*cols elements (checked above), and the strides address
    // exactly those elements; c holds m*n.
    unsafe {
        matrixmultiply::sgemm(m, k, n, 1.0, a.data.as_ptr(), rsa, csa, b.data.as_ptr(), rsb, csb, beta, c.as_mut_ptr(), n as isize, 1);
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

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use std::arch::x86_64::*;
    use std::sync::OnceLock;

    pub fn available() -> bool {
        static AVAILABLE: OnceLock<bool> = OnceLock::new();
        *AVAILABLE.get_or_init(|| std::arch::is_x86_feature_detected!("avx512f") && std::env::var_os("AVATAR_NO_AVX512").is_none())
    }

    const MR: usize = 8;
    const NR: usize = 32;

    /// c (m x n, row-major) = beta c + a b; a element (i, p) at a[i * rsa + p * csa]; b
    /// row-major k x n; n a multiple of 32.
    #[target_feature(enable = "avx512f")]
    #[allow(clippy::too_many_arguments)]
    pub unsafe fn gemm(m: usize, k: usize, n: usize, a: *const f32, rsa: isize, csa: isize, b: *const f32, beta: f32, c: *mut f32) {
        let mut i0 = 0;
        while i0 < m {
            let rows = MR.min(m - i0);
            let mut j0 = 0;
            while j0 < n {
                // SAFETY: the tile lies inside the m x n result and reads rows i0..i0+rows of
                // a and columns j0..j0+32 of b (the caller's contract).
                unsafe {
                    match rows {
                        8 => tile::<8>(k, n, a, rsa, csa, b, beta, c, i0, j0),
                        7 => tile::<7>(k, n, a, rsa, csa, b, beta, c, i0, j0),
                        6 => tile::<6>(k, n, a, rsa, csa, b, beta, c, i0, j0),
                        5 => tile::<5>(k, n, a, rsa, csa, b, beta, c, i0, j0),
                        4 => tile::<4>(k, n, a, rsa, csa, b, beta, c, i0, j0),
                        3 => tile::<3>(k, n, a, rsa, csa, b, beta, c, i0, j0),
                        2 => tile::<2>(k, n, a, rsa, csa, b, beta, c, i0, j0),
                        _ => tile::<1>(k, n, a, rsa, csa, b, beta, c, i0, j0),
                    }
                }
                j0 += NR;
            }
            i0 += MR;
        }
    }

    #[target_feature(enable = "avx512f")]
    #[allow(clippy::too_many_arguments)]
    #[inline]
    unsafe fn tile<const R: usize>(k: usize, n: usize, a: *const f32, rsa: isize, csa: isize, b: *const f32, beta: f32, c: *mut f32, i0: usize, j0: usize) {
        // SAFETY (whole body): indices stay within the caller's m x k, k x n and m x n views.
        // Pointer steps use wrapping arithmetic: the dev profile's overflow checks in the inner
        // loop kept the accumulators out of registers.
        unsafe {
            let mut acc = [[_mm512_setzero_ps(); 2]; R];
            let rows: [*const f32; R] = std::array::from_fn(|d| a.wrapping_offset(rsa.wrapping_mul((i0 + d) as isize)));
            let mut a_step: isize = 0;
            let mut bp = b.wrapping_add(j0);
            for _ in 0..k {
                let b0 = _mm512_loadu_ps(bp);
                let b1 = _mm512_loadu_ps(bp.wrapping_add(16));
                for d in 0..R {
                    let av = _mm512_set1_ps(*rows[d].wrapping_offset(a_step));
                    acc[d][0] = _mm512_fmadd_ps(av, b0, acc[d][0]);
                    acc[d][1] = _mm512_fmadd_ps(av, b1, acc[d][1]);
                }
                a_step = a_step.wrapping_add(csa);
                bp = bp.wrapping_add(n);
            }
            for (d, acc) in acc.iter().enumerate() {
                let cp = c.wrapping_add((i0 + d).wrapping_mul(n).wrapping_add(j0));
                if beta == 0.0 {
                    _mm512_storeu_ps(cp, acc[0]);
                    _mm512_storeu_ps(cp.add(16), acc[1]);
                } else {
                    _mm512_storeu_ps(cp, _mm512_add_ps(_mm512_loadu_ps(cp), acc[0]));
                    _mm512_storeu_ps(cp.add(16), _mm512_add_ps(_mm512_loadu_ps(cp.add(16)), acc[1]));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{gemm, Mat};

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
        for &(m, k, n) in &[(13, 128, 128), (256, 128, 128), (128, 37, 128), (9, 3, 64), (5, 128, 3), (33, 7, 1), (8, 256, 32)] {
            for at in [false, true] {
                for bt in [false, true] {
                    let a: Vec<f32> = (0..m * k).map(|i| ((i * 37 % 101) as f32 - 50.0) * 0.01).collect();
                    let b: Vec<f32> = (0..k * n).map(|i| ((i * 53 % 97) as f32 - 48.0) * 0.01).collect();
                    let am = if at { Mat::new(&a, k, m).t() } else { Mat::new(&a, m, k) };
                    let bm = if bt { Mat::new(&b, n, k).t() } else { Mat::new(&b, k, n) };
                    let expected = naive(&a, &b, m, k, n, at, bt);
                    let mut c = vec![1f32; m * n];
                    gemm(am, bm, 0.0, &mut c);
                    let mut acc = vec![1f32; m * n];
                    gemm(am, bm, 1.0, &mut acc);
                    for i in 0..m * n {
                        assert!((c[i] - expected[i]).abs() < 1e-4, "{m}x{k}x{n} at {at} bt {bt}: {} vs {}", c[i], expected[i]);
                        assert!((acc[i] - 1.0 - expected[i]).abs() < 1e-4, "accumulate {m}x{k}x{n}");
                    }
                }
            }
        }
    }
}
