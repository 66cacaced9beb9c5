//! A studio's own data: a small data set made with the synthetic generator, saved as clothed
//! scans (OBJ + fitting) and as a capture folder, with bad items beside the good ones. Discovery
//! groups the good items by subject and outfit and refuses each bad one by name; the good ones
//! become meta-training samples whose canonical points lie on the generator's canonical
//! surface; a tiny meta-training run on them gives a model that `fit --model` fine-tunes from,
//! and the avatar names that prior.

use avatar_core::body::{BodyParams, open_body_ref};
use avatar_core::canonical::FieldCache;
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::bvh::Bvh;
use avatar_core::mesh::io::write_obj;
use avatar_core::motion::library_split;
use avatar_core::own_data::{ItemKind, discover};
use avatar_core::synth::{
    ClothedTemplate, Outfit, PoseFeatures, SynthJob, canonical_surface, generate_capture,
    pose_surface, subject_betas,
};
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::data::own_data::{OwnDataOptions, prepare};
use avatar_neural::model::encoder::PoseEncoding;
use avatar_neural::model::model_file::{SHIPPED_PRIOR, sha256_hex};
use avatar_neural::training::meta_training::{MetaOptions, meta_train};
use avatar_neural::*;
use std::path::Path;

/// A training pose (no shape) of the library's training clips.
/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn pose(k: usize) -> BodyParams {
    let (train, _) = library_split();
    let frames: Vec<&BodyParams> = train.iter().flat_map(|c| &c.frames).collect();
    frames[(k * 37) % frames.len()].clone()
}

/// The generator's clothed subject posed at `params` (shape filled in), and its canonical
/// surface at that pose.
fn clothed(subject: u64, outfit: Outfit, params: &mut BodyParams) -> (TriMesh, TriMesh) {
    let body = open_body_ref();
    params.betas = subject_betas(body, subject);
    let template = ClothedTemplate::build(body, &params.betas, outfit);
    let bones = body.pose(params).bones;
    let canonical = canonical_surface(&template, &PoseFeatures::of(&bones), subject);
    let posed = pose_surface(&template, &canonical, &bones);
    (TriMesh::new(posed, template.faces.clone()), TriMesh::new(canonical, template.faces.clone()))
}

fn write_fitting(path: &Path, params: &BodyParams) {
    let json = serde_json::json!({
        "pose": params.flat_pose(),
        "betas": params.betas,
        "trans": params.trans.to_array(),
    });
    std::fs::write(path, serde_json::to_string(&json).unwrap()).unwrap();
}

/// Save a scan and its fitting as `dir/name.obj` + `dir/name.json`; the canonical surface.
fn save_scan(dir: &Path, name: &str, subject: u64, outfit: Outfit, k: usize) -> TriMesh {
    let mut params = pose(k);
    let (posed, canonical) = clothed(subject, outfit, &mut params);
    write_obj(dir.join(format!("{name}.obj")), &posed).unwrap();
    write_fitting(&dir.join(format!("{name}.json")), &params);
    canonical
}

