//! `avatar-studio eval`: run an evaluation protocol on held-out synthetic subjects and write a
//! JSON report and a Markdown table.

use anyhow::{bail, Context};
use avatar_core::eval::dataset::EVAL_SUBJECT_SEEDS;
use avatar_core::eval::{run as run_eval, EvalConfig, NakedBody, Predictor, Protocol, StaticOutfit};
use avatar_core::synth::Outfit;
use avatar_neural::eval_rows::{NeuralRow, RowKind};
use avatar_neural::loss::IgrWeights;
use avatar_neural::{HyperFitOptions, MetaModel};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// interpolation, extrapolation, few-shot (all six fractions) or all.
    #[arg(long, default_value = "all")]
    protocol: String,
    /// JSON report (written atomically).
    #[arg(long)]
    out: PathBuf,
    /// Also write the Markdown table here.
    #[arg(long)]
    markdown: Option<PathBuf>,
    /// Use the first N held-out subjects (at most 4).
    #[arg(long, default_value_t = 4)]
    subjects: usize,
    /// Outfits (default: longsleeve_trousers and the unseen blazer_tails).
    #[arg(long, value_delimiter = ',')]
    outfits: Option<Vec<String>>,
    /// Evaluate every n-th frame of the held-out clips.
    #[arg(long, default_value_t = 5)]
    stride: usize,
    /// Points sampled per surface for Chamfer-L2.
    #[arg(long, default_value_t = 10_000)]
    chamfer_samples: usize,
    /// Grid points along the longest side for IoU.
    #[arg(long, default_value_t = 128)]
    iou_resolution: usize,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Rows to add: meta (MetaAvatar), scratch (same networks from scratch), static (the static
    /// meta-SDF), outfit-static (the ground-truth outfit without its pose-dependent
    /// deformation: an exact pose-independent avatar), comma-separated.
    /// Default: none (the naked body and ground-truth rows only).
    #[arg(long, value_delimiter = ',')]
    rows: Vec<String>,
    /// Meta-learned model file (default: the shipped compact model).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Fine-tuning steps of every neural row (the same budget for each).
    #[arg(long, default_value_t = 256)]
    steps: usize,
    /// Fine-tune on at most this many of the protocol's frames.
    #[arg(long, default_value_t = 1000)]
    max_frames: usize,
    /// Marching-cubes resolution of the neural rows' meshes.
    #[arg(long, default_value_t = 128)]
    resolution: usize,
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
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let inputs = avatar_core::io::Inputs::new().maybe_file(args.model.as_ref());
    inputs.check_file(&args.out, &["json"])?;
    if let Some(md) = &args.markdown {
        inputs.clone().file(&args.out).check_file(md, &["md"])?;
    }
    let protocols = Protocol::parse_list(&args.protocol)
        .with_context(|| format!("unknown protocol {:?}: use interpolation, extrapolation, few-shot or all", args.protocol))?;
    if args.subjects == 0 || args.subjects > EVAL_SUBJECT_SEEDS.len() {
        bail!("--subjects must be between 1 and {}", EVAL_SUBJECT_SEEDS.len());
    }
    let mut config = EvalConfig::paper(protocols);
    config.subjects.truncate(args.subjects);
    if let Some(o) = &args.outfits {
        config.outfits = o.iter().map(|n| Outfit::from_name(n)).collect::<Result<_, _>>()?;
    }
    config.heldout_stride = args.stride.max(1);
    config.metrics.chamfer_samples = args.chamfer_samples.max(100);
    config.metrics.iou_resolution = args.iou_resolution.clamp(16, 512);
    config.seed = args.seed;
    let body = avatar_core::body::open_body_ref();
    let mut rows: Vec<Box<dyn Predictor>> = vec![Box::new(NakedBody::new(body.clone()))];
    // Loaded by the first neural row (the reference rows need none).
    let mut model: Option<std::sync::Arc<MetaModel>> = None;
    let defaults = HyperFitOptions::default();
    let options = HyperFitOptions {
        steps: args.steps.max(1),
        seed: args.seed,
        lr_heads: args.lr_heads.unwrap_or(defaults.lr_heads),
        lr_encoder: args.lr_encoder.unwrap_or(defaults.lr_encoder),
        lr_sdf: args.lr_sdf.unwrap_or(defaults.lr_sdf),
        residual_weight: args.residual_weight.unwrap_or(defaults.residual_weight),
        poses_per_step: args.poses_per_step.unwrap_or(defaults.poses_per_step).max(1),
        surface_per_pose: args.points_per_pose.unwrap_or(defaults.surface_per_pose).max(1),
        off_per_pose: args.points_per_pose.unwrap_or(defaults.off_per_pose).max(1),
        weights: IgrWeights { normal: args.normal_weight.unwrap_or(defaults.weights.normal), ..defaults.weights },
        ..defaults
    };
    for name in &args.rows {
        let kind = match name.as_str() {
            "meta" => RowKind::MetaLearned,
            "scratch" => RowKind::FromScratch,
            "static" => RowKind::StaticMetaSdf,
            "outfit-static" => {
                rows.push(Box::new(StaticOutfit::new(body.clone())));
                continue;
            }
            other => bail!("unknown --rows entry {other:?}: use meta, scratch, static or outfit-static"),
        };
        let model = match &model {
            Some(m) => m.clone(),
            None => model.insert(std::sync::Arc::new(MetaModel::load_or_shipped(args.model.as_deref())?)).clone(),
        };
        rows.push(Box::new(NeuralRow::new(kind, model, options.clone(), args.max_frames.max(1), args.resolution.clamp(16, 512))));
    }
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
