//! The bad-input corpus: corrupted variants of every input kind (truncations, bit flips, wrong
//! dtypes, huge sizes, NaN and infinity, wrong units, out-of-range header fields) and outputs
//! that are inputs, each with the command that reads it and the file its error must name.

use super::fixtures::*;
use serde_json::{Value, json};
use std::ffi::OsString;
use std::path::{Path, PathBuf};

mod captures;
mod poses_bodies;
mod training_outputs;

/// A change to a capture's manifest (given its folder), returning the changed manifest.
type ManifestEdit = Box<dyn FnOnce(&Path, Value) -> Value>;

/// An npz file's entries: name and bytes.
type NpzEntries = Vec<(&'static str, Vec<u8>)>;

pub struct Case {
    pub name: String,
    pub args: Vec<OsString>,
    /// The error must name this file (None: an argument error, named by its flag).
    pub names: Option<PathBuf>,
}

pub struct Corpus<'a> {
    pub f: &'a Fixtures,
    bad: PathBuf,
    out: PathBuf,
    pub cases: Vec<Case>,
}

fn os(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<OsString> {
    args.iter().map(|a| a.as_ref().to_os_string()).collect()
}

/// Set a JSON field at a /-separated path (array indices as numbers), or remove it with None.
fn set(v: &Value, path: &str, new: Option<Value>) -> Value {
    let mut v = v.clone();
    let (parent, key) = path.rsplit_once('/').unwrap_or(("", path));
    let mut p = &mut v;
    for k in parent.split('/').filter(|k| !k.is_empty()) {
        p = match k.parse::<usize>() {
            Ok(i) => &mut p[i],
            Err(_) => &mut p[k],
        };
    }
    match (new, key.parse::<usize>()) {
        (Some(n), Ok(i)) => p[i] = n,
        (Some(n), Err(_)) => p[key] = n,
        (None, _) => {
            p.as_object_mut().unwrap().remove(key);
        }
    }
    v
}

/// Byte-level corruptions of a weights file (magic, length, header, weights).
fn weights_variants(bytes: &[u8]) -> Vec<(&'static str, Vec<u8>)> {
    let len = u64::from_le_bytes(bytes[8..16].try_into().unwrap()) as usize;
    let with = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = bytes.to_vec();
        f(&mut b);
        b
    };
    vec![
        ("empty", Vec::new()),
        ("magic-only", bytes[..8].to_vec()),
        ("no-header", bytes[..16].to_vec()),
        ("truncated-header", bytes[..16 + len / 2].to_vec()),
        ("truncated-weights", bytes[..bytes.len() - 4].to_vec()),
        ("truncated-half", bytes[..bytes.len() / 2].to_vec()),
        ("padded", with(&|b| b.extend([0; 4]))),
        ("bit-flip-magic", with(&|b| b[0] ^= 0x10)),
        ("header-length-huge", with(&|b| b[8..16].copy_from_slice(&u64::MAX.to_le_bytes()))),
        (
            "header-length-beyond",
            with(&|b| {
                let n = b.len() as u64;
                b[8..16].copy_from_slice(&n.to_le_bytes())
            }),
        ),
        ("bit-flip-header-brace", with(&|b| b[16] ^= 0x01)),
        ("weight-nan", with(&|b| b[16 + len..20 + len].copy_from_slice(&f32::NAN.to_le_bytes()))),
        (
            "weight-inf",
            with(&|b| {
                let n = b.len();
                b[n - 4..].copy_from_slice(&f32::INFINITY.to_le_bytes())
            }),
        ),
    ]
}

/// The JSON header and the weights of a weights file.
fn split_weights(path: &Path) -> (Value, Vec<f32>) {
    let b = std::fs::read(path).unwrap();
    let len = u64::from_le_bytes(b[8..16].try_into().unwrap()) as usize;
    let header = serde_json::from_slice(&b[16..16 + len]).unwrap();
    (
        header,
        b[16 + len..].chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect(),
    )
}

