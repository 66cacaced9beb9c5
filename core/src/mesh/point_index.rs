//! Nearest-neighbour queries over a fixed point set (a k-d tree: kiddo).

use crate::error::{Error, Result};
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

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
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn nearest_matches_brute_force_and_handles_duplicates() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut pts: Vec<Vec3> =
            (0..2000).map(|_| Vec3::new(rng.random(), rng.random(), rng.random())).collect();
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
