//! The studio under egui_kittest with the wgpu renderer (lavapipe on machines without a GPU;
//! scripts/test.sh sets WGPU_BACKEND=vulkan). Snapshots live in tests/snapshots/ and are
//! (re)written with UPDATE_SNAPSHOTS=1.

use avatar_studio::studio::camera::Preset;
use avatar_studio::studio::fit_config::FitConfig;
use avatar_studio::studio::project::ViewMode;
use avatar_studio::studio::settings::ScriptedDialogs;
use avatar_studio::studio::{Command, StudioApp, StudioOptions};
use eframe::egui;
use eframe::egui::accesskit::Role;
use egui_kittest::kittest::Queryable;
use egui_kittest::{Harness, SnapshotOptions};
use std::path::Path;
use std::time::{Duration, Instant};

const SIZE: [f32; 2] = [920.0, 560.0];

fn harness(options: StudioOptions) -> Harness<'static, StudioApp> {
    let mut h = Harness::builder()
        .with_size(SIZE)
        .wgpu()
        .build_eframe(move |cc| StudioApp::new(cc, options));
    h.state_mut().show_timings = false; // timings vary from run to run
    h
}

/// Step the UI until the studio has nothing running in the background.
fn settle(h: &mut Harness<'static, StudioApp>, what: &str) {
    let t = Instant::now();
    loop {
        h.step();
        if !h.state().busy() {
            break;
        }
        assert!(t.elapsed() < Duration::from_secs(300), "{what}: still busy after 300 s");
        std::thread::sleep(Duration::from_millis(20));
    }
    for _ in 0..3 {
        h.step();
    }
}

/// The 3D scene is rendered by lavapipe: allow a few pixels of rasterisation noise, and
/// (for the fit) of numeric noise in the plotted loss.
fn tolerant(pixels: usize) -> SnapshotOptions {
    SnapshotOptions::new().max_failed_pixels(pixels)
}

fn click(h: &mut Harness<'static, StudioApp>, label: &str) {
    h.get_by_label(label).scroll_to_me();
    for _ in 0..30 {
        h.step(); // the scroll animation
    }
    h.get_by_label(label).click();
    h.step();
}

fn snap(h: &mut Harness<'static, StudioApp>, name: &str, options: &SnapshotOptions) {
    h.remove_cursor();
    h.step();
    h.snapshot_options(name, options);
}

/// A fine-tuning configuration a test can afford (seconds on two cores).
fn test_fit() -> FitConfig {
    FitConfig::tiny()
}

#[test]
fn demo_fit_and_pose_snapshots() {
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    settle(&mut h, "loading the demo");
    {
        let app = h.state();
        let c = app.capture.as_ref().expect("the demo capture is open");
        assert!(c.usable() >= 8, "the demo has usable frames");
        assert!(app.error.is_none(), "{:?}", app.error);
        assert!(app.posed.is_some(), "the body is posed");
    }
    click(&mut h, "Depth points");
    settle(&mut h, "depth view");
    assert!(!h.state().build_scene().points.is_empty(), "the depth points are in the scene");
    snap(&mut h, "demo_loaded", &tolerant(200));

    // A fine-tuning job held after its first chunk: progress, plot and the partial result.
    let dir = h.state().capture.as_ref().unwrap().dir.clone();
    let ctx = h.ctx.clone();
    let job = avatar_studio::studio::avatar_job::FitJob::start(dir, test_fit(), move || {
        ctx.request_repaint()
    });
    job.pause();
    h.state_mut().apply(Command::WatchFit(job));
    h.state_mut().set_mode(ViewMode::Canonical);
    let t = Instant::now();
    while h.state().job_view.preview_step.is_none() {
        h.step();
        assert!(t.elapsed() < Duration::from_secs(300), "no partial result");
        std::thread::sleep(Duration::from_millis(20));
    }
    for _ in 0..3 {
        h.step();
    }
    assert!(h.state().job.is_some(), "the job is still running");
    assert_eq!(h.state().job_view.step, test_fit().preview_every);
    assert!(h.state().job_view.losses.len() >= 10, "the loss plot has points");
    h.state_mut().job_view.elapsed_s = 4.0; // the time left shown in the snapshot
    h.step();
    snap(&mut h, "fit_in_progress", &tolerant(3000));

    // Let it finish: the avatar replaces the partial result.
    h.state().job.as_ref().unwrap().resume();
    settle(&mut h, "finishing the fit");
    assert!(h.state().avatar.is_some(), "the fit produced an avatar: {:?}", h.state().status);
    h.state_mut().set_mode(ViewMode::Posed);
    h.state_mut().view.skeleton = true;
    settle(&mut h, "posing the avatar");
    let before: Vec<_> = h.state().posed.as_ref().unwrap().positions.clone();
    snap(&mut h, "avatar_posed", &tolerant(1500));
    let image_before = h.render().expect("render");

    // Move the pose slider: the newest pose is computed and the mesh changes.
    let frames = h.state().timeline.frames();
    h.get_by_role_and_label(Role::Slider, "pose").set_value_accesskit((frames / 2) as f64);
    h.step();
    settle(&mut h, "posing after the slider moved");
    assert_eq!(h.state().timeline.current_frame(), frames / 2);
    let after = &h.state().posed.as_ref().unwrap().positions;
    assert_eq!(after.len(), before.len());
    let moved = before.iter().zip(after).map(|(a, b)| (*a - *b).length()).fold(0.0f32, f32::max);
    assert!(moved > 0.05, "the posed mesh moved by {moved} m");
    let image_after = h.render().expect("render");
    let differing = image_before.pixels().zip(image_after.pixels()).filter(|(a, b)| a != b).count();
    assert!(differing > 1000, "the viewport changed ({differing} pixels)");
    snap(&mut h, "avatar_pose_moved", &tolerant(1500));
}

