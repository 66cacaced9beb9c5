//! A depth video of 3,000 frames in the studio: it opens reading only its first frames, shows
//! the first usable one, reads a frame's points and the thumbnails on screen when they are
//! shown, and holds at most a bounded number of them whatever is looked at.

use super::*;
use avatar_studio::studio::capture_frames::{MAX_POINT_FRAMES, MAX_THUMBNAILS};
use avatar_studio::studio::capture_view::FRAMES_READ_AT_OPEN;

/// The demo's 32 frames repeated to `frames` in the manifest (the same depth files; the
/// manifest is generated here, a few MB in a temporary folder), in a folder of a fixed name
/// (the panel shows it).
fn long_capture(frames: usize) -> (tempfile::TempDir, std::path::PathBuf) {
    let demo = private_demo();
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("long-capture");
    std::fs::rename(demo.path(), &dir)
        .or_else(|_| {
            std::fs::create_dir_all(dir.join("depth"))?;
            for e in std::fs::read_dir(demo.path().join("depth"))? {
                let e = e?;
                std::fs::copy(e.path(), dir.join("depth").join(e.file_name()))?;
            }
            std::fs::copy(demo.path().join("capture.json"), dir.join("capture.json")).map(|_| ())
        })
        .unwrap();
    let path = dir.join("capture.json");
    let mut m: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let records = m["frames"].as_array().unwrap().clone();
    m["frames"] = (0..frames).map(|i| records[i % records.len()].clone()).collect();
    std::fs::write(&path, serde_json::to_vec(&m).unwrap()).unwrap();
    (root, dir)
}

#[test]
fn a_3000_frame_capture_opens_reading_frames_as_they_are_shown() {
    let (_root, dir) = long_capture(3000);
    let mut h = harness(StudioOptions { capture: Some(dir.clone()), ..Default::default() });
    settle(&mut h, "opening a 3,000-frame capture");
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let c = h.state().capture.clone().expect("the capture opens");
    assert_eq!(c.frames.len(), 3000);
    let s = h.state();
    // Checked at open: the first frames and those on screen, not the take.
    let checked = s.frame_store.checked();
    assert!((FRAMES_READ_AT_OPEN..300).contains(&checked), "{checked} frames checked");
    assert_eq!(s.frame_store.usable(), checked);
    assert!(
        h.query_by_label_contains(&format!("3000 frames · {checked} of {checked} checked usable"))
            .is_some(),
        "the panel says how many were checked"
    );

    // Any frame shows when selected: its points are read then.
    h.state_mut().set_mode(ViewMode::Capture);
    for (k, i) in [2999usize, 1500, 7, 2100].into_iter().chain((100..3000).step_by(180)).enumerate()
    {
        h.state_mut().apply(Command::SelectFrame(i));
        settle(&mut h, "reading a frame");
        let scene = h.state().build_scene();
        assert!(scene.points.len() > 1000, "frame {i}: {} points shown", scene.points.len());
        assert!(h.state().frame_store.verdict(i).is_some_and(|v| v.is_ok()));
        let (point_frames, _, _) = h.state().frame_store.held();
        assert!(point_frames <= MAX_POINT_FRAMES.min(k + 2), "{point_frames} frames of points");
    }

    // Thumbnails of more frames than the store keeps: the oldest go.
    let store = &mut h.state_mut().frame_store;
    for i in 1000..1000 + MAX_THUMBNAILS + 40 {
        assert!(store.thumbnail(i).is_none(), "frame {i} is not read yet");
    }
    settle(&mut h, "reading thumbnails");
    let (point_frames, thumbnails, bytes) = h.state().frame_store.held();
    assert!(point_frames <= MAX_POINT_FRAMES);
    assert!(thumbnails <= MAX_THUMBNAILS, "{thumbnails} thumbnails held");
    assert!(h.state_mut().frame_store.thumbnail(1000 + MAX_THUMBNAILS + 39).is_some());
    // Points of 8 frames of 250 x 250 and 256 thumbnails of 72 x 72: a few MB, not the take.
    assert!(bytes < 32 << 20, "{bytes} bytes held");
    assert!(h.state().frame_store.checked() < 1000, "only what was shown is read");
    // The status names the temporary folder, which changes between runs.
    h.state_mut().status = None;
    snap(&mut h, "long_capture", &tolerant(300));
}
