//! Data-parallel meta-training on localhost: the same seeded run in one process and in two
//! processes (this test binary started twice by `mpirun` as ranks 0 and 1, MPI over TCP on
//! loopback) gives the same meta-model within float tolerance; only rank 0 writes files; a run
//! cancelled on one rank stops on both, and restarted it resumes on both from rank 0's
//! checkpoint (rank 1 has its own, empty output folder: no shared disk needed). Needs the `mpi`
//! feature and OpenMPI's `mpirun` (scripts/test.sh installs it).
#![cfg(feature = "mpi")]

use avatar_neural::data::meta_data::{MetaData, MetaDataConfig};
use avatar_neural::training::collective::{Collective, Transport};
use avatar_neural::training::meta_training::{
    MODEL_FILE, MetaOptions, meta_train, meta_train_collective,
};
use avatar_neural::*;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Test-only switch: set, this binary's `rank_process` test runs one rank of a run
/// ("OUT-BASE DATA [stop-stage stop-iteration stop-rank]"; rank r writes OUT-BASE/rR).
const CHILD: &str = "AVATAR_COLLECTIVE_TEST_CHILD";

fn options() -> MetaOptions {
    MetaOptions {
        config: HyperConfig {
            siren: SirenConfig { hidden: 16, layers: 2 },
            head_hidden: 8,
            rank: Some(2),
            encoding: PoseEncoding::Hierarchical,
        },
        sdf_iterations: 3,
        sdf_inner_steps: 2,
        hyper_iterations: 4,
        hyper_max_task: 2,
        hyper_inner_epochs: 1,
        // Two tasks an Alg. 2 iteration: each rank adapts one; Alg. 1 has 3 (ranks 2 + 1).
        hyper_meta_batch: 2,
        hyper_inner: HyperFitOptions {
            poses_per_step: 2,
            surface_per_pose: 100,
            off_per_pose: 100,
            ..HyperFitOptions::default()
        },
        points_per_step: 100,
        checkpoint_every: 1,
        seed: 4,
        ..MetaOptions::default()
    }
}

fn data(dir: &Path) -> MetaData {
    let config = MetaDataConfig {
        subjects: 2,
        outfits: vec!["tshirt_shorts".into()],
        poses_per_group: 3,
        points_per_pose: 300,
        seed: 1,
    };
    MetaData::load_or_generate(dir, avatar_core::body::open_body_ref(), &config, &|_| {}).unwrap()
}

/// One rank, in a child process; writes the iterations it saw to `seen.txt` in its folder.
#[test]
fn rank_process() {
    let Ok(spec) = std::env::var(CHILD) else { return };
    let f: Vec<&str> = spec.split(' ').collect();
    let collective = Collective::join(Transport::Mpi).unwrap();
    assert_eq!(collective.world(), 2);
    let out = Path::new(f[0]).join(format!("r{}", collective.rank()));
    let d = MetaData::load(Path::new(f[1])).unwrap();
    let stop_at = f
        .get(2)
        .filter(|_| f[4].parse::<usize>().unwrap() == collective.rank())
        .map(|stage| (stage.to_string(), f[3].parse::<usize>().unwrap()));
    let cancel = AtomicBool::new(false);
    let mut seen = String::new();
    let r = meta_train_collective(
        &d,
        &options(),
        &out,
        Some(&cancel),
        &mut |p| {
            seen += &format!("{} {} {:e}\n", p.stage, p.iteration, p.loss);
            if stop_at.as_ref().is_some_and(|(s, i)| s == p.stage && *i == p.iteration) {
                cancel.store(true, Ordering::Relaxed);
            }
        },
        &collective,
    );
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("seen.txt"), &seen).unwrap();
    std::fs::write(out.join("result.txt"), format!("{:?}", r.map_err(|e| e.to_string()))).unwrap();
}