#[test]
fn a_bad_capture_shows_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("capture.json"),
        "{ \"format\": \"avatar-studio-capture\", \"version\": 1, \"frames\": [ }",
    )
    .unwrap();
    let mut h =
        harness(StudioOptions { capture: Some(dir.path().to_path_buf()), ..Default::default() });
    settle(&mut h, "opening a bad capture");
    let err = h.state().error.clone().expect("an error is shown");
    assert!(err.contains("capture.json"), "{err}");
    assert!(h.state().capture.is_none());
    // The message is on screen (the left panel), not only in the state.
    h.get_by_label("Error");
    // The temporary folder name changes between runs: show a fixed one in the snapshot.
    eprintln!("error shown: {err}");
    let shown = err.replace(&dir.path().display().to_string(), "/captures/broken");
    h.state_mut().error = Some(shown);
    h.state_mut().status = None;
    // A few frames for the new text's layout (CI once caught a frame without the box).
    for _ in 0..5 {
        h.step();
    }
    assert!(
        h.state().error.is_some() && !h.state().busy(),
        "the error stays shown and nothing runs"
    );
    assert!(
        h.query_by_label_contains("/captures/broken/capture.json").is_some(),
        "the error's text is on screen before the snapshot"
    );
    snap(&mut h, "error_bad_capture", &tolerant(200));
}

