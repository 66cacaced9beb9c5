//! `avatar-studio export`: an animated binary glTF (or an OBJ/PLY sequence) of an avatar
//! playing a motion clip.

use anyhow::{Context, bail};
use avatar_core::canonical::FieldOptions;
use avatar_core::export::{
    CANCELLED, Control, ExportOptions, FrameMaker, Progress, SyntheticAvatar, export_glb_streaming,
    for_each_posed,
};
use avatar_core::io::Inputs;
use avatar_core::motion::{DEFAULT_TARGET_FPS, MotionClip, clip_file, open_clip_at};
use avatar_core::synth::Outfit;
use std::io::{IsTerminal, Write as _};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// The avatar (NAME.avatar from `avatar-studio fit`). Without it, a synthetic avatar (see
    /// --synthetic-outfit) is exported.
    avatar: Option<PathBuf>,
    /// Motion clip: a library name (walk, squat, ...) or a clip file (.json, AMASS .npz, BVH .bvh).
    #[arg(long)]
    motion: String,
    /// Output: a .glb file, or a folder for --format obj|ply.
    #[arg(long)]
    out: PathBuf,
    /// glb (default), obj or ply (a mesh per frame).
    #[arg(long, default_value = "glb")]
    format: String,
    /// Export only the first N frames of the clip (after resampling to --fps).
    #[arg(long)]
    frames: Option<usize>,
    /// Frame rate of the exported animation: the clip is resampled to it (rotations slerped
    /// per joint, the root translation interpolated linearly); 1 to 240.
    #[arg(long, default_value_t = DEFAULT_TARGET_FPS)]
    fps: f32,
    /// At most this many morph targets (the constant compensation target included).
    #[arg(long, default_value_t = 64)]
    targets: usize,
    /// Outfit of the synthetic avatar.
    #[arg(long, default_value = "longsleeve_trousers")]
    synthetic_outfit: String,
    /// Shape seed of the synthetic avatar (2024 = the demo capture's subject).
    #[arg(long, default_value_t = 2024)]
    synthetic_subject: u64,
    /// The glTF material's base colour, linear RGB from 0 to 1 (as the studio's View panel
    /// sets it), e.g. 0.2,0.5,0.3; default a neutral skin tone.
    #[arg(long, value_parser = parse_color)]
    color: Option<[f32; 3]>,
}

/// "R,G,B" with each channel a number from 0 to 1.
fn parse_color(s: &str) -> anyhow::Result<[f32; 3]> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>().map_err(|_| anyhow::anyhow!("{c:?} is not a number")))
        .collect::<anyhow::Result<_>>()?;
    match v[..] {
        [r, g, b] if v.iter().all(|c| (0.0..=1.0).contains(c)) => Ok([r, g, b]),
        [_, _, _] => bail!("each channel must be between 0 and 1 (linear RGB)"),
        _ => bail!("expected three numbers R,G,B, got {}", v.len()),
    }
}

/// Set by Ctrl-C (the first one): exports and poses stop between chunks of frames and write
/// nothing more; every file written is whole (atomic writes).
pub(super) fn cancel_on_ctrl_c() -> &'static AtomicBool {
    static CANCEL: AtomicBool = AtomicBool::new(false);
    let _ = ctrlc::set_handler(|| CANCEL.store(true, Ordering::Relaxed));
    &CANCEL
}

/// Frames done / total and the time left, on stderr (one line rewritten on a terminal, a line
/// every 5 s otherwise).
pub(super) fn progress_printer(label: &'static str) -> impl Fn(Progress) + Sync {
    let start = Instant::now();
    let last = std::sync::Mutex::new(0f64);
    let terminal = std::io::stderr().is_terminal();
    move |p: Progress| {
        let elapsed = start.elapsed().as_secs_f64();
        let mut last = last.lock().unwrap_or_else(|e| e.into_inner());
        let finished = p.done >= p.total;
        if !terminal && !finished && elapsed - *last < 5.0 {
            return;
        }
        *last = elapsed;
        let left = elapsed * (p.total - p.done.min(p.total)) as f64 / p.done.max(1) as f64;
        let line =
            format!("{label}: frames {}/{} ({elapsed:.0} s, {left:.0} s left)", p.done, p.total);
        if terminal {
            eprint!("\r{line} ");
            if finished {
                eprintln!();
            }
        } else {
            eprintln!("{line}");
        }
        let _ = std::io::stderr().flush();
    }
}

