//! The personal avatar: the hypernetwork fine-tuned on a capture's canonical depth points, from
//! the meta-learned model (MetaAvatar) or from scratch (the baseline). Novel poses go pose ->
//! bone encoding -> hypernetwork -> SIREN -> the body's mesh wrapped onto its surface (with the
//! loose pieces of the coarse-to-fine marching cubes beside it where the clothing is loose:
//! `canonical::body_wrap`) -> forward skinning (the body's own weights on
//! the wrapped body).

mod source;

use crate::avatar::body::{self as avatar_body, BodySection};
use crate::avatar::header::{
    AVATAR_FORMAT, PartialFit, avatar_field, check_avatar_header, check_subject,
};
use crate::avatar::refined_poses::{self, RefinedPose};
use crate::avatar::resolution::MeshResolution;
use crate::data::capture_points::CapturePoints;
use crate::error::{Error, Result};
use crate::model::flat_params::{flatten, load_flat};
use crate::model::hyper::{HyperConfig, HyperNet};
use crate::model::model_file::MetaModel;
use crate::model::siren_eval::{MetricSdf, SirenEval};
use crate::model::weights_file;
use crate::training::pose_refine::PoseRefiner;
use avatar_core::avatar::PoseTemplate;
use avatar_core::body::{BodyModel, BodyParams, NUM_JOINTS, Weights};
use avatar_core::canonical::{
    BodyWrap, FieldCache, GarmentSkinner, GarmentSkinning, Normalisation, SkinningField,
    SurfaceChoice, field_weights, forward_skin_with_weights,
};
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::extract::extract;
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::{Arc, OnceLock};

pub const META_AVATAR_KIND: &str = "meta-hyper";

/// Where fine-tuning starts.
pub enum Init<'a> {
    /// The meta-learned hypernetwork (MetaAvatar).
    MetaLearned(&'a MetaModel),
    /// The same networks at their random initialisation (the from-scratch baseline).
    Scratch { config: HyperConfig, seed: u64 },
}