#[test]
fn a_whole_session_through_the_ui() {
    let out = tempfile::tempdir().unwrap();
    let glb = out.path().join("walk.glb");
    let obj = out.path().join("pose.obj");
    let project = out.path().join("session.studio.json");
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    h.state_mut().set_dialogs(Box::new(ScriptedDialogs::new([glb.clone(), obj.clone()])));
    settle(&mut h, "loading the demo");

    // Fine-tune a tiny configuration from the panel.
    click(&mut h, "Quick (tiny)");
    click(&mut h, "Start fine-tuning");
    assert!(h.state().job.is_some(), "the job started");
    settle(&mut h, "fine-tuning");
    assert!(h.state().avatar.is_some(), "{:?}", h.state().status);
    assert!(h.state().job_view.losses.len() >= 10);

    // Scrub the pose.
    h.get_by_role_and_label(Role::Slider, "pose").set_value_accesskit(12.0);
    h.step();
    settle(&mut h, "posing");
    assert_eq!(h.state().timeline.current_frame(), 12);
    // Keys: . and , step a frame, Space plays and pauses.
    h.key_press(egui::Key::Period);
    h.step();
    assert_eq!(h.state().timeline.current_frame(), 13);
    h.key_press(egui::Key::Comma);
    h.step();
    assert_eq!(h.state().timeline.current_frame(), 12);
    h.key_press(egui::Key::Space);
    h.step();
    assert!(h.state().timeline.playing);
    h.key_press(egui::Key::Space);
    h.step();
    assert!(!h.state().timeline.playing);
    h.state_mut().timeline.set_frame(12);
    h.state_mut().apply(Command::PoseChanged);
    settle(&mut h, "posing");
    // P saves the viewport as a PNG.
    let shots = out.path().join("shots");
    std::fs::create_dir_all(&shots).unwrap();
    h.state_mut().screenshot_dir = shots.clone();
    h.key_press(egui::Key::P);
    h.step();
    h.step();
    let png: Vec<_> = std::fs::read_dir(&shots).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(png.len(), 1, "one screenshot");
    let img = image::open(&png[0]).expect("the screenshot is a PNG");
    let vp = h.state().viewport_rect().unwrap();
    assert_eq!(
        (img.width(), img.height()),
        (vp.width().round() as u32, vp.height().round() as u32),
        "the viewport is cropped"
    );

    // The side view with a material colour of the artist's choice (exported too).
    h.state_mut().view.material = [0.2, 0.5, 0.3];
    h.state_mut().apply(Command::SceneChanged);
    h.state_mut().apply(Command::CameraPreset(Preset::Side));
    h.state_mut().status = None; // a temporary folder's name
    h.state_mut().job_view.finished = None; // the fit's time
    h.step();
    snap(&mut h, "avatar_side_material", &tolerant(1500));

    // Export the animated glTF and the posed OBJ through the buttons (dialogs scripted).
    click(&mut h, "Export glTF…");
    settle(&mut h, "exporting");
    assert!(glb.exists(), "{:?}", h.state().status);
    let g = gltf::Gltf::from_slice(&std::fs::read(&glb).expect("the glTF was written"))
        .expect("the exported glTF parses");
    let buffers = vec![g.blob.clone().expect("a binary chunk")];
    let doc = g.document;
    let anim = doc.animations().next().expect("an animation");
    let frames = h.state().timeline.frames();
    let channel = anim.channels().next().unwrap();
    let times: Vec<f32> =
        channel.reader(|b| Some(&buffers[b.index()][..])).read_inputs().unwrap().collect();
    assert_eq!(times.len(), frames, "one key per clip frame");
    assert_eq!(doc.skins().next().unwrap().joints().count(), 24);
    let material = doc.meshes().next().unwrap().primitives().next().unwrap().material();
    assert_eq!(
        material.pbr_metallic_roughness().base_color_factor(),
        [0.2, 0.5, 0.3, 1.0],
        "the studio's colour is exported"
    );
    // The Khronos validator accepts it (scripts/test.sh installs it, as for the CLI's test).
    let validator = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/gltf-validator");
    assert!(
        validator.join("node_modules/gltf-validator").exists(),
        "run `npm ci --prefix tests/gltf-validator` (scripts/test.sh does)"
    );
    let v = std::process::Command::new("node")
        .arg(validator.join("validate.mjs"))
        .arg(&glb)
        .output()
        .unwrap();
    let report: serde_json::Value = serde_json::from_slice(&v.stdout).unwrap();
    assert_eq!(report["issues"]["numErrors"], 0, "{}", report["issues"]["messages"]);
    click(&mut h, "Export OBJ…");
    let text = std::fs::read_to_string(&obj).expect("the OBJ was written");
    let verts = text.lines().filter(|l| l.starts_with("v ")).count();
    assert_eq!(verts, h.state().posed.as_ref().unwrap().positions.len());

    // Save the project (the avatar is saved beside it) and restore it in a new studio.
    h.state_mut().view.mode = ViewMode::Canonical;
    h.state_mut().view.camera.yaw += 0.5;
    h.state_mut().view.camera.distance *= 1.3;
    h.state_mut().save_project_to(&project);
    assert!(out.path().join("session.avatar").exists(), "the avatar is saved beside the project");
    let saved = h.state().project();
    let mut h2 = harness(StudioOptions { project: Some(project.clone()), ..Default::default() });
    settle(&mut h2, "opening the project");
    let s = h2.state();
    assert!(s.error.is_none(), "{:?}", s.error);
    assert!(s.capture.is_some() && s.avatar.is_some());
    assert_eq!(s.timeline.current_frame(), 12);
    assert_eq!(s.view.mode, ViewMode::Canonical);
    assert_eq!(s.view.camera, saved.view.camera, "the camera is restored");
    assert_eq!(s.project().motion, saved.motion);
    assert!(Path::new(&s.project().avatar.unwrap()).exists());
}

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
    let flagged: Vec<_> = c.frames.iter().filter(|f| f.problem.is_some()).collect();
    assert_eq!(flagged.len(), 1);
    assert_eq!(flagged[0].index, 3);
    assert_eq!(c.usable(), c.frames.len() - 1);
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

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// A copy of the demo capture that no other test touches.
fn private_demo() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let demo = avatar_studio::studio::demo::demo_capture_dir().unwrap();
    std::fs::create_dir_all(dir.path().join("depth")).unwrap();
    std::fs::copy(demo.join("capture.json"), dir.path().join("capture.json")).unwrap();
    for e in std::fs::read_dir(demo.join("depth")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.path().join("depth").join(e.file_name())).unwrap();
    }
    dir
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

