//! `avatar-studio pose`: pose an avatar along a motion clip and write a mesh per frame.

use avatar_core::export::{ExportOptions, export_glb, write_mesh_sequence};
use avatar_core::io::Inputs;
use avatar_core::mesh::io::write_mesh;
use avatar_neural::AnyAvatar;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The avatar (NAME.avatar).
    avatar: PathBuf,
    /// Motion clip: a library name or a clip file (.json, AMASS .npz, BVH .bvh).
    #[arg(long)]
    motion: String,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    /// obj or ply.
    #[arg(long, default_value = "obj")]
    format: String,
    /// Marching-cubes resolution of the canonical mesh (16 to 512).
    #[arg(long, default_value_t = avatar_neural::avatar::header::OUTPUT_RESOLUTION)]
    resolution: usize,
    /// Only the first N frames.
    #[arg(long)]
    frames: Option<usize>,
}

/// Marching-cubes resolutions: below 16 cells no body survives, above 512 a mesh takes minutes.
const RESOLUTION: std::ops::RangeInclusive<usize> = 16..=512;

pub fn run(args: Args) -> anyhow::Result<()> {
    if !matches!(args.format.as_str(), "obj" | "ply") {
        anyhow::bail!("unknown --format {:?}: use obj or ply", args.format);
    }
    if !RESOLUTION.contains(&args.resolution) {
        anyhow::bail!(
            "--resolution {} is out of range ({} to {})",
            args.resolution,
            RESOLUTION.start(),
            RESOLUTION.end()
        );
    }
    if args.frames == Some(0) {
        anyhow::bail!("--frames must be at least 1");
    }
    let inputs =
        Inputs::new().file(&args.avatar).maybe_file(avatar_core::motion::clip_file(&args.motion));
    inputs.check_folder(&args.out)?;
    let mut avatar = AnyAvatar::load(&args.avatar)?;
    avatar.set_resolution(args.resolution);
    if let Some(p) = avatar.partial() {
        eprintln!(
            "note: {} is a partial avatar ({p}): its fit was cancelled",
            args.avatar.display()
        );
    }
    let mut clip = avatar_core::motion::open_clip(&args.motion)?;
    if let Some(n) = args.frames {
        clip.frames.truncate(n);
    }
    let name = |i: usize| match &avatar {
        AnyAvatar::Meta(_) => args.out.join(format!("frame_{i:04}.{}", args.format)),
        AnyAvatar::Static(_) => args.out.join(format!("frame_{i:06}.{}", args.format)),
    };
    for i in 0..clip.len() {
        inputs.check_file(&name(i), &[&args.format])?;
    }
    let in_avatar = |e: avatar_core::Error| e.in_file(&args.avatar);
    let t = std::time::Instant::now();
    match &avatar {
        // Pose-dependent clothing: pose -> hypernetwork -> SDF -> mesh -> forward skinning, per frame.
        AnyAvatar::Meta(a) => {
            std::fs::create_dir_all(&args.out)
                .map_err(|e| anyhow::anyhow!("{}: {e}", args.out.display()))?;
            let mut vertices = 0;
            for (i, params) in clip.frames.iter().enumerate() {
                let mesh =
                    a.posed_mesh(params).map_err(avatar_core::Error::from).map_err(in_avatar)?;
                vertices += mesh.positions.len();
                write_mesh(name(i), &mesh)?;
            }
            println!(
                "wrote {} {} meshes (mean {} vertices) to {} in {:.1} s",
                clip.len(),
                args.format,
                vertices / clip.len().max(1),
                args.out.display(),
                t.elapsed().as_secs_f64()
            );
        }
        // Pose-independent surface: extract once, then forward skinning (the exporter's path).
        AnyAvatar::Static(a) => {
            let exported =
                export_glb(a, &clip, &ExportOptions { max_targets: 1, ..ExportOptions::default() })
                    .map_err(in_avatar)?;
            let n = write_mesh_sequence(&exported, &args.out, &args.format)?;
            println!(
                "wrote {n} {} meshes ({} vertices) to {}",
                args.format,
                exported.rest.positions.len(),
                args.out.display()
            );
        }
    }
    Ok(())
}
