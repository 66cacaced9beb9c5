//! Pose an avatar and export it: one posed mesh as OBJ, and the avatar animated by a motion
//! clip as a glTF binary (a skinned mesh with morph targets) that Blender and game engines
//! import. This is what `avatar-studio pose` and `avatar-studio export` do.
//!
//! cargo run --release -p avatar-neural --example pose_and_export -- ME.avatar [CLIP] [OUT_DIR]
//!
//! ME.avatar comes from `fit_avatar.rs` (or `avatar-studio fit`); CLIP is a library clip
//! (walk, squat, ...) or a motion file (.bvh, AMASS .npz), `walk` by default.

use avatar_core::avatar::PoseTemplate;
use avatar_core::canonical::FieldCache;
use avatar_core::export::{ExportOptions, export_glb};
use avatar_core::mesh::io::write_obj;
use avatar_core::motion::open_clip;
use avatar_neural::AnyAvatar;
use std::path::PathBuf;

fn main() -> avatar_neural::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let Some(avatar_file) = args.get(1) else {
        eprintln!("usage: pose_and_export ME.avatar [CLIP] [OUT_DIR]");
        std::process::exit(2);
    };
    let clip = open_clip(args.get(2).map_or("walk", String::as_str))?;
    let out = args.get(3).map_or_else(|| PathBuf::from("."), PathBuf::from);

    // Either kind of avatar file; its skinning field comes from the cache when it is there.
    let cache = FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"));
    let avatar = AnyAvatar::load(avatar_file, &cache)?;
    // What posing and export see of any avatar: `AvatarSource` (its surface at a pose, its
    // skinning weights, its body).
    let source = avatar.source();

    // One pose: the avatar's rest surface, made once, projected onto the pose's surface and
    // skinned (the clip's poses carry no body shape; the avatar's own is used).
    let template = PoseTemplate::new(source)?;
    let middle = &clip.frames[clip.len() / 2];
    let posed = template.posed_mesh(source, middle)?;
    let obj = out.join("posed.obj");
    write_obj(&obj, &posed)?;
    println!(
        "{}: {} vertices at frame {} of {}",
        obj.display(),
        posed.positions.len(),
        clip.len() / 2,
        clip.name
    );

    // The whole clip as an animated glTF (docs/export.md).
    let exported = export_glb(source, &clip, &ExportOptions::default())?;
    let glb = out.join(format!("{}.glb", clip.name));
    avatar_core::io::write_bytes_atomic(&glb, &exported.glb)?;
    println!(
        "{}: {} frames, {} morph targets (the constant one included)",
        glb.display(),
        clip.len(),
        exported.morphs.targets.len() + 1
    );
    Ok(())
}
