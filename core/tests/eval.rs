//! The evaluation harness end to end on a tiny configuration: the ground truth scores
//! perfectly, the naked body scores the clothing's thickness, reports round trip, and a failing
//! row is an error, not a panic.

use avatar_core::body::{BodyParams, open_body_ref};
use avatar_core::error::{Error, Result};
use avatar_core::eval::*;
use avatar_core::mesh::TriMesh;
use avatar_core::synth::Outfit;

fn tiny(protocols: Vec<Protocol>, name: &str) -> EvalConfig {
    let workdir = std::env::temp_dir().join(format!("eval-test-{}-{name}", std::process::id()));
    let mut c = EvalConfig::paper(protocols, workdir);
    c.subjects.truncate(1);
    c.outfits = vec![Outfit::BlazerTails];
    c.finetune_clips.truncate(2);
    c.heldout_stride = 20;
    c.metrics.chamfer_samples = 800;
    c.metrics.iou_resolution = 40;
    c
}

#[test]
fn reference_rows_score_as_expected() {
    let body = open_body_ref();
    let mut rows: Vec<Box<dyn Predictor>> = vec![Box::new(NakedBody::new(body.clone()))];
    let report = run(
        body,
        &tiny(vec![Protocol::Interpolation, Protocol::Extrapolation], "reference"),
        &mut rows,
        &|_| {},
    )
    .unwrap();
    assert_eq!(report.rows.len(), 4);
    for r in &report.rows {
        assert!(r.evaluated_frames >= 5, "{r:?}");
        if r.method.starts_with("ground truth") {
            assert_eq!((r.dp_cm.max, r.df_cm.max), (0.0, 0.0), "{r:?}");
            assert!(r.chamfer_cm.max < 1e-4, "{r:?}");
            assert!((r.nc.min - 1.0).abs() < 1e-6 && (r.iou.min - 1.0).abs() < 1e-6, "{r:?}");
        } else {
            // The blazer is 2-3 cm thick and has tails: the naked body misses by that much.
            assert!(r.df_cm.mean > 1.0 && r.df_cm.mean < 6.0, "{r:?}");
            assert!(r.dp_cm.mean >= r.df_cm.mean, "vertex distance bounds surface distance: {r:?}");
            assert!(r.iou.mean < 0.95 && r.iou.mean > 0.4, "{r:?}");
        }
    }
    // Interpolation trains on every 10th frame of the 2 clips; extrapolation evaluates held-out clips.
    let interp = &report.rows[0];
    assert_eq!(interp.protocol, "interpolation");
    let expected: usize = ["walk", "raise_arms"]
        .iter()
        .map(|c| {
            protocol::finetune_frames(avatar_core::motion::clip_by_name(c).unwrap().len()).len()
        })
        .sum();
    assert_eq!(interp.training_frames, expected);
    assert!(expected >= 16);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.json");
    report.save_json(&path).unwrap();
    let back: Report = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(back, report);
    let md = report.markdown();
    assert!(
        md.contains("**clean capture, extrapolation**")
            && md.contains("| naked body (LBS) | blazer_tails |"),
        "{md}"
    );
    // The naked body lacks the blazer's tails and thickness: surface is missing, more of it in
    // the clothed region than over the whole body (hands, feet and head are exact).
    let naked = &report.rows[1];
    assert!(
        naked.missing.mean > 0.05 && naked.cloth_missing.mean >= naked.missing.mean,
        "{naked:?}"
    );
    assert!(naked.missing.mean > naked.spurious.mean && naked.p99_cm.mean > 2.0, "{naked:?}");
    let truth = &report.rows[2];
    assert_eq!(
        (truth.spurious.max, truth.missing.max, truth.cloth_spurious.max),
        (0.0, 0.0, 0.0),
        "{truth:?}"
    );
}

struct Broken;
impl Predictor for Broken {
    fn name(&self) -> String {
        "broken".into()
    }
    fn fit(&mut self, data: &FitData) -> Result<()> {
        // The fine-tuning capture exists and opens.
        let cap = avatar_core::capture::Capture::open(data.capture_dir)?;
        assert!(!cap.frames.is_empty());
        Ok(())
    }
    fn predict(&self, _: &BodyParams) -> Result<TriMesh> {
        Err(Error::invalid("this row cannot predict"))
    }
}

#[test]
fn a_failing_row_is_an_error_and_fine_tuning_gets_a_capture() {
    let body = open_body_ref();
    let mut rows: Vec<Box<dyn Predictor>> = vec![Box::new(Broken)];
    let mut config = tiny(vec![Protocol::FewShot(Shots::OnePerClip)], "broken");
    config.ground_truth_row = false;
    let err = run(body, &config, &mut rows, &|_| {}).unwrap_err().to_string();
    assert!(err.contains("cannot predict"), "{err}");
}

