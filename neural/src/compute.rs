//! Where training runs: the CPU (burn's flex backend, always built) or a GPU (burn's wgpu
//! backend, behind the `gpu` feature so that CI and laptops without a GPU never build it).
//! Inference (meshing, projection, the pose slider) stays on the CPU path of `siren_eval`.
//!
//! The choice is process-wide: the command line sets it once from `--device` before any fit
//! starts, and every fitting entry point asks [`training_device`].

use crate::error::Error;
use burn::tensor::Device;
use std::sync::atomic::{AtomicU8, Ordering};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compute {
    /// The training path (`crate::train`): hand-derived gradients on all cores.
    #[default]
    Cpu,
    Gpu,
    /// burn's autodiff on the CPU: the reference the training path is tested against, kept
    /// for comparisons (`--device cpu-burn`, the training benchmark).
    CpuBurn,
}

static SELECTED: AtomicU8 = AtomicU8::new(0);

impl Compute {
    /// `cpu` or `gpu`; `gpu` in a build without the `gpu` feature is refused with the reason.
    pub fn parse(name: &str) -> crate::error::Result<Compute> {
        match name {
            "cpu" => Ok(Compute::Cpu),
            "cpu-burn" => Ok(Compute::CpuBurn),
            "gpu" if cfg!(feature = "gpu") => Ok(Compute::Gpu),
            "gpu" => Err(Error::Device { name: name.into(), reason: "this build has no GPU support (rebuild with `cargo build --release --features gpu`)".into() }),
            other => Err(Error::Device { name: other.into(), reason: "expected cpu, gpu or cpu-burn".into() }),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Compute::Cpu => "cpu",
            Compute::Gpu => "gpu",
            Compute::CpuBurn => "cpu-burn",
        }
    }
}

/// Select where later fits train.
pub fn select(compute: Compute) {
    SELECTED.store(compute as u8, Ordering::Relaxed);
}

pub fn selected() -> Compute {
    match SELECTED.load(Ordering::Relaxed) {
        v if v == Compute::Gpu as u8 => Compute::Gpu,
        v if v == Compute::CpuBurn as u8 => Compute::CpuBurn,
        _ => Compute::Cpu,
    }
}

/// Whether fits take the training path (`crate::train`) rather than burn's autodiff.
pub fn flat_training() -> bool {
    selected() == Compute::Cpu
}

/// The device fits train on (with autodiff).
pub fn training_device() -> Device {
    match selected() {
        Compute::Cpu | Compute::CpuBurn => crate::cpu_training_device(),
        Compute::Gpu => gpu_device().autodiff(),
    }
}

#[cfg(feature = "gpu")]
fn gpu_device() -> Device {
    // The best adapter wgpu finds (CUBECL_WGPU_DEFAULT_DEVICE overrides it).
    Device::wgpu(burn::tensor::DeviceKind::DefaultDevice)
}

#[cfg(not(feature = "gpu"))]
fn gpu_device() -> Device {
    // Unreachable: `Compute::parse` refuses gpu in this build and `select` is only given parsed
    // values; fall back to the CPU rather than panic.
    crate::cpu_device()
}

#[cfg(test)]
mod tests {
    use super::Compute;

    #[test]
    fn device_names_parse_and_a_cpu_build_refuses_gpu_with_the_reason() {
        assert_eq!(Compute::parse("cpu").unwrap(), Compute::Cpu);
        assert!(
            Compute::parse("tpu")
                .unwrap_err()
                .to_string()
                .contains("expected cpu, gpu or cpu-burn")
        );
        assert_eq!(Compute::parse("cpu-burn").unwrap(), Compute::CpuBurn);
        if cfg!(feature = "gpu") {
            assert_eq!(Compute::parse("gpu").unwrap(), Compute::Gpu);
        } else {
            assert!(Compute::parse("gpu").unwrap_err().to_string().contains("--features gpu"));
        }
    }
}
