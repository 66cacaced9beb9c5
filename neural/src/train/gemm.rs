//! Row-major single-precision matrix products for the training path, over matrixmultiply's
//! SGEMM: a transposed operand is the same buffer read with swapped strides, so no product
//! copies its inputs.

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

/// c = beta c + a b, with c row-major `m x n` (`m`, `n` from a and b).
pub fn gemm(a: Mat, b: Mat, beta: f32, c: &mut [f32]) {
    let (m, k) = a.shape();
    let (k2, n) = b.shape();
    assert_eq!(k, k2, "inner dimensions of a matrix product");
    assert!(c.len() >= m * n, "product buffer too small");
    if m == 0 || n == 0 {
        return;
    }
    let (rsa, csa) = a.strides();
    let (rsb, csb) = b.strides();
    // SAFETY: the views hold rows*cols elements (checked in `Mat::new` and above), and the
    // strides address exactly those elements; c holds m*n.
    unsafe {
        matrixmultiply::sgemm(m, k, n, 1.0, a.data.as_ptr(), rsa, csa, b.data.as_ptr(), rsb, csb, beta, c.as_mut_ptr(), n as isize, 1);
    }
}
