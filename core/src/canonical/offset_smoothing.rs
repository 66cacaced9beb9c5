//! Depth noise smoothed away relative to the body. A network fitted to noisy depth points
//! carries the noise as bumps a few centimetres wide, and on a fine mesh a millimetre of bump
//! tilts the normals by several degrees: the fitted t-shirt's normals were further from the
//! truth's than the naked body's. Smoothing the surface itself (Taubin) either leaves such
//! bumps or flattens the limbs, whose curvature is of the same size. Where cloth lies close to
//! the body, the surface is the body's smooth surface plus an offset (the cloth's thickness and
//! drape): here that offset, a scalar on the mesh, is smoothed along the mesh and the surface
//! rebuilt from it, so the bumps go and the limbs keep the body's curvature. Loose cloth (a
//! skirt, tails) keeps its own shape; the smoothing fades out with the distance to the body.

use crate::mesh::signed_distance::SignedDistance;
use crate::mesh::smooth::vertex_neighbours;
use crate::mesh::TriMesh;
use glam::Vec3;
use rayon::prelude::*;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffsetSmoothing {
    /// Offsets from the body (metres, either side) up to which the smoothing is whole, and from
    /// which it is off.
    pub tight: (f32, f32),
    /// Averaging sweeps over the mesh's edges: the noise's wavelength it takes off grows with
    /// the square root (about 1 cm x sqrt(sweeps) at the 192-cell meshes).
    pub sweeps: usize,
}

impl Default for OffsetSmoothing {
    fn default() -> Self {
        OffsetSmoothing { tight: (env_f32("AS_OS_A", 0.02), env_f32("AS_OS_B", 0.035)), sweeps: env_f32("AS_OS_N", 40.0) as usize }
    }
}