/// The clip a `--motion` argument names at `fps`, the first `frames` of it; the source rate
/// printed.
pub(super) fn open_motion(
    motion: &str,
    fps: f32,
    frames: Option<usize>,
) -> anyhow::Result<MotionClip> {
    let mut clip = open_clip_at(motion, fps)?;
    if let Some(n) = frames {
        if n == 0 {
            bail!("--frames must be at least 1");
        }
        clip.frames.truncate(n);
    }
    eprintln!(
        "motion {:?}: recorded at {} fps, {} frames at {} fps ({:.1} s)",
        clip.name,
        clip.source_fps,
        clip.len(),
        clip.fps,
        clip.len() as f32 / clip.fps
    );
    Ok(clip)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if !(1..=256).contains(&args.targets) {
        bail!("--targets must be between 1 and 256");
    }
    let inputs = Inputs::new().maybe_file(args.avatar.as_ref()).maybe_file(clip_file(&args.motion));
    match args.format.as_str() {
        "glb" => inputs.check_file(&args.out, &["glb"])?,
        "obj" | "ply" => inputs.check_folder(&args.out)?,
        other => bail!("unknown --format {other:?}: use glb, obj or ply"),
    }
    let clip = open_motion(&args.motion, args.fps, args.frames)?;
    if args.format != "glb" {
        for f in 0..clip.len() {
            inputs.check_file(
                &args.out.join(format!("frame_{f:06}.{}", args.format)),
                &[&args.format],
            )?;
        }
    }
    let cancel = cancel_on_ctrl_c();
    let t = Instant::now();
    let loaded;
    let synthetic;
    let avatar: &dyn avatar_core::avatar::AvatarSource = match &args.avatar {
        Some(path) => {
            loaded = avatar_neural::AnyAvatar::load(path, avatar_studio::cache::field_cache())?;
            if let Some(p) = loaded.partial() {
                eprintln!(
                    "note: {} is a partial avatar ({p}): its fit was cancelled",
                    path.display()
                );
            }
            loaded.source()
        }
        None => {
            let outfit = Outfit::from_name(&args.synthetic_outfit)?;
            synthetic = SyntheticAvatar::new(
                avatar_core::body::open_body(),
                args.synthetic_subject,
                outfit,
                &FieldOptions::default(),
            )?;
            &synthetic
        }
    };
    let in_avatar = |e: avatar_core::Error| match &args.avatar {
        Some(path) => e.in_file(path),
        None => e,
    };
    let printer = progress_printer("export");
    let control = Control { progress: Some(&printer), cancel: Some(cancel) };
    let cancelled = |e: &avatar_core::Error| e.to_string().contains(CANCELLED);
    match args.format.as_str() {
        "glb" => {
            let options = ExportOptions {
                max_targets: args.targets,
                color: args.color.unwrap_or(avatar_core::export::DEFAULT_COLOR),
                ..ExportOptions::default()
            };
            let exported = match export_glb_streaming(avatar, &clip, &options, control) {
                Err(e) if cancelled(&e) => {
                    eprintln!("cancelled: nothing written");
                    std::process::exit(130);
                }
                r => r.map_err(in_avatar)?,
            };
            if cancel.load(Ordering::Relaxed) {
                eprintln!("cancelled: nothing written");
                std::process::exit(130);
            }
            avatar_core::io::write_bytes_atomic(&args.out, &exported.glb)
                .with_context(|| "writing the glTF")?;
            println!(
                "wrote {} ({:.2} MB): {} vertices, {} joints, {} morph targets, {} frames at {} fps (recorded at {} fps), compression error largest {:.2} mm, mean {:.3} mm (basis of {} frames{}), {:.1} s",
                args.out.display(),
                exported.glb.len() as f64 / 1e6,
                exported.rest.positions.len(),
                avatar_core::body::NUM_JOINTS,
                exported.morphs.targets.len() + 1,
                exported.frames,
                exported.fps,
                clip.source_fps,
                exported.max_compression_error * 1000.0,
                exported.mean_compression_error * 1000.0,
                exported.basis_frames,
                match exported.refined_frames {
                    0 => String::new(),
                    r => format!(", {r} of them added by the refinement pass"),
                },
                t.elapsed().as_secs_f64()
            );
            let k = exported.keyframes;
            println!(
                "keyframes: {} full projections and {:.1} frames' worth of vertices projected between them for {} frames; verified on {} frames, largest interpolation error {:.2} mm (tolerance {:.1} mm){}",
                k.full_projections,
                k.vertex_projections as f64 / exported.rest.positions.len().max(1) as f64,
                exported.frames,
                k.verified,
                k.max_verified_error * 1000.0,
                options.interpolation_tolerance * 1000.0,
                match k.failed {
                    0 => String::new(),
                    f => format!(", {f} of them over it and made in full"),
                }
            );
            if exported.max_compression_error > options.compression_bound() {
                eprintln!(
                    "note: the largest compression error is over its {:.1} mm bound: raise --targets",
                    options.compression_bound() * 1000.0
                );
            }
        }
        ext @ ("obj" | "ply") => {
            let maker = FrameMaker::new(avatar, ExportOptions::default().newton_steps)
                .map_err(in_avatar)?;
            std::fs::create_dir_all(&args.out)
                .with_context(|| format!("creating {}", args.out.display()))?;
            let written = write_frames(&maker, &clip, control, |f| {
                args.out.join(format!("frame_{f:06}.{ext}"))
            })
            .map_err(in_avatar)?;
            println!("wrote {written} {ext} meshes to {}", args.out.display());
        }
        other => bail!("unknown --format {other:?}: use glb, obj or ply"),
    }
    Ok(())
}

/// The posed mesh of every frame written, streamed; a Ctrl-C stops after the whole files
/// written so far (exit 130).
pub(super) fn write_frames(
    maker: &FrameMaker,
    clip: &MotionClip,
    control: Control,
    name: impl Fn(usize) -> PathBuf,
) -> avatar_core::Result<usize> {
    let mut written = 0;
    let r = for_each_posed(maker, clip, &ExportOptions::default(), control, |f, mesh| {
        avatar_core::mesh::io::write_mesh(name(f), &mesh)?;
        written += 1;
        Ok(())
    });
    match r {
        Err(e) if e.to_string().contains(CANCELLED) => {
            eprintln!("cancelled: {written} whole frames written, no partial file");
            std::process::exit(130);
        }
        r => r.map(|_| written),
    }
}
