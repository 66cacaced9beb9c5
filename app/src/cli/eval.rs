//! `avatar-studio eval`: score avatars on held-out synthetic subjects and write a JSON report
//! and a Markdown table. Presets (docs/evaluation.md): `full` (the default table: captures as
//! users make them and clean ones, every outfit, four subjects), `quick` (a developer's check
//! after a change, under 15 minutes on 2 cores) and `paper` (MetaAvatar's clean protocols).
//! Every flag overrides its preset's value.

use anyhow::{Context, bail};
use avatar_core::eval::dataset::EVAL_SUBJECT_SEEDS;
use avatar_core::eval::{
    CaptureConditions, EvalConfig, NakedBody, Predictor, Protocol, StaticOutfit, run as run_eval,
};
use avatar_core::synth::Outfit;
use avatar_neural::avatar::MeshResolution;
use avatar_neural::avatar::eval_rows::{NeuralRow, RowKind};
use avatar_neural::training::loss::IgrWeights;
use avatar_neural::{HyperFitOptions, MetaModel};
use std::path::PathBuf;

/// The values a preset gives the flags left out.
struct Preset {
    protocol: &'static str,
    captures: &'static str,
    subjects: usize,
    outfits: &'static [&'static str],
    rows: &'static [&'static str],
    steps: usize,
    resolution: usize,
    stride: usize,
    chamfer_samples: usize,
    iou_resolution: usize,
}

const ALL: &[&str] =
    &["tshirt_shorts", "longsleeve_trousers", "polo_loose", "dress", "blazer_tails"];

fn preset(name: &str) -> anyhow::Result<Preset> {
    Ok(match name {
        "full" => Preset {
            protocol: "few-shot:1/clip",
            captures: "user,clean",
            subjects: 4,
            outfits: ALL,
            rows: &["meta", "static"],
            steps: 256,
            resolution: avatar_neural::avatar::header::OUTPUT_RESOLUTION,
            stride: 5,
            chamfer_samples: 10_000,
            iou_resolution: 128,
        },
        // One subject, a tight, a loose and the unseen outfit, user captures only, a short fit.
        "quick" => Preset {
            protocol: "few-shot:1/clip",
            captures: "user",
            subjects: 1,
            outfits: &["longsleeve_trousers", "dress", "blazer_tails"],
            rows: &["meta", "static"],
            steps: 64,
            resolution: 96,
            stride: 10,
            chamfer_samples: 5_000,
            iou_resolution: 64,
        },
        "paper" => Preset {
            protocol: "all",
            captures: "clean",
            subjects: 4,
            outfits: &["longsleeve_trousers", "blazer_tails"],
            rows: &[],
            steps: 256,
            resolution: 128,
            stride: 5,
            chamfer_samples: 10_000,
            iou_resolution: 128,
        },
        other => bail!("unknown --preset {other:?}: use full, quick or paper"),
    })
}

