//! No lost file, no panic, no bad input accepted.
//!
//! `bad_input_corpus`: every corrupted input of `corpus.rs` given to the command that reads it,
//! through the real binary (a panic exits 101, an abort dies on a signal: both fail here). For
//! each: refused with exit code 1, the error names the file, no input changed, no temporary or
//! output file left, peak memory (the child's maximum RSS from wait4) under 500 MB.
//!
//! `mutation_fuzz`: seeded random mutations of capture.json, .avatar and meta-model files, loaded
//! in process under catch_unwind; AVATAR_STUDIO_FUZZ_CASES sets the cases per kind (default
//! 100; docs/reliability.md has the 1,000-case run).

mod corpus;
mod fixtures;
mod fuzz;

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Every file under `root` (links followed) with a hash of its bytes.
pub fn snapshot(root: &Path) -> BTreeMap<PathBuf, u64> {
    use std::hash::{Hash, Hasher};
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let mut h = std::collections::hash_map::DefaultHasher::new();
                std::fs::read(&p).unwrap_or_default().hash(&mut h);
                out.insert(p, h.finish());
            }
        }
    }
    out
}

/// What a child did: exit code (None when killed by a signal), stderr, peak RSS in MB, seconds.
pub struct Run {
    pub code: Option<i32>,
    pub stderr: String,
    pub peak_mb: f64,
    pub seconds: f64,
}

/// Run the binary and reap it with wait4. Peak memory: GNU time's figure for the command when
/// /usr/bin/time is there (exact); else wait4's, an upper bound (Linux counts the test process's
/// own peak in a child it spawns).
fn run(args: &[OsString], cache: &Path, index: usize) -> Run {
    let t = Instant::now();
    let time = Path::new("/usr/bin/time");
    let measured = cache.join(format!("peak-{index}.txt"));
    let mut command = if time.exists() {
        let mut c = Command::new(time);
        c.arg("-f").arg("%M").arg("-o").arg(&measured).arg(env!("CARGO_BIN_EXE_avatar-studio"));
        c
    } else {
        Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
    };
    // Reaped by wait4 below, whose rusage gives the peak memory.
    #[allow(clippy::zombie_processes)]
    let mut child = command
        .args(args)
        .env("XDG_CACHE_HOME", cache)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut pipe = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = pipe.read_to_string(&mut s);
        s
    });
    let pid = child.id() as libc::pid_t;
    let (mut status, mut usage): (libc::c_int, libc::rusage) = (0, unsafe { std::mem::zeroed() });
    loop {
        // SAFETY: wait4 on our own child with valid out-pointers.
        let r = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
        if r == pid {
            break;
        }
        assert!(r == 0, "wait4 failed");
        if t.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
    let mut peak_mb = usage.ru_maxrss as f64 / 1024.0;
    if let Ok(text) = std::fs::read_to_string(&measured) {
        // GNU time writes "Command exited with non-zero status 1" before the figure.
        peak_mb = text
            .lines()
            .filter_map(|l| l.trim().parse::<f64>().ok())
            .next_back()
            .unwrap_or(peak_mb * 1024.0)
            / 1024.0;
    }
    Run { code, stderr: reader.join().unwrap(), peak_mb, seconds: t.elapsed().as_secs_f64() }
}

#[test]
fn bad_input_corpus() {
    let dir = tempfile::tempdir().unwrap();
    let (root, cache) = (dir.path().join("data"), dir.path().join("cache"));
    std::fs::create_dir_all(&cache).unwrap();
    let f = fixtures::Fixtures::write(&root);
    f.check_valid();
    let cases = corpus::Corpus::new(&f).build();
    let before = snapshot(&root);
    let t = Instant::now();
    // Two workers: the CI machine has two cores.
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<(usize, Run)> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..2)
            .map(|_| {
                s.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(case) = cases.get(i) else { break };
                        mine.push((i, run(&case.args, &cache, i)));
                    }
                    mine
                })
            })
            .collect();
        workers.into_iter().flat_map(|w| w.join().unwrap()).collect()
    });
    let mut failures = Vec::new();
    let (mut worst, mut worst_case) = (0.0f64, String::new());
    for (i, r) in &results {
        let case = &cases[*i];
        let what = format!(
            "{} ({})",
            case.name,
            case.args.iter().map(|a| a.to_string_lossy()).collect::<Vec<_>>().join(" ")
        );
        if r.peak_mb > worst {
            (worst, worst_case) = (r.peak_mb, case.name.clone());
        }
        if r.code != Some(1) {
            failures.push(format!(
                "{what}: exit {:?} (expected a refusal, exit 1): {}",
                r.code, r.stderr
            ));
            continue;
        }
        if r.stderr.contains("panicked") || !r.stderr.contains("error:") {
            failures.push(format!("{what}: no clean error: {}", r.stderr));
        }
        if let Some(named) = &case.names {
            let name = named.file_name().unwrap().to_string_lossy();
            if !r.stderr.contains(&*name) {
                failures.push(format!("{what}: the error does not name {name}: {}", r.stderr));
            }
        }
        if r.peak_mb > 500.0 {
            failures.push(format!("{what}: peak memory {:.0} MB", r.peak_mb));
        }
    }
    // AVATAR_STUDIO_CORPUS_REPORT=FILE: one line per case (name, exit code, seconds, peak MB, error).
    if let Some(path) = std::env::var_os("AVATAR_STUDIO_CORPUS_REPORT") {
        let mut rows: Vec<String> = results
            .iter()
            .map(|(i, r)| {
                format!(
                    "{}\t{:?}\t{:.2}\t{:.0}\t{}",
                    cases[*i].name,
                    r.code,
                    r.seconds,
                    r.peak_mb,
                    r.stderr.lines().next().unwrap_or("")
                )
            })
            .collect();
        rows.sort();
        std::fs::write(path, rows.join("\n") + "\n").unwrap();
    }
    let after = snapshot(&root);
    for (p, h) in &before {
        match after.get(p) {
            None => failures.push(format!("input removed: {}", p.display())),
            Some(g) if g != h => failures.push(format!("input changed: {}", p.display())),
            _ => {}
        }
    }
    for p in after.keys().filter(|p| !before.contains_key(*p)) {
        failures.push(format!("file left behind (an output or a temporary file): {}", p.display()));
    }
    let slowest = results
        .iter()
        .map(|(i, r)| (r.seconds, cases[*i].name.clone()))
        .fold((0.0, String::new()), |a, b| if b.0 > a.0 { b } else { a });
    println!(
        "bad-input corpus: {} cases, {} refused cleanly, {} failures; peak memory {worst:.0} MB ({worst_case}); slowest {:.2} s ({}); {:.1} s in all",
        cases.len(),
        cases.len() - failures.len().min(cases.len()),
        failures.len(),
        slowest.0,
        slowest.1,
        t.elapsed().as_secs_f64()
    );
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn mutation_fuzz() {
    let cases =
        std::env::var("AVATAR_STUDIO_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(100);
    let seed =
        std::env::var("AVATAR_STUDIO_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(19);
    fuzz::run(cases, seed);
}
