//! The training stage's configs check themselves (`config::Check`): counts at least 1 where a
//! step needs one, rates and weights finite and not negative, and the options inside them.

use crate::config::{Check, at_least, non_negative, positive};
use crate::error::Result;
use crate::training::fit::FitOptions;
use crate::training::hyper_fit::HyperFitOptions;
use crate::training::loss::IgrWeights;
use crate::training::meta_training::{MetaOptions, RatesConfig};
use crate::training::pose_refine::PoseRefineOptions;

impl Check for IgrWeights {
    fn check(&self) -> Result<()> {
        non_negative("weights.surface", self.surface as f64)?;
        non_negative("weights.normal", self.normal as f64)?;
        non_negative("weights.off_surface", self.off_surface as f64)?;
        non_negative("weights.alpha", self.alpha as f64)?;
        non_negative("weights.eikonal", self.eikonal as f64)
    }
}

impl Check for FitOptions {
    fn check(&self) -> Result<()> {
        at_least("steps", self.steps, 1)?;
        positive("learning_rate", self.learning_rate)?;
        at_least("batch", self.batch, 1)?;
        at_least("off_surface", self.off_surface, 1)?;
        positive("near_sigma", self.near_sigma as f64)?;
        self.weights.check()?;
        non_negative("prior_weight", self.prior_weight as f64)
    }
}

impl Check for HyperFitOptions {
    fn check(&self) -> Result<()> {
        at_least("steps", self.steps, 1)?;
        non_negative("loose_step_factor", self.loose_step_factor as f64)?;
        non_negative("lr_heads", self.lr_heads)?;
        non_negative("lr_encoder", self.lr_encoder)?;
        non_negative("lr_sdf", self.lr_sdf)?;
        at_least("poses_per_step", self.poses_per_step, 1)?;
        at_least("surface_per_pose", self.surface_per_pose, 1)?;
        at_least("off_per_pose", self.off_per_pose, 1)?;
        positive("near_sigma", self.near_sigma as f64)?;
        self.weights.check()?;
        non_negative("prior_weight", self.prior_weight as f64)?;
        non_negative("residual_weight", self.residual_weight as f64)?;
        self.refine_poses.check()
    }
}

impl Check for PoseRefineOptions {
    /// Off, the rest is not read. On: at least one step a round and one point a frame, priors
    /// not negative, steps and the Huber threshold above 0.
    fn check(&self) -> Result<()> {
        if !self.enabled {
            return Ok(());
        }
        at_least("refine_poses.iterations", self.iterations, 1)?;
        at_least("refine_poses.points_per_frame", self.points_per_frame, 1)?;
        at_least("refine_poses.prealign_points_per_frame", self.prealign_points_per_frame, 1)?;
        non_negative("refine_poses.rotation_prior", self.rotation_prior as f64)?;
        non_negative("refine_poses.translation_prior", self.translation_prior as f64)?;
        positive("refine_poses.huber", self.huber as f64)?;
        positive("refine_poses.max_step_rad", self.max_step_rad as f64)?;
        positive("refine_poses.max_step_m", self.max_step_m as f64)?;
        non_negative("refine_poses.prealign_cutoff", self.prealign_cutoff as f64)
    }
}

impl Check for RatesConfig {
    fn check(&self) -> Result<()> {
        non_negative("hyper_outer.heads", self.heads)?;
        non_negative("hyper_outer.encoder", self.encoder)?;
        non_negative("hyper_outer.sdf", self.sdf)
    }
}

impl Check for MetaOptions {
    fn check(&self) -> Result<()> {
        self.config.check()?;
        at_least("sdf_meta_batch", self.sdf_meta_batch, 1)?;
        at_least("sdf_inner_steps", self.sdf_inner_steps, 1)?;
        positive("sdf_inner_lr", self.sdf_inner_lr)?;
        positive("sdf_outer_lr", self.sdf_outer_lr)?;
        at_least("hyper_max_task", self.hyper_max_task, 1)?;
        at_least("hyper_meta_batch", self.hyper_meta_batch, 1)?;
        at_least("hyper_inner_epochs", self.hyper_inner_epochs, 1)?;
        self.hyper_inner.check()?;
        self.hyper_outer.check()?;
        at_least("points_per_step", self.points_per_step, 1)?;
        at_least("checkpoint_every", self.checkpoint_every, 1)
    }
}
