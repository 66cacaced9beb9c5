//! A simulated garment played through a sequence of poses: it starts from its rest shape at
//! the rest pose, is carried to the first pose and left to settle, then follows every frame,
//! colliding with the clothed body under it (the outfit's other garments).

use super::garment::{garment_mesh, pinned_vertices};
use super::solver::{BodyCollider, Cloth, ClothConfig};
use crate::body::{BodyModel, BodyParams, skin_point};
use crate::mesh::TriMesh;
use crate::synth::deform::{PoseFeatures, canonical_surface, pose_surface};
use crate::synth::outfit::ClothedTemplate;
use glam::{Quat, Vec3};

/// Frames (at 30 fps) that carry the cloth from the rest pose to the first pose, and that it
/// then settles there.
const WARM_UP_FRAMES: usize = 24;
const SETTLE_FRAMES: usize = 36;

/// A garment's posed vertices at every frame of a sequence (garment indices: the template's
/// vertices after the body's).
#[derive(Debug, Clone, PartialEq)]
pub struct GarmentTrack {
    pub frames: Vec<Vec<Vec3>>,
}

/// The pose `t` of the way from `a` to `b` (per-joint slerp, translation lerp).
fn blend(a: &BodyParams, b: &BodyParams, t: f32) -> BodyParams {
    let mut p = b.clone();
    for (j, r) in p.pose.iter_mut().enumerate() {
        let qa = Quat::from_scaled_axis(a.pose[j]);
        let qb = Quat::from_scaled_axis(b.pose[j]);
        *r = qa.slerp(qb, t).to_scaled_axis();
    }
    p.trans = a.trans.lerp(b.trans, t);
    p
}

/// The template's body part (the clothing under the simulated garment) at a pose, and the
/// top row's targets (each skinned with the weights of its nearest body vertex).
fn frame_state(
    body: &BodyModel,
    template: &ClothedTemplate,
    under_faces: &[[u32; 3]],
    pinned: &[u32],
    pin_bodies: &[usize],
    params: &BodyParams,
    subject: u64,
) -> (TriMesh, Vec<Vec3>) {
    let bones = body.pose(params).bones;
    let canonical = canonical_surface(template, &PoseFeatures::of(&bones), subject);
    let n = template.body_vertices;
    let under = pose_surface(template, &canonical[..n], &bones);
    let pins = pinned
        .iter()
        .zip(pin_bodies)
        .map(|(&i, &b)| {
            skin_point(&bones.transforms, &template.weights[b], template.vertices[n + i as usize])
        })
        .collect();
    (TriMesh::new(under, under_faces.to_vec()), pins)
}

/// Simulate the template's garment through `poses` played at `fps`; `subject` seeds the folds
/// of the clothing under it (as `canonical_surface`). An empty sequence gives an empty track.
pub fn simulate_garment(
    body: &BodyModel,
    template: &ClothedTemplate,
    poses: &[BodyParams],
    fps: f32,
    subject: u64,
    config: ClothConfig,
) -> GarmentTrack {
    let Some(first) = poses.first() else { return GarmentTrack { frames: Vec::new() } };
    let n = template.body_vertices;
    let rest = garment_mesh(template, template.vertices[n..].to_vec());
    let pinned = pinned_vertices(template);
    // The top row is skinned as the nearest body vertex is, so a waistband follows the belly
    // and the back as the spine bends instead of cutting into them.
    let pin_bodies: Vec<usize> = pinned
        .iter()
        .map(|&i| {
            let p = template.vertices[n + i as usize];
            (0..n)
                .min_by(|&a, &b| {
                    let da = template.vertices[a].distance_squared(p);
                    da.total_cmp(&template.vertices[b].distance_squared(p))
                })
                .unwrap_or(0)
        })
        .collect();
    let mut cloth = Cloth::new(&rest, &pinned, config);
    let under_faces: Vec<[u32; 3]> =
        template.faces.iter().copied().filter(|f| f.iter().all(|&v| (v as usize) < n)).collect();
    let mut rest_pose = first.clone();
    rest_pose.pose.iter_mut().for_each(|r| *r = Vec3::ZERO);
    let warm_dt = 1.0 / 30.0;
    let step = |cloth: &mut Cloth, p: &BodyParams, dt: f32| {
        let (under, pins) =
            frame_state(body, template, &under_faces, &pinned, &pin_bodies, p, subject);
        cloth.step_frame(dt, &pins, Some(&BodyCollider::new(&under)));
    };
    for k in 1..=WARM_UP_FRAMES {
        let t = k as f32 / WARM_UP_FRAMES as f32;
        step(&mut cloth, &blend(&rest_pose, first, t * t * (3.0 - 2.0 * t)), warm_dt);
    }
    for _ in 0..SETTLE_FRAMES {
        step(&mut cloth, first, warm_dt);
    }
    let dt = 1.0 / fps.max(1.0);
    let mut frames = Vec::with_capacity(poses.len());
    for (i, p) in poses.iter().enumerate() {
        if i > 0 {
            step(&mut cloth, p, dt);
        }
        frames.push(cloth.positions.clone());
    }
    GarmentTrack { frames }
}

/// The whole clothed surface of one frame: the template's body part at `params` with the
/// simulated garment's vertices in place of the fallback ones.
pub fn with_garment(
    body: &BodyModel,
    template: &ClothedTemplate,
    params: &BodyParams,
    subject: u64,
    garment: &[Vec3],
) -> Vec<Vec3> {
    let bones = body.pose(params).bones;
    let canonical = canonical_surface(template, &PoseFeatures::of(&bones), subject);
    let mut posed = pose_surface(template, &canonical, &bones);
    posed[template.body_vertices..].copy_from_slice(garment);
    posed
}
