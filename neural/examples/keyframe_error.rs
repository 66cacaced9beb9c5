//! How far the exporter's keyframes (`avatar_core::export::keyframes`) land from every frame's
//! own projection, and what they cost, for several spacings and tolerances (docs/export.md):
//!
//! `cargo run --release -p avatar-neural --example keyframe_error -- NAME.avatar CLIP [FRAMES]`
//! (CLIP resampled to 30 fps; its first FRAMES frames, default 96, each also projected in full).
use avatar_core::avatar::PROJECTION_STEPS;
use avatar_core::canonical::FieldCache;
use avatar_core::export::FrameMaker;
use avatar_core::export::keyframes::Keyframes;
use glam::Vec3;
use std::time::Instant;

fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(path), Some(motion)) = (args.first(), args.get(1)) else {
        eprintln!("usage: keyframe_error NAME.avatar CLIP [FRAMES]");
        std::process::exit(2);
    };
    let count: usize = args.get(2).map_or(96, |s| s.parse().expect("FRAMES: a count"));
    let avatar = avatar_neural::MetaAvatar::load(path, &field_cache()).expect("avatar loads");
    let mut clip = avatar_core::motion::open_clip_at(motion, 30.0).expect("clip opens");
    clip.frames.truncate(count);
    let maker = FrameMaker::new(&avatar, PROJECTION_STEPS).expect("frame maker");
    let n = clip.len();
    let t = Instant::now();
    let full: Vec<Vec<Vec3>> =
        (0..n).map(|f| maker.surface(&clip.frames[f]).expect("surface")).collect();
    let per_frame = t.elapsed().as_secs_f64() / n as f64;
    println!("{n} frames projected in full: {:.1} ms a frame", per_frame * 1e3);
    let frames: Vec<usize> = (0..n).collect();
    for (spacing, tolerance) in [(8, 1e-3f32), (12, 1e-3), (16, 1e-3)] {
        let keys = Keyframes::new(&maker, &clip, spacing, tolerance);
        let t = Instant::now();
        let mut made = Vec::new();
        for chunk in frames.chunks(8) {
            made.extend(keys.surfaces(chunk).expect("surfaces"));
        }
        let time = t.elapsed().as_secs_f64() / n as f64;
        let errors: Vec<f32> = made
            .iter()
            .zip(&full)
            .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x.distance(*y)).fold(0f32, f32::max))
            .collect();
        let worst = errors.iter().copied().fold(0f32, f32::max);
        let over = errors.iter().filter(|e| **e > tolerance).count();
        let s = keys.stats();
        println!(
            "spacing {spacing:2}, tolerance {:.2} mm: {:.1} ms a frame ({:.0} %); largest error {:.3} mm, mean of the frames' largest {:.3} mm, {over} frames over the tolerance; {} full projections, {:.1} frames' worth of vertices, verified {} (largest {:.3} mm, {} failed)",
            tolerance * 1e3,
            time * 1e3,
            100.0 * time / per_frame,
            worst * 1e3,
            errors.iter().sum::<f32>() / n as f32 * 1e3,
            s.full_projections,
            s.vertex_projections as f64 / maker.rest.positions.len() as f64,
            s.verified,
            s.max_verified_error * 1e3,
            s.failed
        );
    }
}
