//! `avatar-studio meta-train`: MetaAvatar's meta-learning (Alg. 1 then Alg. 2) on synthetic
//! training subjects, or on a folder of the studio's own captures and scans
//! (`avatar_core::own_data`, docs/own-data.md; `--dry-run` lists it). Resumable: run the same
//! command again after a kill.

use super::collective::or_abort;
use anyhow::{Context, bail};
use avatar_core::own_data::{discover, looks_like_own_data};
use avatar_neural::HyperConfig;
use avatar_neural::MetaModel;
use avatar_neural::data::meta_data::{MetaData, MetaDataConfig};
use avatar_neural::data::own_data::{OwnDataOptions, fingerprint, prepare};
use avatar_neural::training::meta_training::{
    MetaOptions, meta_train_collective, start_from_static,
};
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Meta-training data folder: synthetic data (generated there on the first run when the
    /// folder is missing or empty), or a folder of your own captures and scans laid out as
    /// DIR/<subject>/<outfit>/ (docs/own-data.md).
    #[arg(long)]
    data: PathBuf,
    /// Own data: list what was found per subject and outfit and every refused item with its
    /// reason, then stop (nothing is trained or written).
    #[arg(long)]
    dry_run: bool,
    /// Own data: the most frames taken from one capture (chosen over the take).
    #[arg(long, default_value_t = 12)]
    frames_per_capture: usize,
    /// Output folder: checkpoint.bin, loss.csv, meta-model.bin.
    #[arg(long, required_unless_present = "dry_run")]
    out: Option<PathBuf>,
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
    /// Outfits when generating data (comma-separated): the default four, and optionally the
    /// simulated sim_skirt and sim_cape, which the shipped prior holds out.
    #[arg(long, value_delimiter = ',', default_values_t = avatar_core::eval::dataset::TRAIN_OUTFITS.map(|o| o.name().to_string()))]
    outfits: Vec<String>,
    /// Poses per subject and outfit when generating data.
    #[arg(long, default_value_t = 12)]
    poses: usize,
    /// Alg. 1's outer Adam learning rate.
    #[arg(long, default_value_t = 1e-4)]
    sdf_outer_lr: f64,
    /// Skip Alg. 1: start Alg. 2 from this meta-model's static meta-SDF (a fresh --out only):
    /// a meta-model.bin, or `shipped` for the prior built into the program (own data's
    /// recommended start: docs/own-data.md).
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
    /// Alg. 1 tasks (posed frames) per outer iteration (default: 3, or one per rank when a
    /// data-parallel run has more ranks).
    #[arg(long)]
    sdf_meta_batch: Option<usize>,
    /// Alg. 2 tasks per outer iteration, their updates averaged (default: 1, the paper's
    /// Reptile and the shipped model's, or one per rank when a data-parallel run has more
    /// ranks). Give it to make runs on different numbers of ranks the same run.
    #[arg(long)]
    hyper_meta_batch: Option<usize>,
    #[command(flatten)]
    collective: super::collective::CollectiveArgs,
    #[command(flatten)]
    device: super::DeviceArg,
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let compute = args.device.compute()?;
    let config = HyperConfig::preset(&args.preset)
        .with_context(|| format!("unknown --preset {:?}: use compact or paper", args.preset))?;
    if args.subjects == 0 || args.poses == 0 {
        bail!("--subjects and --poses must be at least 1");
    }
    let own = looks_like_own_data(&args.data);
    if args.dry_run && !own {
        bail!(
            "--dry-run lists a folder of your own data (DIR/<subject>/<outfit>/...); {} is not one (docs/own-data.md)",
            args.data.display()
        );
    }
    if args.hyper_meta_batch == Some(0) || args.sdf_meta_batch == Some(0) {
        bail!("--sdf-meta-batch and --hyper-meta-batch must be at least 1");
    }
    args.collective.transport()?;
    if args.frames_per_capture == 0 {
        bail!("--frames-per-capture must be at least 1");
    }
    // The data folder (all of it, for own data) and --sdf-from are inputs; the run writes
    // these three files.
    let inputs = if own {
        avatar_core::io::Inputs::new().capture(&args.data)
    } else {
        avatar_core::io::Inputs::new()
            .file(args.data.join("meta-data.json"))
            .file(args.data.join("samples.bin"))
    }
    .maybe_file(args.sdf_from.as_ref().filter(|p| !is_shipped(p)));
    if let Some(out) = &args.out {
        inputs.check_folder(out)?;
        for (name, ext) in [
            ("checkpoint.bin", "bin"),
            ("meta-model.bin", "bin"),
            ("loss.csv", "csv"),
            ("own-data/meta-data.json", "json"),
            ("own-data/samples.bin", "bin"),
        ] {
            inputs.check_file(&out.join(name), &[ext])?;
        }
    }
    if args.dry_run {
        load_data(&args, own)?;
        return Ok(());
    }
    let Some(out) = args.out.as_deref() else {
        bail!("--out is needed to train (only --dry-run goes without it)");
    };
    // Every rank joins first (waiting for the others); rank 0 makes the data (generates it, or
    // prepares own data's samples) before the others read it (a shared disk) or make their own
    // copy (the same bits).
    let collective = args.collective.join()?;
    if !collective.is_root() {
        collective.barrier()?;
    }
    let data = match load_data(&args, own) {
        Err(e) if collective.world() > 1 => {
            eprintln!("error: rank {}: {e:#}", collective.rank());
            collective.abort_run(1);
            return Err(e);
        }
        r => r?.context("no data to train on")?,
    };
    if collective.is_root() {
        collective.barrier()?;
    }
    let mut options = MetaOptions {
        config,
        sdf_iterations: args.sdf_iterations,
        hyper_iterations: args.hyper_iterations,
        sdf_outer_lr: args.sdf_outer_lr,
        seed: args.seed,
        compute,
        ..MetaOptions::default()
    };
    options.sdf_meta_batch =
        meta_batch(args.sdf_meta_batch, options.sdf_meta_batch, collective.world());
    options.hyper_meta_batch =
        meta_batch(args.hyper_meta_batch, options.hyper_meta_batch, collective.world());
    let inner = &mut options.hyper_inner;
    inner.lr_heads = args.hyper_inner_lr_heads.unwrap_or(inner.lr_heads);
    inner.lr_encoder = args.hyper_inner_lr_encoder.unwrap_or(inner.lr_encoder);
    inner.lr_sdf = args.hyper_inner_lr_sdf.unwrap_or(inner.lr_sdf);
    let outer = &mut options.hyper_outer;
    outer.heads = args.hyper_outer_lr_heads.unwrap_or(outer.heads);
    outer.encoder = args.hyper_outer_lr_encoder.unwrap_or(outer.encoder);
    outer.sdf = args.hyper_outer_lr_sdf.unwrap_or(outer.sdf);
    if let Some(from) = args.sdf_from.as_ref().filter(|_| collective.is_root()) {
        let model = if is_shipped(from) {
            MetaModel::shipped()
        } else {
            or_abort(&collective, MetaModel::load(from))?
        };
        or_abort(&collective, start_from_static(out, &options, &model, from))?;
        eprintln!("meta-train: Alg. 1 skipped, static meta-SDF from {}", from.display());
    }
    eprintln!(
        "meta-train: {} preset ({} hypernetwork parameters), {} samples, {} + {} iterations of {} + {} tasks on {} rank(s), output {}",
        args.preset,
        config.num_params(),
        data.len(),
        options.sdf_iterations,
        options.hyper_iterations,
        options.sdf_meta_batch,
        options.hyper_meta_batch,
        collective.world(),
        out.display()
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
        out,
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

/// Tasks an outer iteration: the one given, else the default raised to one task per rank, so
/// that by default every rank of a data-parallel run has work (weak scaling). An explicit
/// batch keeps the run the same on any number of ranks.
fn meta_batch(given: Option<usize>, default: usize, world: usize) -> usize {
    given.unwrap_or(default.max(world))
}

/// The data to train on: own data (found, checked, its samples prepared or reused from
/// OUT/own-data) or the synthetic generator's; `None` after a dry run's listing.
fn load_data(args: &Args, own: bool) -> anyhow::Result<Option<MetaData>> {
    let data = if own {
        let found = discover(&args.data)?;
        eprint!("meta-train: own data in {}", found.summary());
        if args.dry_run {
            if found.groups.is_empty() {
                bail!("no usable item in {}: {} refused", args.data.display(), found.refused.len());
            }
            println!(
                "dry run: {} items in {} subject-outfit groups would be used, {} refused",
                found.items(),
                found.groups.len(),
                found.refused.len()
            );
            return Ok(None);
        }
        let options = OwnDataOptions {
            frames_per_capture: args.frames_per_capture,
            seed: args.seed,
            field_cache: avatar_studio::cache::field_cache().clone(),
            ..OwnDataOptions::default()
        };
        // The samples are kept in OUT/own-data and reused while the items are unchanged.
        let out = args.out.as_deref().context("--out is needed to train")?;
        let cache = out.join("own-data");
        let print = fingerprint(&found, &options);
        let cached = MetaData::load(&cache).ok().filter(|d| {
            d.manifest
                .source
                .as_deref()
                .is_some_and(|s| s.ends_with(&format!("fingerprint {print}")))
        });
        if let Some(data) = cached {
            eprintln!(
                "meta-train: the samples prepared in {} ({} samples in {} groups; the items are unchanged)",
                cache.display(),
                data.len(),
                data.manifest.groups.len()
            );
            data
        } else {
            let own = prepare(&found, &options, &mut |m| eprintln!("meta-train: {m}"))?;
            let newly: Vec<_> = own.skipped.iter().skip(found.refused.len()).collect();
            for r in &newly {
                eprintln!("meta-train: skipped {r}");
            }
            eprintln!(
                "meta-train: {} items used ({} samples in {} groups), {} skipped ({} refused by the checks, {} while canonicalizing)",
                own.items_used,
                own.data.len(),
                own.data.manifest.groups.len(),
                own.skipped.len(),
                found.refused.len(),
                newly.len()
            );
            own.data.save(&cache)?;
            own.data
        }
    } else {
        let body = avatar_core::body::open_body_ref();
        let data_config = MetaDataConfig {
            subjects: args.subjects,
            poses_per_group: args.poses,
            outfits: args.outfits.clone(),
            seed: args.seed,
            ..MetaDataConfig::default()
        };
        MetaData::load_or_generate(&args.data, body, &data_config, &|m| eprintln!("{m}"))?
    };
    Ok(Some(data))
}

/// `--sdf-from shipped`: the prior built into the program (a file of that name, if there is
/// one, is the file).
fn is_shipped(path: &Path) -> bool {
    path == Path::new("shipped") && !path.exists()
}

#[cfg(test)]
mod tests {
    use super::meta_batch;

    #[test]
    fn the_default_meta_batch_gives_every_rank_a_task() {
        // One process keeps the shipped model's batches (3 Alg. 1 tasks, 1 Alg. 2 task).
        assert_eq!(meta_batch(None, 3, 1), 3);
        assert_eq!(meta_batch(None, 1, 1), 1);
        // More ranks than tasks: one task per rank.
        assert_eq!(meta_batch(None, 1, 4), 4);
        assert_eq!(meta_batch(None, 3, 2), 3);
        assert_eq!(meta_batch(None, 3, 8), 8);
        // A batch given is kept on any number of ranks.
        assert_eq!(meta_batch(Some(2), 1, 8), 2);
        assert_eq!(meta_batch(Some(5), 3, 1), 5);
    }
}
