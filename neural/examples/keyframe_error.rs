//! How far linear interpolation of the canonical surface between keyframes lands from every
//! frame's own projection, for several keyframe spacings (docs/export.md):
//!
//! `cargo run --release -p avatar-neural --example keyframe_error -- NAME.avatar CLIP [FRAMES]`
//! (CLIP resampled to 30 fps; its first FRAMES frames, default 96, each projected).
use avatar_core::avatar::{AvatarSource, PROJECTION_STEPS};
use avatar_core::canonical::FieldCache;
use avatar_core::export::FrameMaker;
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
    let clip = avatar_core::motion::open_clip_at(motion, 30.0).expect("clip opens");
    let maker = FrameMaker::new(&avatar, PROJECTION_STEPS).expect("frame maker");
    let n = count.min(clip.len());
    let t = Instant::now();
    let surfaces: Vec<Vec<Vec3>> =
        (0..n).map(|f| maker.surface(&clip.frames[f]).expect("surface")).collect();
    let posed: Vec<Vec<Vec3>> =
        (0..n).map(|f| maker.skin(&clip.frames[f], &surfaces[f]).0).collect();
    println!("{n} frames projected in {:.1} s", t.elapsed().as_secs_f64());
    let rest = &maker.rest.positions;
    let moved = surfaces
        .iter()
        .map(|s| s.iter().zip(rest).map(|(a, b)| a.distance(*b)).fold(0f32, f32::max))
        .fold(0f32, f32::max);
    println!("largest move of a vertex from the reference: {:.2} mm", moved * 1e3);
    for k in [2usize, 3, 4, 6, 8, 12, 16, 24] {
        let (mut worst, mut worst_mid, mut sum, mut m) = (0f32, 0f32, 0f64, 0usize);
        let mut a = 0;
        while a + 1 < n {
            let b = (a + k).min(n - 1);
            for f in a + 1..b {
                let t = (f - a) as f32 / (b - a) as f32;
                let interp: Vec<Vec3> =
                    surfaces[a].iter().zip(&surfaces[b]).map(|(x, y)| x.lerp(*y, t)).collect();
                let p = maker.skin(&clip.frames[f], &interp).0;
                let e = p.iter().zip(&posed[f]).map(|(x, y)| x.distance(*y)).fold(0f32, f32::max);
                worst = worst.max(e);
                if f == (a + b) / 2 {
                    worst_mid = worst_mid.max(e);
                }
                sum += e as f64;
                m += 1;
            }
            a = b;
        }
        println!(
            "spacing {k:2}: largest vertex error {:.3} mm (at the midpoints {:.3} mm), mean of the frames' largest {:.3} mm",
            worst * 1e3,
            worst_mid * 1e3,
            sum / m.max(1) as f64 * 1e3
        );
    }

    // The projections before smoothing interpolated, each frame smoothed; the vertices whose
    // interpolated normal move is off by more than `tau` at an interval's midpoint taken from
    // their own projection over the whole interval.
    let smoother = avatar.surface_smoother(&maker.rest).expect("a smoother");
    let normals = maker.rest.vertex_normals();
    let raw: Vec<Vec<Vec3>> = (0..n)
        .map(|f| avatar.project(&maker.params(&clip.frames[f]), rest, PROJECTION_STEPS).unwrap())
        .collect();
    for k in [4usize, 8, 16] {
        for tau in [f32::INFINITY, 5e-4, 2e-4, 1e-4] {
            let (mut worst, mut fixed, mut total) = (0f32, 0usize, 0usize);
            let mut a = 0;
            while a + 1 < n {
                let b = (a + k).min(n - 1);
                let mid = (a + b) / 2;
                let lerp = |f: usize| {
                    let t = (f - a) as f32 / (b - a) as f32;
                    raw[a].iter().zip(&raw[b]).map(|(x, y)| x.lerp(*y, t)).collect::<Vec<Vec3>>()
                };
                let at_mid = lerp(mid);
                let exact: Vec<bool> = at_mid
                    .iter()
                    .zip(&raw[mid])
                    .zip(&normals)
                    .map(|((x, y), n)| !((*x - *y).dot(*n).abs() <= tau))
                    .collect();
                fixed += exact.iter().filter(|e| **e).count() * (b - a - 1);
                total += rest.len() * (b - a - 1);
                for f in a + 1..b {
                    let mut points = lerp(f);
                    for (v, p) in points.iter_mut().enumerate() {
                        if exact[v] {
                            *p = raw[f][v];
                        }
                    }
                    smoother.smooth(&mut points);
                    let p = maker.skin(&clip.frames[f], &points).0;
                    let e =
                        p.iter().zip(&posed[f]).map(|(x, y)| x.distance(*y)).fold(0f32, f32::max);
                    worst = worst.max(e);
                }
                a = b;
            }
            println!(
                "raw, spacing {k:2}, tau {:.2} mm: largest vertex error {:.3} mm, {:.2} % of the in-between vertices projected",
                tau * 1e3,
                worst * 1e3,
                100.0 * fixed as f64 / total.max(1) as f64
            );
        }
    }
}
