//! The studio's avatar layer: what the studio needs from an avatar ([`StudioAvatar`]) and the
//! background fine-tuning job ([`FitJob`]) that talks to the UI through a crossbeam channel.
//!
//! The job fine-tunes the MetaAvatar (the shipped meta-model's hypernetwork, pose-dependent
//! clothing) by default, or fits a static SIREN SDF from scratch; both implement
//! [`StudioAvatar`]. Another avatar drops in by implementing it, adding a variant to
//! [`AvatarKind`] with its fit in [`run_fit`], and a branch in [`load_avatar`].

use avatar_core::body::{BodyModel, Weights};
use avatar_core::avatar::AvatarSource;
use avatar_core::mesh::extract::{extract, ExtractOptions};
use avatar_core::mesh::TriMesh;
use avatar_neural::capture_points::CapturePoints;
use avatar_neural::siren_eval::MetricSdf;
use avatar_neural::{fit_sdf, AnyAvatar, FitOptions, HyperFitOptions, Init, MetaAvatar, MetaModel, SirenConfig, StaticAvatar};
use crossbeam_channel::Receiver;
use glam::Vec3;
use std::path::{Path, PathBuf};
use crate::studio::tasks::Task;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

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
    fn save(&self, path: &Path) -> anyhow::Result<()>;
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
        self.resolution = cells.clamp(16, 512);
    }
    fn save(&self, path: &Path) -> anyhow::Result<()> {
        Ok(StaticAvatar::save(self, path)?)
    }
}

impl StudioAvatar for MetaAvatar {
    fn describe(&self) -> String {
        let partial = self.header.partial.map(|p| format!(", {p}")).unwrap_or_default();
        format!("MetaAvatar ({}, {} frames{partial})", self.header.init, self.header.frames)
    }
    fn source(&self) -> &dyn AvatarSource {
        self
    }
    fn pose_dependent(&self) -> bool {
        true
    }
    fn set_resolution(&mut self, cells: usize) {
        self.resolution = cells.clamp(16, 512);
    }
    fn save(&self, path: &Path) -> anyhow::Result<()> {
        Ok(MetaAvatar::save(self, path)?)
    }
    fn refined_poses(&self) -> &[avatar_neural::avatar::refined_poses::RefinedPose] {
        self.header.refined_poses.as_deref().unwrap_or(&[])
    }
}

/// Open an avatar file of any kind this build reads (`avatar-studio fit` writes both).
pub fn load_avatar(path: &Path, resolution: usize) -> anyhow::Result<Arc<dyn StudioAvatar>> {
    Ok(match AnyAvatar::load(path)? {
        AnyAvatar::Static(mut a) => {
            a.set_resolution(resolution);
            Arc::new(a)
        }
        AnyAvatar::Meta(mut a) => {
            StudioAvatar::set_resolution(&mut a, resolution);
            Arc::new(a)
        }
    })
}

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
    /// Surface and off-surface points per step (MetaAvatar: per pose and step).
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
}

impl Default for FitConfig {
    /// `avatar-studio fit`'s defaults: the MetaAvatar, 8 frames, 256 steps.
    fn default() -> Self {
        let fit = HyperFitOptions::default();
        FitConfig {
            kind: AvatarKind::MetaAvatar,
            frames: 8,
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
        }
    }
}

impl FitConfig {
    /// The static SDF from scratch: 500 steps of 2000 + 2000 points.
    pub fn static_sdf() -> Self {
        FitConfig {
            kind: AvatarKind::StaticSdf,
            frames: 8,
            steps: 500,
            hidden: 128,
            layers: 4,
            batch: 2000,
            off_surface: 2000,
            learning_rate: 1e-4,
            seed: 0,
            preview_every: 100,
            preview_resolution: 48,
            final_resolution: 96,
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
        FitConfig { frames: 4, steps: 20, batch: 300, off_surface: 300, preview_every: 10, preview_resolution: 40, final_resolution: 96, ..FitConfig::default() }
    }

    /// A rough static SDF from scratch in seconds.
    pub fn tiny_static() -> Self {
        FitConfig {
            frames: 4,
            steps: 150,
            hidden: 64,
            layers: 3,
            batch: 1000,
            off_surface: 1000,
            learning_rate: 5e-4,
            preview_every: 75,
            preview_resolution: 40,
            final_resolution: 64,
            ..FitConfig::static_sdf()
        }
    }
}

/// A mesh in canonical space with skinning weights per vertex: what the poser needs.
pub struct CanonicalMesh {
    pub mesh: TriMesh,
    pub weights: Vec<Weights>,
}

/// What the job tells the UI.
pub enum JobEvent {
    /// Preparation finished: the canonical points are ready.
    Started { points: usize, frames: usize },
    Progress { step: usize, steps: usize, loss: f32, terms: [f32; 4], elapsed_s: f64 },
    /// The partial result.
    Preview { step: usize, mesh: Arc<CanonicalMesh> },
    /// The fit ended (cancelled fits finish too, with the partial avatar).
    Finished { avatar: Arc<dyn StudioAvatar>, cancelled: bool, warnings: Vec<String>, seconds: f64 },
    Failed(String),
}

/// A running fine-tuning job (a background task). Dropping it cancels the fit (the thread
/// finishes its step and exits; nothing is written to disk by the job).
pub struct FitJob {
    pub events: Receiver<JobEvent>,
    task: Task<(), JobEvent>,
    pub config: FitConfig,
    pub capture: PathBuf,
}

impl FitJob {
    /// Start a fit on its own thread. `wake` is called after each event (the UI repaints).
    pub fn start(capture: PathBuf, config: FitConfig, wake: impl Fn() + Send + Sync + 'static) -> FitJob {
        FitJob::start_gated(capture, config, wake, None)
    }

