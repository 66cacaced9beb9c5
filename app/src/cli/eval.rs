//! `avatar-studio eval`: run an evaluation protocol on held-out synthetic subjects and write a
//! JSON report and a Markdown table.

use anyhow::{bail, Context};
use avatar_core::eval::dataset::EVAL_SUBJECT_SEEDS;
use avatar_core::eval::{run as run_eval, EvalConfig, NakedBody, Predictor, Protocol};
use avatar_core::synth::Outfit;
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
}

pub fn run(args: Args) -> anyhow::Result<()> {
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
