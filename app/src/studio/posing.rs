//! The pose worker: the UI sends pose requests, a thread skins the canonical mesh and sends
//! the posed mesh back. Only the newest request is computed: older ones still queued are
//! dropped, and results of stale requests are ignored by the UI.

use crate::studio::avatar_job::{CanonicalMesh, StudioAvatar};
use avatar_core::body::{blend_transform, BodyModel, BodyParams, NUM_JOINTS};
use crossbeam_channel::{Receiver, Sender};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::Arc;

/// What is posed: a canonical mesh with weights, or an avatar whose surface depends on the
/// pose. For the latter the reference mesh's vertices are projected onto the pose's canonical
/// surface (Newton steps on its SDF) and skinned: the exporter's recipe, so the viewport shows
/// what the glTF will hold, without marching cubes at every pose.
#[derive(Clone)]
pub enum Posable {
    Mesh(Arc<CanonicalMesh>),
    PoseDependent { avatar: Arc<dyn StudioAvatar>, reference: Arc<CanonicalMesh> },
}


pub struct PoseRequest {
    pub id: u64,
    pub params: BodyParams,
    pub posable: Posable,
    pub body: Arc<BodyModel>,
}

pub struct PosedMesh {
    pub id: u64,
    pub positions: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
    pub joints: [Vec3; NUM_JOINTS],
    pub seconds: f64,
}

/// A pose that could not be computed.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseError {
    pub id: u64,
    pub message: String,
}

impl std::fmt::Display for PoseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

pub struct PoseWorker {
    requests: Sender<PoseRequest>,
    pub results: Receiver<Result<PosedMesh, PoseError>>,
    next_id: u64,
    /// The id of the newest request sent.
    pub latest: u64,
}

impl PoseWorker {
    pub fn start(wake: impl Fn() + Send + 'static) -> PoseWorker {
        let (req_tx, req_rx) = crossbeam_channel::unbounded::<PoseRequest>();
        let (res_tx, res_rx) = crossbeam_channel::unbounded();
        std::thread::Builder::new()
            .name("pose worker".into())
            .spawn(move || {
                while let Ok(mut req) = req_rx.recv() {
                    // Newest wins: skip everything but the last queued request.
                    while let Ok(newer) = req_rx.try_recv() {
                        req = newer;
                    }
                    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| pose(&req)))
                        .unwrap_or_else(|_| Err("posing failed".into()))
                        .map_err(|message| PoseError { id: req.id, message });
                    if res_tx.send(out).is_err() {
                        break;
                    }
                    wake();
                }
            })
            .expect("spawning the pose worker");
        PoseWorker { requests: req_tx, results: res_rx, next_id: 1, latest: 0 }
    }

    /// Ask for a pose; returns its id.
    pub fn request(&mut self, params: BodyParams, posable: Posable, body: Arc<BodyModel>) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        self.latest = id;
        let _ = self.requests.send(PoseRequest { id, params, posable, body });
        id
    }

    /// The newest finished result, if it answers the newest request (stale ones are dropped).
    pub fn poll(&mut self) -> Option<Result<PosedMesh, PoseError>> {
        let mut newest = None;
        while let Ok(r) = self.results.try_recv() {
            newest = Some(r);
        }
        match newest {
            Some(Ok(m)) if m.id != self.latest => None,
            Some(Err(e)) if e.id != self.latest => None,
            other => other,
        }
    }

    pub fn pending(&self) -> bool {
        !self.requests.is_empty()
    }
}

/// Linear blend skinning of the canonical mesh by the pose (the exporter's skinning).
pub fn pose(req: &PoseRequest) -> Result<PosedMesh, String> {
    let t = std::time::Instant::now();
    let posed_body = req.body.pose(&req.params);
    let bones = &posed_body.bones;
    let owned;
    let canonical: &CanonicalMesh = match &req.posable {
        Posable::Mesh(m) => m,
        Posable::PoseDependent { avatar, reference } => {
            // The exporter's Newton steps, so the studio shows what the export holds.
            let steps = avatar_core::export::ExportOptions::default().newton_steps;
            let projected = avatar.source().project(&req.params, &reference.mesh.positions, steps).map_err(|e| e.to_string())?;
            let weights = avatar.source().skinning_weights(&projected);
            owned = CanonicalMesh { mesh: avatar_core::mesh::TriMesh::new(projected, reference.mesh.faces.clone()), weights };
            &owned
        }
    };
    let positions: Vec<Vec3> = canonical
        .mesh
        .positions
        .par_iter()
        .zip(&canonical.weights)
        .map(|(p, w)| blend_transform(&bones.transforms, w).transform_point3(*p))
        .collect();
    Ok(PosedMesh { id: req.id, positions, faces: canonical.mesh.faces.clone(), joints: posed_body.posed_joints(), seconds: t.elapsed().as_secs_f64() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::studio::avatar_job::body_canonical;

    #[test]
    fn the_newest_pose_wins_and_stale_requests_are_dropped() {
        let body = Arc::new(avatar_core::body::open_body_ref().clone());
        let posable = Posable::Mesh(Arc::new(body_canonical(&body, &[])));
        let mut worker = PoseWorker::start(|| {});
        let n = 40;
        for k in 0..n {
            let mut p = BodyParams::default();
            p.pose[16] = Vec3::new(0.0, 0.0, -1.2 * k as f32 / n as f32);
            worker.request(p, posable.clone(), body.clone());
        }
        let t = std::time::Instant::now();
        let mut computed = 0;
        let last = loop {
            // Count every result the worker sends (poll() would hide stale ones).
            match worker.results.recv_timeout(std::time::Duration::from_secs(30)) {
                Ok(Ok(m)) => {
                    computed += 1;
                    if m.id == worker.latest {
                        break m;
                    }
                }
                other => panic!("{:?}", other.err()),
            }
            assert!(t.elapsed().as_secs() < 60);
        };
        assert_eq!(last.id, worker.latest);
        assert!(computed < n, "queued requests were skipped ({computed} of {n} computed)");
        // A stale result is never handed to the UI.
        let mut p = BodyParams::default();
        p.pose[17] = Vec3::new(0.0, 0.0, 1.0);
        let stale = worker.request(p.clone(), posable.clone(), body.clone());
        let newest = worker.request(p, posable, body);
        assert!(newest > stale);
        let t = std::time::Instant::now();
        loop {
            if let Some(r) = worker.poll() {
                assert_eq!(r.unwrap().id, newest);
                break;
            }
            assert!(t.elapsed().as_secs() < 60);
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }
}
