//! The studio's fine-tuning settings (what the job panel edits) and how they become a fit of
//! `avatar_neural::avatar::fitting`.

use avatar_neural::avatar::FitKind;
use avatar_neural::data::capture_points::FrameCount;
use avatar_neural::{HyperFitOptions, Init, MetaModel, SirenConfig};

/// Which avatar a fit produces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum AvatarKind {
    /// MetaAvatar: the shipped meta-learned hypernetwork fine-tuned on the frames (clothing
    /// that deforms with the pose).
    MetaAvatar,
    /// A SIREN SDF fitted from scratch to the canonical points (pose-independent).
    StaticSdf,
}

impl AvatarKind {
    pub fn label(self) -> &'static str {
        match self {
            AvatarKind::MetaAvatar => "MetaAvatar (meta-learned)",
            AvatarKind::StaticSdf => "Static SDF (from scratch)",
        }
    }
}

/// A fine-tuning configuration (what the job panel edits).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitConfig {
    pub kind: AvatarKind,
    pub frames: usize,
    pub steps: usize,
    /// The static SDF's network (the MetaAvatar's comes with the meta-model).
    pub hidden: usize,
    pub layers: usize,
    /// Surface and off-surface points per pose and step (the static SDF pools the poses:
    /// `HyperFitOptions::static_equivalent`).
    pub batch: usize,
    pub off_surface: usize,
    /// The static SDF's Adam rate (the MetaAvatar uses the fine-tuning rates of `fit`).
    pub learning_rate: f64,
    pub seed: u64,
    /// A preview mesh of the partial result every this many steps (0 = none).
    pub preview_every: usize,
    /// Marching-cubes resolution of previews and of the final mesh.
    pub preview_resolution: usize,
    pub final_resolution: usize,
    /// The MetaAvatar's prior: a meta-model file `meta-train` wrote; empty for the shipped one.
    #[serde(default)]
    pub model: String,
}

impl Default for FitConfig {
    /// `avatar-studio fit`'s defaults: the MetaAvatar, up to 32 frames, 256 steps.
    fn default() -> Self {
        let fit = HyperFitOptions::default();
        FitConfig {
            kind: AvatarKind::MetaAvatar,
            frames: FrameCount::DEFAULT.at_most,
            steps: fit.steps,
            hidden: 128,
            layers: 4,
            batch: fit.surface_per_pose,
            off_surface: fit.off_per_pose,
            learning_rate: 1e-4,
            seed: 0,
            preview_every: 50,
            preview_resolution: 64,
            final_resolution: 128,
            model: String::new(),
        }
    }
}

impl FitConfig {
    /// The static SDF from scratch: 500 steps of 2000 + 2000 points (250 + 250 for each of
    /// `fit`'s 8 poses a step).
    pub fn static_sdf() -> Self {
        FitConfig {
            kind: AvatarKind::StaticSdf,
            frames: 8,
            steps: 500,
            hidden: 128,
            layers: 4,
            batch: 250,
            off_surface: 250,
            learning_rate: 1e-4,
            seed: 0,
            preview_every: 100,
            preview_resolution: 48,
            final_resolution: 96,
            model: String::new(),
        }
    }

    /// The defaults of a kind (the panel's kind selector).
    pub fn for_kind(kind: AvatarKind) -> Self {
        match kind {
            AvatarKind::MetaAvatar => FitConfig::default(),
            AvatarKind::StaticSdf => FitConfig::static_sdf(),
        }
    }

    /// Seconds on two cores: for tests and a quick look. The MetaAvatar starts from the
    /// meta-model, so a few small steps already give a body-shaped, posable avatar.
    pub fn tiny() -> Self {
        FitConfig {
            frames: 4,
            steps: 20,
            batch: 300,
            off_surface: 300,
            preview_every: 10,
            preview_resolution: 40,
            final_resolution: 96,
            ..FitConfig::default()
        }
    }

    /// A rough static SDF from scratch in seconds.
    pub fn tiny_static() -> Self {
        FitConfig {
            frames: 4,
            steps: 150,
            hidden: 64,
            layers: 3,
            batch: 125,
            off_surface: 125,
            learning_rate: 5e-4,
            preview_every: 75,
            preview_resolution: 40,
            final_resolution: 64,
            ..FitConfig::static_sdf()
        }
    }

    /// The same settings with another budget (`preset`), keeping the chosen prior.
    pub fn keeping_prior(&self, preset: FitConfig) -> FitConfig {
        FitConfig { model: self.model.clone(), ..preset }
    }

    /// The MetaAvatar's prior: the model file typed in the panel, else the shipped model. A
    /// broken file or one of another kind is refused with its name.
    pub fn prior(&self) -> avatar_neural::Result<MetaModel> {
        let path = self.model.trim();
        match self.kind {
            AvatarKind::MetaAvatar if !path.is_empty() => {
                MetaModel::load(std::path::Path::new(path))
            }
            _ => Ok(MetaModel::shipped()),
        }
    }

    /// The fit's options: `fit`'s defaults with this budget (steps, points, seed; the static
    /// SDF's rate).
    pub fn fit_options(&self) -> HyperFitOptions {
        let options = HyperFitOptions {
            steps: self.steps,
            surface_per_pose: self.batch,
            off_per_pose: self.off_surface,
            seed: self.seed,
            ..HyperFitOptions::default()
        };
        match self.kind {
            AvatarKind::MetaAvatar => options,
            AvatarKind::StaticSdf => HyperFitOptions { lr_sdf: self.learning_rate, ..options },
        }
    }

    /// What the fit makes: the MetaAvatar from `model`, or the static SDF of this network
    /// from scratch.
    pub fn fit_kind<'a>(&self, model: &'a MetaModel) -> FitKind<'a> {
        match self.kind {
            AvatarKind::MetaAvatar => FitKind::Meta(Init::MetaLearned(model)),
            AvatarKind::StaticSdf => FitKind::Static {
                siren: SirenConfig { hidden: self.hidden, layers: self.layers },
                init: None,
            },
        }
    }
}
