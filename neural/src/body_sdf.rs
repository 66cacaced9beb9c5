//! The signed distance to the subject's own shaped body at rest (canonical space, metres): the
//! target of pose pre-alignment (`pose_refine`), which the fittings' errors cannot bend, unlike
//! an SDF learned from the misaligned points.

use crate::capture_points::CapturePoints;
use avatar_core::mesh::bvh::Bvh;
use avatar_core::mesh::TriMesh;
use glam::Vec3;
use rayon::prelude::*;

pub struct BodySdf {
    mesh: TriMesh,
    bvh: Bvh,
    vertex_normals: Vec<Vec3>,
}

impl BodySdf {
    pub fn new(capture: &CapturePoints) -> BodySdf {
        Self::of_mesh(capture.body.mesh(capture.rest.clone()))
    }

    pub fn of_mesh(mesh: TriMesh) -> BodySdf {
        let bvh = Bvh::build(&mesh);
        let vertex_normals = mesh.vertex_normals();
        BodySdf { mesh, bvh, vertex_normals }
    }

    /// Signed distance (positive outside) and its gradient at each point. The sign comes from
    /// the vertex normals interpolated at the closest point, which holds at edges and corners
    /// where one face's normal does not.
    pub fn eval(&self, points: &[Vec3]) -> (Vec<f32>, Vec<Vec3>) {
        points
            .par_iter()
            .map(|&p| {
                let Some(h) = self.bvh.closest_point(p) else { return (f32::NAN, Vec3::ZERO) };
                let [a, b, c] = self.mesh.faces[h.face as usize].map(|i| i as usize);
                let n = interpolate(h.point, [self.mesh.positions[a], self.mesh.positions[b], self.mesh.positions[c]], [self.vertex_normals[a], self.vertex_normals[b], self.vertex_normals[c]]);
                let d = p - h.point;
                let sign = if d.dot(n) >= 0.0 { 1.0 } else { -1.0 };
                let g = if h.distance > 1e-6 { d / h.distance * sign } else { n };
                (sign * h.distance, g)
            })
            .unzip()
    }

    /// The signed distance less the clothing's offset over these points (the median of the
    /// distances between 1 cm inside and `band` outside; 0 when none is): tight clothing sits a
    /// few millimetres out, and a uniform offset would otherwise pull every point inward.
    pub fn beyond_clothing(&self, points: &[Vec3], band: f32) -> (Vec<f32>, Vec<Vec3>) {
        let (mut d, g) = self.eval(points);
        let mut near: Vec<f32> = d.iter().copied().filter(|v| (-0.01..band).contains(v)).collect();
        let offset = if near.is_empty() {
            0.0
        } else {
            let mid = near.len() / 2;
            *near.select_nth_unstable_by(mid, f32::total_cmp).1
        };
        d.iter_mut().for_each(|v| *v -= offset);
        (d, g)
    }
}

/// The vertex normals' barycentric blend at `p` (a point of the triangle).
fn interpolate(p: Vec3, [a, b, c]: [Vec3; 3], [na, nb, nc]: [Vec3; 3]) -> Vec3 {
    let (v0, v1, v2) = (b - a, c - a, p - a);
    let (d00, d01, d11, d20, d21) = (v0.dot(v0), v0.dot(v1), v1.dot(v1), v2.dot(v0), v2.dot(v1));
    let den = d00 * d11 - d01 * d01;
    if den.abs() < 1e-20 {
        return (na + nb + nc).normalize_or_zero();
    }
    let v = (d11 * d20 - d01 * d21) / den;
    let w = (d00 * d21 - d01 * d20) / den;
    (na * (1.0 - v - w) + nb * v + nc * w).normalize_or_zero()
}
