//! The export uses the timeline's range; opening another capture closes the avatar of the one
//! before (its loss plot, frame count, bakes and posed mesh), keeping an unsaved one in the
//! cache, and cancels a fit of the one before.

use super::*;
use avatar_studio::studio::scene::Shown;
use avatar_studio::studio::state::Status;

#[test]
fn the_export_takes_the_range_and_another_capture_closes_the_avatar() {
    let out = tempfile::tempdir().unwrap();
    let glb = out.path().join("range.glb");
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    h.state_mut().set_dialogs(Box::new(ScriptedDialogs::new([glb.clone()])));
    h.state_mut().autosave_dir = out.path().join("kept");
    settle(&mut h, "loading the demo");
    h.state_mut().apply(Command::StartFit(test_fit()));
    settle(&mut h, "fine-tuning");
    assert!(h.state().avatar.is_some() && !h.state().avatar_saved);
    assert!(!h.state().job_view.losses.is_empty());

    // Frames 10 to 29 of the walk as the range: the export writes those 20.
    h.state_mut().timeline.set_range(10, 29);
    h.step();
    assert!(h.query_by_label_contains("walk frames 10–29 of 96").is_some(), "said in the panel");
    click(&mut h, "Export glTF…");
    settle(&mut h, "exporting");
    let g = gltf::Gltf::from_slice(&std::fs::read(&glb).expect("the glTF was written")).unwrap();
    let buffers = [g.blob.clone().unwrap()];
    let anim = g.document.animations().next().unwrap();
    let channel = anim.channels().next().unwrap();
    let times: Vec<f32> =
        channel.reader(|b| Some(&buffers[b.index()][..])).read_inputs().unwrap().collect();
    assert_eq!(times.len(), 20, "one key per frame of the range");
    assert!(matches!(&h.state().status, Some(Status::Info(m)) if m.contains("frames 10-29")));

    // Another capture: the fitted avatar (never saved) is kept in the cache and closed.
    let other = private_demo();
    h.state_mut().apply(Command::OpenCapture(other.path().display().to_string()));
    settle(&mut h, "opening another capture");
    let s = h.state();
    assert_eq!(s.capture.as_ref().unwrap().dir, other.path());
    assert!(s.avatar.is_none() && s.avatar_path.is_none());
    assert!(s.job_view.losses.is_empty() && s.job_view.frames == 0, "no loss plot, no count");
    assert!(s.job_view.finished.is_none());
    assert_eq!(s.shown().map(|(w, _)| w), Some(Shown::Body), "the new capture's body is shown");
    let posed = s.posed.as_ref().expect("the body is posed");
    assert_eq!(posed.positions.len(), s.body().v_template.len());
    assert_eq!(s.bakes.held_frames(), 0);
    let Some(Status::Info(m)) = &s.status else { panic!("{:?}", s.status) };
    assert!(m.contains("the previous avatar is closed"), "{m}");
    let kept: Vec<_> = std::fs::read_dir(out.path().join("kept")).unwrap().collect();
    assert_eq!(kept.len(), 1, "{m}");
    let kept = kept[0].as_ref().unwrap().path();
    assert!(m.contains(&kept.display().to_string()), "{m}");
    // The kept avatar opens again.
    h.state_mut().apply(Command::OpenAvatar(kept.clone()));
    settle(&mut h, "opening the kept avatar");
    assert!(h.state().avatar.is_some() && h.state().avatar_saved, "{:?}", h.state().status);

    // A fit running when another capture opens is cancelled; its partial result never shows.
    h.state_mut().apply(Command::StartFit(test_fit()));
    assert!(h.state().job.is_some());
    h.state_mut().apply(Command::OpenCapture("demo".into()));
    settle(&mut h, "opening the demo again");
    let s = h.state();
    assert!(s.job.is_none() && s.avatar.is_none(), "{:?}", s.status);
    let Some(Status::Info(m)) = &s.status else { panic!("{:?}", s.status) };
    assert!(m.contains("its fine-tuning was cancelled"), "{m}");
    assert_eq!(std::fs::read_dir(out.path().join("kept")).unwrap().count(), 1, "saved: not kept");
}
