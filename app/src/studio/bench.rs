//! The studio's speed numbers for `avatar-studio bench --only studio`: opening the demo,
//! meshing an avatar, and the pose slider's round trip (request to posed mesh) through the pose
//! worker. Start-to-first-frame needs a window: `avatar-studio --timing` prints it.

use crate::studio::avatar::{body_canonical, canonical_of};
use crate::studio::avatar_job::run_fit;
use crate::studio::capture_view::load_capture;
use crate::studio::fit_config::FitConfig;
use crate::studio::posing::{Posable, PoseWorker};
use crate::studio::timeline::Timeline;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

fn round_trip(
    worker: &mut PoseWorker,
    timeline: &mut Timeline,
    posable: &Posable,
    body: &Arc<avatar_core::body::BodyModel>,
    betas: &[f32],
) -> f64 {
    let mut times = Vec::new();
    for f in (0..timeline.frames()).step_by((timeline.frames() / 12).max(1)) {
        timeline.set_frame(f);
        let t = Instant::now();
        worker.request(timeline.params(betas), posable.clone(), body.clone());
        loop {
            if let Some(r) = worker.poll() {
                r.expect("posing works");
                break;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

pub fn bench_report() -> String {
    let mut out = String::from("## studio\n\n| what | median | note |\n|---|---|---|\n");
    let dir = match crate::studio::demo::demo_capture_dir() {
        Ok(d) => d,
        Err(e) => return out + &format!("| the demo capture | | {e} |\n"),
    };
    let t = Instant::now();
    let capture = match load_capture(&dir) {
        Ok(c) => c,
        Err(e) => return out + &format!("| open the demo | | {e} |\n"),
    };
    out += &format!(
        "| open the demo capture for the studio ({} frames, thumbnails) | {:.0} ms | start-up shows the window before this finishes |\n",
        capture.frames.len(),
        t.elapsed().as_secs_f64() * 1e3
    );
    let body = capture.body.clone();
    let betas = capture.betas.clone();
    let mut worker = PoseWorker::start(|| {});
    let mut timeline = Timeline::library("walk").expect("library clip");
    let rest = Posable::Mesh(Arc::new(body_canonical(&body, &betas)));
    let s = round_trip(&mut worker, &mut timeline, &rest, &body, &betas);
    out += &format!(
        "| pose slider to posed mesh: the capture's body ({} vertices) | {:.1} ms | target: under 0.5 s on 2 cores |\n",
        body.num_vertices(),
        s * 1e3
    );
    let t = Instant::now();
    let cfg = FitConfig::tiny();
    let fitted = run_fit(&dir, &cfg, &AtomicBool::new(false), &|| {}, &|_| {});
    let fit_s = t.elapsed().as_secs_f64();
    match fitted {
        Ok((avatar, _)) => {
            out += &format!(
                "| fine-tune the quick configuration ({}, {} steps, {} frames) | {:.1} s | |\n",
                avatar.describe(),
                cfg.steps,
                cfg.frames,
                fit_s
            );
            let file = std::env::temp_dir()
                .join(format!("avatar-studio-bench-{}.avatar", std::process::id()));
            if let Err(e) = avatar.save(&file) {
                return out + &format!("| save the avatar | | {e} |\n");
            }
            for res in [96usize, 128] {
                let a = match crate::studio::avatar::load_avatar(&file, res) {
                    Ok(a) => a,
                    Err(e) => return out + &format!("| load the avatar | | {e} |\n"),
                };
                let t = Instant::now();
                let m = canonical_of(a.as_ref(), &betas).expect("meshing works");
                let mesh_s = t.elapsed().as_secs_f64();
                let n = m.mesh.positions.len();
                // As the studio poses it: smooth normals from the SDF's gradient at the rest pose.
                let rest =
                    avatar_core::body::BodyParams { betas: betas.clone(), ..Default::default() };
                let normals = Arc::new(
                    crate::studio::posing::sdf_normals(
                        a.source(),
                        &rest,
                        &m.mesh.positions,
                        &m.mesh.vertex_normals(),
                    )
                    .expect("the SDF evaluates"),
                );
                let posable = if a.pose_dependent() {
                    Posable::PoseDependent {
                        avatar: a.clone(),
                        reference: Arc::new(m),
                        rest_normals: Some(normals),
                    }
                } else {
                    Posable::Smooth { mesh: Arc::new(m), normals }
                };
                let s = round_trip(&mut worker, &mut timeline, &posable, &body, &betas);
                out += &format!(
                    "| mesh the avatar at {res} cells (once per avatar) | {:.2} s | {n} vertices |\n",
                    mesh_s
                );
                out += &format!(
                    "| pose slider to posed mesh: the avatar at {res} cells | {:.1} ms | target: 100 ms on 2 cores |\n",
                    s * 1e3
                );
                if res == 128 {
                    out += &long_take_row(&posable, &body, &betas);
                    out += &playback_rows(&posable, &body, &timeline, &betas);
                }
            }
            let _ = std::fs::remove_file(&file);
        }
        Err(e) => out += &format!("| fine-tune | | {e} |\n"),
    }
    out += &viewport_row();
    out += "| start to first frame, start to demo loaded and posed | | a real window: `avatar-studio --timing` (see README) |\n";
    out
}

/// A long take opened as the studio opens a motion file: the 2,752-frame 120 fps BVH (the
/// library's clips back to back, `motion::bvh_write::long_take`) read and resampled to 30 fps,
/// then its bake started until the first frame plays; the bake is then stopped.
fn long_take_row(
    posable: &Posable,
    body: &Arc<avatar_core::body::BodyModel>,
    betas: &[f32],
) -> String {
    use crate::studio::playback::{BakeKey, Bakes, range_params};
    let fail = |e: String| format!("| long take: first playable frame | | {e} |\n");
    let file = std::env::temp_dir().join(format!("avatar-bench-take-{}.bvh", std::process::id()));
    let written = avatar_core::motion::bvh_write::long_take("take", 2752, 120.0)
        .and_then(|clip| avatar_core::motion::bvh_write::save_bvh(&clip, &file));
    if let Err(e) = written {
        return fail(e.to_string());
    }
    let t = Instant::now();
    let opened = Timeline::load_file(&file);
    let _ = std::fs::remove_file(&file);
    let timeline = match opened {
        Ok(t) => t,
        Err(e) => return fail(e.to_string()),
    };
    let open_s = t.elapsed().as_secs_f64();
    let (key, params) = (BakeKey::of_timeline(posable, &timeline), range_params(&timeline, betas));
    let mut bakes = Bakes::default();
    bakes.start(key.clone(), 0, posable.clone().exact(), body.clone(), params, Arc::new(|| {}));
    while bakes.frame(&key, 0).is_none() {
        if let Some(Err(e)) = bakes.poll() {
            return fail(e.to_string());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let first_s = t.elapsed().as_secs_f64();
    bakes.cancel();
    format!(
        "| long take: the 2,752-frame 120 fps BVH opened and resampled to {} frames at 30 fps; its first baked (playable) frame | {open_s:.2} s; {first_s:.2} s | the bake goes on in the background, each frame playable as it is baked |\n",
        timeline.frames()
    )
}

/// Playback: the walk clip baked for the avatar (in the background, once), then its baked
/// frames shown one after another as the studio does (the scene rebuilt from the frame's mesh
/// and normals, drawn by the viewport's renderer headless at 1280 x 800).
fn playback_rows(
    posable: &Posable,
    body: &Arc<avatar_core::body::BodyModel>,
    timeline: &Timeline,
    betas: &[f32],
) -> String {
    use crate::studio::playback::{BakeKey, Bakes, range_params};
    let (key, params) = (BakeKey::of_timeline(posable, timeline), range_params(timeline, betas));
    let mut bakes = Bakes::default();
    let t = Instant::now();
    bakes.start(key, 0, posable.clone().exact(), body.clone(), params, Arc::new(|| {}));
    let baked = loop {
        match bakes.poll() {
            Some(Ok(b)) => break b,
            Some(Err(e)) => return format!("| bake the clip for playback | | {e} |\n"),
            None => std::thread::sleep(Duration::from_millis(2)),
        }
    };
    let mut out = format!(
        "| bake the walk clip for playback ({} frames, the avatar at 128 cells; once per avatar and clip) | {:.1} s | |\n",
        baked.frames.len(),
        t.elapsed().as_secs_f64()
    );
    let (device, queue, info) = match headless() {
        Ok(d) => d,
        Err(e) => return out + &format!("| playback | | {e} |\n"),
    };
    let size = [1280u32, 800u32];
    let mut camera = crate::studio::camera::OrbitCamera::default();
    let first = &baked.frames[0];
    if let Some((lo, hi)) = avatar_core::mesh::bounds(&first.positions) {
        camera.frame(lo, hi);
    }
    let scene_of = |m: &crate::studio::posing::PosedMesh| {
        let mut scene = crate::studio::viewport::Scene::new();
        scene.add_mesh_with_normals(
            &m.positions,
            m.normals.as_deref(),
            &m.faces,
            avatar_core::export::DEFAULT_COLOR,
        );
        scene.add_grid(glam::Vec3::ZERO, -1.2, 1.5, 0.25);
        scene
    };
    let t = Instant::now();
    let scenes: Vec<_> = baked.frames.iter().map(|m| scene_of(m)).collect();
    let build_ms = t.elapsed().as_secs_f64() * 1e3 / scenes.len() as f64;
    drop(scenes);
    out += &format!(
        "| playback: the scene rebuilt from a baked frame ({} vertices; CPU, uploaded with the draw below) | {build_ms:.2} ms | |\n",
        first.positions.len()
    );
    let software = info.device_type == eframe::egui_wgpu::wgpu::DeviceType::Cpu;
    let mut resources = crate::studio::viewport::ViewportResources::new(
        &device,
        eframe::egui_wgpu::wgpu::TextureFormat::Rgba8Unorm,
        software,
    );
    // While playing (moving) as the studio draws it, then paused (4x MSAA) for comparison.
    for moving in [true, false] {
        let samples = resources.samples(moving);
        let drawn = resources.render_size(size, moving);
        // The first frame (not timed) builds this sample count's pipelines and targets.
        let mut t = Instant::now();
        for (i, m) in std::iter::once(first).chain(baked.frames.iter()).enumerate() {
            if i == 1 {
                t = Instant::now();
            }
            let scene = scene_of(m);
            let mut encoder = device.create_command_encoder(&Default::default());
            resources.render(
                &device,
                &queue,
                &mut encoder,
                &scene,
                &camera.matrices(size[0] as f32 / size[1] as f32),
                crate::studio::viewport::Shading::Lit,
                3.0,
                drawn,
                crate::studio::project::default_light(),
                samples,
            );
            queue.submit([encoder.finish()]);
            if let Err(e) = device.poll(eframe::egui_wgpu::wgpu::PollType::wait_indefinitely()) {
                return out + &format!("| playback | | {e} |\n");
            }
        }
        let fps = baked.frames.len() as f64 / t.elapsed().as_secs_f64();
        let what = if moving { "playing" } else { "the paused look, for comparison" };
        out += &format!(
            "| playback of the baked clip ({what}): each frame's scene rebuilt, uploaded and drawn for a 1280 x 800 view ({} x {} pixels), {samples} sample(s) a pixel, on {} ({:?}) | {fps:.1} fps | target: the clip's 30 fps |\n",
            drawn[0], drawn[1], info.name, info.device_type
        );
    }
    out
}

type Headless = (
    eframe::egui_wgpu::wgpu::Device,
    eframe::egui_wgpu::wgpu::Queue,
    eframe::egui_wgpu::wgpu::AdapterInfo,
);

/// A wgpu device without a window, on the adapter wgpu picks (`WGPU_BACKEND` chooses the API).
fn headless() -> crate::error::Result<Headless> {
    use eframe::egui_wgpu::wgpu;
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
    .map_err(|e| crate::error::StudioError::invalid(format!("no wgpu adapter: {e}")))?;
    let info = adapter.get_info();
    let (device, queue) = pollster::block_on(
        adapter.request_device(&wgpu::DeviceDescriptor::default()),
    )
    .map_err(|e| crate::error::StudioError::invalid(format!("no device on {}: {e}", info.name)))?;
    Ok((device, queue, info))
}

/// The viewport's frame rate with a 50k-triangle avatar: the studio's own renderer (offscreen
/// 4x MSAA target, depth, lit shading) drawing a 1280 x 800 viewport headless, on whichever
/// adapter wgpu picks (`WGPU_BACKEND` chooses the API; the row names the adapter, so a GPU
/// machine's run is told apart from lavapipe's). Each frame is submitted and waited for.
pub fn viewport_row() -> String {
    use crate::studio::camera::OrbitCamera;
    use crate::studio::viewport::{Scene, Shading, ViewportResources};
    use eframe::egui_wgpu::wgpu;
    let (device, queue, info) = match headless() {
        Ok(d) => d,
        Err(e) => return format!("| viewport frame rate | | {e} |\n"),
    };
    // The shipped meta-SDF meshed finely enough for about 50k triangles.
    let sdf = avatar_neural::model::siren_eval::SirenEval::of(
        &avatar_neural::MetaModel::shipped().static_siren(),
    );
    let options = avatar_core::mesh::extract::ExtractOptions::new(
        glam::Vec3::splat(-1.0),
        glam::Vec3::splat(1.0),
        230,
    );
    let mesh = match avatar_core::mesh::extract::extract(
        |p: &[glam::Vec3]| sdf.sdf(&p.iter().map(|q| q.to_array()).collect::<Vec<_>>()),
        &options,
    ) {
        Ok(e) => e.mesh,
        Err(e) => return format!("| viewport frame rate | | meshing failed: {e} |\n"),
    };
    let mut scene = Scene::new();
    scene.add_mesh(&mesh.positions, &mesh.faces, [0.85, 0.87, 0.9]);
    scene.add_grid(glam::Vec3::ZERO, -1.0, 2.0, 0.2);
    let size = [1280u32, 800u32];
    let mut camera = OrbitCamera::default();
    if let Some((lo, hi)) = scene.bounds() {
        camera.frame(lo, hi);
    }
    let mut resources = ViewportResources::new(
        &device,
        wgpu::TextureFormat::Rgba8Unorm,
        info.device_type == wgpu::DeviceType::Cpu,
    );
    let mut frame = |yaw: f32| {
        camera.yaw = yaw; // a turning camera: nothing is cached between frames but the buffers
        let mut encoder = device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("bench frame") });
        resources.render(
            &device,
            &queue,
            &mut encoder,
            &scene,
            &camera.matrices(size[0] as f32 / size[1] as f32),
            Shading::Lit,
            3.0,
            size,
            crate::studio::project::default_light(),
            crate::studio::viewport::MSAA,
        );
        queue.submit([encoder.finish()]);
        device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ())
    };
    for i in 0..3 {
        if let Err(e) = frame(i as f32 * 0.01) {
            return format!("| viewport frame rate | | {e} |\n");
        }
    }
    let (frames, t) = (60, Instant::now());
    for i in 0..frames {
        if let Err(e) = frame(i as f32 * 0.02) {
            return format!("| viewport frame rate | | {e} |\n");
        }
    }
    let fps = frames as f64 / t.elapsed().as_secs_f64();
    format!(
        "| viewport: {} triangles at 1280 x 800, 4x MSAA, headless on {} ({:?}, {:?}) | {fps:.1} fps | target: 60 fps on a GPU |\n",
        mesh.faces.len(),
        info.name,
        info.device_type,
        info.backend
    )
}
