//! Fine-tuning step time of batch shapes side by side (the demo capture, 8 frames, the shipped
//! model): `cargo run -p avatar-neural --example step_timing -- 30`. Each configuration runs
//! twice, interleaved, so drifting machine load hits them alike.
use avatar_core::canonical::FieldCache;
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::training::loss::IgrWeights;
use avatar_neural::{HyperFitOptions, Init, MetaAvatar, MetaModel};
use std::time::Instant;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() {
    let steps: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(30);
    let demo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let capture = CapturePoints::open(&demo, 8, &field_cache()).expect("the demo capture opens");
    let model = MetaModel::shipped();
    let new = HyperFitOptions { steps, ..HyperFitOptions::default() };
    let configs = [
        (
            "4 poses x 1000, encoder 1e-4, normal term (previous)",
            HyperFitOptions {
                poses_per_step: 4,
                surface_per_pose: 1000,
                off_per_pose: 1000,
                lr_encoder: 1e-4,
                weights: IgrWeights::default(),
                ..new.clone()
            },
        ),
        (
            "4 poses x 1000, encoder frozen, no normal term",
            HyperFitOptions {
                poses_per_step: 4,
                surface_per_pose: 1000,
                off_per_pose: 1000,
                ..new.clone()
            },
        ),
        ("8 poses x 500, encoder frozen, no normal term (defaults)", new.clone()),
    ];
    let mut ms = vec![Vec::new(); configs.len()];
    for _round in 0..2 {
        for (k, (_, options)) in configs.iter().enumerate() {
            let t = Instant::now();
            let _ = MetaAvatar::fit_points(
                &capture,
                &Init::MetaLearned(&model),
                options,
                None,
                &mut |_, _, _| {},
            );
            ms[k].push(t.elapsed().as_secs_f64() * 1e3 / steps as f64);
        }
    }
    for ((name, _), m) in configs.iter().zip(&ms) {
        println!("{name}: {:.0} / {:.0} ms a step", m[0], m[1]);
    }
}