impl Init<'_> {
    pub fn label(&self) -> &'static str {
        match self {
            Init::MetaLearned(_) => "meta-learned",
            Init::Scratch { .. } => "from scratch",
        }
    }

    pub(crate) fn config(&self) -> HyperConfig {
        match self {
            Init::MetaLearned(m) => m.header.config,
            Init::Scratch { config, .. } => *config,
        }
    }

    pub(crate) fn network(&self) -> HyperNet {
        match self {
            Init::MetaLearned(m) => m.hyper_net(),
            Init::Scratch { config, seed } => {
                let device = crate::cpu_training_device();
                config.init(config.siren.init(*seed, &device), *seed, &device)
            }
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetaAvatarHeader {
    pub format: String,
    pub version: u32,
    pub kind: String,
    pub config: HyperConfig,
    pub normalisation: Normalisation,
    pub betas: Vec<f32>,
    /// "open_body" or "smpl" (then `body` describes the stored body: avatar_body.rs).
    pub body_model: String,
    pub field_cells: usize,
    /// "meta-learned" or "from scratch", frames and steps of the fine-tuning.
    pub init: String,
    pub frames: usize,
    /// Steps that ran (fewer than asked for in a partial avatar).
    pub steps: usize,
    /// Present when the fit was cancelled before its last step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub partial: Option<PartialFit>,
    /// The frozen body stored after the weights (version 2 files; absent for the open body).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<BodySection>,
    /// Each training frame's given and refined fitting (absent without pose refinement).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refined_poses: Option<Vec<RefinedPose>>,
    /// The capture's frames the avatar was fitted on (manifest indices, in the take's order;
    /// absent in older avatar files, whose fits took the capture's first usable frames).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_indices: Option<Vec<usize>>,
    /// The meta-model the fit started from (absent from scratch and in older avatars).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior: Option<crate::model::model_file::PriorRef>,
}

/// The bone encoder's Adam rate when fine-tuning from scratch (the reference's).
pub const SCRATCH_ENCODER_RATE: f64 = 1e-4;

pub struct MetaAvatar {
    pub header: MetaAvatarHeader,
    pub model: HyperNet,
    body: BodyModel,
    field: SkinningField,
    /// Posing: the field, inpainted along loose clothing.
    skinner: GarmentSkinner,
    rest_joints: [Vec3; NUM_JOINTS],
    device: Device,
    /// What posing and export mesh it at (`AvatarSource::canonical_mesh`), and the surface kind
    /// is decided at (`surface_kind`).
    resolution: MeshResolution,
    /// Which mesh stands for the surface (`canonical::body_wrap`): `Auto` decides once, at the
    /// rest pose.
    pub surface: SurfaceChoice,
    wrap: Arc<BodyWrap>,
    decided: OnceLock<SurfaceChoice>,
    /// The rest surface and its weights, which a surface with loose cloth moves to each pose
    /// (`posed_mesh`); made at the first pose.
    template: OnceLock<PoseTemplate>,
}

impl MetaAvatar {
    /// The body wrap of a capture's subject (what [`MetaAvatar::from_fitted`] takes): the
    /// same for every avatar fitted from it.
    pub(crate) fn body_wrap_of(capture: &CapturePoints) -> Arc<BodyWrap> {
        let (body, ..) = avatar_body::of_capture(capture);
        Arc::new(BodyWrap::new(&body, &capture.betas))
    }

    /// The avatar of a fitted hypernetwork (inference copy of its weights) after `done` of
    /// `requested` steps; `wrap`: [`MetaAvatar::body_wrap_of`] the capture.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn from_fitted(
        capture: &CapturePoints,
        init: &Init,
        done: usize,
        requested: usize,
        model: &HyperNet,
        refiner: Option<&PoseRefiner>,
        wrap: Arc<BodyWrap>,
    ) -> MetaAvatar {
        let refined_poses = refiner.map(|r| {
            capture
                .frames
                .iter()
                .zip(r.refined())
                .map(|(f, refined)| RefinedPose { given: f.params.clone(), refined })
                .collect()
        });
        let (body, body_model, version, section) = avatar_body::of_capture(capture);
        let header = MetaAvatarHeader {
            format: AVATAR_FORMAT.into(),
            version,
            kind: META_AVATAR_KIND.into(),
            config: init.config(),
            normalisation: capture.normalisation,
            betas: capture.betas.clone(),
            body_model: body_model.into(),
            field_cells: capture.field_cells,
            init: init.label().into(),
            frames: capture.frames.len(),
            steps: done,
            partial: PartialFit::of(done, requested),
            body: section,
            refined_poses,
            frame_indices: Some(capture.frames.iter().map(|f| f.index).collect()),
            prior: match init {
                Init::MetaLearned(m) => m.prior(),
                Init::Scratch { .. } => None,
            },
        };
        MetaAvatar {
            header,
            model: model.valid().to_device(&crate::cpu_device()),
            skinner: GarmentSkinner::with_body(capture.rest_sdf.clone()),
            body,
            field: capture.field.clone(),
            rest_joints: capture.rest_joints(),
            device: crate::cpu_device(),
            resolution: MeshResolution::OUTPUT,
            surface: SurfaceChoice::default(),
            wrap,
            decided: OnceLock::new(),
            template: OnceLock::new(),
        }
    }

    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let mut values = flatten(&self.model);
        if let Some(section) = &self.header.body {
            values.extend(avatar_body::encode(&self.body, section));
        }
        weights_file::write(path.as_ref(), &self.header, &values)
    }

    /// Read an avatar file (its skinning field from `field_cache` when it is there).
    pub fn load(path: impl AsRef<Path>, field_cache: &FieldCache) -> Result<MetaAvatar> {
        let path = path.as_ref();
        check_avatar_header(path, META_AVATAR_KIND)?;
        let (header, values): (MetaAvatarHeader, Vec<f32>) =
            weights_file::read_expecting(path, |h: &MetaAvatarHeader| {
                h.config.check()?;
                check_subject(&h.normalisation, &h.betas, &h.body_model, h.field_cells, h.partial)?;
                avatar_body::check_version(h.version, h.body.as_ref())?;
                if let Some(p) = h.partial
                    && p.steps_done != h.steps
                {
                    return Err(Error::invalid(format!(
                        "\"steps\" {} and \"partial\" ({p}) disagree",
                        h.steps
                    )));
                }
                if let Some(poses) = &h.refined_poses {
                    refined_poses::check(poses, h.frames)?;
                }
                if let Some(prior) = &h.prior {
                    prior.check()?;
                }
                if let Some(list) = &h.frame_indices
                    && (list.len() != h.frames || list.windows(2).any(|w| w[0] >= w[1]))
                {
                    return Err(Error::invalid(format!(
                        "\"frame_indices\" holds {} frames, not {} ascending ones",
                        list.len(),
                        h.frames
                    )));
                }
                Ok(h.config.num_params() + h.body.as_ref().map_or(0, BodySection::len))
            })?;
        let (weights, body) = avatar_body::split(
            path,
            &header.body_model,
            header.body.as_ref(),
            values,
            header.config.num_params(),
        )?;
        let device = crate::cpu_device();
        let blank = header.config.init(header.config.siren.init(0, &device), 0, &device);
        let model = load_flat(blank, &weights).map_err(|e| e.in_file(path))?;
        let field = avatar_field(&body, &header.betas, header.field_cells, field_cache)
            .map_err(|e| e.in_file(path))?;
        let rest_joints = body.regress_joints(&body.shaped_vertices(&header.betas));
        let skinner = GarmentSkinner::new(&body, &header.betas);
        let wrap = Arc::new(BodyWrap::new(&body, &header.betas));
        Ok(MetaAvatar {
            header,
            model,
            skinner,
            body,
            field,
            rest_joints,
            device,
            resolution: MeshResolution::OUTPUT,
            surface: SurfaceChoice::default(),
            wrap,
            decided: OnceLock::new(),
            template: OnceLock::new(),
        })
    }

    /// The SIREN layers of a pose, as burn tensors (the hypernetwork's prediction).
    pub fn siren_at(&self, params: &BodyParams) -> (Vec<Tensor<2>>, Vec<Tensor<1>>) {
        let input = self.header.config.encoding.input(
            params,
            &self.rest_joints,
            &self.header.normalisation,
        );
        self.model.siren_for(&input, &self.device)
    }

    /// The SDF of a pose, predicted once and then evaluated as often as meshing or projection
    /// needs (fast CPU path: `siren_eval`).
    pub fn sdf_at(&self, params: &BodyParams) -> MetricSdf {
        let (w, b) = self.siren_at(params);
        MetricSdf {
            siren: SirenEval::from_tensors(&w, &b),
            normalisation: self.header.normalisation,
        }
    }

    /// [`MetaAvatar::sdf_at`] through burn's forward (the path before `siren_eval`, kept as its
    /// reference: the bench compares the two).
    pub fn burn_sdf_at(&self, params: &BodyParams) -> impl Fn(&[Vec3]) -> Vec<f32> + Sync + use<> {
        use rayon::prelude::*;
        let (w, b) = self.siren_at(params);
        let (n, device) = (self.header.normalisation, self.device.clone());
        move |points: &[Vec3]| -> Vec<f32> {
            points
                .par_chunks(
                    points.len().div_ceil(rayon::current_num_threads().max(1)).clamp(1024, 16_384),
                )
                .flat_map_iter(|chunk| {
                    let flat: Vec<f32> =
                        chunk.iter().flat_map(|p| n.to_unit(*p).to_array()).collect();
                    let f = crate::model::siren::sdf_only(
                        &w,
                        &b,
                        Tensor::from_data(
                            burn::tensor::TensorData::new(flat, [chunk.len(), 3]),
                            &device,
                        ),
                    );
                    f.into_data()
                        .as_slice::<f32>()
                        .expect("f32 tensor")
                        .iter()
                        .map(|v| v * n.metres_per_unit())
                        .collect::<Vec<f32>>()
                })
                .collect()
        }
    }

    /// The clothed surface at a pose in canonical space (metres): the body's mesh wrapped onto
    /// the pose's surface, with the extracted mesh's loose pieces where the clothing has some,
    /// or the extracted mesh (`surface_kind`).
    pub fn canonical_mesh_at(
        &self,
        params: &BodyParams,
        resolution: MeshResolution,
    ) -> Result<TriMesh> {
        let sdf = self.sdf_at(params);
        match self.surface_kind() {
            SurfaceChoice::WrappedBody => Ok(self.wrapped_surface(&sdf, self.wrap.options.outside)),
            SurfaceChoice::WrappedWithLoose => {
                // Extracted at the zero level: extracting the level 0.7 cells out and projecting it back
                // kept one dress whole at rest but on the quick preset cost every loose outfit
                // (all Chamfer-L2 0.920 -> 1.186 cm, simulated skirt spurious 11 -> 46 %).
                let extracted = self.extracted_surface(&sdf, resolution.loose())?;
                Ok(self.wrap.with_loose_pieces(
                    &self.wrapped_surface(&sdf, self.wrap.options.tight_outside),
                    &extracted,
                    |p| sdf.sdf(p),
                ))
            }
            _ => self.extracted_surface(&sdf, resolution.cells()),
        }
    }

    fn extracted_surface(&self, sdf: &MetricSdf, resolution: usize) -> Result<TriMesh> {
        Ok(self.skinner.finish_surface(
            extract(
                |p: &[Vec3]| sdf.sdf(p),
                &super::header::extract_options(&self.header.normalisation, resolution),
            )?
            .mesh,
        ))
    }

    fn wrapped_surface(&self, sdf: &MetricSdf, outside: f32) -> TriMesh {
        let mut mesh = self.wrap.wrap_within(|p| sdf.sdf(p), outside).mesh;
        self.skinner.smooth_surface(&mut mesh);
        // Last: smoothing pulls neighbours together, which can push a crease's cloth through
        // its neighbours (`WrapOptions::span_crossings`).
        self.wrap.span_crossings(&mut mesh);
        mesh
    }

    /// Which mesh stands for the surface: `surface`, or under `Auto` the wrapped body alone
    /// where it covers the rest pose's extracted surface (tight clothing), else the wrapped body
    /// with the loose pieces. Decided once per avatar, so every pose and every exported frame
    /// is made the same way.
    pub fn surface_kind(&self) -> SurfaceChoice {
        if self.surface != SurfaceChoice::Auto {
            return self.surface;
        }
        // Decided under the lock: poses meshed in parallel wait for one decision. An error here
        // leaves the extracted mesh, whose own extraction then reports it.
        *self.decided.get_or_init(|| self.rest_surface_kind().unwrap_or(SurfaceChoice::Extracted))
    }

    fn rest_surface_kind(&self) -> Result<SurfaceChoice> {
        let sdf = self.sdf_at(&self.rest_params());
        // Two independent meshes of the same SDF: made side by side.
        let (extracted, wrapped) = rayon::join(
            || self.extracted_surface(&sdf, self.resolution.cells()),
            || self.wrapped_surface(&sdf, self.wrap.options.outside),
        );
        Ok(if self.wrap.covers(&wrapped, &extracted?) {
            SurfaceChoice::WrappedBody
        } else {
            SurfaceChoice::WrappedWithLoose
        })
    }

    /// The resolution posing and export mesh it at ([`MeshResolution::OUTPUT`] unless set).
    pub fn mesh_resolution(&self) -> MeshResolution {
        self.resolution
    }

    /// Mesh it at `resolution` from now on (before the first mesh: the surface kind is decided
    /// at the resolution of the first).
    pub fn set_mesh_resolution(&mut self, resolution: MeshResolution) {
        self.template = OnceLock::new();
        self.resolution = resolution;
    }

    /// How the surface is wrapped and its loose cloth remade, to change before the avatar is
    /// shared (`None` once it is; examples measure variants with it).
    pub fn wrap_mut(&mut self) -> Option<&mut BodyWrap> {
        self.template = OnceLock::new();
        Arc::get_mut(&mut self.wrap)
    }

    /// How loose cloth is skinned (examples measure variants with it).
    pub fn garment_skinning_mut(&mut self) -> &mut GarmentSkinning {
        self.template = OnceLock::new();
        &mut self.skinner.options
    }

    /// The zero pose with the avatar's shape: where the surface kind is decided and where the
    /// studio and the exporter take their reference mesh.
    pub fn rest_params(&self) -> BodyParams {
        BodyParams { betas: self.header.betas.clone(), ..BodyParams::default() }
    }

    /// The clothed mesh at a pose in the world, as the exporter and the studio pose it. A
    /// surface with loose cloth is its rest surface moved to the pose and skinned
    /// (`PoseTemplate`, FITE's explicit template): the garment sheet, whole at rest, is whole
    /// at every pose, its waist and hem the same loops (each pose's own sheet drew its top
    /// border down a raised thigh). Any other surface is the pose's own canonical surface,
    /// skinned (a wrapped body is whole at every pose either way). docs/integrity.md.
    pub fn posed_mesh(&self, params: &BodyParams) -> Result<TriMesh> {
        if self.surface_kind() == SurfaceChoice::WrappedWithLoose {
            let template = match self.template.get() {
                Some(t) => t,
                None => {
                    let made = PoseTemplate::new(self)?;
                    self.template.get_or_init(|| made)
                }
            };
            return Ok(template.posed_mesh(self, params)?);
        }
        self.posed_mesh_of_surface_at(params, params)
    }

    /// Diagnostic: the canonical surface the SDF gives at `surface_pose`, skinned to `params`.
    /// With the rest pose ([`MetaAvatar::rest_params`]) it measures what the pose-conditioned
    /// SDF adds (`examples/posed_errors`).
    pub fn posed_mesh_of_surface_at(
        &self,
        params: &BodyParams,
        surface_pose: &BodyParams,
    ) -> Result<TriMesh> {
        let canonical = self.canonical_mesh_at(surface_pose, self.resolution)?;
        let mut p = params.clone();
        p.betas = self.header.betas.clone();
        let bones = self.body.pose(&p).bones;
        Ok(forward_skin_with_weights(&bones, &canonical, &self.mesh_weights(&canonical)))
    }

    /// The skinning weights of a canonical mesh of this avatar: a wrapped body's vertices (and
    /// the seams of its loose pieces) with the body's own weights, the rest the field's, then
    /// inpainted along loose clothing (`GarmentSkinner`).
    fn mesh_weights(&self, mesh: &TriMesh) -> Vec<Weights> {
        match self.surface_kind() {
            SurfaceChoice::WrappedBody | SurfaceChoice::WrappedWithLoose => {
                let own = self.wrap.own_weights(
                    &self.body.weights,
                    mesh,
                    field_weights(&self.field, mesh),
                );
                self.skinner.weights_from(own, mesh)
            }
            _ => self.skinner.weights(&self.field, mesh),
        }
    }

    pub fn num_params(&self) -> usize {
        self.model.num_params()
    }
}