    /// Like [`FitJob::start`], but after each chunk of steps the job waits for a message (or
    /// the sender's drop) on `gate`: tests hold a job in a known state.
    pub fn start_gated(capture: PathBuf, config: FitConfig, wake: impl Fn() + Send + Sync + 'static, gate: Option<Receiver<()>>) -> FitJob {
        let (dir, cfg) = (capture.clone(), config.clone());
        let task = Task::spawn("fit job", Arc::new(wake), move |cx| {
            let send = |e: JobEvent| cx.send(e);
            let t = Instant::now();
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run_fit(&dir, &cfg, cx.cancel_flag(), gate.as_ref(), &send)));
            match result {
                Ok(Ok((avatar, warnings))) => send(JobEvent::Finished { avatar, cancelled: cx.cancelled(), warnings, seconds: t.elapsed().as_secs_f64() }),
                Ok(Err(e)) => send(JobEvent::Failed(format!("{e:#}"))),
                Err(_) => send(JobEvent::Failed("the fit stopped on an internal error".into())),
            }
            Ok(())
        });
        FitJob { events: task.events.clone(), task, config, capture }
    }

    pub fn cancel(&self) {
        self.task.cancel();
    }

    pub fn is_cancelling(&self) -> bool {
        self.task.is_cancelling()
    }
}

/// The fit itself (runs on the job thread).
pub fn run_fit(dir: &Path, cfg: &FitConfig, cancel: &AtomicBool, gate: Option<&Receiver<()>>, send: &dyn Fn(JobEvent)) -> anyhow::Result<(Arc<dyn StudioAvatar>, Vec<String>)> {
    match cfg.kind {
        AvatarKind::MetaAvatar => fit_meta(dir, cfg, cancel, gate, send),
        AvatarKind::StaticSdf => fit_static(dir, cfg, cancel, gate, send),
    }
}

/// Between chunks a gated job (tests) waits for the gate's message, its sender's drop or a
/// cancel.
fn wait_at_gate(gate: Option<&Receiver<()>>, cancel: &AtomicBool) {
    if let Some(g) = gate {
        while let Err(crossbeam_channel::RecvTimeoutError::Timeout) = g.recv_timeout(std::time::Duration::from_millis(50)) {
            if cancel.load(Ordering::Relaxed) {
                break;
            }
        }
    }
}

/// `avatar-studio fit`'s MetaAvatar fine-tuning from the shipped meta-model, in chunks of
/// `preview_every` steps: after each the partial avatar's canonical surface at the rest pose
/// is meshed for the preview.
fn fit_meta(dir: &Path, cfg: &FitConfig, cancel: &AtomicBool, gate: Option<&Receiver<()>>, send: &dyn Fn(JobEvent)) -> anyhow::Result<(Arc<dyn StudioAvatar>, Vec<String>)> {
    if cfg.steps == 0 || cfg.frames == 0 || cfg.batch == 0 {
        anyhow::bail!("steps, frames and points per step must be at least 1");
    }
    let t = Instant::now();
    let capture = CapturePoints::open(dir, cfg.frames)?;
    send(JobEvent::Started { points: capture.num_points(), frames: capture.frames.len() });
    let model = MetaModel::shipped();
    let options = HyperFitOptions { steps: cfg.steps, surface_per_pose: cfg.batch, off_per_pose: cfg.off_surface, seed: cfg.seed, ..HyperFitOptions::default() };
    let mut progress = |step: usize, loss: f32, terms: [f32; 4]| {
        send(JobEvent::Progress { step: step + 1, steps: cfg.steps, loss, terms, elapsed_s: t.elapsed().as_secs_f64() });
    };
    let rest = avatar_core::body::BodyParams { betas: capture.betas.clone(), ..Default::default() };
    let mut look = |done: usize, partial: &MetaAvatar| {
        if let Ok(mesh) = partial.canonical_mesh_at(&rest, cfg.preview_resolution.clamp(8, 256)) {
            let weights = partial.skinning_weights(&mesh.positions);
            send(JobEvent::Preview { step: done, mesh: Arc::new(CanonicalMesh { mesh, weights }) });
        }
        wait_at_gate(gate, cancel);
    };
    let chunks: Option<(usize, &mut dyn FnMut(usize, &MetaAvatar))> = (cfg.preview_every > 0).then_some((cfg.preview_every, &mut look as &mut dyn FnMut(usize, &MetaAvatar)));
    let (mut avatar, report) = MetaAvatar::fit_points_in_chunks(&capture, &Init::MetaLearned(&model), &options, chunks, Some(cancel), &mut progress);
    StudioAvatar::set_resolution(&mut avatar, cfg.final_resolution);
    Ok((Arc::new(avatar), report.warnings))
}

