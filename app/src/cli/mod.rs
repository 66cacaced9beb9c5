//! Subcommands, one module each. Each module exposes `Args` (clap) and `run`.

mod bench;
mod body;
mod canonicalize;
mod check;
mod collective;
mod eval;
mod export;
mod fit;
mod fit_progress;
mod import;
mod meta_train;
mod pose;
mod synth;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "avatar-studio",
    version,
    about = "Turn a few depth images of a clothed person into an animatable 3D avatar."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    #[command(flatten)]
    pub studio: StudioArgs,
}

/// Options of the studio window (no subcommand).
#[derive(clap::Args, Debug, Default)]
pub struct StudioArgs {
    /// A capture folder, an OBJ scan or a project (.studio.json) to open instead of the demo;
    /// a motion file (JSON, npz, BVH) opens with the demo.
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

// Parsed once per run; boxing the larger subcommands' arguments buys nothing.
#[allow(clippy::large_enum_variant)]
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
    /// Whether an avatar's surface is whole: holes, torn or folded parts, inside-out patches.
    Check(check::Args),
}

/// Run a subcommand (no subcommand opens the studio: main.rs).
pub fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Body(a) => body::run(a),
        Command::Synth(a) => synth::run(a),
        Command::Canonicalize(a) => canonicalize::run(a),
        Command::Eval(a) => eval::run(a),
        Command::MetaTrain(a) => meta_train::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Import(a) => import::run(a),
        Command::Pose(a) => pose::run(a),
        Command::Export(a) => export::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Check(a) => check::run(a),
    }
}

/// Where training runs (`fit`, `meta-train`).
#[derive(clap::Args)]
pub struct DeviceArg {
    /// cpu (the training path), gpu in a build with the `gpu` feature (`cargo build --release --features gpu`), or
    /// cpu-burn (burn's autodiff on the CPU: the reference, about 5x slower).
    #[arg(long, default_value = "cpu")]
    device: String,
}

impl DeviceArg {
    /// Where the fits of this command train (refused with the reason when this build lacks it).
    pub fn compute(&self) -> anyhow::Result<avatar_neural::compute::Compute> {
        Ok(avatar_neural::compute::Compute::parse(&self.device)?)
    }
}
