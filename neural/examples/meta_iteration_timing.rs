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
use avatar_neural::collective::{Collective, Transport};
use avatar_neural::meta_data::{MetaData, MetaDataConfig};
use avatar_neural::meta_training::{MetaOptions, meta_train_collective};
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
    let _ = std::fs::remove_dir_all(&out);
    let mut last = 0.0;
    let mut times: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    meta_train_collective(
        &data,
        &options,
        &out,
        None,
        &mut |p| {
            let stage = usize::from(p.stage == "hyper");
            times[stage].push(p.seconds - last);
            last = p.seconds;
        },
        &c,
    )
    .unwrap();
    if c.is_root() {
        for (name, mut t) in ["Alg. 1", "Alg. 2"].into_iter().zip(times) {
            t.remove(0);
            t.sort_by(f64::total_cmp);
            println!(
                "{} ranks, {name}: median {:.3} s an iteration (min {:.3}, max {:.3}, {} iterations)",
                c.world(),
                t[t.len() / 2],
                t[0],
                t[t.len() - 1],
                t.len()
            );
        }
    }
}
