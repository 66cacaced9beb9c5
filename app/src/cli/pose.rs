//! `avatar-studio pose`: pose an avatar along a motion clip and write a mesh per frame.

use avatar_core::export::{export_glb, write_mesh_sequence, ExportOptions};
use avatar_neural::StaticAvatar;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The avatar (NAME.avatar).
    avatar: PathBuf,
    /// Motion clip: a library name or a clip file (.json, AMASS .npz).
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
    let mut avatar = StaticAvatar::load(&args.avatar)?;
    avatar.resolution = args.resolution.clamp(16, 512);
    let mut clip = super::export::load_clip(&args.motion)?;
    if let Some(n) = args.frames {
        clip.frames.truncate(n.max(1));
    }
    // Posing shares the exporter's path: canonical mesh once, then forward skinning per frame.
    let exported = export_glb(&avatar, &clip, &ExportOptions { max_targets: 1, ..ExportOptions::default() })?;
    let n = write_mesh_sequence(&exported, &args.out, &args.format)?;
    println!("wrote {n} {} meshes ({} vertices) to {}", args.format, exported.rest.positions.len(), args.out.display());
    Ok(())
}
