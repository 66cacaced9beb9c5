//! Adam fused into a weight gradient's product. The paper preset's heads end in five output
//! layers of 256 x 65,792 weights (84 M of its 85.6 M parameters): their gradient x^T d
//! (a layer's inputs and output adjoints over a step's poses) was written whole (344 MB), then
//! read back by Adam's pass over parameters, moments and gradient. Here the product's
//! epilogue applies Adam to each tile of the gradient while it is in registers, so it is
//! never stored.

use super::adam::{self, AdamStep};
use super::gemm::{Epilogue, Mat, gemm_then_with};
#[cfg(target_arch = "x86_64")]
use super::kernel;
use super::{KernelPath, kernel_path};
#[cfg(target_arch = "x86_64")]
use rayon::prelude::*;

/// Rows of the weight a task updates (a multiple of both kernels' tile heights, 6 and 12).
#[cfg(target_arch = "x86_64")]
const BLOCK: usize = 24;

/// Adam's `step` applied to a weight W [rows x n] (`p`, moments `m`, `v`) from its gradient
/// x^T d, x [k x rows] and d [k x n] row-major: the same parameters and moments as
/// `gemm(x^T, d)` into a buffer and then `step.apply` on it (bit for bit on the kernels,
/// which make each element's sum the same way either way). Where no kernel takes the product
/// (the portable path; n not a multiple of the kernel's tile) it is exactly that, with
/// `scratch` (rows x n) as the buffer.
#[allow(clippy::too_many_arguments)]
pub fn weight_grad_adam(
    x: &[f32],
    d: &[f32],
    (k, rows, n): (usize, usize, usize),
    p: &mut [f32],
    m: &mut [f32],
    v: &mut [f32],
    scratch: &mut [f32],
    step: AdamStep,
) {
    weight_grad_adam_with(kernel_path(), x, d, (k, rows, n), p, m, v, scratch, step)
}

/// [`weight_grad_adam`] on the kernels `path` runs on this CPU (the tests hold each path;
/// the example `kernel_path_rate` times it).
#[allow(clippy::too_many_arguments)]
pub fn weight_grad_adam_with(
    path: KernelPath,
    x: &[f32],
    d: &[f32],
    (k, rows, n): (usize, usize, usize),
    p: &mut [f32],
    m: &mut [f32],
    v: &mut [f32],
    scratch: &mut [f32],
    step: AdamStep,
) {
    let size = rows * n;
    assert!(x.len() >= k * rows && d.len() >= k * n, "operands smaller than their shapes");
    assert!(p.len() == size && m.len() == size && v.len() == size, "a weight of another shape");
    // The AVX2 kernel on an AVX-512 CPU too: its row tiles copy the transposed x once per
    // strip, and the product's time is the memory traffic of p, m and v (one head of the
    // paper preset, one thread: 9.4-10 ms, where the AVX-512 kernel took 17 ms, as long as
    // its plain product and Adam's pass after it). Every element is the same chain of fused
    // multiply-adds on either kernel, so the values are the same.
    #[cfg(target_arch = "x86_64")]
    if let Some(isa) = kernel::resolve(path).and_then(|_| kernel::resolve(KernelPath::Avx2))
        && n % kernel::tile_columns(isa) == 0
        && k > 0
    {
        let chunk = BLOCK * n;
        p.par_chunks_mut(chunk)
            .zip(m.par_chunks_mut(chunk))
            .zip(v.par_chunks_mut(chunk))
            .enumerate()
            .for_each(|(b, ((p, m), v))| {
                let (i0, block_rows) = (b * BLOCK, p.len() / n);
                let ep = kernel::Raw::Adam { m: m.as_mut_ptr(), v: v.as_mut_ptr(), step };
                // SAFETY: the CPU has `isa` (`kernel::current`); x^T's rows i0.. (element
                // (i, q) at x[q * rows + i0 + i]) lie in x, d holds k x n with n a multiple of
                // the tile's columns, and p, m, v hold the block's rows of n.
                unsafe {
                    kernel::gemm(
                        isa,
                        block_rows,
                        k,
                        n,
                        x.as_ptr().wrapping_add(i0),
                        1,
                        rows as isize,
                        d.as_ptr(),
                        p.as_mut_ptr(),
                        ep,
                    )
                };
            });
        return;
    }
    let g = &mut scratch[..size];
    gemm_then_with(
        path,
        Mat::new(x, k, rows).t(),
        Mat::new(d, k, n),
        g,
        Epilogue::Store { beta: 0.0 },
    );
    adam::update(p, g, m, v, step);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(len: usize, seed: usize) -> Vec<f32> {
        (0..len)
            .map(|i| (((i * 7919 + seed * 104_729) % 1000) as f32 / 500.0 - 1.0) * 0.1)
            .collect()
    }

    /// Fused and unfused over two steps (the first step's moments start from the gradient,
    /// the second's decay), on every path, at widths the kernels take (multiples of 32) and
    /// not (48 is a multiple of AVX2's 16 but not of AVX-512's 32; 257 of neither), with a
    /// last block of rows shorter than the others: the same parameters and moments to the
    /// bit.
    #[test]
    fn fused_adam_equals_the_product_then_adam() {
        for path in [KernelPath::Fastest, KernelPath::Avx2, KernelPath::Portable] {
            for (k, rows, n) in [(8, 57, 64), (3, 30, 48), (8, 26, 257), (1, 5, 32)] {
                let (x, d) = (data(k * rows, 1), data(k * n, 2));
                let p0 = data(rows * n, 3);
                let (mut pa, mut ma, mut va) =
                    (p0.clone(), vec![0f32; rows * n], vec![0f32; rows * n]);
                let (mut pb, mut mb, mut vb) =
                    (p0.clone(), vec![0f32; rows * n], vec![0f32; rows * n]);
                let mut scratch = vec![0f32; rows * n];
                for (t, first) in [(1, true), (2, false)] {
                    let step = AdamStep { first, lr: 1e-3 * t as f32, factor: 1.5, eps: 1e-5 };
                    let mut g = vec![0f32; rows * n];
                    let (a, b) = (Mat::new(&x, k, rows).t(), Mat::new(&d, k, n));
                    gemm_then_with(path, a, b, &mut g, Epilogue::Store { beta: 0.0 });
                    step.apply(&mut pa, &g, &mut ma, &mut va);
                    weight_grad_adam_with(
                        path,
                        &x,
                        &d,
                        (k, rows, n),
                        &mut pb,
                        &mut mb,
                        &mut vb,
                        &mut scratch,
                        step,
                    );
                }
                let differ = |a: &[f32], b: &[f32]| {
                    a.iter().zip(b).filter(|(a, b)| a.to_bits() != b.to_bits()).count()
                };
                let what = format!("{path:?}, {k} x {rows} x {n}");
                assert_eq!(differ(&pa, &pb), 0, "parameters that differ, {what}");
                assert_eq!(differ(&ma, &mb), 0, "first moments that differ, {what}");
                assert_eq!(differ(&va, &vb), 0, "second moments that differ, {what}");
                assert!(
                    pa.iter().zip(&p0).filter(|(a, b)| a != b).count() > rows * n / 2,
                    "a step moves the weights"
                );
            }
        }
    }
}
