//! The animated glTF export: the Khronos validator reports nothing, and reading the file back
//! with the gltf crate (skinning the rest mesh with the exported morph weights and joint
//! rotations) reproduces the studio's posed mesh of every frame within 2 mm.

use avatar_core::body::{NUM_JOINTS, open_body_ref};
use avatar_core::canonical::FieldOptions;
use avatar_core::export::*;
use avatar_core::motion::clip_by_name;
use avatar_core::synth::Outfit;
use glam::{Mat4, Quat, Vec3};
use std::path::Path;
use std::process::Command;

fn tiny_export(outfit: Outfit, frames: usize, targets: usize) -> Exported {
    let avatar = SyntheticAvatar::new(
        open_body_ref().clone(),
        5,
        outfit,
        &FieldOptions { cells_along_height: 64, ..FieldOptions::default() },
    )
    .unwrap();
    let clip = clip_by_name("squat").unwrap();
    let step = clip.len() / frames;
    let clip = avatar_core::motion::MotionClip::new(
        "squat",
        clip.fps / step as f32,
        clip.frames.iter().step_by(step).take(frames).cloned().collect(),
    );
    export_glb(&avatar, &clip, &ExportOptions { max_targets: targets, ..ExportOptions::default() })
        .unwrap()
}

/// Run the Khronos validator (Node) on a GLB; returns (errors, warnings, messages).
pub fn validate(glb: &Path) -> (u64, u64, String) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/gltf-validator");
    assert!(
        dir.join("node_modules/gltf-validator").exists(),
        "the glTF validator is not installed: run `npm ci --prefix tests/gltf-validator` (scripts/test.sh does)"
    );
    let out = Command::new("node")
        .arg(dir.join("validate.mjs"))
        .arg(glb)
        .output()
        .expect("node runs (scripts/test.sh installs nodejs)");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!("validator output: {e}: {}", String::from_utf8_lossy(&out.stderr))
    });
    let issues = &report["issues"];
    (
        issues["numErrors"].as_u64().unwrap(),
        issues["numWarnings"].as_u64().unwrap(),
        issues["messages"].to_string(),
    )
}

#[test]
fn validator_reports_no_errors_and_no_warnings() {
    let dir = tempfile::tempdir().unwrap();
    for (outfit, targets) in [(Outfit::LongsleeveTrousers, 8), (Outfit::Dress, 64)] {
        let e = tiny_export(outfit, 12, targets);
        let path = dir.path().join(format!("{}.glb", outfit.name()));
        std::fs::write(&path, &e.glb).unwrap();
        let (errors, warnings, messages) = validate(&path);
        assert_eq!((errors, warnings), (0, 0), "{}: {messages}", outfit.name());
        assert!(e.morphs.targets.len() < targets);
    }
}

/// Skin the file's rest mesh at keyframe `f` exactly as a glTF viewer does.
fn viewer_pose(doc: &gltf::Document, buffers: &[Vec<u8>], f: usize) -> Vec<Vec3> {
    let buf = |b: gltf::Buffer| Some(&buffers[b.index()][..]);
    let mesh = doc.meshes().next().unwrap();
    let prim = mesh.primitives().next().unwrap();
    let reader = prim.reader(buf);
    let base: Vec<Vec3> = reader.read_positions().unwrap().map(Vec3::from_array).collect();
    let joints: Vec<[u16; 4]> = reader.read_joints(0).unwrap().into_u16().collect();
    let weights: Vec<[f32; 4]> = reader.read_weights(0).unwrap().into_f32().collect();
    let targets: Vec<Vec<Vec3>> = reader
        .read_morph_targets()
        .map(|(p, _, _)| p.unwrap().map(Vec3::from_array).collect())
        .collect();
    // Animated values at keyframe f.
    let anim = doc.animations().next().unwrap();
    let mut rot = vec![Quat::IDENTITY; NUM_JOINTS];
    let mut trans: Vec<Vec3> = doc
        .nodes()
        .take(NUM_JOINTS)
        .map(|n| Vec3::from_array(n.transform().decomposed().0))
        .collect();
    let mut morph_w = Vec::new();
    for ch in anim.channels() {
        let r = ch.reader(buf);
        let node = ch.target().node().index();
        match r.read_outputs().unwrap() {
            gltf::animation::util::ReadOutputs::Rotations(q) => {
                rot[node] = Quat::from_array(q.into_f32().nth(f).unwrap())
            }
            gltf::animation::util::ReadOutputs::Translations(t) => {
                trans[node] = Vec3::from_array(t.into_iter().nth(f).unwrap())
            }
            gltf::animation::util::ReadOutputs::MorphTargetWeights(w) => {
                let all: Vec<f32> = w.into_f32().collect();
                morph_w = all[f * targets.len()..(f + 1) * targets.len()].to_vec();
            }
            _ => panic!("unexpected channel"),
        }
    }
    let mut world = [Mat4::IDENTITY; NUM_JOINTS];
    for n in doc.nodes().take(NUM_JOINTS) {
        let j = n.index();
        let local = Mat4::from_rotation_translation(rot[j], trans[j]);
        let parent = avatar_core::body::SMPL_PARENTS[j];
        world[j] = if parent < 0 { local } else { world[parent as usize] * local };
    }
    let skin = doc.skins().next().unwrap();
    let ibm: Vec<Mat4> = skin
        .reader(buf)
        .read_inverse_bind_matrices()
        .unwrap()
        .map(|m| Mat4::from_cols_array_2d(&m))
        .collect();
    let joint_nodes: Vec<usize> = skin.joints().map(|n| n.index()).collect();
    base.iter()
        .enumerate()
        .map(|(v, &p)| {
            let mut x = p;
            for (t, w) in targets.iter().zip(&morph_w) {
                x += t[v] * *w;
            }
            let mut m = Mat4::ZERO;
            for k in 0..4 {
                let j = joints[v][k] as usize;
                m += (world[joint_nodes[j]] * ibm[j]) * weights[v][k];
            }
            m.transform_point3(x)
        })
        .collect()
}

