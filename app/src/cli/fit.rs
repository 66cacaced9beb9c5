//! `avatar-studio fit`: fine-tune a personal avatar on a capture. By default the meta-learned
//! hypernetwork (MetaAvatar) starts from the shipped model; `--from-scratch` gives the baseline
//! with the same networks, `--static` the pose-independent SDF.

use anyhow::bail;
use avatar_neural::avatar::{AnyAvatar, AvatarFit, FitKind, fit_avatar};
use avatar_neural::data::capture_points::{CapturePoints, FrameCount};
use avatar_neural::training::pose_trace::{PoseTrace, Snap, TraceLines};
use avatar_neural::{HyperConfig, HyperFitOptions, Init, MetaModel};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Capture folder (with capture.json).
    capture: PathBuf,
    /// Output avatar file (NAME.avatar).
    #[arg(long)]
    out: PathBuf,
    /// The SMPL-family model file (.npz) the capture's fittings were made with; replaces the
    /// body model capture.json names. The avatar stores the subject's shaped body, not the file.
    #[arg(long)]
    body_model: Option<PathBuf>,
    /// Use N usable frames, chosen over the whole capture (default: up to 32, refused under 8; more frames average
    /// down the fittings' shared error, which pose refinement cannot see: docs/results.md).
    #[arg(long)]
    frames: Option<usize>,
    /// Optimisation steps (each over up to 8 frames: one epoch of the reference). A MetaAvatar
    /// with loose cloth after them (a skirt, a coat's tails) goes on to twice as many.
    #[arg(long, default_value_t = 256)]
    steps: usize,
    /// Meta-learned model file (default: the shipped compact model).
    #[arg(long)]
    model: Option<PathBuf>,
    /// The baseline: the same networks from their random initialisation (network preset
    /// from --preset).
    #[arg(long)]
    from_scratch: bool,
    /// A static (pose-independent) SDF instead of the hypernetwork.
    #[arg(long = "static")]
    static_sdf: bool,
    /// Network preset for --from-scratch: compact or paper.
    #[arg(long, default_value = "compact")]
    preset: String,
    #[command(flatten)]
    device: super::DeviceArg,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Joint refinement of each frame's pose (24 joint rotations and the translation) with the
    /// avatar (PINA 3.2), kept close to the given fitting: on or off. The pose-dependent
    /// avatar only; the refined poses are saved in the avatar.
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    refine_poses: String,
    /// Diagnostic: a capture folder whose capture.json holds the exact fittings of this
    /// capture's frames; every pose refinement round prints the refined poses' errors.
    #[arg(long, value_name = "DIR")]
    true_poses: Option<PathBuf>,
    /// Diagnostic, with --true-poses: joints (comma-separated indices, `t` for the
    /// translation) set to the truth after every refinement round.
    #[arg(long, value_name = "LIST", requires = "true_poses")]
    snap_to_truth: Option<String>,
    /// Print the seconds each phase of the fit took (canonicalization, pre-alignment,
    /// training, refinement rounds, the loose check, saving) at the end.
    #[arg(long)]
    timings: bool,
    /// The training path's kernels: fastest (AVX-512 where the CPU has it, else AVX2 + FMA,
    /// else plain loops), avx2 (what a CPU without AVX-512 runs) or portable; to time a fit as
    /// another CPU runs it (the avatar differs by roundings only).
    #[arg(long, default_value = "fastest", value_parser = ["fastest", "avx2", "portable"])]
    kernels: String,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let compute = args.device.compute()?;
    if args.steps == 0 || args.frames == Some(0) {
        bail!("--steps and --frames must be at least 1");
    }
    avatar_core::io::Inputs::new()
        .capture(&args.capture)
        .maybe_file(args.model.as_ref())
        .check_file(&args.out, &["avatar"])?;
    let Some(preset) = HyperConfig::preset(&args.preset) else {
        bail!("unknown --preset {:?}: use compact or paper", args.preset);
    };
    // The first Ctrl-C cancels the fit and the partial avatar is still written; a second one
    // ends the process.
    let cancel = Arc::new(AtomicBool::new(false));
    {
        let c = cancel.clone();
        let _ = ctrlc::set_handler(move || {
            if c.swap(true, Ordering::Relaxed) {
                std::process::exit(130);
            }
        });
    }
    use avatar_neural::training::step::{KernelPath, kernel_name, set_kernel_path};
    set_kernel_path(match args.kernels.as_str() {
        "avx2" => KernelPath::Avx2,
        "portable" => KernelPath::Portable,
        _ => KernelPath::Fastest,
    });
    let t = Instant::now();
    let mut progress = super::fit_progress::FitProgress::new();
    // The hypernetwork from scratch needs no meta-model (its networks come from --preset).
    let model = if args.from_scratch && !args.static_sdf {
        None
    } else {
        Some(MetaModel::load_or_shipped(args.model.as_deref())?)
    };
    let mut options = HyperFitOptions {
        steps: args.steps,
        seed: args.seed,
        compute,
        ..HyperFitOptions::default()
    };
    options.refine_poses.enabled = args.refine_poses == "on";
    let (kind, what) = match (&model, args.static_sdf) {
        (None, _) => {
            (FitKind::Meta(Init::Scratch { config: preset, seed: args.seed }), String::new())
        }
        (Some(m), false) => (FitKind::Meta(Init::MetaLearned(m)), String::new()),
        (Some(m), true) if args.from_scratch => (
            FitKind::Static { siren: m.header.config.siren, init: None },
            "static SDF (from scratch)".to_string(),
        ),
        (Some(m), true) => (
            FitKind::Static { siren: m.header.config.siren, init: Some(m) },
            "static SDF (static meta-SDF)".to_string(),
        ),
    };
    let frames = args.frames.map_or(FrameCount::DEFAULT, FrameCount::exactly);
    let capture = progress.outer("canonicalization", || {
        CapturePoints::open_with(
            &args.capture,
            frames,
            args.body_model.as_deref(),
            avatar_studio::cache::field_cache(),
        )
    })?;
    eprintln!("{}", capture.choice_summary());
    let trace = match &args.true_poses {
        Some(dir) => Some(PoseTrace {
            snap: args.snap_to_truth.as_deref().map(Snap::parse),
            ..PoseTrace::from_capture(dir, TraceLines::new(|line| eprintln!("pose trace: {line}")))?
        }),
        None => None,
    };
    let fit = AvatarFit { kind, options, chunk: 0, cancel: Some(&cancel), trace: trace.as_ref() };
    let (avatar, report) = fit_avatar(&capture, &fit, &mut |e| progress.event(&e))?;
    progress.finish();
    progress.outer("saving", || avatar.save(&args.out))?;
    let what = match (&avatar, &fit.kind) {
        (AnyAvatar::Meta(a), FitKind::Meta(init)) => {
            let refined = match &a.header.refined_poses {
                Some(poses) => {
                    let (deg, cm) = avatar_neural::avatar::refined_poses::mean_correction(poses);
                    format!(", poses refined by {deg:.2} deg per joint and {cm:.2} cm on average")
                }
                None => String::new(),
            };
            let prior = match &a.header.prior {
                Some(p) => format!(" from the prior {}", p.label()),
                None => String::new(),
            };
            format!(
                "pose-dependent avatar ({}{prior}, {} parameters{refined})",
                init.label(),
                a.num_params()
            )
        }
        (AnyAvatar::Static(a), _) => match &a.header.prior {
            Some(p) => format!("{what} from the prior {}", p.label()),
            None => what,
        },
        _ => what,
    };
    let partial = avatar.partial();
    eprintln!();
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    let cancelled = match partial {
        Some(p) => format!(" (cancelled: {p})"),
        None => String::new(),
    };
    println!(
        "wrote {}: {what}, {} frames, {} canonical points ({} dropped by the 2 cm filter), {:.1} s{cancelled}",
        args.out.display(),
        report.frames,
        report.points,
        report.dropped,
        t.elapsed().as_secs_f64()
    );
    if args.timings {
        print!("\n{}", progress.table());
        println!("kernels: {}", kernel_name());
    }
    Ok(())
}
