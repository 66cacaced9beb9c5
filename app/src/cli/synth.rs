//! `avatar-studio synth`: synthetic clothed-human captures with ground truth.

use anyhow::{Context, bail};
use avatar_core::body::open_body_ref;
use avatar_core::motion::{MotionClip, clip_file, open_clip};
use avatar_core::synth::{
    ALL_OUTFITS, DepthNoise, Outfit, SynthJob, contact_sheet::write_contact_sheet,
    generate_capture, save_scans, subject_betas,
};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Output folder. One combination of subject, outfit and clip is written straight into it;
    /// several go into sub-folders named `sNN_OUTFIT_CLIP`.
    #[arg(long)]
    out: PathBuf,
    /// Seed: subject k has shape seed `seed + k`; the depth noise is seeded from it too.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Number of subjects.
    #[arg(long, default_value_t = 1)]
    subjects: u64,
    /// Outfits, comma separated (tshirt_shorts, longsleeve_trousers, polo_loose, dress, blazer_tails).
    #[arg(long, value_delimiter = ',', default_value = "longsleeve_trousers")]
    outfits: Vec<String>,
    /// Motion clips from the library (by name) or clip files (.json / AMASS .npz), comma separated.
    #[arg(long, value_delimiter = ',', default_value = "walk")]
    clips: Vec<String>,
    /// Keep this many frames per clip, evenly spread (default: every frame).
    #[arg(long)]
    frames_per_clip: Option<usize>,
    /// Turn of the person between frames, degrees (the paper's protocol: 45).
    #[arg(long, default_value_t = 45.0)]
    turn: f32,
    /// Kinect-like noise and holes: kinect_v1 or kinect_v2.
    #[arg(long)]
    noise: Option<String>,
    /// Skip the ground truth (gt/), e.g. for a small demo capture.
    #[arg(long)]
    no_ground_truth: bool,
    /// Also write a contact sheet PNG of every outfit at three poses.
    #[arg(long)]
    contact_sheet: Option<PathBuf>,
    /// Write the layout of own meta-training data (`meta-train --data OUT`, docs/own-data.md):
    /// OUT/sSEED/OUTFIT/CLIP/ capture folders, or OUT/sSEED/OUTFIT/CLIP_FFFF.obj + .json scans
    /// (each frame's clothed surface and its fitting).
    #[arg(long, value_parser = ["captures", "scans"])]
    own_data: Option<String>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let inputs = args
        .clips
        .iter()
        .filter_map(|c| clip_file(c))
        .fold(avatar_core::io::Inputs::new(), |i, c| i.file(c));
    inputs.check_folder(&args.out)?;
    if !(args.turn.is_finite() && args.turn.abs() <= 360.0) {
        bail!("--turn {} is not an angle in degrees (-360 to 360)", args.turn);
    }
    if args.frames_per_clip == Some(0) {
        bail!("--frames-per-clip must be at least 1");
    }
    if let Some(sheet) = &args.contact_sheet {
        inputs.check_file(sheet, &["png"])?;
    }
    let body = open_body_ref();
    let outfits: Vec<Outfit> =
        args.outfits.iter().map(|o| Outfit::from_name(o)).collect::<Result<_, _>>()?;
    let clips: Vec<MotionClip> =
        args.clips.iter().map(|c| open_clip(c)).collect::<avatar_core::Result<_>>()?;
    let noise =
        match &args.noise {
            None => None,
            Some(n) => Some(DepthNoise::preset(n).with_context(|| {
                format!("unknown noise preset {n:?}: use kinect_v1 or kinect_v2")
            })?),
        };
    if args.subjects == 0 {
        bail!("--subjects must be at least 1");
    }
    let single =
        args.own_data.is_none() && args.subjects == 1 && outfits.len() == 1 && clips.len() == 1;
    let mut total = 0;
    for s in 0..args.subjects {
        for &outfit in &outfits {
            for clip in &clips {
                let own_dir = args.out.join(format!("s{:04}", args.seed + s)).join(outfit.name());
                let dir = if single {
                    args.out.clone()
                } else if args.own_data.is_some() {
                    own_dir.join(&clip.name)
                } else {
                    args.out.join(format!("s{s:02}_{}_{}", outfit.name(), clip.name))
                };
                let mut job = SynthJob::new(args.seed + s, outfit, clip.clone());
                job.frames = args.frames_per_clip;
                job.turn_per_frame_deg = args.turn;
                job.noise = noise;
                job.noise_seed = args.seed.wrapping_mul(1_000_003).wrapping_add(s);
                job.write_ground_truth = !args.no_ground_truth;
                if args.own_data.as_deref() == Some("scans") {
                    let n = save_scans(&own_dir, body, &job, &clip.name)?;
                    total += n;
                    eprintln!(
                        "{}: subject {} in {} doing {}: {n} scans",
                        own_dir.display(),
                        args.seed + s,
                        outfit.name(),
                        clip.name
                    );
                    continue;
                }
                let report = generate_capture(&dir, body, &job)?;
                total += report.frames;
                eprintln!(
                    "{}: subject {} in {} doing {}: {} frames, {} clothed vertices, {} depth pixels",
                    dir.display(),
                    args.seed + s,
                    outfit.name(),
                    clip.name,
                    report.frames,
                    report.vertices,
                    report.depth_pixels
                );
            }
        }
    }
    if let Some(path) = &args.contact_sheet {
        let poses = contact_sheet_poses();
        write_contact_sheet(path, body, &subject_betas(body, args.seed), &ALL_OUTFITS, &poses)?;
        eprintln!("contact sheet: {}", path.display());
    }
    let what = if args.own_data.as_deref() == Some("scans") { "scans" } else { "frames" };
    println!("wrote {total} {what}");
    Ok(())
}

/// Three poses that show the pose-dependent clothing: relaxed, a stride with bent elbows,
/// arms raised with a squat.
pub fn contact_sheet_poses() -> Vec<avatar_core::body::BodyParams> {
    use avatar_core::motion::{PoseBuilder, Side};
    let relaxed = PoseBuilder::relaxed();
    let mut stride = PoseBuilder::relaxed();
    stride
        .hip(Side::Left, 35.0, 0.0, 0.0)
        .hip(Side::Right, -20.0, 0.0, 0.0)
        .knee(Side::Right, 40.0)
        .elbow(Side::Left, 90.0)
        .elbow(Side::Right, 70.0);
    let mut raised = PoseBuilder::tpose();
    raised
        .shoulder(Side::Left, 70.0, 0.0, 0.0)
        .shoulder(Side::Right, 70.0, 0.0, 0.0)
        .hip(Side::Left, 60.0, 10.0, 0.0)
        .hip(Side::Right, 60.0, 10.0, 0.0)
        .knee(Side::Left, 90.0)
        .knee(Side::Right, 90.0);
    vec![relaxed.build(), stride.build(), raised.build()]
}
