//! A long motion-capture take in the studio: the 120 fps BVH is resampled to 30 fps on
//! opening (its source rate on the timeline), its first frames play while the rest bakes, and
//! Stop keeps the frames baked so far without baking again.

use super::*;

#[test]
fn a_long_take_plays_while_it_bakes_and_stop_keeps_what_was_baked() {
    use avatar_core::motion::bvh_write::{long_take, save_bvh};
    let dir = tempfile::tempdir().unwrap();
    let take = dir.path().join("take.bvh");
    save_bvh(&long_take("take", 2752, 120.0).unwrap(), &take).unwrap();
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    settle(&mut h, "loading the demo");
    h.state_mut().apply(Command::LoadMotion(take.display().to_string()));
    h.step();
    let frames = h.state().timeline.frames();
    assert_eq!(frames, 688, "2,752 frames at 120 fps played at 30");
    assert!((h.state().timeline.clip.source_fps - 120.0).abs() < 1e-3);
    assert_eq!(h.state().timeline.clip.fps, 30.0);
    // Play: the bake starts, and a baked frame is shown before the bake is done.
    h.state_mut().apply(Command::TogglePlay);
    let t = Instant::now();
    loop {
        h.step();
        let s = h.state();
        if s.bakes.progress.is_some_and(|(done, _)| done >= 2) {
            break;
        }
        assert!(s.bakes.baking(), "the bake runs until stopped");
        assert!(t.elapsed() < Duration::from_secs(120), "the first frames bake");
        std::thread::sleep(Duration::from_millis(5));
    }
    h.state_mut().apply(Command::TogglePlay); // pause
    h.state_mut().timeline.set_frame(1);
    h.state_mut().apply(Command::PoseChanged);
    h.step();
    assert!(h.state().bakes.baking(), "still baking the rest of the take");
    assert_eq!(h.state().posed.as_ref().expect("a posed mesh").id, 0, "frame 1 is baked");
    // Stop: the frames baked so far are kept; the bake does not start again.
    click(&mut h, "Stop");
    let t = Instant::now();
    while h.state().bakes.baking() {
        h.step();
        assert!(t.elapsed() < Duration::from_secs(60), "stopping");
        std::thread::sleep(Duration::from_millis(5));
    }
    for _ in 0..5 {
        h.step();
    }
    assert!(!h.state().bakes.baking(), "a stopped bake is not started again");
    let kept = match &h.state().status {
        Some(avatar_studio::studio::state::Status::Info(m)) if m.starts_with("Kept ") => m
            .split_whitespace()
            .nth(1)
            .and_then(|n| n.parse::<usize>().ok())
            .expect("a frame count"),
        other => panic!("{other:?}"),
    };
    assert!((2..frames).contains(&kept), "kept {kept} of {frames}");
    // A baked frame comes from the bake, one past it is posed live.
    h.state_mut().timeline.set_frame(1);
    h.state_mut().apply(Command::PoseChanged);
    h.step();
    assert_eq!(h.state().posed.as_ref().unwrap().id, 0);
    h.state_mut().timeline.set_frame(frames - 1);
    h.state_mut().apply(Command::PoseChanged);
    settle(&mut h, "posing a frame past the bake");
    assert_ne!(h.state().posed.as_ref().unwrap().id, 0, "posed live");
    // The timeline of the long take: its last frame, the source rate beside the time.
    let label = h.query_all_by_label_contains("120 fps source at 30").count();
    assert_eq!(label, 1, "the source rate is shown");
    h.state_mut().status = None; // it names the number of frames kept
    // The frames kept vary with the machine's speed: none on the timeline's strip in the image.
    h.state_mut().bakes.clear();
    h.step();
    snap(&mut h, "long_take_stopped", &tolerant(200));
}
