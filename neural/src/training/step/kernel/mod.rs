//! The SIMD kernels of `gemm` and `elementwise`, chosen at run time: AVX-512 (`avx512`) where
//! the CPU has it, else AVX2 + FMA (`avx2`), else none (the portable loops and
//! matrixmultiply). Both kernels compute the same products and epilogues; they differ in
//! tile shape (12 x 32 in 24 of AVX-512's 32 registers, 6 x 16 in 12 of AVX2's 16) and in
//! the lanes of their sine. [`KernelPath`] narrows the choice for tests and benchmarks.

use super::KernelPath;

#[cfg(target_arch = "x86_64")]
pub mod avx2;
#[cfg(target_arch = "x86_64")]
pub mod avx2_dots;
#[cfg(target_arch = "x86_64")]
pub mod avx512;

/// An instruction set with a kernel of its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub enum Isa {
    Avx512,
    Avx2,
}

/// (AVX-512F, AVX2 + FMA) as the CPU reports them (once per process).
#[cfg(target_arch = "x86_64")]
fn detected() -> (bool, bool) {
    use std::sync::OnceLock;
    static DETECTED: OnceLock<(bool, bool)> = OnceLock::new();
    *DETECTED.get_or_init(|| {
        (
            std::arch::is_x86_feature_detected!("avx512f"),
            std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma"),
        )
    })
}

/// The kernels `path` runs on this CPU (None: the portable loops).
pub fn resolve(path: KernelPath) -> Option<Isa> {
    #[cfg(target_arch = "x86_64")]
    {
        let (avx512, avx2) = detected();
        match path {
            KernelPath::Fastest if avx512 => Some(Isa::Avx512),
            KernelPath::Fastest | KernelPath::Avx2 if avx2 => Some(Isa::Avx2),
            _ => None,
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = path;
        None
    }
}

/// The kernels the process's [`super::kernel_path`] runs on this CPU.
pub fn current() -> Option<Isa> {
    resolve(super::kernel_path())
}

/// An epilogue over raw pointers: every pointer addresses a buffer laid out like the result
/// (`bias` is one row). See `gemm::Epilogue` for the meaning of each; `Adam` (no `Epilogue`
/// of its own: `weight_adam`) applies Adam's `step` to a weight gradient that is never
/// stored, `out` holding the parameters and `m`, `v` the moments.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub enum Raw {
    Store { beta: f32 },
    Sine { w0: f32, bias: *const f32, deriv: *mut f32 },
    AlsoTimes { factor: *const f32, times: *mut f32 },
    GradChain { scale: f32, v: *mut f32, h: *const f32, c: *const f32 },
    AddTimes { factor: *const f32 },
    Adam { m: *mut f32, v: *mut f32, step: super::adam_step::AdamStep },
}

/// The columns of the result a kernel's tile spans: `gemm` runs on `isa` when n is a
/// multiple of it.
#[cfg(target_arch = "x86_64")]
pub fn tile_columns(isa: Isa) -> usize {
    match isa {
        Isa::Avx512 => 32,
        Isa::Avx2 => 16,
    }
}

/// out (m x n, row-major) = epilogue(a b) on `isa`'s kernel; a element (i, p) at
/// a[i * rsa + p * csa]; b row-major k x n; n a multiple of [`tile_columns`].
///
/// # Safety
/// The CPU has `isa` (from [`resolve`]); a's strides address its m x k view inside its
/// buffer; b holds k x n; out and every epilogue pointer hold m x n (bias: n).
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
pub unsafe fn gemm(
    isa: Isa,
    m: usize,
    k: usize,
    n: usize,
    a: *const f32,
    rsa: isize,
    csa: isize,
    b: *const f32,
    out: *mut f32,
    ep: Raw,
) {
    debug_assert_eq!(n % tile_columns(isa), 0);
    // SAFETY: the caller's contract, passed on.
    unsafe {
        match isa {
            Isa::Avx512 => avx512::gemm(m, k, n, a, rsa, csa, b, out, ep),
            Isa::Avx2 => avx2::gemm(m, k, n, a, rsa, csa, b, out, ep),
        }
    }
}

/// out[i * r + j] = beta out[i * r + j] + a_i . rows_j for a [m x k] and rows [r x k], both
/// row-major, on `isa`.
///
/// # Safety
/// The CPU has `isa`; a holds m x k, rows r x k, out m x r.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
pub unsafe fn dots(
    isa: Isa,
    m: usize,
    k: usize,
    r: usize,
    a: *const f32,
    rows: *const f32,
    beta: f32,
    out: *mut f32,
) {
    // From this k on, a's rows no longer fit in L1 and `rows` is read once per row of a
    // by the row-by-row loop: the chunked one reads it once.
    const WIDE: usize = 4096;
    // SAFETY: the caller's contract, passed on.
    unsafe {
        match isa {
            Isa::Avx512 if k >= WIDE => avx512::dots_wide(m, k, r, a, rows, beta, out),
            Isa::Avx512 => avx512::dots(m, k, r, a, rows, beta, out),
            Isa::Avx2 if k >= WIDE => avx2_dots::dots_wide(m, k, r, a, rows, beta, out),
            Isa::Avx2 => avx2_dots::dots(m, k, r, a, rows, beta, out),
        }
    }
}
