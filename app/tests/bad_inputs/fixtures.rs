//! Valid inputs of every kind, small and written by the test itself (no SMPL or AMASS file is
//! shipped): the bases the corpus and the fuzz test corrupt. Each is checked to load first, so a
//! refusal comes from the corruption, not from a broken base.

use avatar_core::body::{SMPL_PARENTS, open_body_lowpoly_ref, open_body_ref};
use avatar_core::canonical::FieldCache;
use avatar_core::canonical::Normalisation;
use avatar_core::motion::MotionClip;
use avatar_neural::avatar::meta_avatar::{META_AVATAR_KIND, MetaAvatarHeader};
use avatar_neural::avatar::static_avatar::{AVATAR_FORMAT, AvatarHeader};
use avatar_neural::data::meta_data::{DATA_FORMAT, DATA_VERSION, Group, Manifest, MetaDataConfig};
use avatar_neural::model::encoder::PoseEncoding;
use avatar_neural::model::flat_params::flatten;
use avatar_neural::training::meta_training::MetaOptions;
use avatar_neural::{HyperConfig, MetaModel, SirenConfig, weights_file};
use std::io::Write;
use std::path::{Path, PathBuf};

pub struct Fixtures {
    /// Everything below lives here (the folder whose files must never change).
    pub root: PathBuf,
    /// A two-frame copy of the demo capture.
    pub capture: PathBuf,
    pub static_avatar: PathBuf,
    pub meta_avatar: PathBuf,
    pub model: PathBuf,
    pub clip: PathBuf,
    pub amass: PathBuf,
    pub smpl: PathBuf,
    pub pose: PathBuf,
    /// Meta-training data (meta-data.json, samples.bin) and a run folder with its checkpoint.
    pub meta_data: PathBuf,
}

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

pub fn small_config() -> HyperConfig {
    HyperConfig {
        siren: SirenConfig { hidden: 16, layers: 2 },
        head_hidden: 8,
        rank: Some(2),
        encoding: PoseEncoding::Hierarchical,
    }
}

pub fn demo_betas() -> Vec<f32> {
    vec![0.15, 0.04, 0.016, 0.49, 0.27, 0.16, 0.33]
}

fn normalisation() -> Normalisation {
    Normalisation::from_body(&open_body_ref().shaped_vertices(&demo_betas()))
}

pub fn static_header() -> AvatarHeader {
    AvatarHeader {
        format: AVATAR_FORMAT.into(),
        version: avatar_neural::avatar::body::VERSION_OPEN_BODY,
        kind: "static-sdf".into(),
        siren: small_config().siren,
        normalisation: normalisation(),
        betas: demo_betas(),
        body_model: "open_body".into(),
        field_cells: 16,
        partial: None,
        body: None,
        prior: None,
    }
}

pub fn meta_header() -> MetaAvatarHeader {
    MetaAvatarHeader {
        format: AVATAR_FORMAT.into(),
        version: avatar_neural::avatar::body::VERSION_OPEN_BODY,
        kind: META_AVATAR_KIND.into(),
        config: small_config(),
        normalisation: normalisation(),
        betas: demo_betas(),
        body_model: "open_body".into(),
        field_cells: 16,
        init: "meta-learned".into(),
        frames: 2,
        steps: 10,
        partial: None,
        body: None,
        refined_poses: None,
        frame_indices: None,
        prior: None,
    }
}

pub fn static_weights() -> Vec<f32> {
    flatten(&small_config().siren.init(0, &avatar_neural::cpu_device()))
}

pub fn meta_weights() -> Vec<f32> {
    let (c, d) = (small_config(), avatar_neural::cpu_device());
    flatten(&c.init(c.siren.init(0, &d), 0, &d))
}

/// A weights file from a JSON header value (for headers the typed structs cannot express).
pub fn write_weights_json(path: &Path, header: &serde_json::Value, weights: &[f32]) {
    let header = serde_json::to_vec(header).unwrap();
    let mut out = b"AVATAR\0\x01".to_vec();
    out.extend((header.len() as u64).to_le_bytes());
    out.extend(&header);
    for w in weights {
        out.extend(w.to_le_bytes());
    }
    std::fs::write(path, out).unwrap();
}

