//! Signed distance to a closed mesh with outward faces: the distance to the nearest surface
//! point, negative where that point's face looks away (inside). Exact for the distance; the
//! sign is the nearest face's, which is right away from sharp folds (the body's SDF for the
//! sign prior and the shells behind loose clothing).

use super::TriMesh;
use super::bvh::Bvh;
use glam::Vec3;

pub struct SignedDistance {
    bvh: Bvh,
    face_normals: Vec<Vec3>,
    /// The mesh's faces, and its area-weighted unit vertex normals: the smooth surface that
    /// [`SignedDistance::smooth_offset`] measures from.
    faces: Vec<[u32; 3]>,
    positions: Vec<Vec3>,
    vertex_normals: Vec<Vec3>,
}

impl SignedDistance {
    pub fn new(mesh: &TriMesh) -> SignedDistance {
        SignedDistance {
            bvh: Bvh::build(mesh),
            face_normals: mesh.face_normals(),
            faces: mesh.faces.clone(),
            positions: mesh.positions.clone(),
            vertex_normals: mesh.vertex_normals(),
        }
    }

    /// Metres, positive outside (on the surface counts as outside); `None` for an empty mesh.
    pub fn at(&self, p: Vec3) -> Option<f32> {
        self.with_closest(p).map(|(d, _)| d)
    }

    /// The distance to the surface (unsigned) where it is below `cap`, else `None`: a shorter
    /// search than [`SignedDistance::at`]'s, the same distance.
    pub fn distance_within(&self, p: Vec3, cap: f32) -> Option<f32> {
        self.bvh.closest_point_within(p, cap).map(|h| h.distance)
    }

    /// The signed distance and the nearest surface point.
    pub fn with_closest(&self, p: Vec3) -> Option<(f32, Vec3)> {
        let h = self.bvh.closest_point(p)?;
        let outside = (p - h.point).dot(self.face_normals[h.face as usize]) >= 0.0;
        Some((if outside { h.distance } else { -h.distance }, h.point))
    }

    /// The signed distance where the surface is within `reach` of `p` (else `None`), signed by
    /// the vertex normals blended at the closest point: at an edge or a corner, where the
    /// closest point is shared by faces looking different ways, the nearest face's normal (as
    /// [`SignedDistance::at`] takes it) can call a point outside a sharp ridge inside.
    pub fn within(&self, p: Vec3, reach: f32) -> Option<f32> {
        let h = self.bvh.closest_point_within(p, reach)?;
        let [a, b, c] = self.faces[h.face as usize].map(|i| i as usize);
        let w =
            super::barycentric(h.point, self.positions[a], self.positions[b], self.positions[c]);
        let normal = w.x * self.vertex_normals[a]
            + w.y * self.vertex_normals[b]
            + w.z * self.vertex_normals[c];
        let normal = normal.try_normalize().unwrap_or(self.face_normals[h.face as usize]);
        let outside = (p - h.point).dot(normal) >= 0.0;
        Some(if outside { h.distance } else { -h.distance })
    }

    /// The offset of `p` from the mesh's *smooth* surface along that surface's normal, and the
    /// normal: the nearest face's point moved halfway onto its corners' tangent planes
    /// (Phong tessellation) and the corners' normals blended there. A flat face lies inside a curved
    /// limb by up to a millimetre between its corners; measured from the faces themselves an
    /// offset would carry the body's facets.
    pub fn smooth_offset(&self, p: Vec3) -> Option<(f32, Vec3)> {
        let h = self.bvh.closest_point(p)?;
        let [a, b, c] = self.faces[h.face as usize].map(|i| i as usize);
        let w =
            super::barycentric(h.point, self.positions[a], self.positions[b], self.positions[c]);
        let mut normal = Vec3::ZERO;
        let mut smooth_point = Vec3::ZERO;
        for (k, v) in [a, b, c].into_iter().enumerate() {
            let n = self.vertex_normals[v];
            normal += w[k] * n;
            // Half of Phong's projection: on a circle that is exact to the fourth order in the
            // angle between the corners' normals (the whole projection overshoots by the sag).
            smooth_point += w[k] * (h.point - 0.5 * (h.point - self.positions[v]).dot(n) * n);
        }
        let normal = normal.try_normalize().unwrap_or(self.face_normals[h.face as usize]);
        Some(((p - smooth_point).dot(normal), normal))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_is_negative_inside_and_positive_outside() {
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * 0.5;
        let positions = vec![
            c(-1., -1., -1.),
            c(1., -1., -1.),
            c(1., 1., -1.),
            c(-1., 1., -1.),
            c(-1., -1., 1.),
            c(1., -1., 1.),
            c(1., 1., 1.),
            c(-1., 1., 1.),
        ];
        let faces = vec![
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [3, 7, 6],
            [3, 6, 2],
            [0, 4, 7],
            [0, 7, 3],
            [1, 2, 6],
            [1, 6, 5],
        ];
        let sd = SignedDistance::new(&TriMesh::new(positions, faces));
        assert!((sd.at(Vec3::ZERO).unwrap() + 0.5).abs() < 1e-6);
        assert!((sd.at(Vec3::new(0.0, 0.0, 0.8)).unwrap() - 0.3).abs() < 1e-6);
        assert!((sd.at(Vec3::new(0.1, 0.4, 0.0)).unwrap() + 0.1).abs() < 1e-6);
        assert!(
            SignedDistance::new(&TriMesh::new(Vec::new(), Vec::new())).at(Vec3::ZERO).is_none()
        );
    }
}
