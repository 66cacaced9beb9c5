//! `avatar-studio export`: an animated binary glTF (or an OBJ/PLY sequence) of an avatar
//! playing a motion clip.

use anyhow::{Context, bail};
use avatar_core::canonical::FieldOptions;
use avatar_core::export::{ExportOptions, SyntheticAvatar, export_glb, write_mesh_sequence};
use avatar_core::io::Inputs;
use avatar_core::motion::{clip_file, open_clip};
use avatar_core::synth::Outfit;
use std::path::PathBuf;

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
    /// Export only the first N frames of the clip.
    #[arg(long)]
    frames: Option<usize>,
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
    let mut clip = open_clip(&args.motion)?;
    if let Some(n) = args.frames {
        if n == 0 {
            bail!("--frames must be at least 1");
        }
        clip.frames.truncate(n);
    }
    if args.format != "glb" {
        for f in 0..clip.len() {
            inputs.check_file(
                &args.out.join(format!("frame_{f:06}.{}", args.format)),
                &[&args.format],
            )?;
        }
    }
    let t = std::time::Instant::now();
    let loaded;
    let synthetic;
    let avatar: &dyn avatar_core::avatar::AvatarSource = match &args.avatar {
        Some(path) => {
            loaded = avatar_neural::AnyAvatar::load(path)?;
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
    let exported = export_glb(
        avatar,
        &clip,
        &ExportOptions {
            max_targets: args.targets,
            color: args.color.unwrap_or(avatar_core::export::DEFAULT_COLOR),
            ..ExportOptions::default()
        },
    )
    .map_err(|e| match &args.avatar {
        Some(path) => e.in_file(path),
        None => e,
    })?;
    match args.format.as_str() {
        "glb" => {
            avatar_core::io::write_bytes_atomic(&args.out, &exported.glb)
                .with_context(|| "writing the glTF")?;
            println!(
                "wrote {} ({:.2} MB): {} vertices, {} joints, {} morph targets, {} frames at {} fps, largest compression error {:.2} mm, {:.1} s",
                args.out.display(),
                exported.glb.len() as f64 / 1e6,
                exported.rest.positions.len(),
                avatar_core::body::NUM_JOINTS,
                exported.morphs.targets.len() + 1,
                exported.frames,
                exported.fps,
                exported.max_compression_error * 1000.0,
                t.elapsed().as_secs_f64()
            );
        }
        ext @ ("obj" | "ply") => {
            let n = write_mesh_sequence(&exported, &args.out, ext)?;
            println!("wrote {n} {ext} meshes to {}", args.out.display());
        }
        other => bail!("unknown --format {other:?}: use glb, obj or ply"),
    }
    Ok(())
}