/// With no native dialog (no XDG portal), saving asks with the studio's own dialog: it lists
/// the folder, proposes the default name and saves there; Ctrl+S then saves without asking.
#[test]
fn the_in_app_path_dialog_saves_without_a_portal() {
    use avatar_studio::studio::settings::{NoDialogs, PathPurpose};
    // A fixed folder, so that the snapshot shows the same path on every run.
    let dir = std::env::temp_dir().join("avatar-studio-dialog-test");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("captures")).unwrap();
    std::fs::write(dir.join("old.studio.json"), "{}").unwrap();
    std::fs::write(dir.join("notes.txt"), "not listed").unwrap();
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    h.state_mut().set_dialogs(Box::new(NoDialogs));
    settle(&mut h, "loading the demo");
    h.state_mut().apply(Command::AskPath(PathPurpose::SaveProject));
    h.state_mut().path_dialog.as_mut().expect("the in-app dialog is open").go_to(dir.clone());
    for _ in 0..3 {
        h.step(); // a new window is sized in its first frame
    }
    h.get_by_label("[folder] captures");
    h.get_by_label("old.studio.json");
    assert!(h.query_by_label("notes.txt").is_none(), "the filter hides other files");
    assert_eq!(h.state().path_dialog.as_ref().unwrap().name, "session.studio.json");
    snap(&mut h, "path_dialog", &tolerant(200));
    h.get_by_label("Save").click();
    h.step();
    h.step();
    let project = dir.join("session.studio.json");
    assert!(h.state().path_dialog.is_none(), "the dialog closed");
    assert!(project.exists(), "{:?}", h.state().status);
    assert_eq!(h.state().project_path.as_deref(), Some(project.as_path()));
    // Ctrl+S saves again, no dialog.
    std::fs::remove_file(&project).unwrap();
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::S);
    h.step();
    assert!(project.exists() && h.state().path_dialog.is_none());
    // A failure is a visible message: opening a file that is not there.
    h.state_mut().apply(Command::OpenPath(dir.join("missing.avatar")));
    settle(&mut h, "opening a missing avatar");
    assert!(
        h.state().error.as_deref().is_some_and(|e| e.contains("missing.avatar")),
        "{:?}",
        h.state().error
    );
    let _ = std::fs::remove_dir_all(&dir);
    // ? lists the shortcuts.
    h.key_press(egui::Key::Questionmark);
    for _ in 0..3 {
        h.step();
    }
    assert!(h.state().show_shortcuts);
    h.get_by_label("Ctrl+S");
}

