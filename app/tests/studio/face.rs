//! The first thing every user does: the studio's default fine-tune of the embedded demo
//! (`FitConfig::default()`, the fit's defaults: 32 frames, 256 steps). Its face must come out
//! clean: little of the head's surface may face against the body beneath it (the measure of
//! `avatar-studio check`), few faces may cross others, and a close-up snapshot of the posed
//! face guards the look
//! (docs/integrity.md, "The demo's face").

use super::*;
use avatar_core::body::BodyParams;
use avatar_core::eval::integrity::inside_out_shares;
use avatar_core::eval::metrics::Prepared;
use avatar_core::mesh::integrity::self_intersecting_faces;
use avatar_core::synth::outfit::{dominant, joint};
use avatar_studio::studio::camera::OrbitCamera;
use avatar_studio::studio::fit_config::FitConfig;

/// The head's joints (`avatar-studio check`): the neck and the head.
const HEAD: [usize; 2] = [joint::NECK, 15];

#[test]
fn the_demo_default_fit_has_a_clean_face() {
    let mut h = harness(StudioOptions { load_demo: true, ..Default::default() });
    settle(&mut h, "loading the demo");
    let dir = h.state().capture.as_ref().unwrap().dir.clone();
    let ctx = h.ctx.clone();
    let job =
        avatar_studio::studio::avatar_job::FitJob::start(dir, FitConfig::default(), move || {
            ctx.request_repaint()
        });
    h.state_mut().apply(Command::WatchFit(job));
    let t = Instant::now();
    while h.state().job.is_some() || h.state().avatar.is_none() {
        h.step();
        assert!(t.elapsed() < Duration::from_secs(1500), "the default fit did not finish");
        std::thread::sleep(Duration::from_millis(50));
    }
    let avatar = h.state().avatar.clone().expect("the fit produced an avatar");

    // At rest, the head's surface against the body beneath it.
    let source = avatar.source();
    let body = source.body();
    let rest = BodyParams { betas: source.betas().to_vec(), ..BodyParams::default() };
    let mesh = source.canonical_mesh(&rest).unwrap();
    let naked = body.mesh(body.pose(&rest).vertices);
    let beneath = Prepared::new(&naked, "body").unwrap();
    let on_head =
        |p: glam::Vec3| HEAD.contains(&dominant(&body.weights[beneath.vertices.nearest(p).0]));
    let (_, head) = inside_out_shares(&mesh, &beneath, on_head);
    assert!(head < 0.005, "{:.2} % of the head faces against the body", 100.0 * head);
    // Creases narrower than the cloth's offset (eyelids, nostrils, ears) fold the offset
    // surface through itself unless each offset stays inside the room the body leaves
    // (`WrapOptions::crease_share`): 3.6 % of the faces crossed others before, 0.7 % after; the
    // naked body's own mesh has 0.3 % (its toes). What still crossed on the head (63 faces at
    // the eyelids, lips and nostrils) is spanned as a membrane (`WrapOptions::span_crossings`):
    // no face of the head crosses another.
    let crossing = self_intersecting_faces(&mesh.positions, &mesh.faces);
    let share = crossing.iter().filter(|&&c| c).count() as f32 / crossing.len() as f32;
    assert!(share < 0.006, "{:.2} % of the faces cross others", 100.0 * share);
    let on_head_face = |f: &[u32; 3]| f.iter().all(|&v| on_head(mesh.positions[v as usize]));
    let head_crossing =
        mesh.faces.iter().zip(&crossing).filter(|(f, c)| **c && on_head_face(f)).count();
    assert_eq!(head_crossing, 0, "faces of the head cross others");

    // The posed face, close up from the front.
    h.state_mut().set_mode(ViewMode::Posed);
    settle(&mut h, "posing the avatar");
    let posed = h.state().posed.as_ref().unwrap().positions.clone();
    let top = posed.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    let near_top: Vec<_> = posed.iter().filter(|p| p.y > top - 0.25).collect();
    let centre = near_top.iter().fold(glam::Vec3::ZERO, |s, p| s + **p) / near_top.len() as f32;
    h.state_mut().view.camera = OrbitCamera {
        target: [centre.x, top - 0.12, centre.z],
        yaw: 0.0,
        pitch: 0.05,
        distance: 0.75,
        ..OrbitCamera::default()
    };
    settle(&mut h, "the close-up");
    // The fit's last bits differ between CPUs even on the forced AVX2 path (the loss ends at
    // 21.74 on an AMD EPYC, 21.53 on an Intel Xeon, both faces clean): the close-up moves by
    // 2,323 pixels between those two and by 3,817 on an AMD Zen 5 (eyelids and lips shifted
    // by a pixel, the loss's digits), so it allows 5,000; the face's properties are the
    // asserts above.
    snap(&mut h, "demo_face_closeup", &tolerant(5000));
}
