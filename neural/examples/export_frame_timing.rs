//! Where one exported frame's time goes for a meta avatar (docs/export.md): the hypernetwork's
//! SDF for the pose, the Newton projection of the reference vertices (and how many vertices each
//! step still moves), the smoothing, the skinning and un-skinning, the morph projection.
//!
//! `cargo run --release -p avatar-neural --example export_frame_timing -- NAME.avatar CLIP [FRAMES]`
//! (CLIP: a library name or a clip file, resampled to 30 fps; FRAMES frames spread over it,
//! default 24, made one after the other).
use avatar_core::avatar::{AvatarSource, PROJECTION_STEPS};
use avatar_core::canonical::FieldCache;
use avatar_core::export::{Basis, FrameMaker};
use glam::Vec3;
use std::time::Instant;

fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(path), Some(motion)) = (args.first(), args.get(1)) else {
        eprintln!("usage: export_frame_timing NAME.avatar CLIP [FRAMES]");
        std::process::exit(2);
    };
    let count: usize = args.get(2).map_or(24, |s| s.parse().expect("FRAMES: a count"));
    let avatar = avatar_neural::MetaAvatar::load(path, &field_cache()).expect("avatar loads");
    let clip = avatar_core::motion::open_clip_at(motion, 30.0).expect("clip opens");
    let t = Instant::now();
    let maker = FrameMaker::new(&avatar, PROJECTION_STEPS).expect("frame maker");
    let rest = &maker.rest.positions;
    println!(
        "{} reference vertices, {} frames in the clip; the frame maker (reference mesh, weights, smoother) {:.2} s",
        rest.len(),
        clip.len(),
        t.elapsed().as_secs_f64()
    );
    let scale = avatar.header.normalisation.metres_per_unit();
    let on_surface = avatar_neural::model::siren_eval::PROJECTED * scale;
    let frames: Vec<usize> =
        (0..count).map(|i| i * (clip.len() - 1) / (count - 1).max(1)).collect();
    let mut time = [0f64; 6];
    let mut skin = 0f64;
    let mut moving = [0usize; PROJECTION_STEPS];
    let mut deltas = Vec::new();
    for &f in &frames {
        let p = maker.params(&clip.frames[f]);
        let t = Instant::now();
        let sdf = avatar.sdf_at(&p);
        time[0] += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let values = sdf.sdf(rest);
        time[1] += t.elapsed().as_secs_f64();
        moving[0] += values.iter().filter(|v| v.abs() >= on_surface).count();
        for (k, m) in moving.iter_mut().enumerate().skip(1) {
            let x = sdf.project(rest, k);
            *m += sdf.sdf(&x).iter().filter(|v| v.abs() >= on_surface).count();
        }
        let t = Instant::now();
        let mut raw = avatar.project(&p, rest, PROJECTION_STEPS).unwrap();
        time[2] += t.elapsed().as_secs_f64();
        let t = Instant::now();
        maker.finish(&mut raw);
        time[5] += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let _ = maker.delta_of(&clip.frames[f], &raw);
        skin += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let (delta, _) = maker.delta(&clip.frames[f]).unwrap();
        time[3] += t.elapsed().as_secs_f64();
        deltas.push(delta);
    }
    let t = Instant::now();
    let refs: Vec<&[Vec3]> = deltas.iter().map(|d| d.as_slice()).collect();
    let basis = Basis::fit(&refs, 63, 1e-4);
    let fit = t.elapsed().as_secs_f64();
    let t = Instant::now();
    for d in &deltas {
        let c = basis.coefficients(d);
        let _ = basis.error(d, &c);
    }
    time[4] = t.elapsed().as_secs_f64();
    let n = frames.len() as f64;
    let ms = |s: f64| s / n * 1e3;
    println!("per frame over {} frames:", frames.len());
    println!("  hypernetwork SDF of the pose (sdf_at): {:.1} ms", ms(time[0]));
    println!("  one value pass over every vertex: {:.1} ms", ms(time[1]));
    println!(
        "  projection ({PROJECTION_STEPS} steps at most, gradient + value checks): {:.1} ms",
        ms(time[2])
    );
    for (k, m) in moving.iter().enumerate() {
        println!(
            "    vertices off the surface before step {}: {:.0} of {} ({:.1} %)",
            k + 1,
            *m as f64 / n,
            rest.len(),
            100.0 * *m as f64 / n / rest.len() as f64
        );
    }
    println!(
        "  a whole frame (FrameMaker::delta: sdf_at, projection, smoothing, skinning, un-skinning): {:.1} ms",
        ms(time[3])
    );
    println!("    of which the smoothing (FrameMaker::finish): {:.1} ms", ms(time[5]));
    println!("    and skinning + un-skinning (FrameMaker::delta_of): {:.1} ms", ms(skin));
    println!(
        "  morph projection + error ({} components): {:.1} ms; basis fit on {} frames {:.2} s",
        basis.components.len(),
        ms(time[4]),
        frames.len(),
        fit
    );
}
