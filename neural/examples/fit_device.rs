//! Fine-tune the demo capture on a chosen device and time the steps:
//! `cargo run --release -p avatar-neural --features gpu --example fit_device -- gpu 50 [paper]`.
//! Prints seconds per step and the final loss; with `cpu` it is the same fit as `avatar-studio
//! fit`, so the two devices can be compared side by side.
use avatar_core::canonical::FieldCache;
use avatar_neural::compute::Compute;
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::{HyperConfig, HyperFitOptions, Init, MetaAvatar, MetaModel};
use std::time::Instant;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let device =
        Compute::parse(args.get(1).map_or("cpu", |s| s.as_str())).unwrap_or_else(|e| panic!("{e}"));
    let steps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(20);
    let paper = args.get(3).is_some_and(|s| s == "paper");
    let demo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let capture = CapturePoints::open(&demo, 8, &field_cache()).expect("the demo capture opens");
    let model = MetaModel::shipped();
    let init = if paper {
        Init::Scratch { config: HyperConfig::paper(), seed: 0 }
    } else {
        Init::MetaLearned(&model)
    };
    let options = HyperFitOptions { steps, compute: device, ..HyperFitOptions::default() };
    let mut losses = Vec::new();
    let mut first = None;
    let t = Instant::now();
    let (avatar, _) =
        MetaAvatar::fit_points(&capture, &init, &options, None, &mut |step, loss, _| {
            if step == 0 {
                first = Some(t.elapsed().as_secs_f64());
            }
            losses.push(loss);
        });
    let total = t.elapsed().as_secs_f64();
    let first = first.unwrap_or(total);
    println!(
        "{} {} preset, {steps} steps: {total:.1} s in all, first step {first:.1} s (compilation, upload), then {:.0} ms/step; loss {:.3} -> {:.3}; {} parameters",
        device.name(),
        if paper { "paper" } else { "compact" },
        (total - first) * 1e3 / (steps.saturating_sub(1)).max(1) as f64,
        losses.first().copied().unwrap_or(f32::NAN),
        losses.last().copied().unwrap_or(f32::NAN),
        avatar.num_params()
    );
    let mesh = avatar
        .canonical_mesh_at(
            &avatar_core::body::BodyParams {
                betas: avatar.header.betas.clone(),
                ..Default::default()
            },
            avatar_neural::avatar::MeshResolution::new(64).expect("within the bounds"),
        )
        .expect("meshing");
    println!("canonical mesh at 64: {} vertices", mesh.positions.len());
}