/// A PNG of the given header with one empty IDAT: the size is all a reader may look at.
fn png_header_only(width: u32, height: u32, bit_depth: u8, color: u8) -> Vec<u8> {
    fn crc(data: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in data {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    }
    fn chunk(out: &mut Vec<u8>, kind: &[u8], data: &[u8]) {
        out.extend((data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend(data);
        out.extend(&body);
        out.extend(crc(&body).to_be_bytes());
    }
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend(width.to_be_bytes());
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([bit_depth, color, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(&mut out, b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    chunk(&mut out, b"IEND", &[]);
    out
}

fn png_bytes(img: image::DynamicImage) -> Vec<u8> {
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
    bytes
}

impl<'a> Corpus<'a> {
    pub fn new(f: &'a Fixtures) -> Corpus<'a> {
        let (bad, out) = (f.root.join("bad"), f.root.join("out"));
        std::fs::create_dir_all(&bad).unwrap();
        std::fs::create_dir_all(&out).unwrap();
        Corpus { f, bad, out, cases: Vec::new() }
    }

    fn out(&self, name: &str) -> PathBuf {
        self.out.join(name)
    }

    fn push(&mut self, name: String, args: Vec<OsString>, names: Option<PathBuf>) {
        self.cases.push(Case { name, args, names });
    }

    /// A corrupted file in bad/ (written now), its path.
    fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.bad.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    /// A copy of the capture fixture in bad/NAME, changed by `edit` (given the folder and the
    /// manifest, which it returns changed); the capture's path.
    fn capture(&self, name: &str, edit: impl FnOnce(&Path, Value) -> Value) -> PathBuf {
        let dir = self.bad.join(name);
        write_capture(&dir, 2);
        let manifest: Value =
            serde_json::from_slice(&std::fs::read(dir.join("capture.json")).unwrap()).unwrap();
        let manifest = edit(&dir, manifest);
        if !manifest.is_null() {
            std::fs::write(dir.join("capture.json"), serde_json::to_vec_pretty(&manifest).unwrap())
                .unwrap();
        }
        dir
    }

    pub fn build(mut self) -> Vec<Case> {
        self.avatars();
        self.models();
        self.captures();
        self.poses_and_motions();
        self.body_models();
        self.meta_training();
        self.outputs();
        self.cases
    }

    fn avatars(&mut self) {
        for (kind, base) in
            [("static", self.f.static_avatar.clone()), ("meta", self.f.meta_avatar.clone())]
        {
            let bytes = std::fs::read(&base).unwrap();
            let mut files: Vec<(String, PathBuf)> = weights_variants(&bytes)
                .into_iter()
                .map(|(n, b)| (n.to_string(), self.file(&format!("{kind}-{n}.avatar"), &b)))
                .collect();
            let (header, weights) = split_weights(&base);
            let mut edits: Vec<(&str, &str, Option<Value>)> = vec![
                ("betas-1e30", "betas/0", Some(json!(1e30))),
                ("betas-1e4", "betas/0", Some(json!(1e4))),
                ("betas-null", "betas/0", Some(Value::Null)),
                ("betas-600", "betas", Some(json!(vec![0.1; 600]))),
                ("field-cells-4096", "field_cells", Some(json!(4096))),
                ("field-cells-1e6", "field_cells", Some(json!(1_000_000))),
                ("field-cells-0", "field_cells", Some(json!(0))),
                ("field-cells-negative", "field_cells", Some(json!(-1))),
                ("range-1e38", "normalisation/range", Some(json!(1e38))),
                ("range-0", "normalisation/range", Some(json!(0.0))),
                ("range-negative", "normalisation/range", Some(json!(-1.8))),
                ("range-null", "normalisation/range", Some(Value::Null)),
                ("range-mm", "normalisation/range", Some(json!(1800.0))),
                ("centre-1e30", "normalisation/centre/0", Some(json!(1e30))),
                ("coord-min-1e30", "normalisation/coord_min", Some(json!(1e30))),
                ("body-model-missing", "body_model", Some(json!("missing.npz"))),
                ("body-model-passwd", "body_model", Some(json!("/etc/passwd"))),
                ("body-model-empty", "body_model", Some(json!(""))),
                ("format", "format", Some(json!("something-else"))),
                ("version-2", "version", Some(json!(2))),
                ("no-betas", "betas", None),
                (
                    "partial-not-partial",
                    "partial",
                    Some(json!({"steps_done": 5, "steps_requested": 5})),
                ),
                ("kind-model", "kind", Some(json!("meta-model"))),
            ];
            if kind == "static" {
                edits.extend([
                    ("hidden-0", "siren/hidden", Some(json!(0))),
                    ("layers-1e5", "siren/layers", Some(json!(100_000))),
                    ("huge-network", "siren", Some(json!({"hidden": 4096, "layers": 64}))),
                    ("kind-other", "kind", Some(json!("meta-hyper"))),
                ]);
            } else {
                edits.extend([
                    ("hidden-0", "config/siren/hidden", Some(json!(0))),
                    ("head-1e6", "config/head_hidden", Some(json!(1_000_000))),
                    ("huge-network", "config/siren", Some(json!({"hidden": 4096, "layers": 64}))),
                    ("partial-disagrees", "partial", Some(json!({"steps_done": 3, "steps_requested": 100}))),
                    ("kind-other", "kind", Some(json!("static-sdf"))),
                    // Pose refinement's section: one frame for an avatar of two, and NaN-free
                    // JSON with an angle in degrees.
                    ("refined-poses-count", "refined_poses", Some(json!([{"given": {"pose": vec![[0.0; 3]; 24]}, "refined": {"pose": vec![[0.0; 3]; 24]}}]))),
                    ("refined-poses-degrees", "refined_poses", Some(json!([{"given": {"pose": vec![[0.0; 3]; 24]}, "refined": {"pose": vec![[90.0, 0.0, 0.0]; 24]}}, {"given": {"pose": vec![[0.0; 3]; 24]}, "refined": {"pose": vec![[0.0; 3]; 24]}}]))),
                    ("refined-poses-not-a-list", "refined_poses", Some(json!("all good"))),
                    // The prior the fit started from: a hash that is not SHA-256, not an object.
                    ("prior-sha-short", "prior", Some(json!({"name": "shipped", "sha256": "abc", "provenance": ""}))),
                    ("prior-not-an-object", "prior", Some(json!("shipped"))),
                ]);
            }
            for (n, path, value) in edits {
                let p = self.bad.join(format!("{kind}-{n}.avatar"));
                write_weights_json(&p, &set(&header, path, value), &weights);
                files.push((n.to_string(), p));
            }
            for (i, (n, p)) in files.into_iter().enumerate() {
                // Alternate the two commands that read avatars.
                let args = if i % 2 == 0 {
                    os(&[
                        &"pose",
                        &p,
                        &"--motion",
                        &"walk",
                        &"--frames",
                        &"1",
                        &"--resolution",
                        &"16",
                        &"--out",
                        &self.out(&format!("{kind}-{n}")),
                    ])
                } else {
                    os(&[
                        &"export",
                        &p,
                        &"--motion",
                        &"walk",
                        &"--frames",
                        &"2",
                        &"--out",
                        &self.out(&format!("{kind}-{n}.glb")),
                    ])
                };
                self.push(format!("avatar {kind} {n}"), args, Some(p));
            }
        }
    }

    fn models(&mut self) {
        let bytes = std::fs::read(&self.f.model).unwrap();
        let mut files: Vec<(String, PathBuf)> = weights_variants(&bytes)
            .into_iter()
            .map(|(n, b)| (n.to_string(), self.file(&format!("model-{n}.bin"), &b)))
            .collect();
        let (header, weights) = split_weights(&self.f.model);
        let edits: Vec<(&str, &str, Option<Value>)> = vec![
            ("kind-avatar", "kind", Some(json!("meta-hyper"))),
            ("kind-static", "kind", Some(json!("static-sdf"))),
            ("format-avatar", "format", Some(json!("avatar-studio-avatar"))),
            ("version-9", "version", Some(json!(9))),
            (
                "hyper-params-off",
                "hyper_params",
                Some(json!(header["hyper_params"].as_u64().unwrap() + 1)),
            ),
            ("static-params-0", "static_params", Some(json!(0))),
            ("hidden-0", "config/siren/hidden", Some(json!(0))),
            ("head-1e6", "config/head_hidden", Some(json!(1_000_000))),
            ("rank-0", "config/rank", Some(json!(0))),
            ("encoding-unknown", "config/encoding", Some(json!("Spherical"))),
            ("no-config", "config", None),
        ];
        for (n, path, value) in edits {
            let p = self.bad.join(format!("model-{n}.bin"));
            write_weights_json(&p, &set(&header, path, value), &weights);
            files.push((n.to_string(), p));
        }
        // An avatar given as a model.
        files.push(("an-avatar".into(), self.f.meta_avatar.clone()));
        for (i, (n, p)) in files.into_iter().enumerate() {
            let mut args = os(&[
                &"fit",
                &self.f.capture,
                &"--model",
                &p,
                &"--steps",
                &"1",
                &"--frames",
                &"1",
                &"--out",
                &self.out(&format!("model-{n}.avatar")),
            ]);
            if i % 3 == 2 {
                args.push("--static".into());
            }
            self.push(format!("meta-model {n}"), args, Some(p));
        }
    }
}

fn open_body_lowpoly_vertices() -> usize {
    avatar_core::body::open_body_lowpoly_ref().num_vertices()
}

fn open_body_lowpoly_template() -> Vec<f64> {
    avatar_core::body::open_body_lowpoly_ref()
        .v_template
        .iter()
        .flat_map(|v| v.to_array())
        .map(|x| x as f64)
        .collect()
}
