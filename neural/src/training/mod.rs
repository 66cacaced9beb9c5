//! Training the networks: the IGR loss (`loss`), the inner fits (`fit`: a static SIREN SDF;
//! `hyper_fit`: the hypernetwork), meta-learning (`meta_training`, data-parallel over
//! `collective`), pose refinement during a personal avatar's fit (`pose_refine`, traced against
//! known poses by `pose_trace`), and one training step's arithmetic (`step`: hand-derived
//! gradients, Adam, the CPU kernels). Configs: `FitOptions`, `HyperFitOptions`,
//! `PoseRefineOptions`, `MetaOptions` (`config::Check`).

pub mod collective;
mod config;
pub mod fit;
pub mod hyper_fit;
pub mod loss;
pub mod meta_training;
pub mod pose_refine;
pub mod pose_trace;
pub mod step;