/// Pose refinement: the capture view's body stands at the fitting the open avatar refined the
/// selected frame to (the avatar file's refined poses), not at the capture's given fitting.
#[test]
fn the_capture_view_shows_the_refined_pose_of_a_frame() {
    use avatar_core::export::{AvatarSource, SyntheticAvatar};
    use avatar_neural::avatar::refined_poses::RefinedPose;
    use avatar_studio::studio::avatar::StudioAvatar;
    use std::sync::Arc;
    struct Refined(SyntheticAvatar, Vec<RefinedPose>);
    impl StudioAvatar for Refined {
        fn describe(&self) -> String {
            "refined".into()
        }
        fn source(&self) -> &dyn AvatarSource {
            &self.0
        }
        fn save(&self, _: &Path) -> Result<(), avatar_studio::StudioError> {
            Err(avatar_studio::StudioError::invalid("not saved"))
        }
        fn refined_poses(&self) -> &[RefinedPose] {
            &self.1
        }
    }
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    settle(&mut h, "opening the demo");
    h.state_mut().set_mode(ViewMode::Capture);
    h.state_mut().view.selected_frame = 0;
    let given = h.state().capture.as_ref().unwrap().frames[0]
        .params
        .clone()
        .expect("the demo's frame 0 has a fitting");
    let before: Vec<[f32; 3]> = h.state().build_scene().vertices.iter().map(|v| v.pos).collect();
    let mut refined = given.clone();
    refined.pose[18].y += 0.5; // the left elbow, 29 degrees
    refined.trans.x += 0.05;
    let synthetic = SyntheticAvatar::new(
        avatar_core::body::open_body(),
        2024,
        avatar_core::synth::Outfit::TshirtShorts,
        &Default::default(),
    )
    .unwrap();
    h.state_mut().avatar = Some(Arc::new(Refined(
        synthetic,
        vec![RefinedPose { given: given.clone(), refined: refined.clone() }],
    )));
    assert_eq!(h.state().refined_fitting(&given), Some(&refined));
    let after: Vec<[f32; 3]> = h.state().build_scene().vertices.iter().map(|v| v.pos).collect();
    assert_eq!(before.len(), after.len());
    let moved = before
        .iter()
        .zip(&after)
        .map(|(a, b)| glam::Vec3::from(*a).distance(glam::Vec3::from(*b)))
        .fold(0.0f32, f32::max);
    assert!(moved > 0.05, "the body moved to the refined pose ({moved} m)");
    // Another frame has no refined fitting: its body stays at the given one.
    let other = h.state().capture.as_ref().unwrap().frames[1].params.clone().unwrap();
    assert!(h.state().refined_fitting(&other).is_none());
}

/// An OBJ scan opens like a capture (issue 18): the in-app dialog lists the .obj, the scan is
/// seen by a ring of virtual depth cameras (`import scan`'s recipe) into a capture in the
/// cache, the depth points lie on the scan's surface, the user's folder is only read, and a
/// scan without its fitting is refused with a message naming the file.
#[test]
fn an_obj_scan_opens_as_a_capture() {
    use avatar_core::body::{BodyParams, open_body_ref};
    use avatar_core::synth::{
        ClothedTemplate, Outfit, PoseFeatures, canonical_surface, pose_surface,
    };
    use avatar_studio::studio::settings::{NoDialogs, PathPurpose};
    // A synthetic clothed person, arms lowered and turned, written as an OBJ with its fitting.
    let mut pose = BodyParams::default();
    pose.pose[0].y = 0.4;
    pose.pose[16].z = -0.8;
    pose.pose[17].z = 0.8;
    let body = open_body_ref();
    let t = ClothedTemplate::build(body, &[], Outfit::PoloLoose);
    let posed = body.pose(&pose);
    let canonical = canonical_surface(&t, &PoseFeatures::of(&posed.bones), 7);
    let mesh = avatar_core::mesh::TriMesh::new(
        pose_surface(&t, &canonical, &posed.bones),
        t.faces.clone(),
    );
    let dir = tempfile::tempdir().unwrap();
    let scan = dir.path().join("person.obj");
    avatar_core::mesh::io::write_obj(&scan, &mesh).unwrap();
    std::fs::write(dir.path().join("person.pose.json"), serde_json::to_string(&pose).unwrap())
        .unwrap();
    let scan_bytes = std::fs::read(&scan).unwrap();

    let mut h = harness(StudioOptions::default());
    h.state_mut().set_dialogs(Box::new(NoDialogs));
    h.state_mut().apply(Command::AskPath(PathPurpose::OpenScan));
    h.state_mut()
        .path_dialog
        .as_mut()
        .expect("the in-app dialog is open")
        .go_to(dir.path().to_path_buf());
    for _ in 0..3 {
        h.step();
    }
    assert!(h.query_by_label("person.pose.json").is_none(), "only OBJ files are listed");
    h.get_by_label("person.obj").click();
    h.step();
    h.get_by_label("Open").click();
    h.step();
    settle(&mut h, "importing and opening the scan");
    let app = h.state();
    assert!(app.error.is_none(), "{:?}", app.error);
    let c = app.capture.as_ref().expect("the scan is open as a capture");
    assert_eq!((c.frames.len(), c.usable(), c.name.as_str()), (8, 8, "person.obj"));
    assert_eq!(app.capture_source.as_deref(), Some(scan.to_str().unwrap()));
    assert!(
        c.dir.starts_with(avatar_studio::studio::demo::cache_dir()),
        "imported into the cache: {}",
        c.dir.display()
    );
    // Every frame's back-projected depth lies on the scan (0.1 mm depth steps).
    let surface = avatar_core::eval::metrics::Prepared::new(&mesh, "scan").unwrap();
    for f in &c.frames {
        assert!(f.points.len() > 1000, "frame {}: {} points", f.index, f.points.len());
        let mean = f.points.iter().map(|p| surface.surface_distance(*p)).sum::<f32>()
            / f.points.len() as f32;
        assert!(mean < 2e-3, "frame {}: the depth is {mean} m from the scan", f.index);
    }
    let capture_dir = c.dir.clone();
    assert_eq!(std::fs::read(&scan).unwrap(), scan_bytes, "the scan is only read");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        2,
        "nothing is written beside the scan"
    );
    // Opened again (a typed or dropped path): the same capture, not imported again.
    h.state_mut().apply(Command::OpenPath(scan.clone()));
    settle(&mut h, "reopening the scan");
    assert_eq!(h.state().capture.as_ref().unwrap().dir, capture_dir);
    let _ = std::fs::remove_dir_all(&capture_dir);

    // Without its fitting, the scan is refused with the reason.
    let lone = dir.path().join("lone");
    std::fs::create_dir(&lone).unwrap();
    std::fs::copy(&scan, lone.join("other.obj")).unwrap();
    h.state_mut().apply(Command::OpenPath(lone.join("other.obj")));
    settle(&mut h, "opening a scan without a fitting");
    let e = h.state().error.clone().unwrap_or_default();
    assert!(e.contains("other.obj") && e.contains("other.pose.json"), "{e}");
}

