//! Corrupted meta-training inputs, and outputs that are inputs.

use super::*;

impl Corpus<'_> {
    pub(super) fn meta_training(&mut self) {
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
    pub(super) fn outputs(&mut self) {
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
