//! The all-reduce's cost on its own: every rank all-reduces a vector of N floats (by default the
//! compact preset's Alg. 2 update: 758,969 weights + the loss) REPS times; rank 0 prints the
//! median and quartiles, and the latency of the one-float reduction each iteration starts with.
//! Two ranks on loopback (TCP):
//! ```sh
//! cargo build -p avatar-neural --features mpi --example allreduce_timing
//! mpirun -np 2 --mca pml ob1 --mca btl self,tcp --mca btl_tcp_if_include lo \
//!     $CARGO_TARGET_DIR/debug/examples/allreduce_timing 758970 50
//! ```
use avatar_neural::training::collective::{Collective, Transport};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = a.first().map_or(758_970, |s| s.parse().expect("N"));
    let reps: usize = a.get(1).map_or(30, |s| s.parse().expect("REPS"));
    let c = Collective::join(Transport::Mpi).expect("MPI");
    let mut v: Vec<f32> = (0..n).map(|i| (i % 7) as f32 + c.rank() as f32).collect();
    c.all_reduce_sum(&mut v).expect("warm-up");
    let mut times = Vec::with_capacity(reps);
    for _ in 0..reps {
        c.barrier().expect("barrier");
        let t = Instant::now();
        c.all_reduce_sum(&mut v).expect("all-reduce");
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let mut small = Vec::with_capacity(reps);
    for _ in 0..reps {
        let t = Instant::now();
        c.any(false).expect("any");
        small.push(t.elapsed().as_secs_f64() * 1e3);
    }
    for t in [&mut times, &mut small] {
        t.sort_by(f64::total_cmp);
    }
    let q = |t: &[f64], f: f64| t[((t.len() - 1) as f64 * f).round() as usize];
    if c.is_root() {
        println!(
            "{} ranks: all-reduce of {n} floats ({:.2} MB): median {:.2} ms (quartiles {:.2}-{:.2}); one float: median {:.3} ms",
            c.world(),
            n as f64 * 4e-6,
            q(&times, 0.5),
            q(&times, 0.25),
            q(&times, 0.75),
            q(&small, 0.5)
        );
    }
}
