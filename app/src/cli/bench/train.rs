//! `avatar-studio bench --only train`: `train-step`, the cost of a training step on the
//! training path (`avatar_neural::training::step`) on every kernel path the CPU has (AVX-512, AVX2 +
//! FMA, portable), on burn's autodiff and, when PyTorch is installed, in PyTorch
//! (`benches/train_step_torch.py`), all at the fit's workload, for the compact and the paper
//! presets, wall and CPU time; `train-meta`, the cost of a meta-training iteration (Alg. 1
//! and Alg. 2) and a default 8-frame fit of the demo (canonicalization included).

use avatar_neural::compute::Compute;
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::data::pose_sample::PoseSample;
use avatar_neural::training::hyper_fit::{HyperFitOptions, HyperOptimisers, fit_hyper};
use avatar_neural::training::meta_training::MetaOptions;
use avatar_neural::training::step::{
    KernelPath, kernel_name, kernel_name_of, kernel_path, set_kernel_path,
};
use avatar_neural::{FitOptions, HyperConfig, HyperNet, Init, MetaAvatar, MetaModel, fit_sdf};
use avatar_studio::studio::measure::cpu_seconds;
use std::time::Instant;

/// A step's time (ms): the median wall time and the mean CPU time (all threads).
#[derive(Clone, Copy)]
struct StepTime {
    wall: f64,
    cpu: f64,
}

/// The step time of `steps` steps of a fit, from the progress callback's timestamps (every
/// step is logged when steps <= 50); the first step (buffers) is left out.
fn step_ms(steps: usize, fit: impl FnOnce(&mut dyn FnMut(usize, f32, [f32; 4]))) -> StepTime {
    let mut stamps = Vec::new();
    let t = Instant::now();
    fit(&mut |_, _, _| stamps.push((t.elapsed().as_secs_f64(), cpu_seconds())));
    let mut d: Vec<f64> = stamps.windows(2).map(|w| (w[1].0 - w[0].0) * 1e3).collect();
    assert!(steps <= 50 && !d.is_empty(), "every step logged");
    d.sort_by(f64::total_cmp);
    let cpu = (stamps[stamps.len() - 1].1 - stamps[0].1) * 1e3 / (stamps.len() - 1) as f64;
    StepTime { wall: d[d.len() / 2], cpu }
}

fn hyper_step_ms(
    model: &HyperNet,
    samples: &[PoseSample],
    options: &HyperFitOptions,
    capture: &CapturePoints,
    path: Compute,
) -> StepTime {
    let prior = capture.sign_prior();
    let device = path.training_device();
    let options = HyperFitOptions { compute: path, ..options.clone() };
    step_ms(options.steps, |progress| {
        fit_hyper(
            model.clone(),
            samples,
            &options,
            &mut HyperOptimisers::default(),
            &device,
            Some(&prior),
            None,
            progress,
        );
    })
}

/// The PyTorch side of one preset at a workload (poses, surface and off-surface points a
/// pose): its report line, or why there is none. `avx2`: PyTorch limited to AVX2 as well
/// (ATen's kernels, oneDNN and MKL, through their own environment variables, set for the
/// child only), to stand for a CPU without AVX-512 next to our AVX2 kernels.
fn torch_line(
    preset: &str,
    (poses, surface, off): (usize, usize, usize),
    avx2: bool,
    threads: usize,
) -> String {
    // The script is embedded and read from standard input: the bench runs from the installed
    // package.
    const SCRIPT: &str = include_str!("../../../../benches/train_step_torch.py");
    let mut command = std::process::Command::new("python3");
    if avx2 {
        command.env("ATEN_CPU_CAPABILITY", "avx2");
        command.env("ONEDNN_MAX_CPU_ISA", "AVX2");
        command.env("MKL_ENABLE_INSTRUCTIONS", "AVX2");
    }
    let child = command
        .arg("-")
        .args(["--preset", preset, "--threads", &threads.to_string()])
        .args(["--steps", if preset == "paper" { "5" } else { "30" }])
        .args(["--poses", &poses.to_string(), "--surface", &surface.to_string()])
        .args(["--off", &off.to_string()])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .and_then(|mut child| {
            use std::io::Write;
            child.stdin.take().expect("piped").write_all(SCRIPT.as_bytes())?;
            child.wait_with_output()
        });
    match child {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).trim().to_string(),
        Ok(o) => {
            format!("failed: {}", String::from_utf8_lossy(&o.stderr).lines().last().unwrap_or(""))
        }
        Err(e) => format!("python3 not found ({e})"),
    }
}

