use super::*;
use crate::mesh::topology::face_components;

fn sphere(c: Vec3, r: f32) -> impl Fn(&[Vec3]) -> Vec<f32> {
    move |pts: &[Vec3]| pts.iter().map(|p| p.distance(c) - r).collect()
}

fn torus(major: f32, minor: f32) -> impl Fn(&[Vec3]) -> Vec<f32> {
    move |pts: &[Vec3]| {
        pts.iter()
            .map(|p| {
                let q = glam::Vec2::new(glam::Vec2::new(p.x, p.z).length() - major, p.y);
                q.length() - minor
            })
            .collect()
    }
}

/// Every edge is used exactly twice, once in each direction (closed, consistently
/// oriented two-manifold edges).
fn assert_watertight(mesh: &TriMesh) {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for f in &mesh.faces {
        for i in 0..3 {
            *directed.entry((f[i], f[(i + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "edge {a}-{b} used {n} times in the same direction");
        assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}-{b} has no opposite half");
    }
}

fn check_surface(mesh: &TriMesh, sdf: &dyn Fn(&[Vec3]) -> Vec<f32>, h: f32, expected_volume: f32) {
    assert!(mesh.faces.len() > 100);
    assert_watertight(mesh);
    assert_eq!(face_components(mesh).1, 1);
    // Vertices lie on the true surface up to the linear-interpolation error.
    let d = sdf(&mesh.positions);
    let worst = d.iter().fold(0f32, |m, x| m.max(x.abs()));
    assert!(worst < 0.05 * h, "vertex off the surface by {worst} (cell {h})");
    // Outward normals: positive volume close to the analytic one, and vertex normals
    // agree with the SDF gradient.
    let vol = mesh.signed_volume();
    assert!(
        (vol - expected_volume).abs() < 0.01 * expected_volume,
        "volume {vol} vs {expected_volume}"
    );
    let eps = 1e-3;
    for (p, n) in mesh.positions.iter().zip(mesh.vertex_normals()).step_by(7) {
        let g = Vec3::new(
            sdf(&[*p + Vec3::X * eps])[0] - sdf(&[*p - Vec3::X * eps])[0],
            sdf(&[*p + Vec3::Y * eps])[0] - sdf(&[*p - Vec3::Y * eps])[0],
            sdf(&[*p + Vec3::Z * eps])[0] - sdf(&[*p - Vec3::Z * eps])[0],
        )
        .normalize();
        assert!(n.dot(g) > 0.9, "normal {n} vs gradient {g} at {p}");
    }
}

#[test]
fn sphere_is_watertight_outward_and_on_the_surface() {
    let f = sphere(Vec3::new(0.05, -0.02, 0.03), 0.6);
    let opts = ExtractOptions::new(Vec3::splat(-1.0), Vec3::splat(1.0), 64);
    let out = extract(&f, &opts).unwrap();
    let volume = 4.0 / 3.0 * std::f32::consts::PI * 0.6f32.powi(3);
    check_surface(&out.mesh, &f, 2.0 / 64.0, volume);
    assert!(out.stats.savings() > 2.0, "{:?}", out.stats);
}

#[test]
fn torus_is_watertight_outward_and_one_component() {
    let f = torus(0.55, 0.2);
    let opts = ExtractOptions::new(Vec3::new(-1.0, -0.5, -1.0), Vec3::new(1.0, 0.5, 1.0), 96);
    let out = extract(&f, &opts).unwrap();
    let volume = 2.0 * std::f32::consts::PI.powi(2) * 0.55 * 0.2f32.powi(2);
    check_surface(&out.mesh, &f, 2.0 / 96.0, volume);
}

#[test]
fn coarse_to_fine_equals_dense_for_a_distance_function() {
    let f = torus(0.5, 0.15);
    let opts = ExtractOptions::new(Vec3::splat(-0.8), Vec3::splat(0.8), 64);
    let fast = extract(&f, &opts).unwrap();
    let dense = extract(&f, &opts.clone().dense()).unwrap();
    assert_eq!(fast.mesh.faces.len(), dense.mesh.faces.len());
    assert_eq!(fast.mesh.positions.len(), dense.mesh.positions.len());
    assert!((fast.mesh.signed_volume() - dense.mesh.signed_volume()).abs() < 1e-6);
    assert_eq!(dense.stats.evaluations(), dense.stats.dense_evaluations);
    assert!(fast.stats.evaluations() * 3 < dense.stats.evaluations(), "{:?}", fast.stats);
}

#[test]
fn largest_component_drops_the_small_sphere() {
    let f = |pts: &[Vec3]| -> Vec<f32> {
        pts.iter()
            .map(|p| {
                (p.distance(Vec3::new(-0.4, 0.0, 0.0)) - 0.35)
                    .min(p.distance(Vec3::new(0.55, 0.0, 0.0)) - 0.15)
            })
            .collect()
    };
    let mut opts = ExtractOptions::new(Vec3::splat(-1.0), Vec3::splat(1.0), 64);
    let both = {
        opts.largest_component_only = false;
        extract(f, &opts).unwrap()
    };
    assert_eq!(face_components(&both.mesh).1, 2);
    opts.largest_component_only = true;
    let big = extract(f, &opts).unwrap();
    assert_eq!(face_components(&big.mesh).1, 1);
    assert!(big.mesh.positions.iter().all(|p| p.x < 0.1));
}

#[test]
fn bad_sdf_or_box_is_an_error() {
    let opts = ExtractOptions::new(Vec3::splat(-1.0), Vec3::splat(1.0), 16);
    let nan = extract(|p: &[Vec3]| vec![f32::NAN; p.len()], &opts).unwrap_err();
    assert!(nan.to_string().contains("not finite"), "{nan}");
    let short = extract(|p: &[Vec3]| vec![0.0; p.len() / 2], &opts).unwrap_err();
    assert!(short.to_string().contains("values for"), "{short}");
    let flat = ExtractOptions::new(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0), 16);
    assert!(extract(sphere(Vec3::ZERO, 0.5), &flat).is_err());
    // Nothing inside the box: an empty mesh, not an error.
    let empty = extract(sphere(Vec3::splat(5.0), 0.5), &opts).unwrap();
    assert!(empty.mesh.faces.is_empty());
    assert_eq!(empty.stats.fine_evaluations, 0);
}
