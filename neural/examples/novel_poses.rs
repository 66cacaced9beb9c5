//! Renders of an avatar at novel poses (held-out clips kick, lunge, twist): the canonical
//! surface the hypernetwork predicts for each pose (top row) and the posed mesh (bottom row).
//! `cargo run -p avatar-neural --example novel_poses -- NAME.avatar docs/images/novel-poses.png`
use avatar_core::body::BodyParams;
use avatar_core::canonical::FieldCache;
use avatar_core::motion::clip_by_name;
use avatar_core::synth::contact_sheet::write_mesh_sheet;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (avatar, out) = (
        args.next().expect("usage: novel_poses NAME.avatar OUT.png"),
        args.next().expect("usage: novel_poses NAME.avatar OUT.png"),
    );
    let avatar = avatar_neural::MetaAvatar::load(&avatar, &field_cache()).expect("a meta avatar");
    let poses: Vec<BodyParams> = [("kick", 0.45), ("lunge", 0.5), ("twist", 0.3), ("twist", 0.7)]
        .iter()
        .map(|(c, at)| {
            let clip = clip_by_name(c).expect("library clip");
            clip.frames[((clip.len() - 1) as f32 * at) as usize].clone()
        })
        .collect();
    let cells = avatar_neural::avatar::MeshResolution::new(128).expect("within the bounds");
    let canonical: Vec<_> =
        poses.iter().map(|p| avatar.canonical_mesh_at(p, cells).expect("canonical mesh")).collect();
    let posed: Vec<_> = poses.iter().map(|p| avatar.posed_mesh(p).expect("posed mesh")).collect();
    write_mesh_sheet(std::path::Path::new(&out), &[canonical, posed]).expect("sheet written");
    println!("wrote {out}");
}
