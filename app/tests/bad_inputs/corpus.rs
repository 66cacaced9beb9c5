//! The bad-input corpus: corrupted variants of every input kind (truncations, bit flips, wrong
//! dtypes, huge sizes, NaN and infinity, wrong units, out-of-range header fields) and outputs
//! that are inputs, each with the command that reads it and the file its error must name.

use super::fixtures::*;
use serde_json::{Value, json};
use std::ffi::OsString;
use std::path::{Path, PathBuf};

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

    fn captures(&mut self) {
        let add = |c: &mut Self,
                   name: &str,
                   names: &str,
                   edit: Box<dyn FnOnce(&Path, Value) -> Value>| {
            let dir = c.capture(name, edit);
            let named = dir.join(names);
            let i = c.cases.len();
            let args = if i % 2 == 0 {
                os(&[
                    &"canonicalize",
                    &dir,
                    &"--no-cache",
                    &"--out",
                    &c.out(&format!("cap-{name}.ply")),
                ])
            } else {
                os(&[
                    &"fit",
                    &dir,
                    &"--steps",
                    &"1",
                    &"--out",
                    &c.out(&format!("cap-{name}.avatar")),
                ])
            };
            c.push(format!("capture {name}"), args, Some(named));
        };
        let manifest_edits: Vec<(&str, &str, Option<Value>)> = vec![
            ("format", "format", Some(json!("other"))),
            ("version-2", "version", Some(json!(2))),
            ("fx-0", "intrinsics/fx", Some(json!(0.0))),
            ("fx-negative", "intrinsics/fx", Some(json!(-250.0))),
            ("fx-null", "intrinsics/fx", Some(Value::Null)),
            ("fx-string", "intrinsics/fx", Some(json!("250"))),
            ("width-0", "intrinsics/width", Some(json!(0))),
            ("width-100000", "intrinsics/width", Some(json!(100_000))),
            (
                "huge-image",
                "intrinsics",
                Some(
                    json!({"fx": 250.0, "fy": 250.0, "cx": 125.0, "cy": 125.0, "width": 8000, "height": 8000}),
                ),
            ),
            ("depth-scale-0", "depth_scale", Some(json!(0.0))),
            ("depth-scale-negative", "depth_scale", Some(json!(-1000.0))),
            ("depth-scale-null", "depth_scale", Some(Value::Null)),
            ("fps-1e-30", "fps", Some(json!(1e-30))),
            ("fps-1e9", "fps", Some(json!(1e9))),
            ("no-frames", "frames", Some(json!([]))),
            ("frames-object", "frames", Some(json!({}))),
            ("body-model-missing", "body_model", Some(json!("missing.npz"))),
            ("no-intrinsics", "intrinsics", None),
        ];
        for (n, path, value) in manifest_edits {
            add(self, n, "capture.json", Box::new(move |_, m| set(&m, path, value)));
        }
        add(
            self,
            "body-model-passwd",
            "capture.json",
            Box::new(|_, m| set(&m, "body_model", Some(json!("/etc/passwd")))),
        );
        let smpl_1e300 = {
            let mut e = smpl_entries();
            let nv = open_body_lowpoly_vertices();
            let mut t = vec![0.1f64; nv * 3];
            t[7] = 1e300;
            e[0] = ("v_template", npy("<f8", &[nv, 3], &f64s(&t)));
            e
        };
        add(
            self,
            "body-model-1e300",
            "smpl.npz",
            Box::new(move |d, m| {
                write_npz(&d.join("smpl.npz"), &smpl_1e300, false);
                set(&m, "body_model", Some(json!("smpl.npz")))
            }),
        );
        for (n, bytes) in [
            ("empty", b"".to_vec()),
            ("not-json", b"depth images and poses".to_vec()),
            (
                "truncated",
                b"{\"format\": \"avatar-studio-capture\", \"version\": 1, \"intri".to_vec(),
            ),
        ] {
            add(
                self,
                &format!("manifest-{n}"),
                "capture.json",
                Box::new(move |d, _| {
                    std::fs::write(d.join("capture.json"), &bytes).unwrap();
                    Value::Null
                }),
            );
        }
        add(
            self,
            "manifest-100mb",
            "capture.json",
            Box::new(|d, _| {
                // Sparse: 100 MB of nothing, written instantly.
                std::fs::File::create(d.join("capture.json")).unwrap().set_len(100 << 20).unwrap();
                Value::Null
            }),
        );
        // Every frame broken the same way (one bad frame alone is skipped with a warning).
        let frame_edits: Vec<(&str, &str, Option<Value>)> = vec![
            ("pose-71", "pose", Some(json!(vec![0.0; 71]))),
            ("pose-null", "pose/5", Some(Value::Null)),
            ("pose-missing", "pose", None),
            ("pose-degrees", "pose/55", Some(json!(90.0))),
            ("shape-1e30", "shape/0", Some(json!(1e30))),
            ("shape-1e4", "shape/0", Some(json!(1e4))),
            ("translation-1e9", "translation", Some(json!([1e9, 0.0, 0.0]))),
            (
                "camera-scaled",
                "camera_to_world",
                Some(json!([2.0, 0, 0, 0, 0, 2.0, 0, 0, 0, 0, 2.0, 0, 0, 0, 0, 1.0])),
            ),
            ("depth-missing", "depth", Some(json!("depth/none.png"))),
        ];
        for (n, path, value) in frame_edits {
            add(
                self,
                n,
                "capture.json",
                Box::new(move |_, mut m| {
                    for i in 0..2 {
                        m = set(&m, &format!("frames/{i}/{path}"), value.clone());
                    }
                    m
                }),
            );
        }
        let depth0 = "depth/000000.png";
        type Png = Box<dyn Fn(&[u8]) -> Vec<u8>>;
        let pngs: Vec<(&str, Png)> = vec![
            ("png-truncated", Box::new(|b: &[u8]| b[..b.len() / 2].to_vec())),
            ("png-empty", Box::new(|_: &[u8]| Vec::new())),
            (
                "png-bit-flip",
                Box::new(|b: &[u8]| {
                    let mut b = b.to_vec();
                    b[20] ^= 0x04; // inside IHDR: its CRC fails
                    b
                }),
            ),
            (
                "png-8bit",
                Box::new(|_: &[u8]| {
                    png_bytes(image::DynamicImage::ImageLuma8(image::GrayImage::from_pixel(
                        250,
                        250,
                        image::Luma([128]),
                    )))
                }),
            ),
            (
                "png-rgb",
                Box::new(|_: &[u8]| {
                    png_bytes(image::DynamicImage::ImageRgb8(image::RgbImage::new(250, 250)))
                }),
            ),
            (
                "png-300x300",
                Box::new(|_: &[u8]| {
                    png_bytes(image::DynamicImage::ImageLuma16(image::ImageBuffer::from_pixel(
                        300,
                        300,
                        image::Luma([2000u16]),
                    )))
                }),
            ),
            ("png-15000x15000-header", Box::new(|_: &[u8]| png_header_only(15000, 15000, 16, 0))),
            (
                "png-all-zero",
                Box::new(|_: &[u8]| {
                    png_bytes(image::DynamicImage::ImageLuma16(image::ImageBuffer::new(250, 250)))
                }),
            ),
            (
                "png-65-metres",
                Box::new(|_: &[u8]| {
                    png_bytes(image::DynamicImage::ImageLuma16(image::ImageBuffer::from_pixel(
                        250,
                        250,
                        image::Luma([65535u16]),
                    )))
                }),
            ),
            ("png-text", Box::new(|_: &[u8]| b"not an image".to_vec())),
        ];
        for (n, make) in pngs {
            add(
                self,
                n,
                depth0,
                Box::new(move |d, m| {
                    for i in 0..2 {
                        let p = d.join(m["frames"][i]["depth"].as_str().unwrap());
                        let b = std::fs::read(&p).unwrap();
                        std::fs::write(&p, make(&b)).unwrap();
                    }
                    m
                }),
            );
        }
        add(
            self,
            "depth-scale-1",
            depth0,
            Box::new(|_, m| set(&m, "depth_scale", Some(json!(1.0)))),
        );
        add(
            self,
            "mask-wrong-size",
            "mask.png",
            Box::new(|d, mut m| {
                std::fs::write(
                    d.join("mask.png"),
                    png_bytes(image::DynamicImage::ImageLuma8(image::GrayImage::new(20, 20))),
                )
                .unwrap();
                for i in 0..2 {
                    m = set(&m, &format!("frames/{i}/mask"), Some(json!("mask.png")));
                }
                m
            }),
        );
        add(
            self,
            "mask-huge-header",
            "mask.png",
            Box::new(|d, mut m| {
                std::fs::write(d.join("mask.png"), png_header_only(15000, 15000, 8, 0)).unwrap();
                for i in 0..2 {
                    m = set(&m, &format!("frames/{i}/mask"), Some(json!("mask.png")));
                }
                m
            }),
        );
    }

    fn poses_and_motions(&mut self) {
        let pose: Value = serde_json::from_slice(&std::fs::read(&self.f.pose).unwrap()).unwrap();
        let mut pose_files: Vec<(String, Vec<u8>)> = vec![
            ("empty".into(), Vec::new()),
            ("not-json".into(), b"pose: 0".to_vec()),
            ("truncated".into(), b"{\"pose\": [0, 0,".to_vec()),
        ];
        let pose_edits: Vec<(&str, &str, Option<Value>)> = vec![
            ("pose-71", "pose", Some(json!(vec![0.0; 71]))),
            ("pose-string", "pose/3", Some(json!("x"))),
            ("pose-null", "pose/3", Some(Value::Null)),
            ("pose-degrees", "pose/55", Some(json!(90.0))),
            ("pose-1e30", "pose/4", Some(json!(1e30))),
            ("betas-1e4", "betas/0", Some(json!(1e4))),
            ("betas-1e30", "betas/0", Some(json!(1e30))),
            ("betas-string", "betas", Some(json!("tall"))),
            ("trans-1e9", "trans", Some(json!([1e9, 0, 0]))),
            ("trans-2", "trans", Some(json!([0, 0]))),
            ("pose-nested-wrong", "pose", Some(json!([[1, 2], [3]]))),
        ];
        for (n, path, value) in pose_edits {
            pose_files.push((n.into(), serde_json::to_vec(&set(&pose, path, value)).unwrap()));
        }
        for (n, b) in pose_files {
            let p = self.file(&format!("pose-{n}.json"), &b);
            let args = os(&[
                &"body",
                &"--pose",
                &p,
                &"--lowpoly",
                &"--out",
                &self.out(&format!("pose-{n}.obj")),
            ]);
            self.push(format!("pose {n}"), args, Some(p));
        }

        let clip: Value = serde_json::from_slice(&std::fs::read(&self.f.clip).unwrap()).unwrap();
        let mut clip_files: Vec<(String, Vec<u8>)> = vec![
            ("empty".into(), Vec::new()),
            ("truncated".into(), std::fs::read(&self.f.clip).unwrap()[..100].to_vec()),
        ];
        let clip_edits: Vec<(&str, &str, Option<Value>)> = vec![
            ("fps-1e-30", "fps", Some(json!(1e-30))),
            ("fps-0", "fps", Some(json!(0))),
            ("fps-1e9", "fps", Some(json!(1e9))),
            ("no-frames", "frames", Some(json!([]))),
            ("pose-71", "frames/1/pose", Some(json!(vec![0.0; 71]))),
            ("pose-null", "frames/1/pose/7", Some(Value::Null)),
            ("pose-degrees", "frames/2/pose/55", Some(json!(90.0))),
            ("trans-2", "frames/0/trans", Some(json!([0, 0]))),
            ("betas-1e30", "frames/0/betas", Some(json!([1e30]))),
            ("format", "format", Some(json!("bvh"))),
            ("version-2", "version", Some(json!(2))),
        ];
        for (n, path, value) in clip_edits {
            clip_files.push((n.into(), serde_json::to_vec(&set(&clip, path, value)).unwrap()));
        }
        for (n, b) in clip_files {
            let p = self.file(&format!("clip-{n}.json"), &b);
            let args =
                os(&[&"export", &"--motion", &p, &"--out", &self.out(&format!("clip-{n}.glb"))]);
            self.push(format!("motion clip {n}"), args, Some(p));
        }

        let base = amass_entries();
        let with = |key: &str, entry: Option<Vec<u8>>| -> Vec<(&'static str, Vec<u8>)> {
            let mut e: Vec<(&'static str, Vec<u8>)> =
                base.iter().filter(|(k, _)| *k != key).cloned().collect();
            if let Some(b) = entry {
                let k = base.iter().find(|(k, _)| *k == key).map(|(k, _)| *k).unwrap();
                e.push((k, b));
            }
            e
        };
        let mut degrees = vec![0f32; 3 * 72];
        degrees[60] = 90.0;
        let mut nan = vec![0f32; 3 * 72];
        nan[10] = f32::NAN;
        let amass: Vec<(&str, Vec<(&'static str, Vec<u8>)>)> = vec![
            ("width-71", with("poses", Some(npy("<f4", &[3, 71], &f32s(&[0.0; 213]))))),
            ("width-100", with("poses", Some(npy("<f4", &[2, 100], &f32s(&[0.0; 200]))))),
            ("no-frames", with("poses", Some(npy("<f4", &[0, 72], &[])))),
            ("rank-3", with("poses", Some(npy("<f4", &[1, 3, 72], &f32s(&[0.0; 216]))))),
            ("fps-1e-30", with("mocap_framerate", Some(npy("<f8", &[], &f64s(&[1e-30]))))),
            ("fps-1e9", with("mocap_framerate", Some(npy("<f8", &[], &f64s(&[1e9]))))),
            ("fps-nan", with("mocap_framerate", Some(npy("<f8", &[], &f64s(&[f64::NAN]))))),
            ("pose-nan", with("poses", Some(npy("<f4", &[3, 72], &f32s(&nan))))),
            ("pose-degrees", with("poses", Some(npy("<f4", &[3, 72], &f32s(&degrees))))),
            ("trans-shape", with("trans", Some(npy("<f4", &[2, 3], &f32s(&[0.0; 6]))))),
            ("betas-1e4", with("betas", Some(npy("<f4", &[10], &f32s(&[1e4; 10]))))),
            ("no-poses", with("poses", None)),
            ("poses-float16", with("poses", Some(npy("<f2", &[3, 72], &[0u8; 3 * 72 * 2])))),
            ("poses-strings", with("poses", Some(npy("<U4", &[2], &[0u8; 32])))),
            ("poses-claim-huge", with("poses", Some(npy("<f4", &[100_000_000, 72], &[0u8; 64])))),
            ("poses-truncated-data", with("poses", Some(npy("<f4", &[3, 72], &[0u8; 100])))),
        ];
        for (n, entries) in amass {
            let p = self.bad.join(format!("amass-{n}.npz"));
            write_npz(&p, &entries, false);
            let args =
                os(&[&"export", &"--motion", &p, &"--out", &self.out(&format!("amass-{n}.glb"))]);
            self.push(format!("AMASS {n}"), args, Some(p));
        }
        let whole = std::fs::read(&self.f.amass).unwrap();
        for (n, b) in [
            ("empty", Vec::new()),
            ("truncated", whole[..whole.len() / 2].to_vec()),
            ("text", b"poses".to_vec()),
        ] {
            let p = self.file(&format!("amass-{n}.npz"), &b);
            let args =
                os(&[&"export", &"--motion", &p, &"--out", &self.out(&format!("amass-{n}.glb"))]);
            self.push(format!("AMASS {n}"), args, Some(p));
        }
    }

    fn body_models(&mut self) {
        let base = smpl_entries();
        let nv = open_body_lowpoly_vertices();
        let replace = |key: &str, entry: Option<Vec<u8>>| -> Vec<(&'static str, Vec<u8>)> {
            base.iter()
                .filter_map(|(k, b)| {
                    if *k == key { entry.clone().map(|e| (*k, e)) } else { Some((*k, b.clone())) }
                })
                .collect()
        };
        let template: Vec<f64> = open_body_lowpoly_template();
        let scaled = |s: f64, at: Option<(usize, f64)>| {
            let mut t: Vec<f64> = template.iter().map(|v| v * s).collect();
            if let Some((i, v)) = at {
                t[i] = v;
            }
            npy("<f8", &[nv, 3], &f64s(&t))
        };
        let models: Vec<(&str, Vec<(&'static str, Vec<u8>)>, bool)> = vec![
            ("template-1e300", replace("v_template", Some(scaled(1.0, Some((4, 1e300))))), false),
            ("template-mm", replace("v_template", Some(scaled(1000.0, None))), false),
            ("template-nan", replace("v_template", Some(scaled(1.0, Some((4, f64::NAN))))), false),
            (
                "template-wrong-shape",
                replace("v_template", Some(npy("<f4", &[nv, 2], &f32s(&vec![0.0; nv * 2])))),
                false,
            ),
            ("no-template", replace("v_template", None), false),
            (
                "shapedirs-wrong-shape",
                replace("shapedirs", Some(npy("<f4", &[nv, 3], &f32s(&vec![0.0; nv * 3])))),
                false,
            ),
            (
                "kintree-smplh",
                replace("kintree_table", Some(npy("<f4", &[2, 52], &f32s(&[0.0; 104])))),
                false,
            ),
            (
                "regressor-1e30",
                replace("J_regressor", Some(npy("<f4", &[24, nv], &f32s(&vec![1e30; 24 * nv])))),
                false,
            ),
            (
                "weights-sum-2",
                replace("weights", Some(npy("<f4", &[nv, 24], &f32s(&vec![2.0 / 24.0; nv * 24])))),
                false,
            ),
            (
                "faces-out-of-range",
                replace("f", Some(npy("<f4", &[1, 3], &f32s(&[0.0, 1.0, 1e7])))),
                false,
            ),
            (
                "faces-fractional",
                replace("f", Some(npy("<f4", &[1, 3], &f32s(&[0.0, 0.5, 2.0])))),
                false,
            ),
            (
                "template-float16",
                replace("v_template", Some(npy("<f2", &[nv, 3], &vec![0u8; nv * 6]))),
                false,
            ),
            (
                "template-object",
                replace("v_template", Some(npy("|O", &[nv, 3], &[0u8; 16]))),
                false,
            ),
            (
                "shapedirs-claim-1.5gb",
                replace("shapedirs", Some(npy("<f8", &[6890, 3, 10000], &[0u8; 64]))),
                false,
            ),
        ];
        for (n, entries, deflate) in models {
            let p = self.bad.join(format!("smpl-{n}.npz"));
            write_npz(&p, &entries, deflate);
            let args =
                os(&[&"body", &"--model", &p, &"--out", &self.out(&format!("smpl-{n}.obj"))]);
            self.push(format!("SMPL npz {n}"), args, Some(p));
        }
        // Zip bombs: 1.5 GB of zero float64s deflated to 1.5 MB, refused from the npy header
        // before inflating; and 16 M values (under the size cap) of the wrong shape for this body,
        // inflated (128 MB at most), then refused.
        for (n, shape) in [
            ("zip-bomb-1.5gb", vec![6890usize, 3, 9070]),
            ("zip-bomb-under-cap", vec![(1 << 24) / 3, 3]),
        ] {
            let p = self.bad.join(format!("smpl-{n}.npz"));
            let bytes = 8 * shape.iter().product::<usize>();
            write_npz_with_zeros(
                &p,
                &replace("shapedirs", None),
                false,
                Some(("shapedirs", npy("<f8", &shape, &[]), bytes)),
            );
            let args =
                os(&[&"body", &"--model", &p, &"--out", &self.out(&format!("smpl-{n}.obj"))]);
            self.push(format!("SMPL npz {n}"), args, Some(p));
        }
        let whole = std::fs::read(&self.f.smpl).unwrap();
        for (n, b) in [
            ("empty", Vec::new()),
            ("truncated", whole[..whole.len() / 2].to_vec()),
            ("passwd-like", b"root:x:0:0:root:/root:/bin/bash\n".to_vec()),
        ] {
            let p = self.file(&format!("smpl-{n}.npz"), &b);
            let args =
                os(&[&"body", &"--model", &p, &"--out", &self.out(&format!("smpl-{n}.obj"))]);
            self.push(format!("SMPL npz {n}"), args, Some(p));
        }
    }

    fn meta_training(&mut self) {
        let manifest = serde_json::to_value(meta_manifest()).unwrap();
        let samples = f32s(&meta_samples(2, 4));
        let data_edits: Vec<(&str, &str, Option<Value>)> = vec![
            ("first-sample-beyond", "groups/0/first_sample", Some(json!(5))),
            ("samples-beyond", "groups/0/samples", Some(json!(100))),
            ("rest-joints-1", "groups/0/rest_joints", Some(json!([[0.0, 0.0, 0.0]]))),
            ("rest-joints-1e30", "groups/0/rest_joints/3/1", Some(json!(1e30))),
            ("range-0", "groups/0/normalisation/range", Some(json!(0.0))),
            ("range-1e38", "groups/0/normalisation/range", Some(json!(1e38))),
            ("betas-1e30", "groups/0/betas/0", Some(json!(1e30))),
            ("no-groups", "groups", Some(json!([]))),
            ("points-0", "config/points_per_pose", Some(json!(0))),
            ("points-huge", "config/points_per_pose", Some(json!(1u64 << 40))),
            ("version-2", "version", Some(json!(2))),
        ];
        let mut dirs: Vec<(String, PathBuf, &str)> = Vec::new();
        let write_data = |name: &str, manifest: &[u8], samples: &[u8]| {
            let d = self.bad.join(format!("data-{name}"));
            std::fs::create_dir_all(&d).unwrap();
            std::fs::write(d.join("meta-data.json"), manifest).unwrap();
            std::fs::write(d.join("samples.bin"), samples).unwrap();
            d
        };
        for (n, path, value) in data_edits {
            let d =
                write_data(n, &serde_json::to_vec(&set(&manifest, path, value)).unwrap(), &samples);
            dirs.push((n.into(), d, "meta-data.json"));
        }
        let mut nan = samples.clone();
        nan[80..84].copy_from_slice(&f32::NAN.to_le_bytes());
        let m = serde_json::to_vec(&manifest).unwrap();
        for (n, man, s, named) in [
            ("samples-truncated", m.clone(), samples[..samples.len() - 8].to_vec(), "samples.bin"),
            ("samples-nan", m.clone(), nan, "samples.bin"),
            ("samples-padded", m.clone(), [samples.clone(), vec![0; 4]].concat(), "samples.bin"),
            ("manifest-not-json", b"meta".to_vec(), samples.clone(), "meta-data.json"),
            ("manifest-truncated", m[..m.len() / 2].to_vec(), samples.clone(), "meta-data.json"),
        ] {
            let d = write_data(n, &man, &s);
            dirs.push((n.into(), d, named));
        }
        for (n, d, named) in dirs {
            let args = os(&[
                &"meta-train",
                &"--data",
                &d,
                &"--sdf-iterations",
                &"1",
                &"--hyper-iterations",
                &"1",
                &"--out",
                &self.out(&format!("train-{n}")),
            ]);
            self.push(format!("meta-training data {n}"), args, Some(d.join(named)));
        }

        // Checkpoints in a run folder of the fixture data (valid), each its own run.
        let config = avatar_neural::HyperConfig::compact();
        let (sdf, hyper) = (config.siren.num_params(), config.num_params());
        let mut other = checkpoint_header("sdf");
        other["options"]["seed"] = json!(5);
        let checkpoints: Vec<(&str, Value, Vec<f32>, bool)> = vec![
            ("hyper-too-few-weights", checkpoint_header("hyper"), vec![0.01; sdf], false),
            ("sdf-too-many-weights", checkpoint_header("sdf"), vec![0.01; sdf + hyper], false),
            ("unknown-stage", checkpoint_header("polish"), vec![0.01; sdf], false),
            (
                "nan-weights",
                checkpoint_header("sdf"),
                [vec![0.01; sdf - 1], vec![f32::NAN]].concat(),
                false,
            ),
            ("other-options", other, vec![0.01; sdf], false),
            ("truncated", checkpoint_header("hyper"), vec![0.01; sdf + hyper], true),
        ];
        for (n, header, weights, truncate) in checkpoints {
            let run = self.bad.join(format!("run-{n}"));
            std::fs::create_dir_all(&run).unwrap();
            let ck = run.join("checkpoint.bin");
            write_weights_json(&ck, &header, &weights);
            if truncate {
                let b = std::fs::read(&ck).unwrap();
                std::fs::write(&ck, &b[..b.len() - 1000]).unwrap();
            }
            let args = os(&[
                &"meta-train",
                &"--data",
                &self.f.meta_data,
                &"--sdf-iterations",
                &"1",
                &"--hyper-iterations",
                &"1",
                &"--out",
                &run,
            ]);
            self.push(format!("meta-train checkpoint {n}"), args, Some(ck));
        }
    }

    /// Outputs that are inputs, outputs under the wrong extension, out-of-range arguments.
    fn outputs(&mut self) {
        let f = self.f;
        let cap = &f.capture;
        let model_avatar = self.bad.join("model-named.avatar");
        std::fs::copy(&f.model, &model_avatar).unwrap();
        let link = self.bad.join("link-to-pose.obj");
        std::os::unix::fs::symlink(&f.pose, &link).unwrap();
        let hard = self.bad.join("hard-link-to-clip.glb");
        std::fs::hard_link(&f.clip, &hard).unwrap();
        let cap_extra = self.capture("cap-with-points", |d, m| {
            std::fs::write(d.join("points.ply"), b"ply\n").unwrap();
            m
        });
        let run = self.bad.join("run-sdf-from");
        std::fs::create_dir_all(&run).unwrap();
        std::fs::copy(&f.model, run.join("meta-model.bin")).unwrap();
        let o = |n: &str| self.out(n);
        let cases: Vec<(&str, Vec<OsString>, Option<PathBuf>)> = vec![
            (
                "fit over capture.json",
                os(&[&"fit", cap, &"--out", &cap.join("capture.json")]),
                Some(cap.join("capture.json")),
            ),
            (
                "fit over its model",
                os(&[&"fit", cap, &"--model", &f.model, &"--out", &f.model]),
                Some(f.model.clone()),
            ),
            (
                "fit over its model (.avatar name)",
                os(&[&"fit", cap, &"--model", &model_avatar, &"--out", &model_avatar]),
                Some(model_avatar.clone()),
            ),
            (
                "canonicalize over a depth image",
                os(&[&"canonicalize", cap, &"--out", &cap.join("depth/000001.png")]),
                Some(cap.join("depth/000001.png")),
            ),
            (
                "canonicalize over a capture file",
                os(&[&"canonicalize", &cap_extra, &"--out", &cap_extra.join("points.ply")]),
                Some(cap_extra.join("points.ply")),
            ),
            (
                "canonicalize into the capture folder",
                os(&[&"canonicalize", cap, &"--out", cap]),
                Some(cap.clone()),
            ),
            (
                "export over its avatar",
                os(&[
                    &"export",
                    &f.static_avatar,
                    &"--motion",
                    &"walk",
                    &"--out",
                    &f.static_avatar,
                ]),
                Some(f.static_avatar.clone()),
            ),
            (
                "export over its clip",
                os(&[&"export", &f.static_avatar, &"--motion", &f.clip, &"--out", &f.clip]),
                Some(f.clip.clone()),
            ),
            (
                "export over a hard link of its clip",
                os(&[&"export", &f.static_avatar, &"--motion", &f.clip, &"--out", &hard]),
                Some(hard.clone()),
            ),
            (
                "export as .fbx",
                os(&[&"export", &"--motion", &"walk", &"--out", &o("anim.fbx")]),
                Some(o("anim.fbx")),
            ),
            (
                "export frames over a file",
                os(&[
                    &"export",
                    &f.static_avatar,
                    &"--motion",
                    &"walk",
                    &"--format",
                    &"obj",
                    &"--out",
                    &f.clip,
                ]),
                Some(f.clip.clone()),
            ),
            (
                "body over its pose",
                os(&[&"body", &"--pose", &f.pose, &"--out", &f.pose]),
                Some(f.pose.clone()),
            ),
            (
                "body over a link to its pose",
                os(&[&"body", &"--pose", &f.pose, &"--out", &link]),
                Some(link.clone()),
            ),
            (
                "body over its model",
                os(&[&"body", &"--model", &f.smpl, &"--out", &f.smpl]),
                Some(f.smpl.clone()),
            ),
            ("body as .stl", os(&[&"body", &"--out", &o("body.stl")]), Some(o("body.stl"))),
            (
                "pose over its avatar",
                os(&[&"pose", &f.static_avatar, &"--motion", &"walk", &"--out", &f.static_avatar]),
                Some(f.static_avatar.clone()),
            ),
            (
                "meta-train over --sdf-from",
                os(&[
                    &"meta-train",
                    &"--data",
                    &f.meta_data,
                    &"--sdf-from",
                    &run.join("meta-model.bin"),
                    &"--out",
                    &run,
                ]),
                Some(run.join("meta-model.bin")),
            ),
            (
                "eval over its model",
                os(&[&"eval", &"--rows", &"meta", &"--model", &f.model, &"--out", &f.model]),
                Some(f.model.clone()),
            ),
            (
                "eval markdown over its report",
                os(&[&"eval", &"--out", &o("r.json"), &"--markdown", &o("r.json")]),
                Some(o("r.json")),
            ),
            (
                "synth over a file",
                os(&[&"synth", &"--clips", &f.clip, &"--out", &f.clip]),
                Some(f.clip.clone()),
            ),
            (
                "synth contact sheet over its clip",
                os(&[
                    &"synth",
                    &"--clips",
                    &f.clip,
                    &"--out",
                    &o("synth"),
                    &"--contact-sheet",
                    &f.clip,
                ]),
                Some(f.clip.clone()),
            ),
            (
                "bench report as .json",
                os(&[&"bench", &"--only", &"none", &"--out", &f.clip]),
                Some(f.clip.clone()),
            ),
            (
                "pose --resolution 0",
                os(&[
                    &"pose",
                    &f.static_avatar,
                    &"--motion",
                    &"walk",
                    &"--resolution",
                    &"0",
                    &"--out",
                    &o("p0"),
                ]),
                None,
            ),
            (
                "pose --resolution 100000",
                os(&[
                    &"pose",
                    &f.static_avatar,
                    &"--motion",
                    &"walk",
                    &"--resolution",
                    &"100000",
                    &"--out",
                    &o("p1"),
                ]),
                None,
            ),
            (
                "canonicalize --field-cells 4096",
                os(&[&"canonicalize", cap, &"--field-cells", &"4096", &"--out", &o("c.ply")]),
                None,
            ),
        ];
        for (n, args, names) in cases {
            self.push(format!("output: {n}"), args, names);
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