fn env_f32(name: &str, default: f32) -> f32 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// `mesh` (canonical, metres) with its offset from the rest body (`body`) smoothed where it
/// lies close to the body; faces unchanged.
pub fn smooth_body_offsets(mut mesh: TriMesh, body: &SignedDistance, options: &OffsetSmoothing) -> TriMesh {
    if options.sweeps == 0 || mesh.faces.is_empty() {
        return mesh;
    }
    let (a, b) = options.tight;
    let measured: Vec<Option<(f32, Vec3)>> = mesh.positions.par_iter().map(|&x| body.smooth_offset(x)).collect();
    // How much of the smoothing each vertex takes: 1 within `a` of the body, 0 from `b` on.
    let share: Vec<f32> = measured
        .iter()
        .map(|m| match m {
            Some((d, _)) if b > a => (1.0 - (d.abs() - a) / (b - a)).clamp(0.0, 1.0),
            Some((d, _)) => (d.abs() <= a) as u8 as f32,
            None => 0.0,
        })
        .collect();
    if share.iter().all(|&s| s == 0.0) {
        return mesh;
    }
    let offsets: Vec<f32> = measured.iter().map(|m| m.map_or(0.0, |(d, _)| d)).collect();
    let n = vertex_neighbours(&mesh);
    // Each sweep: a vertex's offset becomes the mean of its own and its neighbours' among the
    // vertices that take part (loose cloth neither gives nor takes).
    let mut smoothed = offsets.clone();
    let mut next = smoothed.clone();
    for _ in 0..options.sweeps {
        next.par_iter_mut().enumerate().for_each(|(v, out)| {
            if share[v] == 0.0 {
                return;
            }
            let (mut sum, mut count) = (smoothed[v], 1.0f32);
            for &u in &n.indices[n.offsets[v]..n.offsets[v + 1]] {
                if share[u as usize] > 0.0 {
                    sum += smoothed[u as usize];
                    count += 1.0;
                }
            }
            *out = sum / count;
        });
        std::mem::swap(&mut smoothed, &mut next);
    }
    mesh.positions.par_iter_mut().enumerate().for_each(|(v, x)| {
        if let Some((d, normal)) = measured[v] {
            *x += share[v] * (smoothed[v] - d) * normal;
        }
    });
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::raster::tests::sphere;

    fn mesh_sphere(r: f32, rings: usize, segs: usize) -> TriMesh {
        let (p, f) = sphere(Vec3::ZERO, r, rings, segs);
        TriMesh::new(p, f)
    }

    #[test]
    fn the_offset_is_measured_from_the_smooth_surface_not_its_facets() {
        // A coarse 10 cm sphere: its faces sag up to 2 mm inside the sphere between corners.
        let body = SignedDistance::new(&mesh_sphere(0.1, 8, 16));
        let (mut flat_worst, mut smooth_worst) = (0f32, 0f32);
        for i in 0..400 {
            // Directions spread over the sphere (a Fibonacci lattice), 1 cm outside.
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / 400.0;
            let phi = i as f32 * 2.399_963;
            let dir = Vec3::new((1.0 - y * y).sqrt() * phi.cos(), y, (1.0 - y * y).sqrt() * phi.sin());
            let p = dir * 0.11;
            flat_worst = flat_worst.max((body.at(p).unwrap() - 0.01).abs());
            let (d, n) = body.smooth_offset(p).unwrap();
            smooth_worst = smooth_worst.max((d - 0.01).abs());
            assert!(n.dot(dir) > 0.98, "normal {n} at {dir}");
        }
        assert!(flat_worst > 1e-3, "the facets' error {flat_worst}");
        assert!(smooth_worst < 0.35 * flat_worst, "smooth offset off by up to {smooth_worst} m (facets: {flat_worst})");
    }

    #[test]
    fn bumps_near_the_body_go_and_the_size_and_loose_cloth_stay() {
        let body = SignedDistance::new(&mesh_sphere(0.1, 48, 96));
        // Cloth 8 mm outside a 10 cm body with 1.5 mm bumps about 2 cm wide; the cap above
        // y = 0.09 m bulges 6 cm out (loose cloth).
        let mut cloth = mesh_sphere(0.108, 96, 192);
        let loose = |p: Vec3| p.y > 0.09;
        for p in cloth.positions.iter_mut() {
            let dir = p.normalize();
            let bump = 0.0015 * (dir.x * 31.0).sin() * (dir.z * 29.0).cos() * (dir.y * 23.0).cos();
            *p = if loose(*p) { dir * 0.16 } else { dir * (0.108 + bump) };
        }
        let offset_spread = |m: &TriMesh| {
            let r: Vec<f32> = m.positions.iter().filter(|p| p.y < 0.06).map(|p| p.length()).collect();
            let mean = r.iter().sum::<f32>() / r.len() as f32;
            (mean, (r.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / r.len() as f32).sqrt())
        };
        let normal_error = |m: &TriMesh| {
            let normals = m.vertex_normals();
            let e: Vec<f32> = m.positions.iter().zip(&normals).filter(|(p, _)| p.y < 0.06).map(|(p, n)| (p.normalize() - *n).length()).collect();
            e.iter().sum::<f32>() / e.len() as f32
        };
        let (mean_before, spread_before) = offset_spread(&cloth);
        let error_before = normal_error(&cloth);
        let smoothed = smooth_body_offsets(cloth.clone(), &body, &OffsetSmoothing { tight: (0.02, 0.035), sweeps: 40 });
        let (mean_after, spread_after) = offset_spread(&smoothed);
        let error_after = normal_error(&smoothed);
        assert!(spread_after < 0.25 * spread_before, "bumps {spread_before} -> {spread_after} m");
        assert!((mean_after - mean_before).abs() < 3e-4, "the cloth's offset moved: {mean_before} -> {mean_after} m");
        assert!(error_after < 0.4 * error_before, "normals' error {error_before} -> {error_after}");
        // Loose cloth (6 cm out) is untouched.
        for (a, b) in cloth.positions.iter().zip(&smoothed.positions) {
            if a.length() > 0.15 {
                assert_eq!(a, b);
            }
        }
    }
}
