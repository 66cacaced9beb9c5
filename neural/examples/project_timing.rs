//! Where an export frame's time goes for a meta avatar: `cargo run -p avatar-neural --example project_timing -- NAME.avatar`.
use avatar_core::avatar::AvatarSource;
use avatar_core::canonical::FieldCache;
use std::time::Instant;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() {
    let path = std::env::args().nth(1).expect("usage: project_timing NAME.avatar");
    let avatar = avatar_neural::MetaAvatar::load(&path, &field_cache()).expect("avatar loads");
    let clip = avatar_core::motion::clip_by_name("walk").unwrap();
    let rest = avatar.canonical_mesh(&avatar_core::body::BodyParams::default()).unwrap();
    println!("{} reference vertices", rest.positions.len());
    for params in clip.frames.iter().step_by(30) {
        let t = Instant::now();
        let sdf = avatar.sdf_at(params);
        let predict = t.elapsed().as_secs_f64();
        let start = sdf.sdf(&rest.positions).iter().map(|f| f.abs()).fold(0f32, f32::max);
        let mut line =
            format!("predict {:.1} ms, start max |f| {:.1} mm;", predict * 1e3, start * 1e3);
        for steps in 1..=4 {
            let t = Instant::now();
            let p = sdf.project(&rest.positions, steps);
            let dt = t.elapsed().as_secs_f64();
            let mut f: Vec<f32> = sdf.sdf(&p).iter().map(|f| f.abs()).collect();
            f.sort_by(f32::total_cmp);
            line += &format!(
                " {steps} steps {:.0} ms (p99 {:.3} mm, max {:.3} mm)",
                dt * 1e3,
                f[f.len() * 99 / 100] * 1e3,
                f[f.len() - 1] * 1e3
            );
        }
        println!("{line}");
    }
}
