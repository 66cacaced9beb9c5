//! The signed distance to the subject's own shaped body at rest (canonical space, metres): the
//! target of pose pre-alignment (`pose_refine`), which the fittings' errors cannot bend, unlike
//! an SDF learned from the misaligned points.

use crate::data::capture_points::CapturePoints;
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::bvh::Bvh;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::Mutex;

pub struct BodySdf {
    mesh: TriMesh,
    bvh: Bvh,
    vertex_normals: Vec<Vec3>,
    /// Each vertex's body part: the joint with the largest skinning weight.
    parts: Vec<usize>,
    /// Per frame ([`BodySdf::beyond_clothing_of`]), the closest face of each point of the
    /// frame's last query, by position: the hint of the next query's closest-point search
    /// (`Bvh::closest_point_hinted`, whose answer does not depend on it). Pre-alignment asks
    /// for the same points of a frame step after step, each moved a little.
    hints: Mutex<Vec<Vec<u32>>>,
}

impl BodySdf {
    pub fn new(capture: &CapturePoints) -> BodySdf {
        let parts = capture
            .body
            .weights
            .iter()
            .map(|w| (0..w.len()).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0))
            .collect();
        Self::of_mesh(capture.body.mesh(capture.rest.clone()), parts)
    }

    /// `parts`: a body-part label per vertex (the clothing's offset is taken per part).
    pub fn of_mesh(mesh: TriMesh, parts: Vec<usize>) -> BodySdf {
        let bvh = Bvh::build(&mesh);
        let vertex_normals = mesh.vertex_normals();
        BodySdf { mesh, bvh, vertex_normals, parts, hints: Mutex::new(Vec::new()) }
    }

    /// Signed distance (positive outside) and its gradient at each point. The sign comes from
    /// the vertex normals interpolated at the closest point, which holds at edges and corners
    /// where one face's normal does not.
    pub fn eval(&self, points: &[Vec3]) -> (Vec<f32>, Vec<Vec3>) {
        let (d, g, _) = self.eval_parts(points, &[]).0;
        (d, g)
    }

    /// [`BodySdf::eval`] with the body part of each point's closest surface point; `hints`:
    /// a face near each point, by position (shorter than `points`: none for the rest). Also
    /// returns each point's closest face (`u32::MAX` where there is none).
    #[allow(clippy::type_complexity)]
    fn eval_parts(
        &self,
        points: &[Vec3],
        hints: &[u32],
    ) -> ((Vec<f32>, Vec<Vec3>, Vec<usize>), Vec<u32>) {
        let rows: Vec<(f32, Vec3, usize, u32)> = points
            .par_iter()
            .enumerate()
            .map(|(i, &p)| {
                let hit = match hints.get(i) {
                    Some(&face) => self.bvh.closest_point_hinted(p, face),
                    None => self.bvh.closest_point(p),
                };
                let Some(h) = hit else { return (f32::NAN, Vec3::ZERO, 0, u32::MAX) };
                let [a, b, c] = self.mesh.faces[h.face as usize].map(|i| i as usize);
                let n = interpolate(
                    h.point,
                    [self.mesh.positions[a], self.mesh.positions[b], self.mesh.positions[c]],
                    [self.vertex_normals[a], self.vertex_normals[b], self.vertex_normals[c]],
                );
                let d = p - h.point;
                let sign = if d.dot(n) >= 0.0 { 1.0 } else { -1.0 };
                let g = if h.distance > 1e-6 { d / h.distance * sign } else { n };
                (sign * h.distance, g, self.parts.get(a).copied().unwrap_or(0), h.face)
            })
            .collect();
        (
            (
                rows.iter().map(|r| r.0).collect(),
                rows.iter().map(|r| r.1).collect(),
                rows.iter().map(|r| r.2).collect(),
            ),
            rows.iter().map(|r| r.3).collect(),
        )
    }

    /// [`BodySdf::beyond_clothing`] of frame `frame`'s points: the same values, found faster
    /// when the frame's previous query asked for nearly the same points in the same order.
    pub fn beyond_clothing_of(
        &self,
        frame: usize,
        points: &[Vec3],
        band: f32,
    ) -> (Vec<f32>, Vec<Vec3>) {
        let hints = {
            let mut all = self.hints.lock().unwrap_or_else(|e| e.into_inner());
            all.get_mut(frame).map(std::mem::take).unwrap_or_default()
        };
        let (parts, faces) = self.eval_parts(points, &hints);
        let mut all = self.hints.lock().unwrap_or_else(|e| e.into_inner());
        if all.len() <= frame {
            all.resize_with(frame + 1, Vec::new);
        }
        all[frame] = faces;
        drop(all);
        self.offset_by_part(parts, band)
    }

    /// The signed distance less the clothing's offset over these points: per body part (the
    /// closest vertex's largest skinning weight), the median of the distances between 1 cm
    /// inside and `band` outside (the median over all parts for a part with fewer than 20).
    /// Tight clothing sits a few millimetres out, more on some parts than on others; without
    /// the offset every point would pull inward.
    pub fn beyond_clothing(&self, points: &[Vec3], band: f32) -> (Vec<f32>, Vec<Vec3>) {
        self.offset_by_part(self.eval_parts(points, &[]).0, band)
    }

    /// The distances less each part's clothing offset ([`BodySdf::beyond_clothing`]).
    fn offset_by_part(
        &self,
        (mut d, g, parts): (Vec<f32>, Vec<Vec3>, Vec<usize>),
        band: f32,
    ) -> (Vec<f32>, Vec<Vec3>) {
        let near = |part: Option<usize>| -> Vec<f32> {
            d.iter()
                .zip(&parts)
                .filter(|(v, p)| (-0.01..band).contains(*v) && part.is_none_or(|q| q == **p))
                .map(|(v, _)| *v)
                .collect()
        };
        let global = median(near(None)).unwrap_or(0.0);
        let mut offsets = [global; avatar_core::body::NUM_JOINTS];
        for (j, o) in offsets.iter_mut().enumerate() {
            let v = near(Some(j));
            // A part with few points keeps the global offset.
            if v.len() >= 20 {
                *o = median(v).unwrap_or(global);
            }
        }
        d.iter_mut()
            .zip(&parts)
            .for_each(|(v, &p)| *v -= offsets.get(p).copied().unwrap_or(global));
        (d, g)
    }
}

fn median(mut v: Vec<f32>) -> Option<f32> {
    if v.is_empty() {
        return None;
    }
    let mid = v.len() / 2;
    Some(*v.select_nth_unstable_by(mid, f32::total_cmp).1)
}

/// The vertex normals' barycentric blend at `p` (a point of the triangle).
fn interpolate(p: Vec3, [a, b, c]: [Vec3; 3], [na, nb, nc]: [Vec3; 3]) -> Vec3 {
    let w = avatar_core::mesh::barycentric(p, a, b, c);
    (na * w.x + nb * w.y + nc * w.z).normalize_or_zero()
}