#[derive(clap::Args)]
pub struct Args {
    /// full (the default table), quick (under 15 minutes on 2 cores) or paper (MetaAvatar's
    /// clean protocols, reference rows only). Flags override the preset's values.
    #[arg(long, default_value = "full")]
    preset: String,
    /// interpolation, extrapolation, few-shot (all six fractions), all, or a comma-separated
    /// list (few-shot:50, few-shot:1/clip pick one setting).
    #[arg(long)]
    protocol: Option<String>,
    /// Capture conditions of the fine-tuning captures (diagnostics: noisy = depth noise only,
    /// misfit = fitting errors only): user (depth noise and holes, fitting
    /// errors, 30-60 degree turns), clean (MetaAvatar's protocol), front (user, but 3-4 degree
    /// turns: the back is never seen), comma-separated.
    #[arg(long)]
    captures: Option<String>,
    /// The depth noise model of user captures: kinect_v1 or kinect_v2 (default).
    #[arg(long)]
    noise: Option<String>,
    /// JSON report (written atomically).
    #[arg(long)]
    out: PathBuf,
    /// Also write the Markdown table here.
    #[arg(long)]
    markdown: Option<PathBuf>,
    /// Write a contact sheet per outfit into this folder (eval-OUTFIT.png: truth and every row
    /// at a held-out pose, front and side; first subject, first setting).
    #[arg(long)]
    contact_sheets: Option<PathBuf>,
    /// Use the first N held-out subjects (at most 4).
    #[arg(long)]
    subjects: Option<usize>,
    /// Outfits, comma-separated (tshirt_shorts, longsleeve_trousers, polo_loose, dress,
    /// blazer_tails; all = every one of those; sim_skirt and sim_cape: garments simulated as
    /// cloth through each motion).
    #[arg(long, value_delimiter = ',')]
    outfits: Option<Vec<String>>,
    /// Evaluate every n-th frame of the held-out clips.
    #[arg(long)]
    stride: Option<usize>,
    /// Points sampled per surface for Chamfer-L2 and the spurious/missing shares.
    #[arg(long)]
    chamfer_samples: Option<usize>,
    /// Grid points along the longest side for IoU.
    #[arg(long)]
    iou_resolution: Option<usize>,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Rows besides the naked body and the ground truth: meta (MetaAvatar), scratch (same
    /// networks from scratch), static (the static meta-SDF), outfit-static (the ground-truth
    /// outfit without its pose-dependent deformation), outfit-static-field (the same posed with
    /// the body's skinning field, as avatars are), comma-separated; none for no row.
    #[arg(long, value_delimiter = ',')]
    rows: Option<Vec<String>>,
    /// Meta-learned model file (default: the shipped compact model).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Fine-tuning steps of every neural row (the same budget for each).
    #[arg(long)]
    steps: Option<usize>,
    /// Fine-tune on at most this many of the protocol's frames.
    #[arg(long, default_value_t = 1000)]
    max_frames: usize,
    /// Marching-cubes resolution of the neural rows' meshes.
    #[arg(long)]
    resolution: Option<usize>,
    /// Fine-tuning Adam rate of the hypernetwork's heads (default: `fit`'s).
    #[arg(long)]
    lr_heads: Option<f64>,
    /// Fine-tuning Adam rate of the bone encoder (default: `fit`'s).
    #[arg(long)]
    lr_encoder: Option<f64>,
    /// Fine-tuning Adam rate of the SDF's base weights and of the static row (default: `fit`'s).
    #[arg(long)]
    lr_sdf: Option<f64>,
    /// Poses per fine-tuning step of the hypernetwork rows, and surface (and as many
    /// off-surface) points per pose (default: `fit`'s); the static row gets the product.
    #[arg(long)]
    poses_per_step: Option<usize>,
    #[arg(long)]
    points_per_pose: Option<usize>,
    /// Weight of the normal term in fine-tuning, every neural row (default: `fit`'s).
    #[arg(long)]
    normal_weight: Option<f32>,
    /// Weight of the residual regulariser in fine-tuning (default: `fit`'s).
    #[arg(long)]
    residual_weight: Option<f32>,
    /// Write the fine-tuning captures into this folder and keep them (named
    /// s<subject>_<outfit>_<setting>), to inspect or fit them by hand.
    #[arg(long)]
    keep_captures: Option<PathBuf>,
    /// Diagnostic: save each fitted MetaAvatar as DIR/<capture>.avatar (with --keep-captures,
    /// `examples/posed_errors` then measures changes to posing without a refit).
    #[arg(long, value_name = "DIR")]
    save_avatars: Option<PathBuf>,
    /// Free-space samples (outside constraints on the camera rays) among each pose's
    /// off-surface points, 0 to turn them off (default: `fit`'s).
    #[arg(long)]
    free_space: Option<usize>,
    /// Fitting errors of user captures: DEGREES,CENTIMETRES RMS per joint and of the
    /// translation (default 3,1; 0,0 gives user captures with exact fittings). Also spelled
    /// `--fit-error`.
    #[arg(long, alias = "fit-error")]
    fitting_error: Option<String>,
    /// Joint refinement of the fine-tuning frames' poses in the hypernetwork rows (`fit`'s
    /// --refine-poses): on or off (default: `fit`'s).
    #[arg(long, value_parser = ["on", "off"])]
    refine_poses: Option<String>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let p = preset(&args.preset)?;
    if args.markdown.as_ref() == Some(&args.out) {
        bail!("--markdown and --out are the same file ({}): give two paths", args.out.display());
    }
    let inputs = avatar_core::io::Inputs::new().maybe_file(args.model.as_ref());
    inputs.check_file(&args.out, &["json"])?;
    if let Some(md) = &args.markdown {
        inputs.clone().file(&args.out).check_file(md, &["md"])?;
    }
    let protocol = args.protocol.as_deref().unwrap_or(p.protocol);
    let protocols = Protocol::parse_list(protocol).with_context(|| {
        format!("unknown protocol {protocol:?}: use interpolation, extrapolation, few-shot or all")
    })?;
    let subjects = args.subjects.unwrap_or(p.subjects);
    if subjects == 0 || subjects > EVAL_SUBJECT_SEEDS.len() {
        bail!("--subjects must be between 1 and {}", EVAL_SUBJECT_SEEDS.len());
    }
    let workdir = std::env::temp_dir().join(format!("avatar-studio-eval-{}", std::process::id()));
    let mut config = EvalConfig::paper(protocols, workdir);
    config.field_cache = avatar_studio::cache::field_cache().clone();
    config.captures = CaptureConditions::parse_list(
        args.captures.as_deref().unwrap_or(p.captures),
        args.noise.as_deref(),
    )?;
    config.subjects.truncate(subjects);
    if let Some(text) = &args.fitting_error {
        let values: Vec<f32> = text
            .split(',')
            .map(|v| v.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .unwrap_or_default();
        let [deg, cm] = values[..] else {
            bail!("--fitting-error {text:?}: expected DEGREES,CENTIMETRES (for example 5,2)");
        };
        if !(0.0..=45.0).contains(&deg) || !(0.0..=50.0).contains(&cm) {
            bail!("--fitting-error {deg},{cm} is out of range (0 to 45 degrees, 0 to 50 cm)");
        }
        for c in config.captures.iter_mut().filter(|c| c.name == "user") {
            c.fitting_error =
                avatar_core::eval::conditions::FittingError { joint_deg: deg, trans_m: cm / 100.0 };
        }
    }
    let outfits: Vec<String> =
        args.outfits.clone().unwrap_or_else(|| p.outfits.iter().map(|o| o.to_string()).collect());
    let outfits: Vec<String> =
        if outfits == ["all"] { ALL.iter().map(|o| o.to_string()).collect() } else { outfits };
    config.outfits = outfits.iter().map(|n| Outfit::from_name(n)).collect::<Result<_, _>>()?;
    config.heldout_stride = args.stride.unwrap_or(p.stride).max(1);
    config.metrics.chamfer_samples = args.chamfer_samples.unwrap_or(p.chamfer_samples).max(100);
    let iou_resolution = args.iou_resolution.unwrap_or(p.iou_resolution);
    if !(16..=512).contains(&iou_resolution) {
        bail!("--iou-resolution {iou_resolution} is out of range (16 to 512)");
    }
    config.metrics.iou_resolution = iou_resolution;
    config.seed = args.seed;
    config.contact_sheets = args.contact_sheets.clone();
    if let Some(dir) = &args.keep_captures {
        config.workdir = dir.clone();
        config.keep_captures = true;
    }
    let row_names: Vec<String> = match &args.rows {
        Some(r) if r.len() == 1 && r[0] == "none" => Vec::new(),
        Some(r) => r.clone(),
        None => p.rows.iter().map(|r| r.to_string()).collect(),
    };
    let (steps, resolution) =
        (args.steps.unwrap_or(p.steps), args.resolution.unwrap_or(p.resolution));
    let resolution = MeshResolution::new(resolution)?;
    if args.max_frames == 0 {
        bail!("--max-frames must be at least 1");
    }
    let body = avatar_core::body::open_body_ref();
    let mut rows: Vec<Box<dyn Predictor>> = vec![Box::new(NakedBody::new(body.clone()))];
    // Loaded by the first neural row (the reference rows need none).
    let mut model: Option<std::sync::Arc<MetaModel>> = None;
    let defaults = HyperFitOptions::default();
    let options = HyperFitOptions {
        steps: steps.max(1),
        seed: args.seed,
        lr_heads: args.lr_heads.unwrap_or(defaults.lr_heads),
        lr_encoder: args.lr_encoder.unwrap_or(defaults.lr_encoder),
        lr_sdf: args.lr_sdf.unwrap_or(defaults.lr_sdf),
        residual_weight: args.residual_weight.unwrap_or(defaults.residual_weight),
        poses_per_step: args.poses_per_step.unwrap_or(defaults.poses_per_step).max(1),
        surface_per_pose: args.points_per_pose.unwrap_or(defaults.surface_per_pose).max(1),
        off_per_pose: args.points_per_pose.unwrap_or(defaults.off_per_pose).max(1),
        free_space_per_pose: args.free_space.unwrap_or(defaults.free_space_per_pose),
        weights: IgrWeights {
            normal: args.normal_weight.unwrap_or(defaults.weights.normal),
            ..defaults.weights
        },
        refine_poses: match args.refine_poses.as_deref() {
            Some(v) => avatar_neural::training::pose_refine::PoseRefineOptions {
                enabled: v == "on",
                ..defaults.refine_poses
            },
            None => defaults.refine_poses,
        },
        ..defaults
    };
    for name in &row_names {
        let kind = match name.as_str() {
            "meta" => RowKind::MetaLearned,
            "scratch" => RowKind::FromScratch,
            "static" => RowKind::StaticMetaSdf,
            "outfit-static" => {
                rows.push(Box::new(StaticOutfit::new(body.clone())));
                continue;
            }
            "outfit-static-field" => {
                rows.push(Box::new(StaticOutfit::with_body_field(
                    body.clone(),
                    avatar_core::canonical::FieldOptions::default(),
                )));
                continue;
            }
            other => bail!(
                "unknown --rows entry {other:?}: use meta, scratch, static, outfit-static, outfit-static-field or none"
            ),
        };
        let model = match &model {
            Some(m) => m.clone(),
            None => model
                .insert(std::sync::Arc::new(MetaModel::load_or_shipped(args.model.as_deref())?))
                .clone(),
        };
        rows.push(Box::new(
            NeuralRow::new(kind, model, options.clone(), args.max_frames, resolution)
                .saving_avatars(args.save_avatars.clone()),
        ));
    }
    eprintln!(
        "eval: preset {}, {} setting(s) x {} outfit(s) x {} subject(s), {} row(s)",
        args.preset,
        config.captures.len() * config.protocols.len(),
        config.outfits.len(),
        subjects,
        rows.len()
    );
    let t = std::time::Instant::now();
    let report = run_eval(body, &config, &mut rows, &|msg| eprintln!("eval: {msg}"))?;
    report.save_json(&args.out)?;
    let table = report.markdown();
    if let Some(md) = &args.markdown {
        avatar_core::io::write_bytes_atomic(md, table.as_bytes())?;
    }
    print!("{table}");
    eprintln!("eval: done in {:.1} s", t.elapsed().as_secs_f64());
    Ok(())
}
