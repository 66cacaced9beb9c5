//! Flagged frames, pose-dependent avatars, cancelled jobs and playback after baking.

use super::*;

#[test]
fn frames_with_problems_are_flagged_with_the_reason() {
    // The demo with one depth image truncated: that frame is flagged, the others load.
    let dir = private_demo();
    let broken = dir.path().join("depth/000003.png");
    let bytes = std::fs::read(&broken).unwrap();
    std::fs::write(&broken, &bytes[..bytes.len() / 3]).unwrap();
    let mut h =
        harness(StudioOptions { capture: Some(dir.path().to_path_buf()), ..Default::default() });
    settle(&mut h, "opening a capture with a bad frame");
    let c = h.state().capture.clone().expect("the capture opens");
    assert!(h.state().error.is_none());
    let store = &h.state().frame_store;
    let flagged: Vec<_> = store.flagged().map(|(i, _)| i).collect();
    assert_eq!(flagged, [3]);
    assert_eq!(store.usable(), c.frames.len() - 1);
    // The reason is listed in the capture panel, naming the file.
    let listed = h.query_all_by_label_contains("frame 3 (000003.png)").count();
    assert_eq!(listed, 1, "the flagged frame is listed with its file");
}

/// A pose-dependent avatar (the meta avatar's shape): the poser projects the reference mesh
/// onto each pose's surface. Checked with the synthetic avatar, whose clothing moves with the
/// pose.
#[test]
fn pose_dependent_avatars_are_projected_per_pose() {
    use avatar_core::export::{AvatarSource, SyntheticAvatar};
    use avatar_studio::studio::avatar::{StudioAvatar, canonical_of};
    use avatar_studio::studio::posing::{Posable, PoseWorker};
    use avatar_studio::studio::timeline::Timeline;
    use std::sync::Arc;
    struct Synthetic(SyntheticAvatar);
    impl StudioAvatar for Synthetic {
        fn describe(&self) -> String {
            "synthetic".into()
        }
        fn source(&self) -> &dyn AvatarSource {
            &self.0
        }
        fn pose_dependent(&self) -> bool {
            true
        }
        fn save(&self, _: &Path) -> Result<(), avatar_studio::StudioError> {
            Err(avatar_studio::StudioError::invalid("not saved"))
        }
    }
    let body = avatar_core::body::open_body();
    let synthetic = SyntheticAvatar::new(
        body.clone(),
        2024,
        avatar_core::synth::Outfit::LongsleeveTrousers,
        &Default::default(),
    )
    .unwrap();
    let avatar: Arc<dyn StudioAvatar> = Arc::new(Synthetic(synthetic));
    let betas = avatar.source().betas().to_vec();
    let reference = Arc::new(canonical_of(avatar.as_ref(), &betas).unwrap());
    let mut worker = PoseWorker::start(|| {});
    let mut timeline = Timeline::library("squat").unwrap();
    let body = Arc::new(body);
    let f = timeline.frames() / 2;
    let mut pose_at = |f: usize, posable: Posable| {
        timeline.set_frame(f);
        worker.request(timeline.params(&betas), posable, body.clone());
        let t = Instant::now();
        loop {
            if let Some(r) = worker.poll() {
                return r.unwrap().positions;
            }
            assert!(t.elapsed() < Duration::from_secs(60));
            std::thread::sleep(Duration::from_millis(2));
        }
    };
    let projected = pose_at(
        f,
        Posable::PoseDependent {
            avatar: avatar.clone(),
            reference: reference.clone(),
            rest_normals: None,
        },
    );
    let rigid = pose_at(f, Posable::Mesh(reference.clone()));
    assert_eq!(projected.len(), rigid.len());
    let differs =
        projected.iter().zip(&rigid).map(|(a, b)| (*a - *b).length()).fold(0.0f32, f32::max);
    assert!(differs > 1e-3, "the clothing follows the pose ({differs} m)");
}

/// Cancelling keeps the partial avatar; dropping a job (the window closed) stops its thread and
/// leaves the capture folder untouched.
#[test]
fn cancelled_and_dropped_jobs() {
    use avatar_studio::studio::avatar_job::{FitJob, JobEvent};
    let private = private_demo();
    let dir = private.path().to_path_buf();
    let listing = || -> Vec<(std::path::PathBuf, u64, std::time::SystemTime)> {
        let mut v: Vec<_> = walk(&dir)
            .into_iter()
            .map(|p| {
                let m = std::fs::metadata(&p).unwrap();
                (p, m.len(), m.modified().unwrap())
            })
            .collect();
        v.sort();
        v
    };
    let before = listing();
    let long = FitConfig { steps: 100_000, preview_every: 0, ..FitConfig::tiny() };
    let wait_progress = |job: &FitJob| loop {
        match job.events.recv_timeout(Duration::from_secs(120)).expect("the job reports") {
            JobEvent::Progress { .. } => break,
            JobEvent::Failed(e) => panic!("{e}"),
            _ => {}
        }
    };
    let job = FitJob::start(dir.clone(), long.clone(), || {});
    wait_progress(&job);
    job.cancel();
    let t = Instant::now();
    loop {
        match job.events.recv_timeout(Duration::from_secs(60)).expect("the job ends") {
            JobEvent::Finished { cancelled, avatar, .. } => {
                assert!(cancelled);
                assert!(!avatar.describe().is_empty());
                break;
            }
            JobEvent::Failed(e) => panic!("{e}"),
            _ => {}
        }
    }
    assert!(t.elapsed() < Duration::from_secs(30), "cancel is prompt");
    let job = FitJob::start(dir.clone(), long, || {});
    wait_progress(&job);
    let events = job.events.clone();
    drop(job);
    let t = Instant::now();
    loop {
        match events.recv_timeout(Duration::from_secs(60)) {
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
            Err(e) => panic!("the job thread did not stop: {e}"),
            Ok(_) => {}
        }
    }
    assert!(t.elapsed() < Duration::from_secs(30), "the thread stops promptly");
    assert_eq!(listing(), before, "the capture folder is untouched");
}

