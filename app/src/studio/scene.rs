//! From the studio's state to the viewport's scene: which mesh is shown (the one rule for
//! preview, avatar or body), what the poser skins, and the scene of each view mode.

use crate::studio::avatar::CanonicalMesh;
use crate::studio::posing::Posable;
use crate::studio::project::ViewMode;
use crate::studio::state::StudioApp;
use crate::studio::viewport::Scene;
use avatar_core::body::SMPL_PARENTS;
use glam::Vec3;
use std::sync::Arc;

/// Which mesh the studio shows and poses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shown {
    /// The running fit's partial result (or one kept while the avatar is meshed).
    Preview,
    /// The fitted or opened avatar.
    Avatar,
    /// The capture's body, until an avatar exists.
    Body,
}

const BODY_COLOR: [f32; 3] = [0.72, 0.62, 0.55];
const PREVIEW_COLOR: [f32; 3] = [0.80, 0.62, 0.40];
const SKELETON_COLOR: [f32; 3] = [1.0, 0.62, 0.18];
/// The floor grid's spacing (m).
const GRID_STEP: f32 = 0.25;

impl StudioApp {
    /// The rule: the partial result while a fit runs (or until the avatar's mesh is ready),
    /// else the avatar, else the body.
    pub fn shown(&self) -> Option<(Shown, Arc<CanonicalMesh>)> {
        match (&self.preview, &self.avatar_canonical) {
            (Some(p), a) if self.job.is_some() || a.is_none() => Some((Shown::Preview, p.clone())),
            (_, Some(a)) => Some((Shown::Avatar, a.clone())),
            _ => self.body_rest.clone().map(|b| (Shown::Body, b)),
        }
    }

    fn color(&self, shown: Shown) -> [f32; 3] {
        match shown {
            Shown::Preview => PREVIEW_COLOR,
            Shown::Avatar => self.view.material,
            Shown::Body => BODY_COLOR,
        }
    }

    /// What the poser skins now.
    pub(crate) fn posable(&self) -> Option<Posable> {
        let (shown, mesh) = self.shown()?;
        Some(match (shown, &self.avatar, &self.avatar_normals) {
            (Shown::Avatar, Some(a), n) if a.pose_dependent() => Posable::PoseDependent {
                avatar: a.clone(),
                reference: mesh,
                rest_normals: n.clone(),
            },
            (Shown::Avatar, _, Some(n)) => Posable::Smooth { mesh, normals: n.clone() },
            _ => Posable::Mesh(mesh),
        })
    }

    /// The viewport's scene for the current view mode.
    pub fn build_scene(&self) -> Scene {
        let mut s = Scene::new();
        let body = self.body();
        match self.view.mode {
            ViewMode::Capture => {
                let i = self.view.selected_frame;
                if let Some(f) = self.capture.as_ref().and_then(|c| c.frames.get(i))
                    && self.frame_store.problem(i).is_none()
                {
                    if let Some(p) = self.frame_store.held_points(i) {
                        s.add_lit_points(&p.points, &p.normals, [0.35, 0.85, 0.95], 1.0);
                    }
                    if let Some(params) = &f.params {
                        // The fitting the avatar refined this frame to, when it did.
                        let params = self.refined_fitting(params).unwrap_or(params);
                        let posed = body.pose(params);
                        s.add_mesh(&posed.vertices, &body.faces, [0.42, 0.40, 0.40]);
                        if self.view.skeleton {
                            s.add_skeleton(&posed.posed_joints(), &SMPL_PARENTS, SKELETON_COLOR);
                        }
                    }
                }
            }
            ViewMode::Canonical => {
                if let Some((shown, m)) = self.shown() {
                    let normals = (shown == Shown::Avatar)
                        .then_some(self.avatar_normals.as_deref())
                        .flatten();
                    s.add_mesh_with_normals(
                        &m.mesh.positions,
                        normals.map(|n| &n[..]),
                        &m.mesh.faces,
                        self.color(shown),
                    );
                }
                if self.view.skeleton {
                    s.add_skeleton(&body.rest_joints(&self.betas()), &SMPL_PARENTS, SKELETON_COLOR);
                }
            }
            ViewMode::Posed => {
                if let Some(p) = &self.posed {
                    let color = self.shown().map_or(BODY_COLOR, |(shown, _)| self.color(shown));
                    s.add_mesh_with_normals(&p.positions, p.normals.as_deref(), &p.faces, color);
                    if self.view.skeleton {
                        s.add_skeleton(&p.joints, &SMPL_PARENTS, SKELETON_COLOR);
                    }
                }
            }
        }
        let (lo, hi) =
            s.bounds().unwrap_or((Vec3::new(-0.5, -1.0, -0.5), Vec3::new(0.5, 1.0, 0.5)));
        let mut center = (lo + hi) * 0.5;
        if self.following() {
            // Lines fixed on the floor: the body is seen to travel over them.
            center = (center / GRID_STEP).round() * GRID_STEP;
        }
        s.add_grid(Vec3::new(center.x, 0.0, center.z), lo.y - 0.01, 1.5, GRID_STEP);
        s
    }

    /// The camera follows the root now: the toggle is on and the posed body is shown.
    fn following(&self) -> bool {
        self.view.follow_root && self.view.mode == ViewMode::Posed && self.posed.is_some()
    }

    /// With the follow toggle on, the camera's target moves over the floor to the posed body's
    /// root (the pelvis), keeping its height, direction and distance: root motion cannot walk
    /// the body out of view.
    pub fn follow_root(&mut self) {
        if self.following()
            && let Some(p) = &self.posed
        {
            let root = p.joints[0];
            self.view.camera.target[0] = root.x;
            self.view.camera.target[2] = root.z;
        }
    }

    /// The open avatar's refined fitting of a capture frame given `params` (pose refinement).
    pub fn refined_fitting(
        &self,
        params: &avatar_core::body::BodyParams,
    ) -> Option<&avatar_core::body::BodyParams> {
        avatar_neural::avatar::refined_poses::refined_for(
            self.avatar.as_ref()?.refined_poses(),
            params,
        )
    }

    /// Frame the subject (F).
    pub fn frame_subject(&mut self) {
        if let Some((lo, hi)) = self.scene.bounds() {
            self.view.camera.frame(lo, hi);
        }
    }

    pub fn set_mode(&mut self, mode: ViewMode) {
        if self.view.mode != mode {
            self.view.mode = mode;
            self.scene_dirty = true;
        }
    }
}
