//! `avatar-studio bench --only train`: the cost of a training step on the training path
//! (`avatar_neural::train`) and on burn's autodiff, measured side by side in one run (the two
//! interleaved), for the compact and the paper presets; a default 8-frame fit of the demo
//! (canonicalization included) and the cost of a meta-training iteration (Alg. 1 and Alg. 2);
//! and, when PyTorch is installed, the same step in PyTorch (`benches/train_step_torch.py`).

use avatar_neural::capture_points::CapturePoints;
use avatar_neural::compute::{Compute, select};
use avatar_neural::hyper_fit::{HyperFitOptions, HyperOptimisers, fit_hyper};
use avatar_neural::meta_training::MetaOptions;
use avatar_neural::pose_sample::PoseSample;
use avatar_neural::{FitOptions, HyperConfig, HyperNet, Init, MetaAvatar, MetaModel, fit_sdf};
use std::time::Instant;

/// Median step time (ms) of `steps` steps of a fit, from the progress callback's timestamps
/// (every step is logged when steps <= 50); the first step (buffers) is left out.
fn step_ms(steps: usize, fit: impl FnOnce(&mut dyn FnMut(usize, f32, [f32; 4]))) -> f64 {
    let mut stamps = Vec::new();
    let t = Instant::now();
    fit(&mut |_, _, _| stamps.push(t.elapsed().as_secs_f64()));
    let mut d: Vec<f64> = stamps.windows(2).map(|w| (w[1] - w[0]) * 1e3).collect();
    assert!(steps <= 50 && !d.is_empty(), "every step logged");
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

fn hyper_step_ms(
    model: &HyperNet,
    samples: &[PoseSample],
    options: &HyperFitOptions,
    capture: &CapturePoints,
    path: Compute,
) -> f64 {
    select(path);
    let prior = capture.sign_prior();
    let device = avatar_neural::compute::training_device();
    let ms = step_ms(options.steps, |progress| {
        fit_hyper(
            model.clone(),
            samples,
            options,
            &mut HyperOptimisers::default(),
            &device,
            Some(&prior),
            None,
            progress,
        );
    });
    select(Compute::Cpu);
    ms
}

fn torch_line(preset: &str) -> String {
    // The script is embedded and read from standard input: the bench runs from the installed
    // package.
    const SCRIPT: &str = include_str!("../../../../benches/train_step_torch.py");
    let child = std::process::Command::new("python3")
        .arg("-")
        .args([
            "--preset",
            preset,
            "--threads",
            &threads().to_string(),
            "--steps",
            if preset == "paper" { "5" } else { "30" },
        ])
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

fn threads() -> usize {
    std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
}

pub fn bench_report() -> String {
    let mut out = String::from("## train\n\n");
    let opened = super::demo_capture()
        .and_then(|demo| Ok((CapturePoints::open(&demo, 8).map_err(|e| e.to_string())?, demo)));
    let (capture, demo) = match opened {
        Ok(c) => c,
        Err(e) => return out + &format!("the demo capture does not open: {e}\n"),
    };
    let shipped = MetaModel::shipped();
    let samples = capture.pose_samples(shipped.header.config.encoding);
    out += "| step (8 poses x (500 + 500) points, fine-tuning defaults) | training path | burn autodiff | ratio |\n|---|---|---|---|\n";

    // Compact: the shipped model, fine-tuning defaults; the two paths interleaved twice.
    let compact = shipped.hyper_net();
    let ours_opts = HyperFitOptions { steps: 30, ..HyperFitOptions::default() };
    let burn_opts = HyperFitOptions { steps: 6, ..HyperFitOptions::default() };
    let (mut ours, mut burn) = (Vec::new(), Vec::new());
    for _ in 0..2 {
        ours.push(hyper_step_ms(&compact, &samples, &ours_opts, &capture, Compute::Cpu));
        burn.push(hyper_step_ms(&compact, &samples, &burn_opts, &capture, Compute::CpuBurn));
    }
    let (o, b) = (
        ours.iter().copied().fold(f64::MAX, f64::min),
        burn.iter().copied().fold(f64::MAX, f64::min),
    );
    out += &format!("| compact (1.0 M parameters) | {o:.1} ms | {b:.0} ms | {:.1}x |\n", b / o);

    // Paper: 85.6 M parameters, from its initialisation (the cost does not depend on values).
    let config = HyperConfig::paper();
    let device = avatar_neural::cpu_training_device();
    let paper = config.init(config.siren.init(0, &device), 0, &device);
    let paper_samples: Vec<PoseSample> = capture.pose_samples(config.encoding);
    let o = hyper_step_ms(
        &paper,
        &paper_samples,
        &HyperFitOptions { steps: 6, ..HyperFitOptions::default() },
        &capture,
        Compute::Cpu,
    );
    let b = hyper_step_ms(
        &paper,
        &paper_samples,
        &HyperFitOptions { steps: 3, ..HyperFitOptions::default() },
        &capture,
        Compute::CpuBurn,
    );
    out += &format!("| paper (85.6 M parameters) | {o:.0} ms | {b:.0} ms | {:.1}x |\n", b / o);
    drop(paper);

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
    out += "\n| meta-training iteration (compact) | training path | burn autodiff | ratio |\n|---|---|---|---|\n";
    let time_alg1 = |path: Compute| {
        select(path);
        let t = Instant::now();
        for _ in 0..meta.sdf_meta_batch {
            let siren = shipped.static_siren();
            fit_sdf(
                siren,
                &frame.points,
                &frame.normals,
                &[],
                &alg1,
                &avatar_neural::compute::training_device(),
                None,
                None,
                &mut |_, _, _| {},
            );
        }
        select(Compute::Cpu);
        t.elapsed().as_secs_f64()
    };
    let time_alg2 = |path: Compute| {
        select(path);
        let t = Instant::now();
        fit_hyper(
            compact.clone(),
            &samples,
            &alg2,
            &mut HyperOptimisers::default(),
            &avatar_neural::compute::training_device(),
            None,
            None,
            &mut |_, _, _| {},
        );
        select(Compute::Cpu);
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

    out += &format!(
        "\nPyTorch (`benches/train_step_torch.py`, {} threads), same sitting:\n\n- compact: {}\n- paper: {}\n",
        threads(),
        torch_line("compact"),
        torch_line("paper")
    );
    out
}
