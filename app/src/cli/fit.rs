//! `avatar-studio fit`: fit an avatar to a capture. This build fits the static SDF avatar
//! (a SIREN trained from scratch on the canonicalized depth points); the meta-learned,
//! pose-conditioned avatar of issue 6 will take over the same command.

use anyhow::bail;
use avatar_neural::{FitOptions, SirenConfig, StaticAvatar};
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Capture folder (with capture.json).
    capture: PathBuf,
    /// Output avatar file (NAME.avatar).
    #[arg(long)]
    out: PathBuf,
    /// Use the first N usable frames.
    #[arg(long, default_value_t = 8)]
    frames: usize,
    /// Optimisation steps.
    #[arg(long, default_value_t = 500)]
    steps: usize,
    /// Network size: compact (4 x 128) or paper (5 x 256).
    #[arg(long, default_value = "compact")]
    preset: String,
    /// cpu (gpu needs a build with the `gpu` feature, not in this build).
    #[arg(long, default_value = "cpu")]
    device: String,
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let siren = match args.preset.as_str() {
        "compact" => SirenConfig::compact(),
        "paper" => SirenConfig::paper(),
        other => bail!("unknown --preset {other:?}: use compact or paper"),
    };
    if args.device != "cpu" {
        bail!("--device {}: this build has the CPU backend only", args.device);
    }
    if args.steps == 0 || args.frames == 0 {
        bail!("--steps and --frames must be at least 1");
    }
    let options = FitOptions { steps: args.steps, seed: args.seed, ..FitOptions::default() };
    let t = Instant::now();
    let steps = args.steps;
    let mut progress = |step: usize, loss: f32, terms: [f32; 4]| {
        let done = (step + 1) as f64 / steps as f64;
        let left = t.elapsed().as_secs_f64() * (1.0 - done) / done.max(1e-9);
        eprint!(
            "\rfit: step {:>5}/{steps} loss {loss:>9.3} (surface {:.3} normal {:.3} off {:.3} eikonal {:.3}) {:>4.0} s left ",
            step + 1,
            terms[0],
            terms[1],
            terms[2],
            terms[3],
            left
        );
        let _ = std::io::stderr().flush();
    };
    let (avatar, report) = StaticAvatar::fit_capture(&args.capture, args.frames, siren, &options, None, &mut progress)?;
    eprintln!();
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    avatar.save(&args.out)?;
    println!(
        "wrote {}: static SDF avatar ({} x {}), {} frames, {} canonical points ({} dropped), {:.1} s",
        args.out.display(),
        siren.layers,
        siren.hidden,
        report.frames,
        report.points,
        report.dropped,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
