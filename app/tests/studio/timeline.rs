//! The timeline with a long take: a loaded motion file stays in the clip list after switching
//! away (switching stops its bake and frees its frames), the slider zooms to a range, the range
//! plays and bakes; the camera follows the root of a clip that travels.

use super::*;
use avatar_core::motion::MotionClip;
use egui_kittest::kittest::NodeT;

/// The 2,752-frame 120 fps BVH (688 frames at 30 fps in the studio).
fn write_take(dir: &Path) -> std::path::PathBuf {
    use avatar_core::motion::bvh_write::{long_take, save_bvh};
    let take = dir.join("take.bvh");
    save_bvh(&long_take("take", 2752, 120.0).unwrap(), &take).unwrap();
    take
}

fn wait(h: &mut Harness<'static, StudioApp>, what: &str, done: impl Fn(&StudioApp) -> bool) {
    let t = Instant::now();
    while !done(h.state()) {
        h.step();
        assert!(t.elapsed() < Duration::from_secs(120), "{what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Choose `entry` in the timeline's clip list (the combo box, then its entry). The clicks are
/// accessibility actions on the widgets, not pointer events at their last drawn place: while a
/// bake runs the panel is redrawn every frame, and a pointer click at a stale place can land on
/// the bake's Stop button (which keeps the frames baked so far).
fn choose_clip(h: &mut Harness<'static, StudioApp>, entry: &str) {
    for _ in 0..3 {
        h.get_by_role_and_label(Role::ComboBox, "clip").click_accesskit();
        h.step();
        h.step();
        if h.query_by_label(entry).is_some() {
            break;
        }
    }
    h.get_by_label(entry).click_accesskit();
    h.step();
}

#[test]
fn a_long_take_stays_listed_and_its_timeline_zooms_to_a_range() {
    let dir = tempfile::tempdir().unwrap();
    let take = write_take(dir.path());
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    settle(&mut h, "loading the demo");
    h.state_mut().apply(Command::LoadMotion(take.display().to_string()));
    h.step();
    assert_eq!(h.state().timeline.frames(), 688);
    assert_eq!(h.state().loaded_clips.len(), 1);

    // Playing bakes it; choosing another clip stops that bake and drops its frames.
    h.state_mut().apply(Command::TogglePlay);
    wait(&mut h, "the take's first frames bake", |s| s.bakes.held_frames() >= 2);
    choose_clip(&mut h, "walk");
    assert_eq!(h.state().timeline.clip.name, "walk");
    let status = h.state().status.clone();
    assert_eq!(
        h.state().bakes.held_frames(),
        0,
        "the take's frames are freed at once ({status:?})"
    );
    wait(&mut h, "the take's bake stops", |s| !s.bakes.baking());
    h.step();
    assert_eq!(h.state().bakes.held_frames(), 0, "and stay freed");

    // The take is still in the list, and comes back without its file.
    std::fs::remove_file(&take).unwrap();
    choose_clip(&mut h, "take · 688 frames");
    let s = h.state();
    assert!(s.error.is_none(), "{:?}", s.error);
    assert_eq!((s.timeline.frames(), s.timeline.clip.fps), (688, 30.0));
    assert!((s.timeline.clip.source_fps - 120.0).abs() < 1e-3);

    // A range with the keys I and O, the slider zoomed to it.
    h.state_mut().timeline.set_frame(300);
    h.key_press(egui::Key::I);
    h.step();
    h.state_mut().timeline.set_frame(420);
    h.key_press(egui::Key::O);
    h.step();
    assert_eq!(h.state().timeline.range(), Some((300, 420)));
    click(&mut h, "to range");
    assert_eq!(h.state().timeline.zoom_range(), (300, 420));
    h.step(); // the slider above the button is drawn with the new bounds

    // The slider spans the range: its value is the frame, its bounds the range's.
    let slider = h.get_by_role_and_label(Role::Slider, "frame");
    let node = slider.accesskit_node();
    assert_eq!((node.min_numeric_value(), node.max_numeric_value()), (Some(300.0), Some(420.0)));
    slider.set_value_accesskit(360.0);
    h.step();
    assert_eq!(h.state().timeline.current_frame(), 360);

    // Play: the range is baked (not the take from its start), from the playhead round, and
    // playing does not run ahead of the bake: the frame is baked or the one it makes next.
    h.state_mut().apply(Command::TogglePlay);
    let t = Instant::now();
    let mut first_run = None;
    while h.state().bakes.baking() || h.state().bakes.held_frames() == 0 {
        h.step();
        let (spans, f) = (h.state().baked_spans(), h.state().timeline.current_frame());
        first_run = first_run.or(spans.first().map(|s| s.0));
        if h.state().bakes.baking() {
            let next = spans.iter().any(|&(a, n)| (a..=a + n).contains(&f));
            assert!(next || (spans.is_empty() && f == 360), "{f}: {spans:?}");
        }
        assert!(t.elapsed() < Duration::from_secs(120), "the range bakes");
        std::thread::sleep(Duration::from_millis(5));
    }
    assert_eq!(first_run, Some(360), "the bake began at the playhead");
    assert_eq!(h.state().baked_spans(), vec![(300, 121)]);
    for _ in 0..20 {
        h.step();
        let f = h.state().timeline.current_frame();
        assert!((300..=420).contains(&f), "playing within the range: {f}");
    }
    h.state_mut().apply(Command::TogglePlay);
    h.state_mut().timeline.set_frame(360);
    h.state_mut().apply(Command::PoseChanged);
    settle(&mut h, "showing frame 360");
    assert_eq!(h.state().posed.as_ref().unwrap().id, 0, "frame 360 comes from the bake");
    h.state_mut().status = None; // the bake's time
    snap(&mut h, "timeline_long_take_range", &tolerant(200));
}

/// The walk clip travelling forward 1.5 m a second (3.2 s: 4.75 m).
fn travelling_walk(dir: &Path) -> std::path::PathBuf {
    let walk = avatar_core::motion::clip_by_name("walk").unwrap();
    let mut frames = walk.frames.clone();
    for (i, f) in frames.iter_mut().enumerate() {
        f.trans.z += 0.05 * i as f32;
    }
    let path = dir.join("stroll.json");
    MotionClip::new("stroll", 30.0, frames).save_json(&path).unwrap();
    path
}

#[test]
fn the_camera_follows_the_root() {
    let dir = tempfile::tempdir().unwrap();
    let stroll = travelling_walk(dir.path());
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    settle(&mut h, "loading the demo");
    h.state_mut().apply(Command::LoadMotion(stroll.display().to_string()));
    settle(&mut h, "posing the first frame");
    let root = |s: &StudioApp| s.posed.as_ref().unwrap().joints[0];
    let target = |s: &StudioApp| glam::Vec3::from(s.view.camera.target);
    // Without following, the last frame is metres away from where the camera looks.
    h.state_mut().timeline.set_frame(95);
    h.state_mut().apply(Command::PoseChanged);
    settle(&mut h, "posing the last frame");
    let away = (root(h.state()) - target(h.state())).with_y(0.0).length();
    assert!(away > 3.0, "the root is {away} m from the target");
    // Follow: the target moves over the floor to the root, the height stays.
    let height = target(h.state()).y;
    click(&mut h, "Follow");
    assert!(h.state().view.follow_root);
    let s = h.state();
    assert!((root(s) - target(s)).with_y(0.0).length() < 1e-4);
    assert_eq!(target(s).y, height);
    for f in [40, 70] {
        h.state_mut().timeline.set_frame(f);
        h.state_mut().apply(Command::PoseChanged);
        settle(&mut h, "posing");
        let s = h.state();
        assert!((root(s) - target(s)).with_y(0.0).length() < 1e-4, "frame {f}");
    }
    // The follow is part of the project's view.
    assert!(h.state().project().view.follow_root);
    h.state_mut().status = None; // names the temporary folder
    snap(&mut h, "follow_root", &tolerant(200));
}
