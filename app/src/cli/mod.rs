//! Subcommands, one module each. Each module exposes `Args` (clap) and `run`.

mod bench;
mod bench_train;
mod body;
mod canonicalize;
mod eval;
mod export;
mod fit;
mod import;
mod meta_train;
mod pose;
mod synth;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "avatar-studio", version, about = "Turn a few depth images of a clothed person into an animatable 3D avatar.")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    #[command(flatten)]
    pub studio: StudioArgs,
}

/// Options of the studio window (no subcommand).
#[derive(clap::Args, Debug, Default)]
pub struct StudioArgs {
    /// A capture folder or a project (.studio.json) to open instead of the demo.
    #[arg(long, global = false)]
    pub open: Option<std::path::PathBuf>,
    /// Save a screenshot of the window here once it is idle, then exit (also
    /// AVATAR_STUDIO_SCREENSHOT).
    #[arg(long, hide = true)]
    pub screenshot: Option<std::path::PathBuf>,
    /// Print start-up timings to stderr (also AVATAR_STUDIO_TIMING=1).
    #[arg(long, hide = true)]
    pub timing: bool,
    /// Start the quick fine-tuning configuration as soon as the capture is open.
    #[arg(long, hide = true)]
    pub quick_fit: bool,
    /// Once idle, play the clip; after its bake print the frames drawn a second, then exit.
    #[arg(long, hide = true)]
    pub measure_playback: bool,
}

#[derive(Subcommand)]
pub enum Command {
    /// Pose the embedded open body (or your SMPL .npz) and write a mesh.
    Body(body::Args),
    /// Generate synthetic clothed-human captures with ground truth.
    Synth(synth::Args),
    /// Map a capture's depth points to the canonical (unposed) space.
    Canonicalize(canonicalize::Args),
    /// Run an evaluation protocol and write a JSON report and a Markdown table.
    Eval(eval::Args),
    /// Meta-train the SDF and hypernetwork on synthetic people.
    MetaTrain(meta_train::Args),
    /// Fine-tune a personal avatar from a capture.
    Fit(fit::Args),
    /// Make a capture folder from depth images with fittings, or from a 3D scan (OBJ).
    Import(import::Args),
    /// Pose an avatar along a motion clip and write meshes.
    Pose(pose::Args),
    /// Export an animated binary glTF.
    Export(export::Args),
    /// Run the benchmarks and print a report.
    Bench(bench::Args),
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        None => headless_summary(),
        Some(Command::Body(a)) => body::run(a),
        Some(Command::Synth(a)) => synth::run(a),
        Some(Command::Canonicalize(a)) => canonicalize::run(a),
        Some(Command::Eval(a)) => eval::run(a),
        Some(Command::MetaTrain(a)) => meta_train::run(a),
        Some(Command::Fit(a)) => fit::run(a),
        Some(Command::Import(a)) => import::run(a),
        Some(Command::Pose(a)) => pose::run(a),
        Some(Command::Export(a)) => export::run(a),
        Some(Command::Bench(a)) => bench::run(a),
    }
}

/// Until the studio window exists, running with no subcommand poses the embedded body and
/// reports what is available.
fn headless_summary() -> anyhow::Result<()> {
    body::summary()
}

/// Placeholder error for subcommands whose implementation has not landed yet.
#[allow(dead_code)]
pub(crate) fn not_yet(name: &str) -> anyhow::Result<()> {
    anyhow::bail!("`avatar-studio {name}` is not implemented yet in this build")
}