#[test]
fn the_pose_independent_outfit_is_exact_at_rest_and_misses_only_the_pose_dependent_clothing() {
    let body = open_body_ref();
    let betas = avatar_core::synth::subject_betas(body, 1001);
    let mut row = StaticOutfit::new(body.clone());
    let dir = tempfile::tempdir().unwrap();
    let field_cache = avatar_core::canonical::FieldCache::none();
    let data = FitData {
        capture_dir: dir.path(),
        body,
        betas: &betas,
        outfit: Outfit::PoloLoose,
        field_cache: &field_cache,
    };
    row.fit(&data).unwrap();
    let template = avatar_core::synth::ClothedTemplate::build(body, &betas, Outfit::PoloLoose);
    let regions = Regions::of_template(&template).unwrap();
    let score = |params: &BodyParams| {
        let p = BodyParams { betas: betas.clone(), ..params.clone() };
        let gt = runner::ground_truth_mesh(body, &template, &p, 1001);
        metrics::evaluate_frame(
            &row.predict(&p).unwrap(),
            &gt,
            &regions,
            &metrics::MetricOptions {
                chamfer_samples: 500,
                iou_resolution: 32,
                ..Default::default()
            },
            0,
        )
        .unwrap()
    };
    // At the rest pose there is no fold, lift or swing: the row is the ground truth.
    let rest = score(&BodyParams::default());
    assert!(rest.df_cm < 1e-3 && rest.nc > 0.999, "{rest:?}");
    // A deep squat folds the trousers at the knees and lifts nothing else: close, not exact.
    let squat = avatar_core::motion::clip_by_name("squat").unwrap();
    let deep = squat.frames[squat.len() / 2].clone();
    let s = score(&deep);
    assert!(s.df_cm > 0.05 && s.df_cm < 1.5 && s.nc < 0.995 && s.nc > 0.8, "{s:?}");
}

/// Records what each fine-tuning capture holds; predicts the naked body.
struct Inspect {
    naked: NakedBody,
    /// Per fit: the fittings and the depth's roughness (median |second difference| along rows, m).
    seen: Seen,
}
type Seen = std::sync::Arc<std::sync::Mutex<Vec<(Vec<BodyParams>, f32)>>>;
impl Predictor for Inspect {
    fn name(&self) -> String {
        "inspect".into()
    }
    fn fit(&mut self, data: &FitData) -> Result<()> {
        let manifest = avatar_core::capture::CaptureManifest::load(data.capture_dir)?;
        let params = manifest.frames.iter().map(|f| f.params()).collect::<Result<Vec<_>>>()?;
        let mut second = Vec::new();
        for f in &manifest.frames {
            let d = avatar_core::capture::read_depth_png(
                data.capture_dir.join(&f.depth),
                manifest.depth_scale,
            )?;
            for row in d.metres.chunks(d.width as usize) {
                for w in row.windows(3) {
                    if w.iter().all(|&z| z > 0.0) && (w[2] - w[0]).abs() < 0.05 {
                        second.push((w[0] - 2.0 * w[1] + w[2]).abs());
                    }
                }
            }
        }
        second.sort_by(f32::total_cmp);
        self.seen.lock().unwrap().push((params, second[second.len() / 2]));
        self.naked.fit(data)
    }
    fn predict(&self, p: &BodyParams) -> Result<TriMesh> {
        self.naked.predict(p)
    }
}

#[test]
fn user_captures_have_holes_fitting_errors_and_other_turns_and_sheets_are_drawn() {
    let body = open_body_ref();
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let mut rows: Vec<Box<dyn Predictor>> =
        vec![Box::new(Inspect { naked: NakedBody::new(body.clone()), seen: seen.clone() })];
    let mut config = tiny(vec![Protocol::FewShot(Shots::OnePerClip)], "user");
    config.captures = vec![CaptureConditions::user(), CaptureConditions::clean()];
    config.ground_truth_row = false;
    let sheets = tempfile::tempdir().unwrap();
    config.contact_sheets = Some(sheets.path().to_path_buf());
    let report = run(body, &config, &mut rows, &|_| {}).unwrap();
    assert_eq!(report.rows.len(), 2);
    assert_eq!(
        (report.rows[0].capture.as_str(), report.rows[1].capture.as_str()),
        ("user", "clean")
    );
    assert!(report.captures[0].contains("kinect_v2"), "{:?}", report.captures);
    let seen = seen.lock().unwrap();
    let ((user, user_rough), (clean, clean_rough)) = (&seen[0], &seen[1]);
    assert_eq!(user.len(), 2);
    // Depth noise (4 mm at 2.4 m): the user capture's depth is much rougher than the exact render.
    assert!(
        *user_rough > 3.0 * clean_rough && *user_rough > 0.003,
        "{user_rough} vs {clean_rough}"
    );
    // The fittings are off by a few degrees per joint and about a centimetre.
    let knee = |p: &BodyParams| glam::Quat::from_scaled_axis(p.pose[4]);
    let knee_error: f32 = user
        .iter()
        .zip(clean.iter())
        .map(|(u, c)| knee(u).angle_between(knee(c)).to_degrees())
        .sum::<f32>()
        / 2.0;
    assert!(knee_error > 0.3 && knee_error < 12.0, "{knee_error}");
    assert!((user[0].trans - clean[0].trans).length() < 0.05);
    assert!(user.iter().zip(clean.iter()).any(|(u, c)| u.trans != c.trans));
    assert!(user.iter().zip(clean.iter()).all(|(u, c)| u.betas == c.betas), "the shape is exact");
    // One sheet per outfit: truth and the row, front and side.
    let img = image::open(sheets.path().join("eval-blazer_tails.png")).unwrap();
    assert_eq!((img.width(), img.height()), (2 * 180, 2 * 270));
}
