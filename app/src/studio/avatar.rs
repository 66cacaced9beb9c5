//! What the studio needs from an avatar ([`StudioAvatar`]: both kinds of
//! `avatar_neural::avatar` implement it), opening one, and the canonical meshes the poser skins.

use crate::error::Result;
use avatar_core::avatar::AvatarSource;
use avatar_core::body::{BodyModel, Weights};
use avatar_core::mesh::TriMesh;
use avatar_neural::avatar::MeshResolution;
use avatar_neural::{AnyAvatar, MetaAvatar, StaticAvatar};
use std::path::Path;
use std::sync::Arc;

/// What the studio needs from an avatar.
pub trait StudioAvatar: Send + Sync {
    /// A short name for the UI ("static SDF 4 x 128").
    fn describe(&self) -> String;
    /// The exporter's and poser's view of it.
    fn source(&self) -> &dyn AvatarSource;
    /// Whether the canonical surface changes with the pose (the meta avatar's clothing does):
    /// then the poser projects the reference mesh onto each pose's surface
    /// (`AvatarSource::project`) before skinning, as the exporter does.
    fn pose_dependent(&self) -> bool {
        false
    }
    /// Marching-cubes resolution used for the studio's meshes.
    fn set_resolution(&mut self, _cells: usize) {}
    fn save(&self, path: &Path) -> Result<()>;
    /// The training frames' given and refined fittings (pose refinement; empty without).
    fn refined_poses(&self) -> &[avatar_neural::avatar::refined_poses::RefinedPose] {
        &[]
    }
}

impl StudioAvatar for StaticAvatar {
    fn describe(&self) -> String {
        let partial = self.header.partial.map(|p| format!(" ({p})")).unwrap_or_default();
        format!("static SDF {} x {}{partial}", self.header.siren.layers, self.header.siren.hidden)
    }
    fn source(&self) -> &dyn AvatarSource {
        self
    }
    fn set_resolution(&mut self, cells: usize) {
        self.set_mesh_resolution(MeshResolution::clamped(cells));
    }
    fn save(&self, path: &Path) -> Result<()> {
        Ok(StaticAvatar::save(self, path)?)
    }
}

impl StudioAvatar for MetaAvatar {
    fn describe(&self) -> String {
        let partial = self.header.partial.map(|p| format!(", {p}")).unwrap_or_default();
        // The shipped prior is the default and goes unsaid; another one is named by its file.
        let prior = match &self.header.prior {
            Some(p) if p.name != avatar_neural::model::model_file::SHIPPED_PRIOR => {
                let name = Path::new(&p.name);
                let short = match (name.parent().and_then(Path::file_name), name.file_name()) {
                    (Some(dir), Some(file)) => Path::new(dir).join(file).display().to_string(),
                    _ => p.name.clone(),
                };
                format!(", prior {short}")
            }
            _ => String::new(),
        };
        format!("MetaAvatar ({}{prior}, {} frames{partial})", self.header.init, self.header.frames)
    }
    fn source(&self) -> &dyn AvatarSource {
        self
    }
    fn pose_dependent(&self) -> bool {
        true
    }
    fn set_resolution(&mut self, cells: usize) {
        self.set_mesh_resolution(MeshResolution::clamped(cells));
    }
    fn save(&self, path: &Path) -> Result<()> {
        Ok(MetaAvatar::save(self, path)?)
    }
    fn refined_poses(&self) -> &[avatar_neural::avatar::refined_poses::RefinedPose] {
        self.header.refined_poses.as_deref().unwrap_or(&[])
    }
}

/// Open an avatar file of any kind this build reads (`avatar-studio fit` writes both).
pub fn load_avatar(path: &Path, resolution: usize) -> Result<Arc<dyn StudioAvatar>> {
    Ok(studio_avatar(AnyAvatar::load(path, crate::cache::field_cache())?, resolution))
}

/// The studio's view of an avatar, meshed at `resolution` (clamped to 16 to 512).
pub fn studio_avatar(avatar: AnyAvatar, resolution: usize) -> Arc<dyn StudioAvatar> {
    match avatar {
        AnyAvatar::Static(mut a) => {
            StudioAvatar::set_resolution(&mut a, resolution);
            Arc::new(a)
        }
        AnyAvatar::Meta(mut a) => {
            StudioAvatar::set_resolution(&mut a, resolution);
            Arc::new(a)
        }
    }
}

/// A mesh in canonical space with skinning weights per vertex: what the poser needs.
pub struct CanonicalMesh {
    pub mesh: TriMesh,
    pub weights: Vec<Weights>,
    /// The avatar's smoothing of its surfaces, measured for this mesh: applied to the mesh's
    /// projections onto each pose's surface (`AvatarSource::surface_smoother`).
    pub smoother: Option<Arc<avatar_core::canonical::SurfaceSmoother>>,
}

/// The canonical mesh of an avatar (at the rest pose) with its skinning weights.
pub fn canonical_of(avatar: &dyn StudioAvatar, body_betas: &[f32]) -> Result<CanonicalMesh> {
    let params = avatar_core::body::BodyParams {
        betas: body_betas.to_vec(),
        ..avatar.source().reference_params()
    };
    let mesh = avatar.source().canonical_mesh(&params)?;
    let weights = avatar.source().mesh_skinning_weights(&mesh);
    let smoother = avatar.source().surface_smoother(&mesh).map(Arc::new);
    Ok(CanonicalMesh { mesh, weights, smoother })
}

/// The body model's own skinning of its rest mesh (the placeholder before an avatar exists).
pub fn body_canonical(body: &BodyModel, betas: &[f32]) -> CanonicalMesh {
    let rest = body
        .pose(&avatar_core::body::BodyParams { betas: betas.to_vec(), ..Default::default() })
        .rest_vertices;
    CanonicalMesh { mesh: body.mesh(rest), weights: body.weights.clone(), smoother: None }
}
