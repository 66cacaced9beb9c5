//! A long depth video: the frames a fit takes are chosen over the whole take (poses, views of
//! the body, time) from the manifest alone, and a capture too large to hold whole is refused
//! before any depth image is read, while its chosen frames still open.

use avatar_core::body::open_body_ref;
use avatar_core::capture::{
    Capture, CaptureManifest, CaptureOptions, CaptureSource, FrameChoice, MAX_OPEN_BYTES,
};
use avatar_core::motion::{MotionClip, library};
use avatar_core::synth::{Outfit, SynthJob, generate_capture};
use glam::{Quat, Vec3};
use std::path::Path;

/// Frames of each library clip kept in the long take (every 6th of its 72-96).
const STRIDE: usize = 6;

/// Every library clip back to back, every 6th frame (a 13-clip take), and where each clip
/// starts in it.
fn long_clip() -> (MotionClip, Vec<usize>) {
    let (mut frames, mut starts) = (Vec::new(), Vec::new());
    for clip in library::library() {
        starts.push(frames.len());
        frames.extend(clip.frames.iter().step_by(STRIDE).cloned());
    }
    (MotionClip::new("long_take", 5.0, frames), starts)
}

/// The long take rendered as a capture (no ground truth), the person turning 7 degrees a
/// frame.
fn long_capture(dir: &Path) -> Vec<usize> {
    let (clip, starts) = long_clip();
    let mut job = SynthJob::new(3, Outfit::LongsleeveTrousers, clip);
    job.turn_per_frame_deg = 7.0;
    job.write_ground_truth = false;
    generate_capture(dir, open_body_ref(), &job).unwrap();
    starts
}

/// Which clip of the take frame `i` belongs to.
fn clip_of(starts: &[usize], i: usize) -> usize {
    starts.iter().rposition(|&s| s <= i).unwrap()
}

/// The direction the camera sees the body from, in the body's frame.
fn view(manifest: &CaptureManifest, i: usize) -> Vec3 {
    let rec = &manifest.frames[i];
    let p = rec.params().unwrap();
    let to_camera = rec.camera_to_world().unwrap().w_axis.truncate() - p.trans;
    (Quat::from_scaled_axis(p.pose[0]).inverse() * to_camera).normalize()
}

#[test]
fn the_choice_spans_the_whole_take_its_clips_and_the_sides_of_the_body() {
    let dir = tempfile::tempdir().unwrap();
    let starts = long_capture(dir.path());
    let manifest = CaptureManifest::load(dir.path()).unwrap();
    let n = manifest.frames.len();
    assert!(n > 150, "{n} frames");
    let chosen = FrameChoice::first(&manifest, 32);
    assert_eq!(chosen.len(), 32);
    assert!(chosen.windows(2).all(|w| w[0] < w[1]), "sorted, distinct: {chosen:?}");
    assert_eq!(chosen, FrameChoice::first(&manifest, 32), "deterministic");
    // Every eighth of the take has a chosen frame; the first 32 frames cover one eighth.
    for part in 0..8 {
        let (lo, hi) = (part * n / 8, (part + 1) * n / 8);
        assert!(chosen.iter().any(|&i| (lo..hi).contains(&i)), "nothing in {lo}..{hi}: {chosen:?}");
    }
    // Every clip of the take (each a different kind of motion) gives a frame, but "turn",
    // which only turns the body (the generator turns it anyway: its views are chosen from the
    // other clips); the first 32 frames hold three clips.
    let mut clips: Vec<usize> = chosen.iter().map(|&i| clip_of(&starts, i)).collect();
    clips.dedup();
    let turn = library::clip_names().iter().position(|&c| c == "turn").unwrap();
    let others: Vec<usize> = (0..starts.len()).filter(|&c| c != turn).collect();
    assert!(others.iter().all(|c| clips.contains(c)), "clips {clips:?} of {}", starts.len());
    assert!(clip_of(&starts, 31) < 3);
    // The body is seen from the front, the back and both sides.
    for side in [Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::X] {
        let best = chosen.iter().map(|&i| view(&manifest, i).dot(side)).fold(-1.0, f32::max);
        assert!(best > 0.8, "no frame sees the body from {side}: best cosine {best}");
    }
    // A short prefix of the choice is spread too.
    let eight = FrameChoice::first(&manifest, 8);
    assert!(eight[7] - eight[0] > n * 3 / 4, "{eight:?} of {n}");
    // The whole order visits every frame once.
    let mut all: Vec<usize> = FrameChoice::new(&manifest).collect();
    all.sort_unstable();
    assert_eq!(all, (0..n).collect::<Vec<_>>());
}

