//! Posing: skin the canonical mesh at a pose, off the UI thread. The pose worker runs one pose
//! at a time as a background [`Task`]; of the requests that arrive meanwhile only the newest is
//! kept, and it starts when the running one finishes. Every finished pose is handed to the UI
//! (a result is shown rather than dropped while nothing newer is ready).

use crate::studio::avatar::{CanonicalMesh, StudioAvatar};
use crate::studio::tasks::{Task, TaskError, Wake, take_done};
use avatar_core::avatar::{AvatarSource, PROJECTION_STEPS, PoseSurface};
use avatar_core::body::{BodyModel, BodyParams, NUM_JOINTS, blend_transform};
use glam::{Mat4, Vec3};
use rayon::prelude::*;
use std::sync::Arc;

/// What is posed: a canonical mesh with weights (normals from the posed triangles), the same
/// with smooth canonical normals (an SDF's gradient) that turn with the skinning, or an avatar
/// whose surface depends on the pose. For the latter the reference mesh's vertices are
/// projected onto the pose's canonical surface (Newton steps on its SDF) and skinned: the
/// exporter's recipe, so the viewport shows what the glTF will hold, without marching cubes
/// at every pose. Its normals are the pose's SDF gradient (six more SDF values a vertex: what
/// playback bakes), or with `rest_normals` the rest pose's gradient turned by the skinning (no
/// cost: what the slider shows until the clip is baked).
#[derive(Clone)]
pub enum Posable {
    Mesh(Arc<CanonicalMesh>),
    Smooth {
        mesh: Arc<CanonicalMesh>,
        normals: Arc<Vec<Vec3>>,
    },
    PoseDependent {
        avatar: Arc<dyn StudioAvatar>,
        reference: Arc<CanonicalMesh>,
        rest_normals: Option<Arc<Vec<Vec3>>>,
    },
}

impl Posable {
    /// The canonical mesh this posable starts from (its identity for the bake cache).
    pub fn canonical(&self) -> &Arc<CanonicalMesh> {
        match self {
            Posable::Mesh(m) | Posable::Smooth { mesh: m, .. } => m,
            Posable::PoseDependent { reference, .. } => reference,
        }
    }

    /// The same posable with the best normals (the pose's SDF gradient): for baking.
    pub fn exact(self) -> Posable {
        match self {
            Posable::PoseDependent { avatar, reference, .. } => {
                Posable::PoseDependent { avatar, reference, rest_normals: None }
            }
            p => p,
        }
    }
}

#[derive(Clone)]
pub struct PoseRequest {
    pub id: u64,
    pub params: BodyParams,
    pub posable: Posable,
    pub body: Arc<BodyModel>,
}

pub struct PosedMesh {
    pub id: u64,
    pub positions: Vec<Vec3>,
    /// Smooth unit normals (None: the viewport takes them from the triangles).
    pub normals: Option<Vec<Vec3>>,
    pub faces: Arc<Vec<[u32; 3]>>,
    pub joints: [Vec3; NUM_JOINTS],
    pub seconds: f64,
}

/// A pose that could not be computed.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{error}")]
pub struct PoseError {
    pub id: u64,
    pub error: TaskError,
}

pub struct PoseWorker {
    wake: Wake,
    running: Option<(u64, Task<PosedMesh>)>,
    queued: Option<PoseRequest>,
    next_id: u64,
    /// The id of the newest request sent.
    pub latest: u64,
}

impl PoseWorker {
    pub fn start(wake: impl Fn() + Send + Sync + 'static) -> PoseWorker {
        PoseWorker { wake: Arc::new(wake), running: None, queued: None, next_id: 1, latest: 0 }
    }

    /// Ask for a pose; returns its id. A request still queued is replaced by this one.
    pub fn request(&mut self, params: BodyParams, posable: Posable, body: Arc<BodyModel>) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        self.latest = id;
        self.queued = Some(PoseRequest { id, params, posable, body });
        self.start_queued();
        id
    }

    fn start_queued(&mut self) {
        if self.running.is_none()
            && let Some(req) = self.queued.take()
        {
            let id = req.id;
            self.running =
                Some((id, Task::spawn("pose worker", self.wake.clone(), move |_| pose(&req))));
        }
    }

    /// A finished pose (the newest request's or an older one's), if any; starts the queued
    /// request.
    pub fn poll(&mut self) -> Option<Result<PosedMesh, PoseError>> {
        let id = self.running.as_ref()?.0;
        let mut slot = self.running.take().map(|(_, t)| t);
        let done = take_done(&mut slot);
        self.running = slot.map(|t| (id, t));
        let r = done?;
        self.start_queued();
        Some(r.map_err(|error| PoseError { id, error }))
    }

    /// True while a pose is computed or queued.
    pub fn busy(&self) -> bool {
        self.running.is_some() || self.queued.is_some()
    }
}

/// Unit normals of canonical points from the SDF's gradient at a pose (central differences);
/// where the gradient vanishes, `fallback`'s normal is kept.
pub fn sdf_normals(
    source: &dyn AvatarSource,
    params: &BodyParams,
    points: &[Vec3],
    fallback: &[Vec3],
) -> crate::error::Result<Vec<Vec3>> {
    const H: f32 = 1e-3;
    let probe: Vec<Vec3> = points
        .iter()
        .flat_map(|&p| {
            [Vec3::X, Vec3::Y, Vec3::Z].into_iter().flat_map(move |a| [p + a * H, p - a * H])
        })
        .collect();
    let f = source.sdf(params, &probe)?;
    Ok(f.chunks_exact(6)
        .zip(fallback)
        .map(|(v, n)| {
            let g = Vec3::new(v[0] - v[1], v[2] - v[3], v[4] - v[5]);
            if g.is_finite() && g.length_squared() > 1e-12 { g.normalize() } else { *n }
        })
        .collect())
}

