//! Corrupted captures: their manifest, images, units, cameras and fittings.

use super::*;

impl Corpus<'_> {
    pub(super) fn captures(&mut self) {
        let add = |c: &mut Self, name: &str, names: &str, edit: ManifestEdit| {
            let dir = c.capture(name, edit);
            let named = dir.join(names);
            let i = c.cases.len();
            let args = if i.is_multiple_of(2) {
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
}
