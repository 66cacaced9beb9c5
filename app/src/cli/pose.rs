//! `avatar-studio pose`: pose an avatar along a motion clip and write a mesh per frame.

use avatar_core::export::{export_glb, write_mesh_sequence, ExportOptions};
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
    /// Marching-cubes resolution of the canonical mesh.
    #[arg(long, default_value_t = 128)]
    resolution: usize,
    /// Only the first N frames.
    #[arg(long)]
    frames: Option<usize>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if !matches!(args.format.as_str(), "obj" | "ply") {
        anyhow::bail!("unknown --format {:?}: use obj or ply", args.format);
    }
    let mut avatar = AnyAvatar::load(&args.avatar)?;
    avatar.set_resolution(args.resolution.clamp(16, 512));
    let mut clip = super::export::load_clip(&args.motion)?;
    if let Some(n) = args.frames {
        clip.frames.truncate(n.max(1));
    }
    let t = std::time::Instant::now();
    match &avatar {
        // Pose-dependent clothing: pose -> hypernetwork -> SDF -> mesh -> forward skinning, per frame.
        AnyAvatar::Meta(a) => {
            std::fs::create_dir_all(&args.out).map_err(|e| anyhow::anyhow!("{}: {e}", args.out.display()))?;
            let mut vertices = 0;
            for (i, params) in clip.frames.iter().enumerate() {
                let mesh = a.posed_mesh(params)?;
                vertices += mesh.positions.len();
                write_mesh(args.out.join(format!("frame_{i:04}.{}", args.format)), &mesh)?;
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
            let exported = export_glb(a, &clip, &ExportOptions { max_targets: 1, ..ExportOptions::default() })?;
            let n = write_mesh_sequence(&exported, &args.out, &args.format)?;
            println!("wrote {n} {} meshes ({} vertices) to {}", args.format, exported.rest.positions.len(), args.out.display());
        }
    }
    Ok(())
}