/// While the view moves on lavapipe (the turntable here), the panels are painted by the
/// studio's own shader (viewport::ui_meshes, a fraction of egui-wgpu's cost there) and look as
/// egui paints them: outside the 3D view (and the Turntable button, on while moving) a moving
/// frame is the still window's, up to the filtering of glyph edges (egui's test renderer
/// filters by hand, ours with the sampler); also after the panels changed between two moving
/// frames (the timeline's frame).
#[test]
fn a_moving_view_paints_the_panels_as_egui_does() {
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    settle(&mut h, "loading the demo");
    h.remove_cursor();
    let compare = |h: &mut Harness<'static, StudioApp>, frame: usize| {
        h.state_mut().turntable = false;
        h.state_mut().timeline.set_frame(frame);
        h.step();
        h.step();
        let still = h.render().expect("render");
        assert!(!h.state().ui_meshes_painted, "a still window is painted by egui");
        h.state_mut().turntable = true;
        h.step();
        h.step();
        let moving = h.render().expect("render");
        let software = h.state().viewport_moving && h.state().flat_painting();
        assert_eq!(
            h.state().ui_meshes_painted,
            software,
            "the panels are ours exactly when moving on a software renderer"
        );
        let view = h.state().viewport_rect().expect("a viewport");
        let button = h.get_by_label("Turntable").rect();
        let ppp = h.ctx.pixels_per_point();
        let (mut compared, mut differing, mut worst) = (0, 0, 0);
        for (x, y, a) in still.enumerate_pixels() {
            let p = egui::pos2(x as f32 / ppp, y as f32 / ppp);
            if view.expand(1.0).contains(p) || button.expand(1.0).contains(p) {
                continue;
            }
            let b = moving.get_pixel(x, y);
            let d = a.0.iter().zip(b.0).map(|(a, b)| a.abs_diff(b)).max().unwrap_or(0);
            compared += 1;
            worst = worst.max(d);
            differing += usize::from(d > 8);
        }
        // Measured: none differs at all (a texture coordinate 1 % off: 12,000 pixels).
        assert!(compared > 100_000, "{compared} pixels outside the view");
        assert!(
            differing <= compared / 10_000,
            "frame {frame}: {differing} of {compared} pixels differ by more than 8 levels (worst {worst})"
        );
        moving
    };
    let first = compare(&mut h, 0);
    let second = compare(&mut h, 40);
    assert_ne!(first, second, "the timeline moved on between the two moving frames");
}
