//! `avatar-studio pose`: pose an avatar along a motion clip and write a mesh per frame. The
//! frames are streamed: the avatar's reference mesh (extracted once at the rest pose, at
//! `--resolution`) projected onto each pose's surface and skinned, the studio's and the
//! exporter's posed mesh, written as it is made.

use super::export::{cancel_on_ctrl_c, open_motion, progress_printer, write_frames};
use avatar_core::export::{Control, ExportOptions, FrameMaker};
use avatar_core::io::Inputs;
use avatar_core::motion::DEFAULT_TARGET_FPS;
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
    /// Marching-cubes resolution of the canonical mesh (16 to 512: `MeshResolution`).
    #[arg(long, default_value_t = avatar_neural::avatar::header::OUTPUT_RESOLUTION)]
    resolution: usize,
    /// Only the first N frames (after resampling to --fps).
    #[arg(long)]
    frames: Option<usize>,
    /// Frame rate the clip is resampled to (rotations slerped per joint); 1 to 240.
    #[arg(long, default_value_t = DEFAULT_TARGET_FPS)]
    fps: f32,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if !matches!(args.format.as_str(), "obj" | "ply") {
        anyhow::bail!("unknown --format {:?}: use obj or ply", args.format);
    }
    let resolution = avatar_neural::avatar::MeshResolution::new(args.resolution)?;
    if args.frames == Some(0) {
        anyhow::bail!("--frames must be at least 1");
    }
    let inputs =
        Inputs::new().file(&args.avatar).maybe_file(avatar_core::motion::clip_file(&args.motion));
    inputs.check_folder(&args.out)?;
    let clip = open_motion(&args.motion, args.fps, args.frames)?;
    let mut avatar = AnyAvatar::load(&args.avatar, avatar_studio::cache::field_cache())?;
    avatar.set_mesh_resolution(resolution);
    if let Some(p) = avatar.partial() {
        eprintln!(
            "note: {} is a partial avatar ({p}): its fit was cancelled",
            args.avatar.display()
        );
    }
    let name = |i: usize| match &avatar {
        AnyAvatar::Meta(_) => args.out.join(format!("frame_{i:04}.{}", args.format)),
        AnyAvatar::Static(_) => args.out.join(format!("frame_{i:06}.{}", args.format)),
    };
    for i in 0..clip.len() {
        inputs.check_file(&name(i), &[&args.format])?;
    }
    let cancel = cancel_on_ctrl_c();
    let t = std::time::Instant::now();
    let maker = FrameMaker::new(avatar.source(), ExportOptions::default().newton_steps)
        .map_err(|e| e.in_file(&args.avatar))?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.out.display()))?;
    let ready = t.elapsed().as_secs_f64();
    let printer = progress_printer("pose");
    let control = Control { progress: Some(&printer), cancel: Some(cancel) };
    let n = write_frames(&maker, &clip, control, name).map_err(|e| e.in_file(&args.avatar))?;
    let total = t.elapsed().as_secs_f64();
    println!(
        "wrote {n} {} meshes ({} vertices) to {} in {total:.1} s: reference mesh {ready:.1} s, then {:.0} ms a frame",
        args.format,
        maker.rest.positions.len(),
        args.out.display(),
        (total - ready) * 1000.0 / n.max(1) as f64
    );
    Ok(())
}
