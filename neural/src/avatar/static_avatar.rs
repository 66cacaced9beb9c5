//! A static (pose-independent) SDF avatar fitted from scratch to a capture's canonicalized
//! depth points: the "static SDF" and "from scratch" baselines of the paper, and the first
//! avatar the studio can fit, pose and export. The meta-learned hypernetwork avatar
//! (`meta_avatar`) replaces the static SDF with a pose-conditioned one.

use crate::avatar::body::{self as avatar_body, BodySection};
use crate::avatar::header::{PartialFit, avatar_field, check_avatar_header, check_subject};
use crate::avatar::resolution::MeshResolution;
use crate::data::capture_points::CapturePoints;
use crate::error::Result;
use crate::model::flat_params::{flatten, load_flat};
use crate::model::siren::{Siren, SirenConfig};
use crate::model::siren_eval::MetricSdf;
use crate::model::weights_file;
use avatar_core::avatar::AvatarSource;
use avatar_core::body::{BodyModel, BodyParams, Weights};
use avatar_core::canonical::{FieldCache, GarmentSkinner, Normalisation, SkinningField};
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::extract::extract;
use burn::module::Module;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The header kind of a static-SDF avatar file.
pub const STATIC_AVATAR_KIND: &str = "static-sdf";

pub use crate::avatar::header::{AVATAR_FORMAT, AVATAR_VERSION};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AvatarHeader {
    pub format: String,
    pub version: u32,
    pub kind: String,
    pub siren: SirenConfig,
    pub normalisation: Normalisation,
    pub betas: Vec<f32>,
    /// "open_body" or "smpl" (then `body` describes the stored body: avatar_body.rs).
    pub body_model: String,
    pub field_cells: usize,
    /// Present when the fit was cancelled before its last step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub partial: Option<PartialFit>,
    /// The frozen body stored after the weights (version 2 files; absent for the open body).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<BodySection>,
    /// The meta-model whose static SDF the fit started from (absent from scratch and in older
    /// avatars).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior: Option<crate::model::model_file::PriorRef>,
}

pub struct StaticAvatar {
    pub header: AvatarHeader,
    /// The fitted weights (saved as they are).
    pub model: Siren,
    /// `model` prepared for evaluation once, with the normalisation: metres in and out.
    sdf: MetricSdf,
    body: BodyModel,
    field: SkinningField,
    /// Posing: the field, inpainted along loose clothing.
    skinner: GarmentSkinner,
    /// What posing and export mesh it at (`AvatarSource::canonical_mesh`).
    resolution: MeshResolution,
}

impl StaticAvatar {
    /// The resolution posing and export mesh it at ([`MeshResolution::OUTPUT`] unless set).
    pub fn mesh_resolution(&self) -> MeshResolution {
        self.resolution
    }

    /// Mesh it at `resolution` from now on.
    pub fn set_mesh_resolution(&mut self, resolution: MeshResolution) {
        self.resolution = resolution;
    }

    /// The avatar of a SIREN fitted to a canonicalized capture (not marked partial).
    pub(crate) fn from_fitted(
        capture: &CapturePoints,
        siren: SirenConfig,
        model: &Siren,
    ) -> StaticAvatar {
        let (body, body_model, version, section) = avatar_body::of_capture(capture);
        let header = AvatarHeader {
            format: AVATAR_FORMAT.into(),
            version,
            kind: STATIC_AVATAR_KIND.into(),
            siren,
            normalisation: capture.normalisation,
            betas: capture.betas.clone(),
            body_model: body_model.into(),
            field_cells: capture.field_cells,
            body: section,
            partial: None,
            prior: None,
        };
        let model = model.valid().to_device(&crate::cpu_device());
        let sdf = MetricSdf::of(&model, header.normalisation);
        StaticAvatar {
            header,
            model,
            sdf,
            skinner: GarmentSkinner::with_body(capture.rest_sdf.clone()),
            body,
            field: capture.field.clone(),
            resolution: MeshResolution::OUTPUT,
        }
    }

