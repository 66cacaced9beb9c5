//! One kernel path's products on one thread, at the paper preset's shapes: the SIREN's
//! (a block of 128 points through a 128- or 256-wide layer: GFLOP/s) and the heads' output
//! layer (8 poses x 256 -> 65,792: ms a product, and its weights' Adam step: the weight
//! gradient then Adam's pass over it, as `HyperGradient::compute` and `Adam::step` do, or
//! both in one pass, as `HyperGradient::step` does). `cargo run --release -p avatar-neural
//! --example kernel_path_rate -- [avx2|fast|portable] [reps]`. Each figure is the median of 7
//! rounds of `reps` products (default 2,000), timed by the thread's CPU time
//! (/proc/thread-self/schedstat, which some virtual machines count in 4 ms ticks: a round of
//! fewer than about 100 ms is then too coarse) or, with a third argument `wall`, the wall
//! clock (steadier on an idle machine).
use avatar_neural::training::step::adam::AdamStep;
use avatar_neural::training::step::gemm::{Epilogue, Mat, dots_with, gemm_then_with};
use avatar_neural::training::step::weight_adam::weight_grad_adam_with;
use avatar_neural::training::step::{KernelPath, kernel_name_of};
use std::time::Instant;

fn data(len: usize, seed: usize) -> Vec<f32> {
    (0..len).map(|i| (((i * 37 + seed * 11) % 101) as f32 - 50.0) * 0.001).collect()
}

/// Seconds of this thread on a CPU (or of the wall clock).
fn seconds(wall: bool) -> f64 {
    static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    let clock = || START.get_or_init(Instant::now).elapsed().as_secs_f64();
    if wall {
        return clock();
    }
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or_else(clock, |ns| ns * 1e-9)
}

/// The median time of one call of `run` over 7 rounds of `reps` calls.
fn time(reps: usize, wall: bool, run: &mut dyn FnMut()) -> f64 {
    run();
    let mut rounds: Vec<f64> = (0..7)
        .map(|_| {
            let t = seconds(wall);
            for _ in 0..reps {
                run();
            }
            (seconds(wall) - t) / reps as f64
        })
        .collect();
    rounds.sort_by(f64::total_cmp);
    rounds[3]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = match args.get(1).map(|s| s.as_str()) {
        Some("fast") => KernelPath::Fastest,
        Some("portable") => KernelPath::Portable,
        _ => KernelPath::Avx2,
    };
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2000);
    let wall = args.get(3).is_some_and(|s| s == "wall");
    println!("{} kernels, one thread, {}", kernel_name_of(path), if wall { "wall" } else { "CPU" });
    for (m, k, n) in [(128, 128, 128), (128, 256, 256)] {
        let (a, w, f, bias) = (data(m * k, 1), data(k * n, 2), data(m * n, 3), data(n, 4));
        let (mut out, mut aux, mut grad) =
            (vec![0f32; m * n], vec![0f32; m * n], vec![0f32; k * n]);
        let names = ["sine layer h W", "chain q W^T", "weight gradient h^T v", "plain product"];
        for (case, name) in names.iter().enumerate() {
            let (am, wm) = (Mat::new(&a, m, k), Mat::new(&w, k, n));
            let s = time(reps, wall, &mut || match case {
                0 => gemm_then_with(
                    path,
                    am,
                    wm,
                    &mut out,
                    Epilogue::Sine { w0: 30.0, bias: &bias, deriv: &mut aux },
                ),
                1 => gemm_then_with(
                    path,
                    am,
                    wm,
                    &mut out,
                    Epilogue::AlsoTimes { factor: &f, times: &mut aux },
                ),
                2 => gemm_then_with(
                    path,
                    am.t(),
                    Mat::new(&f, m, n),
                    &mut grad,
                    Epilogue::Store { beta: 1.0 },
                ),
                _ => gemm_then_with(path, am, wm, &mut out, Epilogue::Store { beta: 0.0 }),
            });
            println!("{name} ({m} x {k} x {n}): {:.1} GFLOP/s", 2.0 * (m * k * n) as f64 / s / 1e9);
        }
    }
    // The heads' output layer: forward, weight gradient (written) and d_out W^T.
    let (poses, hidden, outputs) = (8, 256, 65_792);
    let (a, w, d) = (data(poses * hidden, 1), data(hidden * outputs, 2), data(poses * outputs, 3));
    let (mut out, mut g, mut dx) =
        (vec![0f32; poses * outputs], vec![0f32; hidden * outputs], vec![0f32; poses * hidden]);
    let (am, wm, dm) =
        (Mat::new(&a, poses, hidden), Mat::new(&w, hidden, outputs), Mat::new(&d, poses, outputs));
    let heads = (reps / 100).max(5);
    let fwd = time(heads, wall, &mut || {
        gemm_then_with(path, am, wm, &mut out, Epilogue::Store { beta: 1.0 })
    });
    let grad = time(heads, wall, &mut || {
        gemm_then_with(path, am.t(), dm, &mut g, Epilogue::Store { beta: 0.0 })
    });
    let back = time(heads, wall, &mut || dots_with(path, &d, &w, outputs, 0.0, &mut dx));
    println!(
        "heads' output layer ({poses} x {hidden} x {outputs}): forward {:.2} ms, weight gradient {:.2} ms, d_out W^T {:.2} ms",
        fwd * 1e3,
        grad * 1e3,
        back * 1e3
    );
    // Its weights' Adam step: the gradient written, then Adam's pass over parameters,
    // gradient and moments (one thread: `AdamStep::apply`), against both in one pass.
    let (mut p, mut m, mut v) = (w.clone(), vec![0f32; w.len()], vec![0f32; w.len()]);
    let step = AdamStep { first: false, lr: 1e-4, factor: 1.0, eps: 1e-5 };
    let adam = time(heads, wall, &mut || step.apply(&mut p, &g, &mut m, &mut v));
    let fused = time(heads, wall, &mut || {
        let shape = (poses, hidden, outputs);
        weight_grad_adam_with(path, &a, &d, shape, &mut p, &mut m, &mut v, &mut g, step)
    });
    println!(
        "its Adam step: weight gradient then Adam {:.2} ms ({:.2} + {:.2}), fused {:.2} ms",
        (grad + adam) * 1e3,
        grad * 1e3,
        adam * 1e3,
        fused * 1e3
    );
}
