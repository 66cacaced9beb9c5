//! The training path: loss and gradient of a step computed by hand on flat f32 parameters
//! (SGEMM blocks on all cores, reverse over reverse for the spatial gradient), and Adam on
//! the same vectors. Fine-tuning (`fit_hyper`, `fit_sdf`) and meta-learning (Alg. 1 and 2)
//! train through it on the CPU; burn's autodiff stays the reference (and the GPU path): the
//! tests in `tests/train_gradients.rs` hold every parameter's gradient here to burn's.
//!
//! - `siren_grad`: one SIREN over a block of points, values + spatial gradient + reverse.
//! - `blocks`: blocks of points spread over rayon's threads, buffers kept across steps.
//! - `igr`: the IGR loss per point and its adjoints.
//! - `heads`, `hyper_step`: the encoder and heads, and the whole hypernetwork step.
//! - `adam`: Adam matching burn's; `weight_adam`: Adam fused into a weight gradient's product.

pub mod adam;
mod adam_step;
pub mod blocks;
mod elementwise;
pub mod gemm;
pub mod heads;
pub mod hyper_step;
pub mod igr;
mod kernel;
pub mod layout;
pub mod siren_grad;
pub mod weight_adam;

/// Which kernels the training path's products and element-wise passes run. A test and
/// benchmark choice, never read from the environment: every path gives the same gradients to
/// float rounding (`tests/train_gradients*.rs` hold each to burn's on the CPU at hand).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KernelPath {
    /// AVX-512 where the CPU has it, else AVX2 + FMA, else the plain loops (checked at run
    /// time).
    #[default]
    Fastest,
    /// AVX2 + FMA where the CPU has them (even with AVX-512), else the plain loops: what a
    /// CPU without AVX-512 runs.
    Avx2,
    /// The plain loops (and matrixmultiply, which picks its own SIMD) everywhere.
    Portable,
}

static PATH: std::sync::atomic::AtomicU8 = std::sync::atomic::AtomicU8::new(0);

/// Choose the kernels for the whole process (the `train_gradients*` tests,
/// `avatar-studio bench --only train`, `--portable-kernels`; docs/architecture.md).
pub fn set_kernel_path(path: KernelPath) {
    let code = match path {
        KernelPath::Fastest => 0,
        KernelPath::Avx2 => 1,
        KernelPath::Portable => 2,
    };
    PATH.store(code, std::sync::atomic::Ordering::Relaxed);
}

/// The kernels chosen by [`set_kernel_path`] ([`KernelPath::Fastest`] unless set).
pub fn kernel_path() -> KernelPath {
    match PATH.load(std::sync::atomic::Ordering::Relaxed) {
        1 => KernelPath::Avx2,
        2 => KernelPath::Portable,
        _ => KernelPath::Fastest,
    }
}

/// The kernels `path` runs on this CPU: "AVX-512", "AVX2" or "portable" (plain loops and
/// matrixmultiply, which picks its own SIMD at run time).
pub fn kernel_name_of(path: KernelPath) -> &'static str {
    match kernel::resolve(path) {
        Some(kernel::Isa::Avx512) => "AVX-512",
        Some(kernel::Isa::Avx2) => "AVX2",
        None => "portable",
    }
}

/// The kernels the training path runs now ([`kernel_name_of`] the chosen path).
pub fn kernel_name() -> &'static str {
    kernel_name_of(kernel_path())
}

pub use adam::Adam;
pub use hyper_step::{HyperBatch, HyperGradient, StepLoss};
pub use igr::IgrPoints;
pub use layout::HyperLayout;
pub use siren_grad::{LossTerms, SirenShape};

/// Loss and gradient of one static SIREN on a step's points (one group), with its own block
/// buffers: the static fit's step.
pub struct SirenGradient {
    runner: blocks::BlockRunner,
    grads: Vec<Vec<f32>>,
}

impl SirenGradient {
    pub fn new(shape: SirenShape) -> SirenGradient {
        SirenGradient { runner: blocks::BlockRunner::new(shape), grads: vec![Vec::new()] }
    }

    /// The loss of `points` under `params` and its gradient into `grad` (overwritten).
    pub fn compute(
        &mut self,
        params: &[f32],
        points: &[[f32; 3]],
        loss: &IgrPoints,
        grad: &mut [f32],
    ) -> StepLoss {
        let terms = self.runner.run(&[params], &[points], loss, &mut self.grads);
        grad.copy_from_slice(&self.grads[0]);
        let t = terms.terms;
        StepLoss {
            total: terms.total() as f32,
            terms: [t[0] as f32, t[1] as f32, t[2] as f32, t[3] as f32],
        }
    }
}
