//! What a meta-model's static meta-SDF looks like before any fine-tuning: its largest
//! component's bounds in the normalised cube (a body spans about +-0.9 along y).
//! `cargo run -p avatar-neural --example shipped_shape [-- meta-model.bin]`
use avatar_core::mesh::extract::{ExtractOptions, extract};
use avatar_neural::*;
use glam::Vec3;

fn main() {
    let path = std::env::args().nth(1);
    let model = MetaModel::load_or_shipped(path.as_deref().map(std::path::Path::new))
        .expect("a meta-model");
    println!("{}", model.header.provenance);
    let sdf = siren_eval::SirenEval::of(&model.static_siren());
    let e = extract(
        |p: &[Vec3]| sdf.sdf(&p.iter().map(|q| q.to_array()).collect::<Vec<_>>()),
        &ExtractOptions::new(Vec3::splat(-1.0), Vec3::splat(1.0), 48),
    )
    .expect("extraction");
    println!(
        "static meta-SDF at 48^3: {} vertices, bounds {:?}",
        e.mesh.positions.len(),
        e.mesh.bounds()
    );
}