/// Linear blend skinning of the canonical mesh by the pose (the exporter's skinning); smooth
/// normals turn with the blended transform.
pub fn pose(req: &PoseRequest) -> crate::error::Result<PosedMesh> {
    let t = std::time::Instant::now();
    let posed_body = req.body.pose(&req.params);
    let bones = &posed_body.bones;
    let owned;
    let (canonical, normals): (&CanonicalMesh, Option<std::borrow::Cow<[Vec3]>>) = match &req
        .posable
    {
        Posable::Mesh(m) => (m, None),
        Posable::Smooth { mesh, normals } => (mesh, Some(std::borrow::Cow::Borrowed(&normals[..]))),
        Posable::PoseDependent { avatar, reference, rest_normals } => {
            // The exporter's recipe and Newton steps, so the studio shows what the export holds.
            let surface = PoseSurface::project(
                avatar.source(),
                &req.params,
                &reference.mesh.positions,
                &reference.weights,
                reference.smoother.as_deref(),
                PROJECTION_STEPS,
            )?;
            let n = match rest_normals {
                // A smoothed surface's own normals: the SDF's gradient would show the noise the
                // smoothing took off.
                _ if reference.smoother.is_some() => std::borrow::Cow::Owned(
                    avatar_core::mesh::vertex_normals(&surface.points, &reference.mesh.faces),
                ),
                Some(n) => std::borrow::Cow::Borrowed(&n[..]),
                None => {
                    let fallback =
                        avatar_core::mesh::vertex_normals(&surface.points, &reference.mesh.faces);
                    std::borrow::Cow::Owned(sdf_normals(
                        avatar.source(),
                        &req.params,
                        &surface.points,
                        &fallback,
                    )?)
                }
            };
            owned = CanonicalMesh {
                mesh: avatar_core::mesh::TriMesh::new(surface.points, reference.mesh.faces.clone()),
                weights: surface.weights,
                smoother: None,
            };
            (&owned, Some(n))
        }
    };
    let skin = |(p, w): (&Vec3, &avatar_core::body::Weights)| -> (Vec3, Mat4) {
        let m = blend_transform(&bones.transforms, w);
        (m.transform_point3(*p), m)
    };
    let (positions, normals) = match normals {
        None => (
            canonical
                .mesh
                .positions
                .par_iter()
                .zip(&canonical.weights)
                .map(|x| skin(x).0)
                .collect(),
            None,
        ),
        Some(n) => {
            let (p, n): (Vec<Vec3>, Vec<Vec3>) = canonical
                .mesh
                .positions
                .par_iter()
                .zip(&canonical.weights)
                .zip(&n[..])
                .map(|(x, n)| {
                    let (p, m) = skin(x);
                    (p, m.transform_vector3(*n).normalize_or(*n))
                })
                .unzip();
            (p, Some(n))
        }
    };
    Ok(PosedMesh {
        id: req.id,
        positions,
        normals,
        faces: Arc::new(canonical.mesh.faces.clone()),
        joints: posed_body.posed_joints(),
        seconds: t.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::studio::avatar::body_canonical;

    #[test]
    fn queued_requests_are_skipped_and_every_finished_pose_is_shown() {
        let body = Arc::new(avatar_core::body::open_body_ref().clone());
        let posable = Posable::Mesh(Arc::new(body_canonical(&body, &[])));
        let mut worker = PoseWorker::start(|| {});
        let n = 40;
        let mut ids = Vec::new();
        for k in 0..n {
            let mut p = BodyParams::default();
            p.pose[16] = Vec3::new(0.0, 0.0, -1.2 * k as f32 / n as f32);
            ids.push(worker.request(p, posable.clone(), body.clone()));
        }
        let t = std::time::Instant::now();
        let mut shown = Vec::new();
        while worker.busy() {
            if let Some(r) = worker.poll() {
                shown.push(r.unwrap().id);
            }
            assert!(t.elapsed().as_secs() < 60);
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        // The first request was running; the 38 in between were replaced while queued; the
        // newest ran last, and both results were handed over (none dropped).
        assert_eq!(shown, vec![ids[0], *ids.last().unwrap()]);
        assert_eq!(worker.latest, *ids.last().unwrap());
    }

    #[test]
    fn smooth_normals_turn_with_the_bones() {
        let body = Arc::new(avatar_core::body::open_body_ref().clone());
        let rest = body_canonical(&body, &[]);
        let normals = Arc::new(rest.mesh.vertex_normals());
        let posable = Posable::Smooth { mesh: Arc::new(rest), normals };
        let mut p = BodyParams::default();
        p.pose[0] = Vec3::new(0.0, std::f32::consts::FRAC_PI_2, 0.0); // the whole body turns 90 degrees
        let posed = pose(&PoseRequest { id: 1, params: p, posable, body: body.clone() }).unwrap();
        let flat = avatar_core::mesh::vertex_normals(&posed.positions, &posed.faces);
        let n = posed.normals.unwrap();
        let agree = n.iter().zip(&flat).filter(|(a, b)| a.dot(**b) > 0.99).count();
        assert!(
            agree as f32 > 0.95 * n.len() as f32,
            "{agree} of {} normals follow the turned mesh",
            n.len()
        );
    }
}
