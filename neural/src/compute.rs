//! Where training runs: the CPU (burn's flex backend, always built) or a GPU (burn's wgpu
//! backend, behind the `gpu` feature so that CI and laptops without a GPU never build it).
//! Inference (meshing, projection, the pose slider) stays on the CPU path of `siren_eval`.
//!
//! The choice is part of each fit's options (`FitOptions::compute`, `HyperFitOptions::compute`,
//! `MetaOptions::compute`): the command line fills it from `--device`, the benchmark names a
//! path per measurement, and the default is the CPU's training path.

use crate::error::Error;
use burn::tensor::Device;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compute {
    /// The training path (`crate::training::step`): hand-derived gradients on all cores.
    #[default]
    Cpu,
    Gpu,
    /// burn's autodiff on the CPU: the reference the training path is tested against, kept
    /// for comparisons (`--device cpu-burn`, the training benchmark).
    CpuBurn,
}

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

impl Compute {
    /// Whether fits take the training path (`crate::training::step`) rather than burn's autodiff.
    pub fn flat_training(self) -> bool {
        self == Compute::Cpu
    }

    /// The device fits train on (with autodiff).
    pub fn training_device(self) -> Device {
        match self {
            Compute::Cpu | Compute::CpuBurn => crate::cpu_training_device(),
            Compute::Gpu => gpu_device().autodiff(),
        }
    }
}

#[cfg(feature = "gpu")]
fn gpu_device() -> Device {
    // The best adapter wgpu finds (CUBECL_WGPU_DEFAULT_DEVICE overrides it).
    Device::wgpu(burn::tensor::DeviceKind::DefaultDevice)
}

#[cfg(not(feature = "gpu"))]
fn gpu_device() -> Device {
    // Only reached with a `Compute::Gpu` not made by `Compute::parse` (which refuses gpu in
    // this build): fall back to the CPU rather than panic.
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
