//! `avatar-studio bench`: the speed targets, measured side by side in one run and printed as a
//! Markdown report (these machines are noisy: compare ratios within one report).

mod canonical;
mod eval;
mod export;
mod neural;
mod train;

use avatar_core::body::{BodyModel, BodyParams};
use glam::Vec3;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Only run sections whose name contains this text, or one of several separated by commas (body, capture, canonical, eval, export,
    /// neural, train-step, train-meta, studio; `train` runs both of the training sections).
    #[arg(long)]
    only: Option<String>,
    /// Also write the report to this Markdown file.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run the training path's portable loops even where the CPU has AVX-512
    /// (`avatar_neural::training::step::KernelPath::Portable`).
    #[arg(long)]
    portable_kernels: bool,
}

/// The embedded demo capture, written to the studio's cache folder (as the studio does), so
/// the bench runs from the installed package.
fn demo_capture() -> Result<PathBuf, String> {
    avatar_studio::studio::demo::demo_capture_dir().map_err(|e| e.to_string())
}

/// A report section: its name (for `--only`) and what writes it.
type Section = (&'static str, fn() -> String);

/// Time `f` over `reps` repetitions after one warm-up; returns the median in seconds.
pub fn median_seconds(reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut times: Vec<f64> = (0..reps.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn walking_pose(t: f32) -> BodyParams {
    let mut p = BodyParams::default();
    let s = (t * std::f32::consts::TAU).sin();
    p.pose[1] = Vec3::new(-0.5 * s, 0.0, 0.0);
    p.pose[2] = Vec3::new(0.5 * s, 0.0, 0.0);
    p.pose[4] = Vec3::new(0.6 * s.max(0.0), 0.0, 0.0);
    p.pose[5] = Vec3::new(0.6 * (-s).max(0.0), 0.0, 0.0);
    p.pose[16] = Vec3::new(0.0, 0.0, -1.2);
    p.pose[17] = Vec3::new(0.0, 0.0, 1.2);
    p
}

fn body_section() -> String {
    let bytes = avatar_core::body::embedded::FULL_NPZ;
    let mut out = String::from("## body\n\n| what | median | note |\n|---|---|---|\n");
    let load = median_seconds(5, || {
        let _ = BodyModel::from_npz_bytes(bytes, "bench").expect("embedded body loads");
    });
    out += &format!(
        "| load the open body (13.4k vertices) from npz | {:.1} ms | target: well under 1 s |\n",
        load * 1e3
    );
    for (name, model) in [
        ("full", avatar_core::body::open_body_ref()),
        ("low-poly", avatar_core::body::open_body_lowpoly_ref()),
    ] {
        let mut i = 0;
        let t = median_seconds(20, || {
            i += 1;
            std::hint::black_box(model.pose(&walking_pose(i as f32 * 0.05)));
        });
        out += &format!(
            "| pose {name} body ({} vertices): shape + FK + LBS | {:.2} ms | |\n",
            model.num_vertices(),
            t * 1e3
        );
    }
    out + &closest_point_lines()
}

/// The rest body's closest-point queries as pose pre-alignment asks them (one thread): points
/// from 5 mm inside to 15 mm outside along each vertex's normal, each asked again a millimetre
/// away with its last closest face as the hint, and without a hint.
fn closest_point_lines() -> String {
    use avatar_core::mesh::bvh::Bvh;
    let body = avatar_core::body::open_body_ref();
    let mesh = body.mesh(body.v_template.clone());
    let build = median_seconds(5, || {
        std::hint::black_box(Bvh::build(&mesh));
    });
    let bvh = Bvh::build(&mesh);
    let points: Vec<Vec3> = mesh
        .positions
        .iter()
        .zip(mesh.vertex_normals())
        .enumerate()
        .map(|(i, (&p, n))| p + n * (-0.005 + 0.02 * ((i * 7919) % 61) as f32 / 60.0))
        .collect();
    let hints: Vec<u32> =
        points.iter().map(|&p| bvh.closest_point(p).map_or(0, |h| h.face)).collect();
    let moved = Vec3::new(0.001, -0.0005, 0.0007);
    let hinted = median_seconds(5, || {
        for (&p, &hint) in points.iter().zip(&hints) {
            std::hint::black_box(bvh.closest_point_hinted(p + moved, hint));
        }
    });
    let plain = median_seconds(5, || {
        for &p in &points {
            std::hint::black_box(bvh.closest_point(p + moved));
        }
    });
    let n = points.len() as f64;
    format!(
        "| build the rest body's BVH ({} faces) | {:.1} ms | surface area heuristic |\n\
         | closest point near the rest body, hinted (pre-alignment's query) | {:.2} us | one thread |\n\
         | closest point near the rest body, no hint | {:.2} us | one thread |\n",
        mesh.faces.len(),
        build * 1e3,
        hinted / n * 1e6,
        plain / n * 1e6
    )
}

fn capture_section() -> String {
    use avatar_core::capture::Capture;
    use avatar_core::synth::{Outfit, SynthJob, generate_capture};
    let mut out = String::from("## capture\n\n| what | median | note |\n|---|---|---|\n");
    let dir =
        std::env::temp_dir().join(format!("avatar-studio-bench-capture-{}", std::process::id()));
    let mut job = SynthJob::new(
        1,
        Outfit::LongsleeveTrousers,
        avatar_core::motion::clip_by_name("walk").expect("library clip"),
    );
    job.frames = Some(8);
    job.write_ground_truth = false;
    let t = Instant::now();
    if let Err(e) = generate_capture(&dir, avatar_core::body::open_body_ref(), &job) {
        return out + &format!("| synth failed | | {e} |\n");
    }
    out += &format!(
        "| synthesize 8 frames (250x250) with the clothed body | {:.1} ms/frame | |\n",
        t.elapsed().as_secs_f64() * 1e3 / 8.0
    );
    let secs = median_seconds(3, || {
        std::hint::black_box(Capture::open(&dir).expect("bench capture opens"));
    });
    out += &format!(
        "| open a capture: read, back-project, crop, PCA normals (250x250) | {:.1} ms/frame | |\n",
        secs * 1e3 / 8.0
    );
    let _ = std::fs::remove_dir_all(&dir);
    out
}

fn neural_section() -> String {
    neural::bench_report(avatar_neural::HyperFitOptions::default().steps)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(path) = &args.out {
        avatar_core::io::Inputs::new().check_file(path, &["md"])?;
    }
    if args.portable_kernels {
        avatar_neural::training::step::set_kernel_path(
            avatar_neural::training::step::KernelPath::Portable,
        );
    }
    let sections: Vec<Section> = vec![
        ("body", body_section),
        ("capture", capture_section),
        ("canonical", canonical::bench_report),
        ("eval", eval::bench_report),
        ("export", export::bench_report),
        ("neural", neural_section),
        ("train-step", train::bench_report),
        ("train-meta", train::meta_report),
        ("studio", avatar_studio::studio::bench::bench_report),
    ];
    let mut report = format!(
        "# Avatar Studio benchmarks\n\n{} threads, profile {}, `avatar-studio bench`\n\n",
        std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        if cfg!(debug_assertions) { "dev (debug assertions)" } else { "release" }
    );
    for (name, section) in sections {
        if args.only.as_deref().is_some_and(|o| !o.split(',').any(|o| name.contains(o.trim()))) {
            continue;
        }
        let text = section();
        println!("{text}");
        report += &text;
        report += "\n";
    }
    if let Some(path) = &args.out {
        avatar_core::io::write_bytes_atomic(path, report.as_bytes())?;
    }
    Ok(())
}