/// The median step and the CPU a step (ms) in PyTorch's line ("...: 123.4 ms a step (...;
/// 234.5 ms CPU a step)").
fn torch_ms(line: &str) -> Option<StepTime> {
    let number_before = |mark: &str| -> Option<f64> {
        let (before, _) = line.split_once(mark)?;
        before.rsplit(' ').next()?.parse().ok()
    };
    Some(StepTime { wall: number_before(" ms a step")?, cpu: number_before(" ms CPU a step")? })
}

/// The CPU's model name (/proc/cpuinfo; "unknown CPU" elsewhere).
pub(super) fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

fn threads() -> usize {
    std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
}

pub fn bench_report() -> String {
    let mut out = String::from("## train-step\n\n");
    let opened = super::demo_capture().and_then(|demo| {
        CapturePoints::open(&demo, 8, avatar_studio::cache::field_cache())
            .map_err(|e| e.to_string())
    });
    let capture = match opened {
        Ok(c) => c,
        Err(e) => return out + &format!("the demo capture does not open: {e}\n"),
    };
    let shipped = MetaModel::shipped();
    let samples = capture.pose_samples(shipped.header.config.encoding);
    let fit = HyperFitOptions::default();
    let work = (samples.len().min(fit.poses_per_step), fit.surface_per_pose, fit.off_per_pose);
    let points = work.0 * (work.1 + work.2);
    let label = format!("{} poses x ({} + {}) points", work.0, work.1, work.2);
    out += &format!(
        "CPU: {}, {} threads. Every line: one step of the fit's defaults ({label}: sampling, \
         sign prior, loss and gradient, Adam); PyTorch at the same workload (no sampling, no \
         sign prior), right after ours.\n\n",
        cpu_model(),
        threads()
    );
    out += &format!(
        "| preset | workload | kernels | ours | ours a point | ours CPU | burn autodiff | PyTorch, {} threads | PyTorch CPU, 1 thread | ours / PyTorch | by CPU |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
        threads()
    );
    // Every kernel path this CPU has (AVX-512, AVX2 + FMA, portable), each once.
    let mut paths: Vec<KernelPath> = Vec::new();
    for path in [KernelPath::Fastest, KernelPath::Avx2, KernelPath::Portable] {
        if paths.iter().all(|p| kernel_name_of(*p) != kernel_name_of(path)) {
            paths.push(path);
        }
    }
    let chosen = kernel_path();
    let compact = shipped.hyper_net();
    let config = HyperConfig::paper();
    let device = avatar_neural::cpu_training_device();
    let paper = config.init(config.siren.init(0, &device), 0, &device);
    let paper_samples: Vec<PoseSample> = capture.pose_samples(config.encoding);
    for (preset, model, samples, ours_steps, burn_steps) in
        [("compact", &compact, &samples, 30, 6), ("paper", &paper, &paper_samples, 6, 3)]
    {
        // PyTorch on all threads (wall time) and on one (CPU time: its OpenMP threads spin at
        // every barrier, which on a busy machine inflates both its wall and its CPU time).
        let torch =
            [torch_line(preset, work, false, threads()), torch_line(preset, work, false, 1)];
        let mut torch_avx2 = None;
        for (i, path) in paths.iter().enumerate() {
            set_kernel_path(*path);
            let avx2 = kernel_name() == "AVX2" && kernel_name_of(KernelPath::Fastest) != "AVX2";
            let torch = if avx2 {
                &*torch_avx2.get_or_insert_with(|| {
                    [torch_line(preset, work, true, threads()), torch_line(preset, work, true, 1)]
                })
            } else {
                &torch
            };
            let ours_opts = HyperFitOptions { steps: ours_steps, ..fit.clone() };
            let o = (0..2)
                .map(|_| hyper_step_ms(model, samples, &ours_opts, &capture, Compute::Cpu))
                .min_by(|a, b| a.wall.total_cmp(&b.wall))
                .expect("two runs");
            let burn = if i == 0 {
                let opts = HyperFitOptions { steps: burn_steps, ..fit.clone() };
                let b = hyper_step_ms(model, samples, &opts, &capture, Compute::CpuBurn);
                format!("{:.0} ms", b.wall)
            } else {
                String::new()
            };
            let (t, t_cpu, ratio, cpu_ratio) = match (torch_ms(&torch[0]), torch_ms(&torch[1])) {
                (Some(t), Some(one)) => (
                    format!("{:.1} ms", t.wall),
                    format!("{:.1} ms", one.cpu),
                    format!("{:.2}x", o.wall / t.wall),
                    format!("{:.2}x", o.cpu / one.cpu),
                ),
                _ => ("-".into(), "-".into(), "-".into(), "-".into()),
            };
            out += &format!(
                "| {preset} ({:.1} M parameters) | {label} | {} | {:.1} ms | {:.2} us | {:.1} ms | {burn} | {t} | {t_cpu} | {ratio} | {cpu_ratio} |\n",
                model.config().num_params() as f64 / 1e6,
                kernel_name(),
                o.wall,
                o.wall * 1e3 / points as f64,
                o.cpu,
            );
        }
        out += &format!("\nPyTorch, {preset}: {}\n\n{}\n", torch[0], torch[1]);
        if let Some([all, one]) = torch_avx2 {
            out += &format!(
                "\nPyTorch limited to AVX2 (next to our AVX2 line), {preset}: {all}\n\n{one}\n"
            );
        }
        out += "\n";
    }
    set_kernel_path(chosen);
    drop(paper);
    out
}

