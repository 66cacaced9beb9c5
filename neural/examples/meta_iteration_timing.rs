//! Seconds per outer iteration of meta-training with the compact preset, in one process or as
//! the ranks of an MPI run: `meta_iteration_timing DATA OUT SDF_ITERS HYPER_ITERS SDF_BATCH
//! HYPER_BATCH`. Data: 2 training subjects x 4 outfits x 4 poses x 2,000 points (generated into
//! DATA on first use); other options the defaults (the shipped model's inner fits). Rank 0
//! prints the median seconds of an Alg. 1 and an Alg. 2 iteration (the first of each left out).
//! ```sh
//! cargo build -p avatar-neural --features mpi --example meta_iteration_timing
//! E=$CARGO_TARGET_DIR/debug/examples/meta_iteration_timing
//! RAYON_NUM_THREADS=1 $E /tmp/md /tmp/one 12 12 4 2                          # 1 process
//! mpirun -np 2 -x RAYON_NUM_THREADS=1 --mca btl self,tcp $E /tmp/md /tmp/two 12 12 4 2
//! ```
use avatar_neural::data::meta_data::{MetaData, MetaDataConfig};
use avatar_neural::training::collective::{Collective, Transport};
use avatar_neural::training::meta_training::{MetaOptions, meta_train_collective};
use std::path::PathBuf;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() < 6 {
        eprintln!(
            "usage: meta_iteration_timing DATA OUT SDF_ITERS HYPER_ITERS SDF_BATCH HYPER_BATCH"
        );
        std::process::exit(2);
    }
    let num = |i: usize| a[i].parse::<usize>().expect("a count");
    let c = Collective::join(Transport::Mpi).expect("MPI");
    let config = MetaDataConfig { subjects: 2, poses_per_group: 4, ..MetaDataConfig::default() };
    let body = avatar_core::body::open_body_ref();
    if !c.is_root() {
        c.barrier().unwrap();
    }
    let data = MetaData::load_or_generate(&PathBuf::from(&a[0]), body, &config, &|_| {}).unwrap();
    if c.is_root() {
        c.barrier().unwrap();
    }
    let options = MetaOptions {
        sdf_iterations: num(2),
        hyper_iterations: num(3),
        sdf_meta_batch: num(4),
        hyper_meta_batch: num(5),
        checkpoint_every: 1000,
        ..MetaOptions::default()
    };
    let out = PathBuf::from(&a[1]);
    if c.is_root() {
        let _ = std::fs::remove_dir_all(&out);
    }
    let mut last = 0.0;
    let mut last_cpu = cpu_seconds();
    let mut times: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let mut cpu: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    meta_train_collective(
        &data,
        &options,
        &out,
        None,
        &mut |p| {
            let stage = usize::from(p.stage == "hyper");
            times[stage].push(p.seconds - last);
            last = p.seconds;
            let now = cpu_seconds();
            cpu[stage].push(now - last_cpu);
            last_cpu = now;
        },
        &c,
    )
    .unwrap();
    // Every rank's CPU seconds an iteration (median), summed over the ranks.
    let median = |t: &mut Vec<f64>| {
        t.remove(0);
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let mut cpu_sum = [median(&mut cpu[0]) as f32, median(&mut cpu[1]) as f32];
    c.all_reduce_sum(&mut cpu_sum).unwrap();
    if c.is_root() {
        for (i, (name, mut t)) in ["Alg. 1", "Alg. 2"].into_iter().zip(times).enumerate() {
            let m = median(&mut t);
            println!(
                "{} ranks, {name}: median {m:.3} s an iteration (min {:.3}, max {:.3}, {} iterations); CPU {:.3} s an iteration, all ranks",
                c.world(),
                t[0],
                t[t.len() - 1],
                t.len(),
                cpu_sum[i]
            );
        }
    }
}

/// This process's CPU time (user + system, all threads), from /proc (Linux; 10 ms ticks).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = after.split_whitespace().collect();
    // Fields 14 and 15 of the file (utime, stime) are the 12th and 13th after the name.
    let field = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (field(11) + field(12)) / 100.0
}
