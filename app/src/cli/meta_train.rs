//! `avatar-studio meta-train`: MetaAvatar's meta-learning (Alg. 1 then Alg. 2) on synthetic
//! training subjects. Resumable: run the same command again after a kill.

use super::collective::or_abort;
use anyhow::{Context, bail};
use avatar_neural::HyperConfig;
use avatar_neural::MetaModel;
use avatar_neural::meta_data::{MetaData, MetaDataConfig};
use avatar_neural::meta_training::{MetaOptions, meta_train_collective, start_from_static};
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Meta-training data folder (generated there on the first run).
    #[arg(long)]
    data: PathBuf,
    /// Output folder: checkpoint.bin, loss.csv, meta-model.bin.
    #[arg(long)]
    out: PathBuf,
    /// Network preset: compact or paper.
    #[arg(long, default_value = "compact")]
    preset: String,
    /// Alg. 1 outer iterations.
    #[arg(long, default_value_t = 300)]
    sdf_iterations: usize,
    /// Alg. 2 outer iterations.
    #[arg(long, default_value_t = 400)]
    hyper_iterations: usize,
    /// Training subjects (seeds 1..=N) when generating data.
    #[arg(long, default_value_t = 24)]
    subjects: usize,
    /// Poses per subject and outfit when generating data.
    #[arg(long, default_value_t = 12)]
    poses: usize,
    /// Alg. 1's outer Adam learning rate.
    #[arg(long, default_value_t = 1e-4)]
    sdf_outer_lr: f64,
    /// Skip Alg. 1: start Alg. 2 from this meta-model's static meta-SDF (a fresh --out only).
    #[arg(long)]
    sdf_from: Option<PathBuf>,
    /// Alg. 2's inner Adam rates (heads and low-rank bases; bone encoder; base SDF) and outer
    /// rates (default: those of the shipped model).
    #[arg(long)]
    hyper_inner_lr_heads: Option<f64>,
    #[arg(long)]
    hyper_inner_lr_encoder: Option<f64>,
    #[arg(long)]
    hyper_inner_lr_sdf: Option<f64>,
    #[arg(long)]
    hyper_outer_lr_heads: Option<f64>,
    #[arg(long)]
    hyper_outer_lr_encoder: Option<f64>,
    #[arg(long)]
    hyper_outer_lr_sdf: Option<f64>,
    /// Alg. 1 tasks (posed frames) per outer iteration.
    #[arg(long, default_value_t = 3)]
    sdf_meta_batch: usize,
    /// Alg. 2 tasks per outer iteration, their updates averaged (1: the paper's Reptile; give
    /// a data-parallel run at least one per rank).
    #[arg(long, default_value_t = 1)]
    hyper_meta_batch: usize,
    #[command(flatten)]
    collective: super::collective::CollectiveArgs,
    #[command(flatten)]
    device: super::DeviceArg,
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    args.device.select()?;
    let config = HyperConfig::preset(&args.preset)
        .with_context(|| format!("unknown --preset {:?}: use compact or paper", args.preset))?;
    if args.subjects == 0 || args.poses == 0 {
        bail!("--subjects and --poses must be at least 1");
    }
    if args.hyper_meta_batch == 0 || args.sdf_meta_batch == 0 {
        bail!("--sdf-meta-batch and --hyper-meta-batch must be at least 1");
    }
    args.collective.transport()?;
    // The data folder's files and --sdf-from are inputs; the run writes these three files.
    let inputs = avatar_core::io::Inputs::new()
        .file(args.data.join("meta-data.json"))
        .file(args.data.join("samples.bin"))
        .maybe_file(args.sdf_from.as_ref());
    inputs.check_folder(&args.out)?;
    for (name, ext) in [("checkpoint.bin", "bin"), ("meta-model.bin", "bin"), ("loss.csv", "csv")] {
        inputs.check_file(&args.out.join(name), &[ext])?;
    }
    let body = avatar_core::body::open_body_ref();
    let data_config = MetaDataConfig {
        subjects: args.subjects,
        poses_per_group: args.poses,
        seed: args.seed,
        ..MetaDataConfig::default()
    };
    // Every rank joins first (waiting for the others); rank 0 makes the data folder before the
    // others read it (a shared disk) or generate their own copy (the same bits).
    let collective = args.collective.join()?;
    if !collective.is_root() {
        collective.barrier()?;
    }
    let data = MetaData::load_or_generate(&args.data, body, &data_config, &|m| eprintln!("{m}"));
    let data = or_abort(&collective, data)?;
    if collective.is_root() {
        collective.barrier()?;
    }
    let mut options = MetaOptions {
        config,
        sdf_iterations: args.sdf_iterations,
        hyper_iterations: args.hyper_iterations,
        sdf_outer_lr: args.sdf_outer_lr,
        sdf_meta_batch: args.sdf_meta_batch,
        hyper_meta_batch: args.hyper_meta_batch,
        seed: args.seed,
        ..MetaOptions::default()
    };
    let inner = &mut options.hyper_inner;
    inner.lr_heads = args.hyper_inner_lr_heads.unwrap_or(inner.lr_heads);
    inner.lr_encoder = args.hyper_inner_lr_encoder.unwrap_or(inner.lr_encoder);
    inner.lr_sdf = args.hyper_inner_lr_sdf.unwrap_or(inner.lr_sdf);
    let outer = &mut options.hyper_outer;
    outer.heads = args.hyper_outer_lr_heads.unwrap_or(outer.heads);
    outer.encoder = args.hyper_outer_lr_encoder.unwrap_or(outer.encoder);
    outer.sdf = args.hyper_outer_lr_sdf.unwrap_or(outer.sdf);
    if let Some(from) = args.sdf_from.as_ref().filter(|_| collective.is_root()) {
        let model = or_abort(&collective, MetaModel::load(from))?;
        or_abort(&collective, start_from_static(&args.out, &options, &model, from))?;
        eprintln!("meta-train: Alg. 1 skipped, static meta-SDF from {}", from.display());
    }
    eprintln!(
        "meta-train: {} preset ({} hypernetwork parameters), {} samples, {} + {} iterations, output {}",
        args.preset,
        config.num_params(),
        data.len(),
        options.sdf_iterations,
        options.hyper_iterations,
        args.out.display()
    );
    if collective.world() > options.sdf_meta_batch.min(options.hyper_meta_batch) {
        eprintln!(
            "meta-train: {} ranks for {} Alg. 1 and {} Alg. 2 tasks an iteration: some ranks wait (--hyper-meta-batch)",
            collective.world(),
            options.sdf_meta_batch,
            options.hyper_meta_batch
        );
    }
    let root = collective.is_root();
    let result = meta_train_collective(
        &data,
        &options,
        &args.out,
        None,
        &mut |p| {
            if !root {
                return;
            }
            let done = p.iteration as f64 / p.iterations.max(1) as f64;
            eprint!(
                "\rmeta-train: {} {:>5}/{} loss {:>9.3} {:>7.0} s",
                p.stage, p.iteration, p.iterations, p.loss, p.seconds
            );
            if p.iteration == p.iterations || done >= 1.0 {
                eprintln!();
            }
            let _ = std::io::stderr().flush();
        },
        &collective,
    );
    let path = or_abort(&collective, result)?;
    match root {
        true => println!("wrote {}", path.display()),
        false => println!("rank {} done; rank 0 wrote {}", collective.rank(), path.display()),
    }
    Ok(())
}