/// Run two ranks under `mpirun` (MPI over TCP on loopback only; outputs `base/r0`, `base/r1`),
/// 2 minutes at most.
fn run_two(base: &Path, data: &Path, stop: Option<(&str, usize, usize)>) {
    let mut spec = format!("{} {}", base.display(), data.display());
    if let Some((stage, iteration, rank)) = stop {
        spec += &format!(" {stage} {iteration} {rank}");
    }
    let exe = std::env::current_exe().unwrap();
    let log = base.with_extension("log");
    std::fs::create_dir_all(base).unwrap();
    let mut child: Child = Command::new("mpirun")
        .args(["-np", "2", "--oversubscribe", "--allow-run-as-root", "-x", CHILD, "-x"])
        .arg("RAYON_NUM_THREADS=1")
        .args(["--mca", "pml", "ob1", "--mca", "btl", "self,tcp"])
        .args(["--mca", "btl_tcp_if_include", "lo", "--mca", "oob_tcp_if_include", "lo"])
        .arg(&exe)
        .args(["rank_process", "--exact", "--nocapture", "--test-threads=1"])
        .env(CHILD, spec)
        .stdout(Stdio::from(std::fs::File::create(&log).unwrap()))
        .stderr(Stdio::from(std::fs::File::create(log.with_extension("err")).unwrap()))
        .spawn()
        .expect("mpirun (Debian: openmpi-bin) starts");
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let err = std::fs::read_to_string(log.with_extension("err")).unwrap_or_default();
            let out = std::fs::read_to_string(&log).unwrap_or_default();
            assert!(status.success(), "mpirun failed: {err}\n{out}");
            return;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("mpirun did not finish in 2 minutes: {}", log.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// "stage iteration" of each logged line.
fn iterations(seen: &str) -> Vec<String> {
    seen.lines().map(|l| l.rsplit_once(' ').unwrap().0.to_string()).collect()
}

/// max |a - b| over both weight sets, and max |a|.
fn gap(a: &MetaModel, b: &MetaModel) -> (f32, f32) {
    let pairs = a.hyper.iter().zip(&b.hyper).chain(a.static_sdf.iter().zip(&b.static_sdf));
    pairs.fold((0f32, 0f32), |(g, m), (x, y)| (g.max((x - y).abs()), m.max(x.abs())))
}

#[test]
fn one_and_two_processes_give_the_same_meta_model() {
    if std::env::var(CHILD).is_ok() {
        return;
    }
    let root = tempfile::tempdir().unwrap();
    let data_dir = root.path().join("data");
    let d = data(&data_dir);
    let o = options();

    // One process.
    let one =
        MetaModel::load(&meta_train(&d, &o, &root.path().join("one"), None, &mut |_| {}).unwrap())
            .unwrap();

    // Two processes: rank 0 writes the model, rank 1 nothing.
    let two_dir = root.path().join("two");
    run_two(&two_dir, &data_dir, None);
    let (r0, r1) = (two_dir.join("r0"), two_dir.join("r1"));
    assert_eq!(read(&r0.join("result.txt")), format!("Ok({:?})", r0.join(MODEL_FILE)));
    let two = MetaModel::load(&r0.join(MODEL_FILE)).unwrap();
    let mut files: Vec<String> = std::fs::read_dir(&r1)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files, ["result.txt", "seen.txt"], "rank 1 writes no run files");
    // Both ranks saw every iteration with the same mean loss, to the bit (they hold the same
    // all-reduced sums).
    let (seen0, seen1) = (read(&r0.join("seen.txt")), read(&r1.join("seen.txt")));
    assert_eq!(seen0, seen1);
    let every = ["sdf 1", "sdf 2", "sdf 3", "hyper 1", "hyper 2", "hyper 3", "hyper 4"];
    assert_eq!(iterations(&seen0), every);

    // The same meta-model: the sums of the tasks' updates differ only in their order. The
    // tolerance is far below what the run moved the weights (and what another seed gives).
    let (g, scale) = gap(&one, &two);
    let other_seed = MetaModel::load(
        &meta_train(
            &d,
            &MetaOptions { seed: 5, ..o.clone() },
            &root.path().join("other-seed"),
            None,
            &mut |_| {},
        )
        .unwrap(),
    )
    .unwrap();
    let (other, _) = gap(&one, &other_seed);
    eprintln!("1 vs 2 processes: max |diff| {g:e} (weights up to {scale}); another seed: {other}");
    assert!(g <= 1e-5 * scale.max(1.0), "1 vs 2 processes differ by {g}");
    assert!(other > 1e3 * g.max(1e-7), "another seed differs by only {other}");

    // Cancelled on rank 1 after Alg. 2's 2nd iteration: both ranks stop there, rank 0 kept the
    // checkpoint; run again, both resume at the 3rd. One process cancelled and resumed at the
    // same place gives the same model (the outer Adam restarts on both).
    let cancelled = root.path().join("cancelled");
    run_two(&cancelled, &data_dir, Some(("hyper", 2, 1)));
    let (c0, c1) = (cancelled.join("r0"), cancelled.join("r1"));
    for c in [&c0, &c1] {
        assert!(read(&c.join("result.txt")).contains("cancelled"), "{}", c.display());
        assert_eq!(iterations(&read(&c.join("seen.txt"))).last().unwrap(), "hyper 2");
    }
    assert!(c0.join("checkpoint.bin").exists() && !c1.join("checkpoint.bin").exists());
    run_two(&cancelled, &data_dir, None);
    for c in [&c0, &c1] {
        assert_eq!(
            iterations(&read(&c.join("seen.txt"))),
            ["hyper 3", "hyper 4"],
            "{}",
            c.display()
        );
    }
    let single = root.path().join("single");
    let cancel = AtomicBool::new(false);
    let r = meta_train(&d, &o, &single, Some(&cancel), &mut |p| {
        if (p.stage, p.iteration) == ("hyper", 2) {
            cancel.store(true, Ordering::Relaxed);
        }
    });
    assert!(r.unwrap_err().to_string().contains("cancelled"));
    let resumed_one =
        MetaModel::load(&meta_train(&d, &o, &single, None, &mut |_| {}).unwrap()).unwrap();
    let resumed_two = MetaModel::load(&c0.join(MODEL_FILE)).unwrap();
    let (g, scale) = gap(&resumed_one, &resumed_two);
    assert!(g <= 1e-5 * scale.max(1.0), "resumed runs differ by {g}");
}