/// Playback after baking: Play bakes the clip's poses once (the capture's body here), then the
/// viewport plays the baked meshes: frames come from the bake, two frames show different
/// meshes, and a second Play does not bake again.
#[test]
fn playback_after_baking() {
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    settle(&mut h, "loading the demo");
    h.state_mut().apply(Command::TogglePlay);
    h.step();
    assert!(h.state().bakes.baking() || h.state().bakes.progress.is_none(), "a bake started");
    let t = Instant::now();
    while h.state().bakes.baking() {
        h.step();
        assert!(t.elapsed() < Duration::from_secs(120), "baking");
        std::thread::sleep(Duration::from_millis(20));
    }
    // Playing: every step shows the baked mesh of the current frame, and the frames move on.
    let frames = h.state().timeline.frames();
    let mut seen = std::collections::BTreeSet::new();
    for _ in 0..6 {
        h.step();
        let s = h.state();
        assert!(s.timeline.playing);
        let posed = s.posed.as_ref().expect("a posed mesh");
        assert_eq!(
            posed.id,
            0,
            "frame {} is the baked mesh, not a live pose",
            s.timeline.current_frame()
        );
        assert!(s.viewport_moving, "playing redraws every frame (lavapipe: without MSAA)");
        seen.insert(s.timeline.current_frame());
    }
    assert!(seen.len() >= 4, "the clip plays at its rate ({seen:?} of {frames} frames)");
    h.state_mut().apply(Command::TogglePlay);
    h.step();
    assert!(!h.state().viewport_moving, "paused: drawn with MSAA again");
    assert!(!h.state().bakes.baking(), "the bake is cached");
    // Two paused frames: different meshes on screen.
    let shot = |h: &mut Harness<'static, StudioApp>, f: usize| {
        h.state_mut().timeline.set_frame(f);
        h.state_mut().apply(Command::PoseChanged);
        h.step();
        h.step();
        assert_eq!(h.state().posed.as_ref().unwrap().id, 0, "from the bake");
        (h.state().posed.as_ref().unwrap().positions.clone(), h.render().expect("render"))
    };
    let (a, image_a) = shot(&mut h, 0);
    let (b, image_b) = shot(&mut h, frames / 2);
    let moved = a.iter().zip(&b).map(|(p, q)| (*p - *q).length()).fold(0.0f32, f32::max);
    assert!(moved > 0.05, "the baked frames differ by {moved} m");
    let differing = image_a.pixels().zip(image_b.pixels()).filter(|(x, y)| x != y).count();
    assert!(differing > 1000, "the viewport changed ({differing} pixels)");
    assert!(
        matches!(&h.state().status, Some(avatar_studio::studio::state::Status::Info(m)) if m.starts_with("Baked 96 frames")),
        "{:?}",
        h.state().status
    );
    h.state_mut().status = None; // it names the bake's time
    snap(&mut h, "playback_baked", &tolerant(200));
}

/// The fit panel's *Prior*: a file that is not a meta-model stops the fit before the capture is
/// canonicalized, naming the file in the job's event and on the status bar; no avatar is made.
#[test]
fn a_bad_prior_stops_the_fit_naming_the_file() {
    use avatar_studio::studio::avatar_job::{FitJob, JobEvent};
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("not-a-prior.bin");
    std::fs::write(&bad, b"not a meta-model").unwrap();
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let cfg = FitConfig { model: bad.display().to_string(), ..FitConfig::tiny() };
    let job = FitJob::start(demo.clone(), cfg.clone(), || {});
    loop {
        match job.events.recv_timeout(Duration::from_secs(60)).expect("the job reports") {
            JobEvent::Failed(e) => {
                assert!(e.contains("not-a-prior.bin"), "{e}");
                break;
            }
            JobEvent::Progress { .. } | JobEvent::Finished { .. } => panic!("the fit ran"),
            _ => {}
        }
    }
    let mut h = harness(StudioOptions { capture: Some(demo), ..Default::default() });
    settle(&mut h, "opening the demo");
    h.state_mut().settings.fit = cfg.clone();
    h.state_mut().apply(Command::StartFit(cfg));
    settle(&mut h, "the refused fit");
    let err = h.state().error.clone().expect("an error is shown");
    assert!(err.contains("not-a-prior.bin"), "{err}");
    assert!(h.state().avatar.is_none(), "no avatar from a refused prior");
}