/// The bytes of a `.npy` entry.
pub fn npy(descr: &str, shape: &[usize], data: &[u8]) -> Vec<u8> {
    let shape = match shape {
        [] => "()".to_string(),
        [n] => format!("({n},)"),
        s => format!("({})", s.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")),
    };
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    let pad = (64 - (10 + header.len() + 1) % 64) % 64;
    header.push_str(&" ".repeat(pad));
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend((header.len() as u16).to_le_bytes());
    out.extend(header.as_bytes());
    out.extend(data);
    out
}

pub fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

pub fn f64s(v: &[f64]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// An npz archive of raw `.npy` entries, stored or deflated.
pub fn write_npz(path: &Path, entries: &[(&str, Vec<u8>)], deflate: bool) {
    write_npz_with_zeros(path, entries, deflate, None);
}

/// The same, plus one deflated entry of a header followed by `zeros` zero bytes, streamed (a zip
/// bomb: the test process never holds the inflated size).
pub fn write_npz_with_zeros(
    path: &Path,
    entries: &[(&str, Vec<u8>)],
    deflate: bool,
    zeros: Option<(&str, Vec<u8>, usize)>,
) {
    use npyz::zip::{CompressionMethod, ZipWriter, write::FileOptions};
    let mut zip = ZipWriter::new(std::fs::File::create(path).unwrap());
    let method = if deflate { CompressionMethod::Deflated } else { CompressionMethod::Stored };
    for (name, bytes) in entries {
        zip.start_file(format!("{name}.npy"), FileOptions::default().compression_method(method))
            .unwrap();
        zip.write_all(bytes).unwrap();
    }
    if let Some((name, header, n)) = zeros {
        zip.start_file(
            format!("{name}.npy"),
            FileOptions::default().compression_method(CompressionMethod::Deflated),
        )
        .unwrap();
        zip.write_all(&header).unwrap();
        let chunk = vec![0u8; 1 << 20];
        for start in (0..n).step_by(chunk.len()) {
            zip.write_all(&chunk[..chunk.len().min(n - start)]).unwrap();
        }
    }
    zip.finish().unwrap();
}

/// The low-poly open body as SMPL npz arrays (float32), to be corrupted one at a time.
pub fn smpl_entries() -> Vec<(&'static str, Vec<u8>)> {
    let b = open_body_lowpoly_ref();
    let (nv, k) = (b.num_vertices(), b.num_betas);
    let template: Vec<f32> = b.v_template.iter().flat_map(|v| v.to_array()).collect();
    let mut shapedirs = vec![0f32; nv * 3 * k];
    for v in 0..nv {
        for i in 0..k {
            let d = b.shapedirs[v * k + i];
            for c in 0..3 {
                shapedirs[(v * 3 + c) * k + i] = d[c];
            }
        }
    }
    let mut jreg = vec![0f32; 24 * nv];
    for (j, row) in b.j_regressor.iter().enumerate() {
        for &(v, w) in row {
            jreg[j * nv + v as usize] = w;
        }
    }
    let weights: Vec<f32> = b.weights.iter().flatten().copied().collect();
    let kintree: Vec<f32> =
        SMPL_PARENTS.iter().map(|&p| p as f32).chain((0..24).map(|j| j as f32)).collect();
    let faces: Vec<f32> = b.faces.iter().flatten().map(|&i| i as f32).collect();
    vec![
        ("v_template", npy("<f4", &[nv, 3], &f32s(&template))),
        ("shapedirs", npy("<f4", &[nv, 3, k], &f32s(&shapedirs))),
        ("J_regressor", npy("<f4", &[24, nv], &f32s(&jreg))),
        ("weights", npy("<f4", &[nv, 24], &f32s(&weights))),
        ("kintree_table", npy("<f4", &[2, 24], &f32s(&kintree))),
        ("f", npy("<f4", &[b.faces.len(), 3], &f32s(&faces))),
    ]
}

pub fn amass_entries() -> Vec<(&'static str, Vec<u8>)> {
    let mut poses = vec![0f32; 3 * 72];
    poses[3] = 0.3;
    vec![
        ("poses", npy("<f4", &[3, 72], &f32s(&poses))),
        ("betas", npy("<f4", &[10], &f32s(&[0.1; 10]))),
        ("trans", npy("<f4", &[3, 3], &f32s(&[0.0, 0.0, 1.0, 0.0, 0.1, 1.0, 0.0, 0.2, 1.0]))),
        ("mocap_framerate", npy("<f8", &[], &f64s(&[60.0]))),
    ]
}

pub fn meta_manifest() -> Manifest {
    let body = open_body_ref();
    let betas = demo_betas();
    let rest = body.shaped_vertices(&betas);
    Manifest {
        format: DATA_FORMAT.into(),
        version: DATA_VERSION,
        config: MetaDataConfig {
            subjects: 1,
            poses_per_group: 2,
            points_per_pose: 4,
            ..MetaDataConfig::default()
        },
        groups: vec![Group {
            subject: 1,
            outfit: "longsleeve_trousers".into(),
            betas,
            normalisation: Normalisation::from_body(&rest),
            rest_joints: body.regress_joints(&rest).iter().map(|j| j.to_array()).collect(),
            first_sample: 0,
            samples: 2,
            name: None,
        }],
        source: None,
    }
}

/// samples.bin for `samples` samples of `points` points.
pub fn meta_samples(samples: usize, points: usize) -> Vec<f32> {
    let mut v = Vec::new();
    for s in 0..samples {
        v.extend(std::iter::repeat_n(0.0, 72));
        for p in 0..points {
            let t = (s * points + p) as f32 * 0.1;
            v.extend([t.sin() * 0.5, t.cos() * 0.5, 0.1, 0.0, 0.0, 1.0]);
        }
    }
    v
}

/// A meta-training checkpoint header as the CLI's default options would write it.
pub fn checkpoint_header(stage: &str) -> serde_json::Value {
    serde_json::json!({
        "format": "avatar-studio-checkpoint", "version": 1, "kind": "meta-checkpoint",
        "options": MetaOptions::default(), "stage": stage, "iteration": 1, "seconds": 1.0,
    })
}

/// Copy the demo capture with its first `frames` frames.
pub fn write_capture(dir: &Path, frames: usize) {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    std::fs::create_dir_all(dir.join("depth")).unwrap();
    let mut manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(demo.join("capture.json")).unwrap()).unwrap();
    let kept: Vec<serde_json::Value> = manifest["frames"].as_array().unwrap()[..frames].to_vec();
    for f in &kept {
        let name = f["depth"].as_str().unwrap();
        std::fs::copy(demo.join(name), dir.join(name)).unwrap();
    }
    manifest["frames"] = serde_json::Value::Array(kept);
    std::fs::write(dir.join("capture.json"), serde_json::to_vec_pretty(&manifest).unwrap())
        .unwrap();
}

impl Fixtures {
    pub fn write(root: &Path) -> Fixtures {
        let f = Fixtures {
            root: root.to_path_buf(),
            capture: root.join("cap"),
            static_avatar: root.join("static.avatar"),
            meta_avatar: root.join("meta.avatar"),
            model: root.join("model.bin"),
            clip: root.join("clip.json"),
            amass: root.join("amass.npz"),
            smpl: root.join("smpl.npz"),
            pose: root.join("pose.json"),
            meta_data: root.join("metadata"),
        };
        write_capture(&f.capture, 2);
        weights_file::write(&f.static_avatar, &static_header(), &static_weights()).unwrap();
        weights_file::write(&f.meta_avatar, &meta_header(), &meta_weights()).unwrap();
        let (c, d) = (small_config(), avatar_neural::cpu_device());
        let siren = c.siren.init(1, &d);
        MetaModel::from_parts(
            c,
            &c.init(siren.clone(), 1, &d),
            &siren,
            "bad-input corpus base".into(),
        )
        .save(&f.model)
        .unwrap();
        MotionClip::new("three", 30.0, vec![Default::default(); 3]).save_json(&f.clip).unwrap();
        write_npz(&f.amass, &amass_entries(), false);
        write_npz(&f.smpl, &smpl_entries(), false);
        std::fs::write(
            &f.pose,
            serde_json::json!({"pose": vec![0.0; 72], "betas": [0.2, 0.1], "trans": [0, 0, 0]})
                .to_string(),
        )
        .unwrap();
        std::fs::create_dir_all(&f.meta_data).unwrap();
        std::fs::write(
            f.meta_data.join("meta-data.json"),
            serde_json::to_vec_pretty(&meta_manifest()).unwrap(),
        )
        .unwrap();
        std::fs::write(f.meta_data.join("samples.bin"), f32s(&meta_samples(2, 4))).unwrap();
        f
    }

    /// Every base loads: the corpus's refusals come from its corruptions.
    pub fn check_valid(&self) {
        avatar_core::capture::Capture::open(&self.capture).unwrap();
        avatar_neural::AnyAvatar::load(&self.static_avatar, &field_cache()).unwrap();
        avatar_neural::AnyAvatar::load(&self.meta_avatar, &field_cache()).unwrap();
        MetaModel::load(&self.model).unwrap();
        MotionClip::load(&self.clip).unwrap();
        avatar_core::motion::amass::load_amass_clip(&self.amass).unwrap();
        avatar_core::body::BodyModel::load_npz(&self.smpl).unwrap();
        avatar_core::body::BodyParams::load_json(&self.pose).unwrap();
        avatar_neural::data::meta_data::MetaData::load(&self.meta_data).unwrap();
    }
}
