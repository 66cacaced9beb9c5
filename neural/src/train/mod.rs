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
//! - `adam`: Adam matching burn's.

pub mod adam;
pub mod blocks;
mod elementwise;
pub mod gemm;
pub mod heads;
pub mod hyper_step;
pub mod igr;
#[cfg(target_arch = "x86_64")]
mod kernel;
pub mod layout;
pub mod siren_grad;

/// Which kernels the training path's products and element-wise passes run. A test-only
/// choice: both give the same gradients to float rounding (`tests/train_gradients.rs` holds
/// either to burn's); `Portable` covers the plain loops on a CPU with AVX-512.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KernelPath {
    /// AVX-512 where the CPU has it (checked at run time), else the plain loops.
    #[default]
    Fastest,
    /// The plain loops everywhere.
    Portable,
}

static PORTABLE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Choose the kernels for the whole process (`tests/train_gradients.rs` under the test-only
/// `AVATAR_NO_AVX512` switch, `avatar-studio bench --portable-kernels`; docs/architecture.md).
pub fn set_kernel_path(path: KernelPath) {
    PORTABLE.store(path == KernelPath::Portable, std::sync::atomic::Ordering::Relaxed);
}

/// The kernels chosen by [`set_kernel_path`] ([`KernelPath::Fastest`] unless set).
pub fn kernel_path() -> KernelPath {
    if PORTABLE.load(std::sync::atomic::Ordering::Relaxed) {
        KernelPath::Portable
    } else {
        KernelPath::Fastest
    }
}

/// The kernels the training path runs now: "AVX-512" or "portable" (plain loops and
/// matrixmultiply, which picks its own SIMD at run time).
pub fn kernel_name() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    if kernel::available() {
        return "AVX-512";
    }
    "portable"
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
