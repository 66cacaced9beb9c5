//! The shipped meta-model's surfaces: `cargo run -p avatar-neural --example shipped_shape`.
use avatar_core::mesh::extract::{extract, ExtractOptions};
use avatar_neural::*;
use glam::Vec3;

fn main() {
    let m = MetaModel::shipped();
    println!("{}", m.header.provenance);
    let device = cpu_device();
    let s = m.static_siren();
    let h = m.hyper_net();
    let (w, b) = s.params();
    let f = |p: &[Vec3]| -> Vec<f32> { sdf_values(&s, p, &device) };
    let _ = (w, b);
    let e = extract(f, &ExtractOptions::new(Vec3::splat(-1.0), Vec3::splat(1.0), 48)).unwrap();
    println!("static: {} vertices, bounds {:?}", e.mesh.positions.len(), e.mesh.bounds());
    let probe = [Vec3::ZERO, Vec3::new(0.0, 0.3, 0.0), Vec3::splat(0.95), Vec3::new(-0.95, 0.95, -0.95), Vec3::new(0.9, -0.9, 0.9)];
    println!("static at probes {:?}", sdf_values(&s, &probe, &device));
    let _ = h;
}