/// `bench --only train-meta`: a meta-training iteration on the training path and on burn's
/// autodiff, and the user's view of a default 8-frame fit of the demo.
pub fn meta_report() -> String {
    let mut out = String::from("## train-meta\n\n");
    let opened = super::demo_capture().and_then(|demo| {
        Ok((
            CapturePoints::open(&demo, 8, avatar_studio::cache::field_cache())
                .map_err(|e| e.to_string())?,
            demo,
        ))
    });
    let (capture, demo) = match opened {
        Ok(c) => c,
        Err(e) => return out + &format!("the demo capture does not open: {e}\n"),
    };
    let shipped = MetaModel::shipped();
    let samples = capture.pose_samples(shipped.header.config.encoding);
    let compact = shipped.hyper_net();

    // Meta-training: Alg. 1's inner fit (one task) and Alg. 2's (a task of 8 frames).
    let meta = MetaOptions::default();
    let frame = &capture.frames[0];
    let alg1 = FitOptions {
        steps: meta.sdf_inner_steps,
        learning_rate: meta.sdf_inner_lr,
        batch: meta.points_per_step,
        off_surface: meta.points_per_step,
        ..FitOptions::default()
    };
    let alg2 = HyperFitOptions {
        steps: meta.hyper_inner_epochs * samples.len().div_ceil(meta.hyper_inner.poses_per_step),
        ..meta.hyper_inner.clone()
    };
    out += "| meta-training iteration (compact) | training path | burn autodiff | ratio |\n|---|---|---|---|\n";
    let time_alg1 = |path: Compute| {
        let alg1 = FitOptions { compute: path, ..alg1.clone() };
        let t = Instant::now();
        for _ in 0..meta.sdf_meta_batch {
            let siren = shipped.static_siren();
            fit_sdf(
                siren,
                &frame.points,
                &frame.normals,
                &[],
                &alg1,
                &path.training_device(),
                None,
                None,
                &mut |_, _, _| {},
            );
        }
        t.elapsed().as_secs_f64()
    };
    let time_alg2 = |path: Compute| {
        let alg2 = HyperFitOptions { compute: path, ..alg2.clone() };
        let t = Instant::now();
        fit_hyper(
            compact.clone(),
            &samples,
            &alg2,
            &mut HyperOptimisers::default(),
            &path.training_device(),
            None,
            None,
            &mut |_, _, _| {},
        );
        t.elapsed().as_secs_f64()
    };
    let (o1, b1) = (time_alg1(Compute::Cpu), time_alg1(Compute::CpuBurn));
    out += &format!(
        "| Alg. 1 ({} tasks x {} steps x {} + {} points) | {:.2} s | {:.2} s | {:.1}x |\n",
        meta.sdf_meta_batch,
        alg1.steps,
        alg1.batch,
        alg1.off_surface,
        o1,
        b1,
        b1 / o1
    );
    let (o2, b2) = (time_alg2(Compute::Cpu), time_alg2(Compute::CpuBurn));
    out += &format!(
        "| Alg. 2 (a task of 8 frames: {} steps of {} poses) | {:.2} s | {:.2} s | {:.1}x |\n",
        alg2.steps,
        alg2.poses_per_step,
        o2,
        b2,
        b2 / o2
    );

    // The user's view: `fit` of the demo's 8 frames with the defaults, canonicalization included.
    let t = Instant::now();
    let fitted = MetaAvatar::fit_capture(
        &demo,
        8,
        avatar_studio::cache::field_cache(),
        &Init::MetaLearned(&shipped),
        &HyperFitOptions::default(),
        None,
        &mut |_, _, _| {},
    );
    let fit_s = t.elapsed().as_secs_f64();
    out += &format!(
        "\n| fit of the demo, 8 frames, defaults ({} steps), canonicalization included | {} |\n|---|---|\n",
        HyperFitOptions::default().steps,
        if fitted.is_ok() {
            format!("{fit_s:.1} s (target <= 20 s on 2 cores)")
        } else {
            "failed".into()
        }
    );

    out
}
