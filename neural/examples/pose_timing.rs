//! Where the time of one posed mesh goes: `cargo run -p avatar-neural --example pose_timing -- NAME.avatar`.
use avatar_core::canonical::FieldCache;
use avatar_core::mesh::extract::{ExtractOptions, extract};
use glam::Vec3;
use std::time::Instant;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() {
    let path = std::env::args().nth(1).expect("usage: pose_timing NAME.avatar");
    let t = Instant::now();
    let avatar = avatar_neural::MetaAvatar::load(&path, &field_cache()).expect("avatar loads");
    println!("load {:.2} s", t.elapsed().as_secs_f64());
    let params = avatar_core::motion::clip_by_name("squat").unwrap().frames[20].clone();
    let n = avatar.header.normalisation;
    for res in [64, 128] {
        let t = Instant::now();
        let sdf = avatar.sdf_at(&params);
        let predict = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let (lo, hi) = (n.from_unit(Vec3::splat(-1.0)), n.from_unit(Vec3::splat(1.0)));
        for margin in [1.0f32, 0.5, 0.25, 0.0] {
            let t = Instant::now();
            let mut o = ExtractOptions::new(lo, hi, res);
            o.margin = margin;
            let e = extract(|p: &[Vec3]| sdf.sdf(p), &o).unwrap();
            println!(
                "  margin {margin}: {} evaluations, {} vertices, {} faces, {:.2} s",
                e.stats.evaluations(),
                e.mesh.positions.len(),
                e.mesh.faces.len(),
                t.elapsed().as_secs_f64()
            );
        }
        let e = extract(|p: &[Vec3]| sdf.sdf(p), &ExtractOptions::new(lo, hi, res)).unwrap();
        let ex = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mut smoothed = e.mesh.clone();
        avatar_core::mesh::smooth::taubin(
            &mut smoothed,
            avatar_neural::avatar::header::MESH_SMOOTHING,
        );
        println!(
            "  smoothing ({} Taubin iterations): {:.3} s",
            avatar_neural::avatar::header::MESH_SMOOTHING,
            t.elapsed().as_secs_f64()
        );
        let t = Instant::now();
        let _ = avatar.posed_mesh(&params).unwrap();
        println!(
            "res {res}: predict {predict:.3} s, extract {ex:.2} s ({} evaluations, {} vertices), full posed_mesh {:.2} s",
            e.stats.evaluations(),
            e.mesh.positions.len(),
            t.elapsed().as_secs_f64()
        );
    }
}
