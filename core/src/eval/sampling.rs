//! Seeded uniform sampling of points on a triangle surface (Chamfer distance), and a
//! nearest-neighbour index over points (kiddo).

use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rand::Rng;

/// `n` points uniformly distributed over the surface area of `mesh`.
pub fn sample_surface<R: Rng>(mesh: &TriMesh, n: usize, rng: &mut R) -> Result<Vec<Vec3>> {
    Ok(sample_surface_faces(mesh, n, rng)?.into_iter().map(|(p, _)| p).collect())
}

/// `n` points uniformly distributed over the surface with the unit normal of their face.
pub fn sample_surface_with_normals<R: Rng>(mesh: &TriMesh, n: usize, rng: &mut R) -> Result<(Vec<Vec3>, Vec<Vec3>)> {
    let normals = mesh.face_normals();
    Ok(sample_surface_faces(mesh, n, rng)?.into_iter().map(|(p, f)| (p, normals[f])).unzip())
}

/// Area-uniform samples with the index of the face each lies on.
fn sample_surface_faces<R: Rng>(mesh: &TriMesh, n: usize, rng: &mut R) -> Result<Vec<(Vec3, usize)>> {
    let mut cumulative = Vec::with_capacity(mesh.faces.len());
    let mut total = 0f64;
    for f in 0..mesh.faces.len() {
        let [a, b, c] = mesh.triangle(f);
        total += 0.5 * (b - a).cross(c - a).length() as f64;
        cumulative.push(total);
    }
    if !(total > 0.0) || !total.is_finite() {
        return Err(Error::invalid(format!("cannot sample a surface of area {total} ({} faces)", mesh.faces.len())));
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

/// Nearest-neighbour queries over a fixed point set.
pub struct PointIndex {
    tree: ImmutableKdTree<f32, 3>,
    len: usize,
}

impl PointIndex {
    pub fn new(points: &[Vec3]) -> Result<PointIndex> {
        if points.is_empty() {
            return Err(Error::invalid("nearest-neighbour index over an empty point set"));
        }
        if let Some(p) = points.iter().find(|p| !p.is_finite()) {
            return Err(Error::invalid(format!("point {p} is not finite")));
        }
        let coords: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
        let tree = ImmutableKdTree::new_from_slice(&coords)
            .map_err(|e| Error::invalid(format!("cannot index {} points: {e:?}", points.len())))?;
        Ok(PointIndex { tree, len: points.len() })
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// (index, distance) of the nearest indexed point.
    pub fn nearest(&self, q: Vec3) -> (usize, f32) {
        let hit = self.tree.query(&q.to_array()).nearest_one::<SquaredEuclidean<f32>>().execute();
        (hit.item as usize, hit.distance.max(0.0).sqrt())
    }
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
            vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::new(2.0, 0.0, 1.0), Vec3::new(0.0, 2.0, 1.0)],
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

    #[test]
    fn nearest_matches_brute_force_and_handles_duplicates() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut pts: Vec<Vec3> = (0..2000).map(|_| Vec3::new(rng.random(), rng.random(), rng.random())).collect();
        // Many exact duplicates (seams of a mesh) must not break the index.
        pts.extend(std::iter::repeat_n(Vec3::splat(0.5), 300));
        let index = PointIndex::new(&pts).unwrap();
        for _ in 0..200 {
            let q = Vec3::new(rng.random(), rng.random(), rng.random());
            let (_, d) = index.nearest(q);
            let brute = pts.iter().map(|p| p.distance(q)).fold(f32::INFINITY, f32::min);
            assert!((d - brute).abs() < 1e-6);
        }
        assert!(PointIndex::new(&[]).is_err());
        assert!(PointIndex::new(&[Vec3::NAN]).is_err());
    }
}