/// The data set: s1 in a t-shirt (two scans, one capture of 3 frames, and four bad items),
/// s2 in a dress (one scan); returns the canonical surface of s1's first scan.
fn data_set(root: &Path) -> TriMesh {
    let tshirt = root.join("s1/tshirt_shorts");
    let dress = root.join("s2/dress");
    std::fs::create_dir_all(&tshirt).unwrap();
    std::fs::create_dir_all(&dress).unwrap();
    let canonical = save_scan(&tshirt, "scan_a", 1, Outfit::TshirtShorts, 0);
    save_scan(&tshirt, "scan_b", 1, Outfit::TshirtShorts, 1);
    save_scan(&dress, "scan_c", 2, Outfit::Dress, 2);
    let (train, _) = library_split();
    let job = SynthJob {
        frames: Some(3),
        write_ground_truth: false,
        ..SynthJob::new(1, Outfit::TshirtShorts, train[0].clone())
    };
    generate_capture(&tshirt.join("take1"), open_body_ref(), &job).unwrap();
    // A broken OBJ (its fitting is fine), a scan without its fitting, a fitting of another body
    // model (more shape coefficients than the open body has), an unreadable capture.
    std::fs::write(tshirt.join("broken.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
    std::fs::copy(tshirt.join("scan_a.json"), tshirt.join("broken.json")).unwrap();
    std::fs::copy(tshirt.join("scan_a.obj"), tshirt.join("orphan.obj")).unwrap();
    std::fs::copy(tshirt.join("scan_a.obj"), tshirt.join("smpl_fit.obj")).unwrap();
    let mut smpl = pose(0);
    smpl.betas = vec![0.5; open_body_ref().num_betas + 3];
    write_fitting(&tshirt.join("smpl_fit.json"), &smpl);
    std::fs::create_dir_all(tshirt.join("bad_take")).unwrap();
    std::fs::write(tshirt.join("bad_take/capture.json"), "{\"format\": 3").unwrap();
    canonical
}

#[test]
fn own_data_is_discovered_refused_by_name_prepared_and_meta_trained_into_a_prior_for_fit() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("data");
    let canonical_a = data_set(&root);

    // ---- Discovery: two groups, the bad items refused by name with their reason.
    let found = discover(&root).unwrap();
    let groups: Vec<(String, String, usize)> =
        found.groups.iter().map(|g| (g.subject.clone(), g.outfit.clone(), g.items.len())).collect();
    assert_eq!(
        groups,
        [("s1".into(), "tshirt_shorts".into(), 3), ("s2".into(), "dress".into(), 1)]
    );
    let kinds: Vec<bool> =
        found.groups[0].items.iter().map(|i| matches!(i.kind, ItemKind::Scan { .. })).collect();
    assert_eq!(kinds, [true, true, false], "scan_a, scan_b, take1 in name order");
    assert_eq!(found.groups[0].items[2].kind, ItemKind::Capture { frames: 3 });
    let refused: Vec<(String, String)> = found
        .refused
        .iter()
        .map(|r| (r.path.file_name().unwrap().to_string_lossy().into_owned(), r.reason.clone()))
        .collect();
    let reason = |name: &str| {
        refused
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, r)| r.clone())
            .unwrap_or_else(|| panic!("{name} not refused: {refused:?}"))
    };
    assert_eq!(refused.len(), 4, "{refused:?}");
    let broken = reason("broken.obj");
    assert!(broken.contains("out of range") || broken.contains("OBJ"), "{broken}");
    assert!(reason("orphan.obj").contains("without its body fitting"));
    assert!(reason("smpl_fit.obj").contains("shape coefficients"), "{}", reason("smpl_fit.obj"));
    assert!(reason("bad_take").contains("capture.json"), "{}", reason("bad_take"));
    let summary = found.summary();
    assert!(summary.contains("s1 / tshirt_shorts: 1 captures (3 frames), 2 scans"), "{summary}");
    assert!(summary.contains("smpl_fit.obj"), "the dry run names the refused items");

    // A capture folder given as the data folder is named as such.
    let e = discover(&root.join("s1/tshirt_shorts/take1")).unwrap_err().to_string();
    assert!(e.contains("take1") && e.contains("one capture folder"), "{e}");

    // ---- Samples: 2 scans + 2 frames of the capture + 1 scan, each 300 canonical points.
    let options = OwnDataOptions {
        points_per_pose: 300,
        frames_per_capture: 2,
        seed: 0,
        field_cache: field_cache(),
    };
    let own = prepare(&found, &options, &mut |_| {}).unwrap();
    assert_eq!(own.items_used, 4);
    assert_eq!(own.skipped.len(), 4, "only discovery's refusals: {:?}", own.skipped);
    let data = &own.data;
    assert_eq!(data.len(), 5);
    let spans: Vec<(usize, usize)> =
        data.manifest.groups.iter().map(|g| (g.first_sample, g.samples)).collect();
    assert_eq!(spans, [(0, 4), (4, 1)]);
    assert_eq!(data.manifest.groups[1].name.as_deref(), Some("s2"));
    assert!(data.points.iter().all(|p| p.len() == 300));
    assert!(data.normals.iter().flatten().all(|n| (n.length() - 1.0).abs() < 1e-3));
    // The first scan's canonical points lie on the generator's canonical surface of its pose.
    let g = &data.manifest.groups[0];
    let surface = Bvh::build(&canonical_a);
    let mut d: Vec<f32> = data.points[0]
        .iter()
        .map(|q| surface.closest_point(g.normalisation.from_unit(*q)).unwrap().distance)
        .collect();
    d.sort_by(f32::total_cmp);
    assert!(d[d.len() / 2] < 0.005, "median {} m off the canonical surface", d[d.len() / 2]);
    assert!(d[d.len() * 9 / 10] < 0.02, "p90 {} m off the canonical surface", d[d.len() * 9 / 10]);
    // The saved data reads back (the meta-training data format, with the group names).
    data.save(&dir.path().join("prepared")).unwrap();
    let back = meta_data::MetaData::load(&dir.path().join("prepared")).unwrap();
    assert_eq!(back.manifest, data.manifest);

    // ---- A tiny meta-training run on it, then a fit from that prior names it.
    let meta = MetaOptions {
        config: HyperConfig {
            siren: SirenConfig { hidden: 16, layers: 2 },
            head_hidden: 8,
            rank: Some(2),
            encoding: PoseEncoding::Hierarchical,
        },
        sdf_iterations: 2,
        sdf_inner_steps: 2,
        hyper_iterations: 2,
        hyper_max_task: 2,
        hyper_inner_epochs: 1,
        hyper_inner: HyperFitOptions {
            poses_per_step: 2,
            surface_per_pose: 100,
            off_per_pose: 100,
            ..MetaOptions::default().hyper_inner
        },
        points_per_step: 100,
        checkpoint_every: 1,
        seed: 3,
        ..MetaOptions::default()
    };
    let model_path = meta_train(data, &meta, &dir.path().join("run"), None, &mut |_| {}).unwrap();
    let model = MetaModel::load(&model_path).unwrap();
    let prior = model.prior().expect("a model read from a file knows its origin");
    assert_eq!(prior.sha256, sha256_hex(&std::fs::read(&model_path).unwrap()));
    assert!(prior.name.ends_with("meta-model.bin"), "{}", prior.name);
    assert!(prior.provenance.starts_with("meta-train seed 3"), "{}", prior.provenance);

    let capture =
        CapturePoints::open(&root.join("s1/tshirt_shorts/take1"), 3, &field_cache()).unwrap();
    let mut fit = HyperFitOptions {
        steps: 2,
        surface_per_pose: 100,
        off_per_pose: 100,
        ..HyperFitOptions::default()
    };
    fit.refine_poses.enabled = false;
    let (avatar, _) =
        MetaAvatar::fit_points(&capture, &Init::MetaLearned(&model), &fit, None, &mut |_, _, _| {});
    assert_eq!(avatar.header.prior.as_ref(), Some(&prior));
    let path = dir.path().join("a.avatar");
    avatar.save(&path).unwrap();
    match AnyAvatar::load(&path, &field_cache()).unwrap() {
        AnyAvatar::Meta(back) => assert_eq!(back.header.prior, Some(prior)),
        AnyAvatar::Static(_) => panic!("a MetaAvatar saved"),
    }
    // From scratch there is no prior.
    let scratch = Init::Scratch { config: meta.config, seed: 0 };
    let (s, _) = MetaAvatar::fit_points(&capture, &scratch, &fit, None, &mut |_, _, _| {});
    assert_eq!(s.header.prior, None);

    // ---- Model files that are not meta-models are refused by name.
    let bad = dir.path().join("bad.bin");
    let bytes = std::fs::read(&model_path).unwrap();
    std::fs::write(&bad, &bytes[..bytes.len() - 40]).unwrap();
    let e = MetaModel::load(&bad).unwrap_err().to_string();
    assert!(e.contains("bad.bin"), "{e}");
    let e = MetaModel::load(&path).unwrap_err().to_string();
    assert!(e.contains("a.avatar") && e.contains("not a meta-model"), "{e}");
}

#[test]
fn the_shipped_prior_is_named_shipped_with_its_file_hash() {
    let shipped = MetaModel::shipped().prior().unwrap();
    let asset = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/model/meta-compact.bin");
    assert_eq!(shipped.name, SHIPPED_PRIOR);
    assert_eq!(shipped.sha256, sha256_hex(&std::fs::read(asset).unwrap()));
}
