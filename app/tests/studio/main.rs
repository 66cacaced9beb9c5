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
    // The snapshots show fitted avatars: every CPU fits with the AVX2 + FMA kernels here, so
    // that a machine with AVX-512 (whose sums round differently) draws the same pixels.
    avatar_neural::training::step::set_kernel_path(avatar_neural::training::step::KernelPath::Avx2);
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
        assert_eq!(app.frame_store.checked(), c.frames.len(), "a short capture is checked whole");
        assert!(app.frame_store.usable() >= 8, "the demo has usable frames");
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
    // The fitted avatar's last bits differ between CPUs: 1,569 pixels on an AMD Zen 5.
    snap(&mut h, "avatar_pose_moved", &tolerant(2500));
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
    let buffers = [g.blob.clone().expect("a binary chunk")];
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

mod capture_switch;
mod dialogs_and_scans;
mod face;
mod jobs_and_playback;
mod long_capture;
mod long_take;
mod timeline;
