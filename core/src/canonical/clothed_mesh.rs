//! A posed clothed mesh (a scan with its body fitting) brought to the canonical pose by its own
//! skinning weights. Root finding in the body's diffused field canonicalizes each point on its
//! own: a skirt's point between the thighs takes one thigh's weights and the next point the
//! other's, so a dress scanned mid-stride comes apart into the legs' canonical places. A whole
//! mesh can do better: each vertex takes the weights of the posed body beneath it, and where the
//! cloth hangs away from the body those weights are inpainted along the mesh
//! ([`inpaint_loose_weights`], as the avatar skins its own loose cloth), so the skirt unposes
//! as one sheet hanging from the hips. The inverse of each vertex's blended transform then
//! takes it to the canonical pose.

use super::garment_skinning::{GarmentSkinning, inpaint_loose_weights};
use crate::body::{BodyModel, BodyParams, Weights, blend_transform, interpolate_weights};
use crate::mesh::TriMesh;
use crate::mesh::barycentric;
use crate::mesh::bvh::Bvh;
use crate::mesh::signed_distance::SignedDistance;
use glam::{Mat3, Vec3};
use rayon::prelude::*;

/// `mesh` (posed, in the fitting's world) at the canonical pose of `body` with the fitting's
/// shape: every vertex unposed by its own weights (the posed body's beneath it, inpainted
/// along the cloth where it is loose: `skinning`). Faces the unposing turns over (a fold
/// pressed flat at the crotch or an armpit) are left out, so the faces kept face the way their
/// posed faces did. Vertex `i` of the result is vertex `i` of `mesh`.
pub fn unpose_clothed_mesh(
    body: &BodyModel,
    params: &BodyParams,
    mesh: &TriMesh,
    skinning: &GarmentSkinning,
) -> TriMesh {
    let posed = body.pose(params);
    let body_mesh = body.mesh(posed.vertices.clone());
    let bvh = Bvh::build(&body_mesh);
    let beneath: Vec<Weights> = mesh
        .positions
        .par_iter()
        .map(|&x| {
            let hit = bvh.closest_point(x).expect("a body has faces");
            let f = body_mesh.faces[hit.face as usize].map(|k| k as usize);
            let [a, b, c] = f.map(|k| body_mesh.positions[k]);
            interpolate_weights(&body.weights, f, barycentric(hit.point, a, b, c))
        })
        .collect();
    let weights = inpaint_loose_weights(beneath, &SignedDistance::new(&body_mesh), mesh, skinning);
    let transforms: Vec<_> =
        weights.par_iter().map(|w| blend_transform(&posed.bones.transforms, w)).collect();
    let positions: Vec<Vec3> = mesh
        .positions
        .par_iter()
        .zip(&transforms)
        .map(|(&x, m)| m.inverse().transform_point3(x))
        .collect();
    let posed_normals = mesh.face_normals();
    let faces: Vec<[u32; 3]> = mesh
        .faces
        .par_iter()
        .zip(&posed_normals)
        .filter(|(face, posed_normal)| {
            let [a, b, c] = face.map(|v| positions[v as usize]);
            let normal = (b - a).cross(c - a);
            // A canonical normal goes back through the transpose of the blended linear part.
            let linear = face
                .iter()
                .map(|&v| Mat3::from_mat4(transforms[v as usize]))
                .fold(Mat3::ZERO, |acc, m| acc + m * (1.0 / 3.0));
            let expected = linear.transpose() * **posed_normal;
            normal.is_finite() && normal.dot(expected) > 0.0
        })
        .map(|(face, _)| *face)
        .collect();
    // A blend that cannot be inverted leaves a vertex at its posed place, without faces.
    let faces: Vec<[u32; 3]> = faces
        .into_iter()
        .filter(|f| f.iter().all(|&v| positions[v as usize].is_finite()))
        .collect();
    let positions = positions
        .into_iter()
        .zip(&mesh.positions)
        .map(|(p, &x)| if p.is_finite() { p } else { x })
        .collect();
    TriMesh::new(positions, faces)
}

#[cfg(test)]
mod tests;