#[test]
fn a_frame_whose_fitting_cannot_be_read_comes_last() {
    let dir = tempfile::tempdir().unwrap();
    long_capture(dir.path());
    let mut manifest = CaptureManifest::load(dir.path()).unwrap();
    manifest.frames[0].pose = None;
    let order: Vec<usize> = FrameChoice::new(&manifest).collect();
    assert_eq!(order.last(), Some(&0));
    assert_eq!(order[0], 1, "the first readable frame starts the choice");
}

#[test]
fn a_capture_too_large_to_open_whole_is_refused_by_name_but_its_chosen_frames_open() {
    let dir = tempfile::tempdir().unwrap();
    long_capture(dir.path());
    let mut manifest = CaptureManifest::load(dir.path()).unwrap();
    let n = manifest.frames.len();
    let intr = manifest.intrinsics;
    // Enough frames that every pixel of every frame as a point (28 bytes) passes the limit:
    // the take looped, each copy naming the take's own depth files.
    let needed = (MAX_OPEN_BYTES / (intr.width as u64 * intr.height as u64 * 28)) as usize + 1;
    let take = manifest.frames.clone();
    manifest.frames = take.iter().cycle().take(needed.max(n)).cloned().collect();
    let long = tempfile::tempdir().unwrap();
    for rec in &mut manifest.frames {
        rec.depth = dir.path().join(&rec.depth).to_string_lossy().into_owned();
    }
    manifest.save(long.path()).unwrap();
    let err = Capture::open(long.path()).unwrap_err().to_string();
    assert!(err.contains("capture.json") && err.contains("too large to open whole"), "{err}");
    assert!(err.contains(&format!("{} frames", manifest.frames.len())), "{err}");
    // Refused before any depth is read: with every depth file gone, the same refusal.
    let missing = tempfile::tempdir().unwrap();
    let mut gone = manifest.clone();
    for rec in &mut gone.frames {
        rec.depth = "depth/missing.png".into();
    }
    gone.save(missing.path()).unwrap();
    let err = Capture::open(missing.path()).unwrap_err().to_string();
    assert!(err.contains("too large to open whole"), "{err}");
    // The fit's way in: choose, then read only the chosen frames.
    let source = CaptureSource::open(long.path(), &CaptureOptions::default()).unwrap();
    let mut choice = FrameChoice::new(&source.manifest);
    let mut capture = source.into_capture(Vec::new(), Vec::new());
    capture.read_chosen(&mut choice, 16, &CaptureOptions::default()).unwrap();
    assert_eq!(capture.frames.len(), 16);
    assert!(capture.warnings.is_empty(), "{:?}", capture.warnings);
    let (lo, hi) = capture
        .frames
        .iter()
        .fold((usize::MAX, 0), |(lo, hi), f| (lo.min(f.index), hi.max(f.index)));
    let total = manifest.frames.len();
    assert!(lo < total / 8 && hi > total * 7 / 8, "frames {lo}..{hi} of {total}");
}

#[test]
fn unusable_chosen_frames_are_replaced_by_the_next_of_the_choice() {
    let dir = tempfile::tempdir().unwrap();
    long_capture(dir.path());
    let manifest = CaptureManifest::load(dir.path()).unwrap();
    let first = FrameChoice::first(&manifest, 8);
    // Break the depth image of three of the first eight chosen frames.
    for &i in &first[1..4] {
        std::fs::write(dir.path().join(&manifest.frames[i].depth), "not a png").unwrap();
    }
    let source = CaptureSource::open(dir.path(), &CaptureOptions::default()).unwrap();
    let mut choice = FrameChoice::new(&source.manifest);
    let mut capture = source.into_capture(Vec::new(), Vec::new());
    capture.read_chosen(&mut choice, 8, &CaptureOptions::default()).unwrap();
    assert_eq!(capture.frames.len(), 8);
    let broken: Vec<usize> = capture.warnings.iter().map(|w| w.index).collect();
    assert_eq!(broken, first[1..4].to_vec());
    let eleven = FrameChoice::first(&manifest, 11);
    let mut read: Vec<usize> = capture.frames.iter().map(|f| f.index).collect();
    read.sort_unstable();
    let expected: Vec<usize> = eleven.into_iter().filter(|i| !first[1..4].contains(i)).collect();
    assert_eq!(read, expected);
}
