//! How many frames a fit takes (`FrameCount`): `fit`'s default and the studio's panel take up
//! to their most and only refuse below their least; an exact count (`fit --frames N`) refuses
//! fewer usable frames, naming the bad one; a long capture gives frames from all of it.

use avatar_core::body::open_body_ref;
use avatar_core::canonical::FieldCache;
use avatar_core::capture::{CaptureManifest, FrameChoice};
use avatar_core::motion::{MotionClip, library};
use avatar_core::synth::{Outfit, SynthJob, generate_capture};
use avatar_neural::data::capture_points::{CapturePoints, FrameCount};
use std::path::Path;

/// The demo's first five frames in a new folder, frame 2's depth PNG replaced by text.
/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn five_frames_one_broken() -> tempfile::TempDir {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let dir = tempfile::tempdir().unwrap();
    let mut manifest = CaptureManifest::load(&demo).unwrap();
    manifest.frames.truncate(5);
    std::fs::create_dir_all(dir.path().join("depth")).unwrap();
    for (i, f) in manifest.frames.iter().enumerate() {
        let to = dir.path().join(&f.depth);
        if i == 2 {
            std::fs::write(&to, "not a png").unwrap();
        } else {
            std::fs::copy(demo.join(&f.depth), &to).unwrap();
        }
    }
    manifest.save(dir.path()).unwrap();
    dir
}

#[test]
fn a_range_takes_every_usable_frame_up_to_its_most_and_an_exact_count_refuses_fewer() {
    let dir = five_frames_one_broken();
    // Up to 32, at least 3: the four usable frames of five, the broken one skipped.
    let all = CapturePoints::open_with(
        dir.path(),
        FrameCount { at_least: 3, at_most: 32 },
        None,
        &field_cache(),
    )
    .unwrap();
    assert_eq!(all.frames.len(), 4);
    let indices = |c: &CapturePoints| c.frames.iter().map(|f| f.index).collect::<Vec<_>>();
    assert_eq!(indices(&all), [0, 1, 3, 4], "every usable frame, in the capture's order");
    // At most 2: the first two usable frames of the choice over the whole capture.
    let two = CapturePoints::open_with(
        dir.path(),
        FrameCount { at_least: 1, at_most: 2 },
        None,
        &field_cache(),
    )
    .unwrap();
    assert_eq!(two.frames.len(), 2);
    let manifest = CaptureManifest::load(dir.path()).unwrap();
    let mut chosen: Vec<usize> = FrameChoice::new(&manifest).filter(|&i| i != 2).take(2).collect();
    chosen.sort_unstable();
    assert_eq!(indices(&two), chosen);
    let k = all.frames.iter().position(|f| f.index == chosen[1]).unwrap();
    assert_eq!(two.frames[1].params, all.frames[k].params);
    // Exactly 5 is more than are usable: refused, naming the capture and the broken frame.
    let err = CapturePoints::open_with(dir.path(), FrameCount::exactly(5), None, &field_cache())
        .err()
        .expect("4 usable frames of the 5 asked is refused")
        .to_string();
    for want in
        ["capture.json", "only 4 usable frames", "of the 5 asked", "000002.png", "--frames 4"]
    {
        assert!(err.contains(want), "missing {want:?} in {err}");
    }
    // The default asks for at least 8, or every frame of a smaller capture: 5 here, so refused too.
    assert!(
        CapturePoints::open_with(dir.path(), FrameCount::DEFAULT, None, &field_cache()).is_err()
    );
    assert_eq!(FrameCount::exactly(4), FrameCount { at_least: 4, at_most: 4 });
    // The studio's panel: its number is the most, and under 8 also the least.
    assert_eq!(FrameCount::up_to(4), FrameCount::exactly(4));
    assert_eq!(FrameCount::up_to(32), FrameCount::DEFAULT);
    assert_eq!(FrameCount::up_to(20), FrameCount { at_least: 8, at_most: 20 });
}

#[test]
fn a_long_capture_gives_frames_from_all_of_it_and_says_which() {
    // Every library clip back to back (every 12th frame), the person turning as they move.
    let frames: Vec<_> =
        library::library().iter().flat_map(|c| c.frames.iter().step_by(12).cloned()).collect();
    let mut job = SynthJob::new(5, Outfit::TshirtShorts, MotionClip::new("long_take", 2.5, frames));
    job.turn_per_frame_deg = 11.0;
    job.write_ground_truth = false;
    let dir = tempfile::tempdir().unwrap();
    let n = generate_capture(dir.path(), open_body_ref(), &job).unwrap().frames;
    let capture =
        CapturePoints::open_with(dir.path(), FrameCount::up_to(8), None, &field_cache()).unwrap();
    let read: Vec<usize> = capture.frames.iter().map(|f| f.index).collect();
    assert_eq!(read.len(), 8);
    assert_eq!(capture.capture_frames, n);
    assert!(read.windows(2).all(|w| w[0] < w[1]), "in the take's order: {read:?}");
    assert!(read[0] < n / 8 && read[7] - read[0] > n * 3 / 4, "{read:?} of {n} frames");
    let manifest = CaptureManifest::load(dir.path()).unwrap();
    assert_eq!(read, FrameChoice::first(&manifest, 8));
    let summary = capture.choice_summary();
    assert!(summary.contains(&format!("8 of the capture's {n}")), "{summary}");
    assert!(summary.contains("chosen over the whole take"), "{summary}");
}
