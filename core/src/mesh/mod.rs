//! Triangle meshes and point clouds: the currency between stages.

pub mod bvh;
pub mod crossings;
pub mod extract;
pub mod holes;
pub mod integrity;
pub mod io;
mod marching_cubes;
pub mod point_index;
pub mod sdf_grid;
pub mod signed_distance;
pub mod smooth;
pub mod topology;

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// An indexed triangle mesh. Faces are counter-clockwise seen from outside.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
}

/// Points with optional unit normals (depth points, canonical points).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCloud {
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
}

impl TriMesh {
    pub fn new(positions: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Self {
        TriMesh { positions, faces }
    }

    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    pub fn triangle(&self, f: usize) -> [Vec3; 3] {
        let [a, b, c] = self.faces[f];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Unit face normals (zero for degenerate faces).
    pub fn face_normals(&self) -> Vec<Vec3> {
        (0..self.faces.len())
            .map(|f| {
                let [a, b, c] = self.triangle(f);
                (b - a).cross(c - a).normalize_or_zero()
            })
            .collect()
    }

    /// Area-weighted unit vertex normals.
    pub fn vertex_normals(&self) -> Vec<Vec3> {
        vertex_normals(&self.positions, &self.faces)
    }

    /// Axis-aligned bounds (min, max); `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        bounds(&self.positions)
    }

    /// Signed volume (positive for a closed mesh with outward faces).
    pub fn signed_volume(&self) -> f32 {
        (0..self.faces.len())
            .map(|f| {
                let [a, b, c] = self.triangle(f);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    pub fn surface_area(&self) -> f32 {
        (0..self.faces.len()).map(|f| self.triangle_area(f)).sum()
    }

    /// The area of face `f`.
    pub fn triangle_area(&self, f: usize) -> f32 {
        let [a, b, c] = self.triangle(f);
        0.5 * (b - a).cross(c - a).length()
    }
}

/// Barycentric coordinates of `p` in the triangle (a, b, c), clamped to the triangle (the
/// closest point of a triangle lies in it; clamping keeps rounding from going outside). A
/// degenerate triangle gives (1, 0, 0).
pub fn barycentric(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (v0, v1, v2) = (b - a, c - a, p - a);
    let (d00, d01, d11, d20, d21) = (v0.dot(v0), v0.dot(v1), v1.dot(v1), v2.dot(v0), v2.dot(v1));
    let denom = d00 * d11 - d01 * d01;
    if denom.abs() < 1e-20 {
        return Vec3::new(1.0, 0.0, 0.0);
    }
    let v = ((d11 * d20 - d01 * d21) / denom).clamp(0.0, 1.0);
    let w = ((d00 * d21 - d01 * d20) / denom).clamp(0.0, 1.0 - v);
    Vec3::new(1.0 - v - w, v, w)
}

/// Axis-aligned bounds of a point set.
pub fn bounds(points: &[Vec3]) -> Option<(Vec3, Vec3)> {
    let first = *points.first()?;
    Some(points.iter().fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))))
}

impl PointCloud {
    pub fn len(&self) -> usize {
        self.points.len()
    }
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// Area-weighted unit vertex normals of a triangle soup over `positions` (zero for a vertex
/// on no face or only on degenerate faces). The mesh, the exporter and the viewport use it.
pub fn vertex_normals(positions: &[Vec3], faces: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for face in faces {
        let [a, b, c] = face.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a); // length = 2 * area
        for &v in face {
            normals[v as usize] += n;
        }
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barycentric_coordinates_rebuild_points_of_the_triangle() {
        let (a, b, c) =
            (Vec3::new(0.1, 0.0, 0.3), Vec3::new(1.0, 0.2, 0.0), Vec3::new(0.3, 1.1, 0.5));
        let p = a * 0.2 + b * 0.5 + c * 0.3;
        let w = barycentric(p, a, b, c);
        assert!((w - Vec3::new(0.2, 0.5, 0.3)).length() < 1e-5, "{w}");
        assert!((barycentric(b, a, b, c) - Vec3::Y).length() < 1e-6);
        // Outside the triangle: clamped onto it, still summing to one.
        let w = barycentric(a * 1.5 - b * 0.5, a, b, c);
        assert!(w.min_element() >= 0.0 && (w.x + w.y + w.z - 1.0).abs() < 1e-6, "{w}");
        assert_eq!(barycentric(p, a, a, a), Vec3::X);
    }

    pub(crate) fn unit_cube() -> TriMesh {
        let p = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let f = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        TriMesh::new(p, f)
    }

    #[test]
    fn cube_volume_area_and_outward_normals() {
        let cube = unit_cube();
        assert!((cube.signed_volume() - 1.0).abs() < 1e-6);
        assert!((cube.surface_area() - 6.0).abs() < 1e-6);
        let centre = Vec3::splat(0.5);
        for (v, n) in cube.positions.iter().zip(cube.vertex_normals()) {
            assert!(n.dot(*v - centre) > 0.0, "normal points inward at {v}");
        }
    }
}
