//! Seeded uniform sampling of points on a triangle surface (Chamfer distance). The
//! nearest-neighbour index over points is `mesh::point_index` (re-exported here).

use crate::error::{Error, Result};
use crate::mesh::TriMesh;
pub use crate::mesh::point_index::PointIndex;
use glam::Vec3;
use rand::Rng;

/// `n` points uniformly distributed over the surface area of `mesh`.
pub fn sample_surface<R: Rng>(mesh: &TriMesh, n: usize, rng: &mut R) -> Result<Vec<Vec3>> {
    Ok(sample_surface_faces(mesh, n, rng)?.into_iter().map(|(p, _)| p).collect())
}

/// `n` points uniformly distributed over the surface with the unit normal of their face.
pub fn sample_surface_with_normals<R: Rng>(
    mesh: &TriMesh,
    n: usize,
    rng: &mut R,
) -> Result<(Vec<Vec3>, Vec<Vec3>)> {
    let normals = mesh.face_normals();
    Ok(sample_surface_faces(mesh, n, rng)?.into_iter().map(|(p, f)| (p, normals[f])).unzip())
}

/// Area-uniform samples with the index of the face each lies on.
fn sample_surface_faces<R: Rng>(
    mesh: &TriMesh,
    n: usize,
    rng: &mut R,
) -> Result<Vec<(Vec3, usize)>> {
    let mut cumulative = Vec::with_capacity(mesh.faces.len());
    let mut total = 0f64;
    for f in 0..mesh.faces.len() {
        let [a, b, c] = mesh.triangle(f);
        total += 0.5 * (b - a).cross(c - a).length() as f64;
        cumulative.push(total);
    }
    if !(total > 0.0) || !total.is_finite() {
        return Err(Error::invalid(format!(
            "cannot sample a surface of area {total} ({} faces)",
            mesh.faces.len()
        )));
    }
    Ok((0..n)
        .map(|_| {
            let target = rng.random::<f64>() * total;
            let f = cumulative.partition_point(|&c| c <= target).min(cumulative.len() - 1);
            let [a, b, c] = mesh.triangle(f);
            // Uniform on the triangle: the square root keeps the density flat.
            let r1 = rng.random::<f32>().sqrt();
            let r2 = rng.random::<f32>();
            (a * (1.0 - r1) + b * (r1 * (1.0 - r2)) + c * (r1 * r2), f)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn samples_are_uniform_over_area() {
        // Two triangles: one of area 1/2 (z = 0), one of area 2 (z = 1): 1:4 split expected.
        let mesh = TriMesh::new(
            vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::Y,
                Vec3::Z,
                Vec3::new(2.0, 0.0, 1.0),
                Vec3::new(0.0, 2.0, 1.0),
            ],
            vec![[0, 1, 2], [3, 4, 5]],
        );
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let pts = sample_surface(&mesh, 20_000, &mut rng).unwrap();
        let upper = pts.iter().filter(|p| p.z > 0.5).count() as f32 / pts.len() as f32;
        assert!((upper - 0.8).abs() < 0.015, "upper fraction {upper}");
        // Inside the big triangle, the fraction with x + y < 1 is 1/4 of its area.
        let big: Vec<_> = pts.iter().filter(|p| p.z > 0.5).collect();
        let corner = big.iter().filter(|p| p.x + p.y < 1.0).count() as f32 / big.len() as f32;
        assert!((corner - 0.25).abs() < 0.015, "corner fraction {corner}");
        assert!(pts.iter().all(|p| p.x >= -1e-6 && p.y >= -1e-6 && p.x + p.y <= 2.0 + 1e-5));
        // Same seed, same points.
        let again = sample_surface(&mesh, 20_000, &mut ChaCha8Rng::seed_from_u64(1)).unwrap();
        assert_eq!(pts, again);
        assert!(sample_surface(&TriMesh::default(), 10, &mut rng).is_err());
    }
}