    /// The skinning field of the avatar's body shape.
    pub fn field(&self) -> &SkinningField {
        &self.field
    }

    /// SDF in metres at canonical points (metres).
    pub fn sdf_metres(&self, points: &[Vec3]) -> Vec<f32> {
        self.sdf.sdf(points)
    }

    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let mut values = flatten(&self.model);
        if let Some(section) = &self.header.body {
            values.extend(avatar_body::encode(&self.body, section));
        }
        weights_file::write(path.as_ref(), &self.header, &values)
    }

    /// Read an avatar file (its skinning field from `field_cache` when it is there).
    pub fn load(path: impl AsRef<Path>, field_cache: &FieldCache) -> Result<StaticAvatar> {
        let path = path.as_ref();
        check_avatar_header(path, STATIC_AVATAR_KIND)?;
        let (header, values): (AvatarHeader, Vec<f32>) =
            weights_file::read_expecting(path, |h: &AvatarHeader| {
                h.siren.check()?;
                check_subject(&h.normalisation, &h.betas, &h.body_model, h.field_cells, h.partial)?;
                avatar_body::check_version(h.version, h.body.as_ref())?;
                if let Some(prior) = &h.prior {
                    prior.check()?;
                }
                Ok(h.siren.num_params() + h.body.as_ref().map_or(0, BodySection::len))
            })?;
        let (weights, body) = avatar_body::split(
            path,
            &header.body_model,
            header.body.as_ref(),
            values,
            header.siren.num_params(),
        )?;
        let device = crate::cpu_device();
        let model =
            load_flat(header.siren.init(0, &device), &weights).map_err(|e| e.in_file(path))?;
        let field = avatar_field(&body, &header.betas, header.field_cells, field_cache)
            .map_err(|e| e.in_file(path))?;
        let sdf = MetricSdf::of(&model, header.normalisation);
        let skinner = GarmentSkinner::new(&body, &header.betas);
        Ok(StaticAvatar {
            header,
            model,
            sdf,
            skinner,
            body,
            field,
            resolution: MeshResolution::OUTPUT,
        })
    }
}

impl AvatarSource for StaticAvatar {
    fn body(&self) -> &BodyModel {
        &self.body
    }
    fn betas(&self) -> &[f32] {
        &self.header.betas
    }
    /// Pose-independent: the same canonical surface for every pose (coarse-to-fine marching
    /// cubes over the normalised cube, largest component).
    fn canonical_mesh(&self, _params: &BodyParams) -> avatar_core::Result<TriMesh> {
        Ok(self.skinner.finish_surface(
            extract(
                |p: &[Vec3]| self.sdf_metres(p),
                &super::header::extract_options(
                    &self.header.normalisation,
                    self.resolution.cells(),
                ),
            )?
            .mesh,
        ))
    }
    fn sdf(&self, _params: &BodyParams, points: &[Vec3]) -> avatar_core::Result<Vec<f32>> {
        Ok(self.sdf_metres(points))
    }
    fn skinning_weights(&self, points: &[Vec3]) -> Vec<Weights> {
        points.iter().map(|&p| self.field.weights_at(p)).collect()
    }
    fn mesh_skinning_weights(&self, mesh: &TriMesh) -> Vec<Weights> {
        self.skinner.weights(&self.field, mesh)
    }
    /// The surface does not change with the pose: reference vertices already lie on it. (So no
    /// `surface_smoother` either: the reference is `canonical_mesh`, already smoothed, and
    /// smoothing its unmoved vertices at every pose would smooth them twice.)
    fn project(
        &self,
        _params: &BodyParams,
        points: &[Vec3],
        _steps: usize,
    ) -> avatar_core::Result<Vec<Vec3>> {
        Ok(points.to_vec())
    }
}
