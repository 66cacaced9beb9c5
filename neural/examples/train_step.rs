//! Wall and CPU time of training steps on the training path, for profiling: after
//! `cargo build --workspace --locked --all-targets`, `$CARGO_TARGET_DIR/debug/examples/train_step
//! compact 40` (or `paper 5`; `RAYON_NUM_THREADS=1` for one core; a third argument `avx2` or
//! `portable` chooses those kernels). CPU time (all threads) is steadier than wall time on a
//! shared machine.
use avatar_core::canonical::FieldCache;
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::training::hyper_fit::{HyperFitOptions, HyperOptimisers, fit_hyper};
use avatar_neural::{HyperConfig, MetaModel};
use std::time::Instant;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks: f64 = fields.get(11).and_then(|u| u.parse().ok()).unwrap_or(0.0)
        + fields.get(12).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    ticks / 100.0
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = args.get(1).map_or("compact", |s| s.as_str());
    let steps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(40);
    use avatar_neural::training::step::{KernelPath, kernel_name, set_kernel_path};
    match args.get(3).map(|s| s.as_str()) {
        Some("avx2") => set_kernel_path(KernelPath::Avx2),
        Some("portable") => set_kernel_path(KernelPath::Portable),
        _ => {}
    }
    let demo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let capture = CapturePoints::open(&demo, 8, &field_cache()).expect("the demo capture opens");
    let device = avatar_neural::cpu_training_device();
    let model = match preset {
        "paper" => {
            let c = HyperConfig::paper();
            c.init(c.siren.init(0, &device), 0, &device)
        }
        _ => MetaModel::shipped().hyper_net(),
    };
    let samples = capture.pose_samples(model.config().encoding);
    let prior = capture.sign_prior();
    let options = HyperFitOptions { steps, ..HyperFitOptions::default() };
    let (t, c) = (Instant::now(), cpu_seconds());
    let mut stamps = Vec::new();
    fit_hyper(
        model,
        &samples,
        &options,
        &mut HyperOptimisers::default(),
        &device,
        Some(&prior),
        None,
        &mut |_, _, _| stamps.push((t.elapsed().as_secs_f64(), cpu_seconds())),
    );
    let n = (stamps.len() - 1) as f64;
    let (w0, c0) = stamps[0];
    let (w1, c1) = stamps[stamps.len() - 1];
    println!(
        "{preset} ({}): {:.1} ms wall, {:.1} ms CPU a step ({} steps after the first; total {:.1} s wall, {:.1} s CPU)",
        kernel_name(),
        (w1 - w0) * 1e3 / n,
        (c1 - c0) * 1e3 / n,
        n,
        t.elapsed().as_secs_f64(),
        cpu_seconds() - c
    );
}