#[test]
fn round_trip_reproduces_the_posed_mesh_within_2mm() {
    let e = tiny_export(Outfit::LongsleeveTrousers, 10, 64);
    let g = gltf::Gltf::from_slice(&e.glb).unwrap();
    let buffers = vec![g.blob.clone().unwrap()];
    let doc = g.document;
    assert_eq!(doc.nodes().count(), NUM_JOINTS + 1);
    assert_eq!(doc.skins().next().unwrap().joints().count(), NUM_JOINTS);
    let names: Vec<String> = serde_json::from_str::<serde_json::Value>(
        doc.meshes().next().unwrap().extras().as_ref().unwrap().get(),
    )
    .unwrap()["targetNames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    assert_eq!(names[0], "compensation");
    // Named nodes and the avatar's PBR material in the default skin-like colour.
    assert!(doc.nodes().all(|n| n.name().is_some_and(|s| !s.is_empty())));
    let material = doc.meshes().next().unwrap().primitives().next().unwrap().material();
    assert_eq!(material.name(), Some("avatar"));
    let pbr = material.pbr_metallic_roughness();
    assert_eq!(
        pbr.base_color_factor(),
        [DEFAULT_COLOR[0], DEFAULT_COLOR[1], DEFAULT_COLOR[2], 1.0]
    );
    assert_eq!(pbr.metallic_factor(), 0.0);
    let mut worst: f32 = 0.0;
    for f in 0..e.frames {
        let v = viewer_pose(&doc, &buffers, f);
        let mut d: Vec<f32> = v.iter().zip(&e.posed[f]).map(|(a, b)| (*a - *b).length()).collect();
        d.sort_by(f32::total_cmp);
        worst = worst.max(d[d.len() - 1]);
        assert!(d[d.len() / 2] < 0.001, "frame {f}: median {} m", d[d.len() / 2]);
    }
    assert!(worst < 0.002, "largest vertex error {worst} m");
    // With every frame's deltas in the PCA basis (10 frames < 63 components) the compression is exact.
    assert!(e.max_compression_error < 1e-4, "{}", e.max_compression_error);
}

#[test]
fn weights_are_strictly_normalised_and_quaternions_continuous() {
    let e = tiny_export(Outfit::PoloLoose, 6, 8);
    for (j, w) in e.joints.iter().zip(&e.weights) {
        let s: f32 = w.iter().sum();
        assert!((s - 1.0).abs() <= 2e-7 * w.iter().filter(|&&x| x > 0.0).count() as f32, "{w:?}");
        let nz: Vec<u8> = j.iter().zip(w).filter(|(_, w)| **w > 0.0).map(|(j, _)| *j).collect();
        let mut u = nz.clone();
        u.dedup();
        assert_eq!(u.len(), nz.len());
    }
    for f in 0..e.frames {
        assert!(e.morphs.weights[f].iter().all(|w| (0.0..=1.0).contains(w)));
    }
}
