//! The studio's fine-tuning job: `avatar_neural::avatar::fit_avatar` on its own thread (a
//! background [`Task`]), talking to the UI through events. Nothing is written to disk by the job.

use crate::studio::avatar::{CanonicalMesh, StudioAvatar, studio_avatar};
use crate::studio::fit_config::FitConfig;
use crate::studio::tasks::Task;
use avatar_neural::avatar::{AvatarFit, FitEvent, MeshResolution, TimeLeft, fit_avatar};
use avatar_neural::data::capture_points::{CapturePoints, FrameCount};
use crossbeam_channel::Receiver;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// What the job tells the UI.
pub enum JobEvent {
    /// Preparation finished: the canonical points are ready.
    Started {
        points: usize,
        frames: usize,
    },
    Progress {
        step: usize,
        steps: usize,
        loss: f32,
        terms: [f32; 4],
        elapsed_s: f64,
        /// From the fit's plan and each phase's measured cost (None until one has run).
        left_s: Option<f64>,
    },
    /// A phase of the fit starts (pre-alignment, training, a refinement round, ...).
    Phase {
        label: &'static str,
        left_s: Option<f64>,
    },
    /// The partial result.
    Preview {
        step: usize,
        mesh: Arc<CanonicalMesh>,
    },
    /// The fit ended (cancelled fits finish too, with the partial avatar).
    Finished {
        avatar: Arc<dyn StudioAvatar>,
        cancelled: bool,
        warnings: Vec<String>,
        seconds: f64,
    },
    Failed(String),
}

/// A running fine-tuning job (a background task). Dropping it cancels the fit (the thread
/// finishes its step and exits).
pub struct FitJob {
    pub events: Receiver<JobEvent>,
    task: Task<(), JobEvent>,
    paused: Arc<AtomicBool>,
    pub config: FitConfig,
    pub capture: PathBuf,
}

impl FitJob {
    /// Start a fit on its own thread. `wake` is called after each event (the UI repaints).
    pub fn start(
        capture: PathBuf,
        config: FitConfig,
        wake: impl Fn() + Send + Sync + 'static,
    ) -> FitJob {
        let (dir, cfg) = (capture.clone(), config.clone());
        let paused = Arc::new(AtomicBool::new(false));
        let pause = paused.clone();
        let task = Task::spawn("fit job", Arc::new(wake), move |cx| {
            let send = |e: JobEvent| cx.send(e);
            let t = Instant::now();
            // A paused job waits at the end of its chunk (after the preview) until resumed or
            // cancelled.
            let hold = || {
                while pause.load(Ordering::Relaxed) && !cx.cancelled() {
                    std::thread::sleep(Duration::from_millis(20));
                }
            };
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                run_fit(&dir, &cfg, cx.cancel_flag(), &hold, &send)
            }));
            match result {
                Ok(Ok((avatar, warnings))) => send(JobEvent::Finished {
                    avatar,
                    cancelled: cx.cancelled(),
                    warnings,
                    seconds: t.elapsed().as_secs_f64(),
                }),
                Ok(Err(e)) => send(JobEvent::Failed(e.to_string())),
                Err(_) => send(JobEvent::Failed("the fit stopped on an internal error".into())),
            }
            Ok(())
        });
        FitJob { events: task.events.clone(), task, paused, config, capture }
    }

    pub fn cancel(&self) {
        self.task.cancel();
    }

    pub fn is_cancelling(&self) -> bool {
        self.task.is_cancelling()
    }

    /// Hold the fit at the end of its current chunk (after its preview) until [`FitJob::resume`].
    pub fn pause(&self) {
        self.paused.store(true, Ordering::Relaxed);
    }

    pub fn resume(&self) {
        self.paused.store(false, Ordering::Relaxed);
    }
}

/// The fit itself (runs on the job thread): `fit_avatar` in chunks of `preview_every` steps;
/// after each chunk the partial avatar's canonical surface at the rest pose is meshed for the
/// preview, then `after_chunk` runs (it may block: a paused job).
pub fn run_fit(
    dir: &Path,
    cfg: &FitConfig,
    cancel: &AtomicBool,
    after_chunk: &dyn Fn(),
    send: &dyn Fn(JobEvent),
) -> crate::error::Result<(Arc<dyn StudioAvatar>, Vec<String>)> {
    if cfg.steps == 0 || cfg.frames == 0 || cfg.batch == 0 || cfg.hidden == 0 || cfg.layers == 0 {
        return Err(crate::error::StudioError::invalid(
            "steps, frames, points per step, width and layers must be at least 1",
        ));
    }
    let t = Instant::now();
    // The prior first: a bad model file is refused before the capture is canonicalized.
    let model = cfg.prior()?;
    let capture = CapturePoints::open_with(
        dir,
        FrameCount::up_to(cfg.frames),
        None,
        crate::cache::field_cache(),
    )?;
    send(JobEvent::Started { points: capture.num_points(), frames: capture.frames.len() });
    let fit = AvatarFit {
        kind: cfg.fit_kind(&model),
        options: cfg.fit_options(),
        chunk: cfg.preview_every,
        cancel: Some(cancel),
        trace: None,
    };
    let rest = avatar_core::body::BodyParams { betas: capture.betas.clone(), ..Default::default() };
    // The time left counts from the fit's start (canonicalization is done).
    let (start, mut left) = (Instant::now(), TimeLeft::default());
    let (avatar, report) = fit_avatar(&capture, &fit, &mut |event| match event {
        FitEvent::Plan(plan) => left.plan(plan),
        FitEvent::Phase(phase) => {
            let at = start.elapsed().as_secs_f64();
            left.phase(phase, at);
            send(JobEvent::Phase { label: phase.label(), left_s: left.left(at) })
        }
        FitEvent::Progress { step, steps, loss, terms } => {
            let at = start.elapsed().as_secs_f64();
            left.steps(step + 1, at);
            send(JobEvent::Progress {
                step: step + 1,
                steps,
                loss,
                terms,
                elapsed_s: t.elapsed().as_secs_f64(),
                left_s: left.left(at),
            })
        }
        FitEvent::Partial { done, mut avatar } => {
            avatar.set_mesh_resolution(MeshResolution::clamped(cfg.preview_resolution));
            if let Ok(mesh) = avatar.source().canonical_mesh(&rest) {
                let weights = avatar.source().mesh_skinning_weights(&mesh);
                send(JobEvent::Preview {
                    step: done,
                    mesh: Arc::new(CanonicalMesh { mesh, weights, smoother: None }),
                });
            }
            after_chunk();
        }
    })?;
    Ok((studio_avatar(avatar, cfg.final_resolution), report.warnings))
}
