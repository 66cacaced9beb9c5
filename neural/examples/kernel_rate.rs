//! GFLOP/s of the training path's products on one thread, per kernel path, at the shapes a
//! step runs (a block of 128 points through a 128- or 256-wide layer, and the dot products of
//! the layers of width 1 and 3, a block's rows together and one row at a time): `cargo run --release
//! -p avatar-neural --example kernel_rate [reps]`. Each line times every path back to back,
//! timed by the thread's own CPU time (/proc/thread-self/schedstat), so other jobs on the
//! machine slow it less than they slow the wall clock.
use avatar_neural::training::step::gemm::{Epilogue, Mat, dots_with, gemm_then_with};
use avatar_neural::training::step::{KernelPath, kernel_name_of};

/// This thread's time on a CPU in seconds (Linux; the wall clock elsewhere).
fn thread_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or_else(
            || {
                static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
                START.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
            },
            |ns| ns * 1e-9,
        )
}

fn data(len: usize, seed: usize) -> Vec<f32> {
    (0..len).map(|i| (((i * 37 + seed * 11) % 101) as f32 - 50.0) * 0.001).collect()
}

fn main() {
    let reps: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(200);
    let paths = [KernelPath::Fastest, KernelPath::Avx2, KernelPath::Portable];
    println!("| product (m x k x n) | {} |", paths.map(kernel_name_of).join(" | "));
    println!("|---|---|---|---|");
    for (rows, width) in [(128, 128), (128, 256)] {
        let (m, k, n) = (rows, width, width);
        let a = data(m * k, 1);
        let w = data(k * n, 2);
        let f = data(m * n, 3);
        let bias = data(n, 4);
        let (mut out, mut aux) = (vec![0f32; m * n], vec![0f32; m * n]);
        let mut grad = vec![0f32; k * n];
        let names = ["sine layer h W", "chain q W^T (AlsoTimes)", "weight grad h^T v"];
        for (case, name) in names.iter().enumerate() {
            let mut line = format!("| {name} ({m} x {k} x {n}) |");
            for path in paths {
                let mut run = || match case {
                    0 => gemm_then_with(
                        path,
                        Mat::new(&a, m, k),
                        Mat::new(&w, k, n),
                        &mut out,
                        Epilogue::Sine { w0: 30.0, bias: &bias, deriv: &mut aux },
                    ),
                    1 => gemm_then_with(
                        path,
                        Mat::new(&a, m, k),
                        Mat::new(&w, k, n),
                        &mut out,
                        Epilogue::AlsoTimes { factor: &f, times: &mut aux },
                    ),
                    _ => gemm_then_with(
                        path,
                        Mat::new(&a, m, k).t(),
                        Mat::new(&f, m, n),
                        &mut grad,
                        Epilogue::Store { beta: 1.0 },
                    ),
                };
                run();
                let t = thread_seconds();
                for _ in 0..reps {
                    run();
                }
                let s = (thread_seconds() - t) / reps as f64;
                line += &format!(" {:.1} GFLOP/s |", 2.0 * (m * k * n) as f64 / s / 1e9);
            }
            println!("{line}");
        }
    }
    // The layers of width 1 (the SDF) and 3 (the input's gradient): dot products of rows.
    for (m, k, r) in [(128, 128, 1), (128, 128, 3), (128, 256, 1), (128, 256, 3), (128, 128, 128)] {
        let (a, rows) = (data(m * k, 5), data(r * k, 6));
        let mut out = vec![0f32; m * r];
        for (name, by_row) in [("dots, a block's rows together", false), ("dots, row by row", true)]
        {
            let mut line = format!("| {name} ({m} x {k} x {r}) |");
            for path in paths {
                let mut run = || {
                    if by_row {
                        for (ai, oi) in a.chunks_exact(k).zip(out.chunks_exact_mut(r)) {
                            dots_with(path, ai, &rows, k, 0.0, oi);
                        }
                    } else {
                        dots_with(path, &a, &rows, k, 0.0, &mut out);
                    }
                };
                run();
                let t = thread_seconds();
                for _ in 0..reps * 20 {
                    run();
                }
                let s = (thread_seconds() - t) / (reps * 20) as f64;
                line += &format!(" {:.1} GFLOP/s |", 2.0 * (m * k * r) as f64 / s / 1e9);
            }
            println!("{line}");
        }
    }
}