/// The static SDF fit of `StaticAvatar::fit_capture` (same canonical points, same
/// off-surface sign prior, same loss), run in chunks of `preview_every` steps so that the
/// partial result can be shown: after each chunk the current network is meshed.
fn fit_static(dir: &Path, cfg: &FitConfig, cancel: &AtomicBool, gate: Option<&Receiver<()>>, send: &dyn Fn(JobEvent)) -> anyhow::Result<(Arc<dyn StudioAvatar>, Vec<String>)> {
    if cfg.steps == 0 || cfg.frames == 0 || cfg.hidden == 0 || cfg.layers == 0 {
        anyhow::bail!("steps, frames, width and layers must be at least 1");
    }
    let t = Instant::now();
    let capture = CapturePoints::open(dir, cfg.frames)?;
    let warnings = capture.warnings.clone();
    let norm = capture.normalisation;
    let points: Vec<Vec3> = capture.frames.iter().flat_map(|f| f.points.iter().copied()).collect();
    let normals: Vec<Vec3> = capture.frames.iter().flat_map(|f| f.normals.iter().copied()).collect();
    send(JobEvent::Started { points: points.len(), frames: capture.frames.len() });
    let prior = capture.sign_prior();
    let siren = SirenConfig { hidden: cfg.hidden, layers: cfg.layers };
    let device = avatar_neural::cpu_training_device();
    let mut model = siren.init(cfg.seed, &device);
    let chunk = if cfg.preview_every == 0 { cfg.steps } else { cfg.preview_every.min(cfg.steps) };
    let (lo, hi) = (norm.from_unit(Vec3::splat(-1.0)), norm.from_unit(Vec3::splat(1.0)));
    let mut done = 0;
    let steps_run = std::sync::atomic::AtomicUsize::new(0);
    while done < cfg.steps && !cancel.load(Ordering::Relaxed) {
        if done > 0 {
            wait_at_gate(gate, cancel);
        }
        let n = chunk.min(cfg.steps - done);
        let options = FitOptions {
            steps: n,
            learning_rate: cfg.learning_rate,
            batch: cfg.batch,
            off_surface: cfg.off_surface,
            seed: cfg.seed.wrapping_add(done as u64),
            ..FitOptions::default()
        };
        let base = done;
        let mut progress = |step: usize, loss: f32, terms: [f32; 4]| {
            send(JobEvent::Progress { step: base + step + 1, steps: cfg.steps, loss, terms, elapsed_s: t.elapsed().as_secs_f64() });
        };
        // The prior is asked once a step: counting its calls gives the steps that ran.
        let counted = |p: &[Vec3]| {
            steps_run.fetch_add(1, Ordering::Relaxed);
            prior(p)
        };
        model = fit_sdf(model, &points, &normals, &options, &device, Some(&counted), Some(cancel), &mut progress);
        done += n;
        if cfg.preview_every > 0 && done < cfg.steps && !cancel.load(Ordering::Relaxed) {
            let sdf = MetricSdf::of(&model, norm);
            if let Ok(mesh) = extract(|p: &[Vec3]| sdf.sdf(p), &ExtractOptions::new(lo, hi, cfg.preview_resolution.clamp(8, 256))).map(|e| e.mesh) {
                let weights = mesh.positions.iter().map(|&p| capture.field.weights_at(p)).collect();
                send(JobEvent::Preview { step: done, mesh: Arc::new(CanonicalMesh { mesh, weights }) });
            }
        }
    }
    let mut avatar = StaticAvatar::from_fitted(&capture, siren, &model);
    avatar.header.partial = avatar_neural::PartialFit::of(steps_run.load(Ordering::Relaxed).min(cfg.steps), cfg.steps);
    avatar.set_resolution(cfg.final_resolution);
    Ok((Arc::new(avatar), warnings))
}


/// The canonical mesh of an avatar (at the rest pose) with its skinning weights.
pub fn canonical_of(avatar: &dyn StudioAvatar, body_betas: &[f32]) -> anyhow::Result<CanonicalMesh> {
    let params = avatar_core::body::BodyParams { betas: body_betas.to_vec(), ..Default::default() };
    let mesh = avatar.source().canonical_mesh(&params)?;
    let weights = avatar.source().skinning_weights(&mesh.positions);
    Ok(CanonicalMesh { mesh, weights })
}

/// The body model's own skinning of its rest mesh (the placeholder before an avatar exists).
pub fn body_canonical(body: &BodyModel, betas: &[f32]) -> CanonicalMesh {
    let rest = body.pose(&avatar_core::body::BodyParams { betas: betas.to_vec(), ..Default::default() }).rest_vertices;
    CanonicalMesh { mesh: body.mesh(rest), weights: body.weights.clone() }
}
