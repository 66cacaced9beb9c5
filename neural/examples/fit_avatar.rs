//! Fit a personal avatar to a capture and save it: the shipped meta-learned model fine-tuned
//! on the capture's canonicalized points, each frame's pose refined on the way. This is what
//! `avatar-studio fit` does, without its progress bar and checks.
//!
//! cargo run --release -p avatar-neural --example fit_avatar -- CAPTURE_DIR OUT.avatar [STEPS]
//!
//! `assets/demo` is a capture to start with; STEPS defaults to the product's 256 (a few
//! minutes on 2 cores; 16 shows the API in seconds). Next: `pose_and_export.rs` poses the
//! avatar and exports an animated glTF.

use avatar_core::canonical::FieldCache;
use avatar_neural::avatar::{AvatarFit, FitEvent, FitKind, fit_avatar};
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::{HyperFitOptions, Init, MetaModel};

fn main() -> avatar_neural::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let [_, capture_dir, out, ..] = &args[..] else {
        eprintln!("usage: fit_avatar CAPTURE_DIR OUT.avatar [STEPS]");
        std::process::exit(2);
    };
    let defaults = HyperFitOptions::default();
    let steps = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(defaults.steps);

    // Up to 32 usable frames chosen over the capture, their depth points canonicalized (the
    // skinning field cached where the program says: see core's open_capture example).
    let cache = FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"));
    let capture = CapturePoints::open(std::path::Path::new(capture_dir), 32, &cache)?;
    println!("{}", capture.choice_summary());

    // The fit: which avatar (the hypernetwork, from the shipped prior) and its options (steps,
    // rates, points a step, pose refinement, the device: `HyperFitOptions`'s fields).
    let prior = MetaModel::shipped();
    let fit = AvatarFit {
        kind: FitKind::Meta(Init::MetaLearned(&prior)),
        options: HyperFitOptions { steps, ..defaults },
        chunk: 0,
        cancel: None,
        trace: None,
    };
    let (avatar, report) = fit_avatar(&capture, &fit, &mut |event| {
        if let FitEvent::Progress { step, loss, .. } = event
            && step % 16 == 0
        {
            println!("step {step}: loss {loss:.4}");
        }
    })?;
    avatar.save(out)?;
    println!("{} frames, {} points: saved {out}", report.frames, report.points);
    Ok(())
}
