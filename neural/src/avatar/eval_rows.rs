//! The neural rows of the evaluation table (`avatar_core::eval::Predictor`): the meta-learned
//! avatar, the from-scratch baseline (same networks and fine-tuning steps, random
//! initialisation) and the static meta-SDF (Alg. 1's pose-independent SDF fine-tuned).

use crate::avatar::{
    AnyAvatar, AvatarFit, FitKind, Init, MeshResolution, MetaAvatar, StaticAvatar, fit_avatar,
};
use crate::data::capture_points::CapturePoints;
use crate::model::model_file::MetaModel;
use crate::training::hyper_fit::HyperFitOptions;
use avatar_core::avatar::AvatarSource;
use avatar_core::body::BodyParams;
use avatar_core::canonical::forward_skin_with_weights;
use avatar_core::error::{Error, Result};
use avatar_core::eval::{FitData, Predictor};
use avatar_core::mesh::TriMesh;
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowKind {
    MetaLearned,
    FromScratch,
    StaticMetaSdf,
}

// One per evaluation row, made once per fit: boxing the larger kind buys nothing.
#[allow(clippy::large_enum_variant)]
enum Fitted {
    Hyper(MetaAvatar),
    /// The static avatar with its (pose-independent) canonical mesh extracted once, and that
    /// mesh's skinning weights.
    Static(StaticAvatar, TriMesh, Vec<avatar_core::body::Weights>),
}

pub struct NeuralRow {
    kind: RowKind,
    model: Arc<MetaModel>,
    options: HyperFitOptions,
    /// Frames of the capture to fine-tune on (all of the protocol's frames when larger).
    max_frames: usize,
    resolution: MeshResolution,
    /// Diagnostic: save each fitted MetaAvatar as `DIR/<capture>.avatar`.
    save_avatars: Option<std::path::PathBuf>,
    fitted: Option<Fitted>,
}

impl NeuralRow {
    /// `options.steps` is the same for every row, so each gets the same fine-tuning budget.
    pub fn new(
        kind: RowKind,
        model: Arc<MetaModel>,
        options: HyperFitOptions,
        max_frames: usize,
        resolution: MeshResolution,
    ) -> Self {
        NeuralRow { kind, model, options, max_frames, resolution, save_avatars: None, fitted: None }
    }

    /// Diagnostic: save each fitted MetaAvatar as `DIR/<capture>.avatar` (`eval --save-avatars`).
    pub fn saving_avatars(self, dir: Option<std::path::PathBuf>) -> Self {
        NeuralRow { save_avatars: dir, ..self }
    }
}

impl Predictor for NeuralRow {
    fn name(&self) -> String {
        match self.kind {
            RowKind::MetaLearned => "MetaAvatar (meta-learned)".into(),
            RowKind::FromScratch => "hypernetwork from scratch".into(),
            RowKind::StaticMetaSdf => "static meta-SDF".into(),
        }
    }

    fn fit(&mut self, data: &FitData) -> Result<()> {
        let capture = CapturePoints::open(data.capture_dir, self.max_frames, data.field_cache)?;
        let kind = match self.kind {
            RowKind::MetaLearned => FitKind::Meta(Init::MetaLearned(&self.model)),
            RowKind::FromScratch => FitKind::Meta(Init::Scratch {
                config: self.model.header.config,
                seed: self.options.seed,
            }),
            RowKind::StaticMetaSdf => {
                FitKind::Static { siren: self.model.header.config.siren, init: Some(&self.model) }
            }
        };
        let fit =
            AvatarFit { kind, options: self.options.clone(), chunk: 0, cancel: None, trace: None };
        self.fitted = Some(match fit_avatar(&capture, &fit, &mut |_| {})?.0 {
            AnyAvatar::Meta(a) => Fitted::Hyper(a),
            AnyAvatar::Static(mut avatar) => {
                avatar.set_mesh_resolution(self.resolution);
                let canonical = avatar.canonical_mesh(&BodyParams::default())?;
                let weights = avatar.mesh_skinning_weights(&canonical);
                Fitted::Static(avatar, canonical, weights)
            }
        });
        if let Some(Fitted::Hyper(a)) = &mut self.fitted {
            a.set_mesh_resolution(self.resolution);
            if let (Some(dir), Some(name)) = (&self.save_avatars, data.capture_dir.file_name()) {
                let path = dir.join(name).with_extension("avatar");
                a.save(&path).map_err(|e| Error::invalid(format!("{}: {e}", path.display())))?;
            }
        }
        Ok(())
    }

    fn predict(&self, params: &BodyParams) -> Result<TriMesh> {
        match &self.fitted {
            Some(Fitted::Hyper(a)) => Ok(a.posed_mesh(params)?),
            Some(Fitted::Static(a, canonical, weights)) => {
                let mut p = params.clone();
                p.betas = a.betas().to_vec();
                let bones = a.body().pose(&p).bones;
                Ok(forward_skin_with_weights(&bones, canonical, weights))
            }
            None => Err(Error::invalid("predict called before fit")),
        }
    }
}
